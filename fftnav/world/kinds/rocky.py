"""World kind ``rocky``: rocky ruins, random convex rocks and thin wall fragments.

Preset ``worlds/rocky.toml`` (paper Sec. IV-B): 20 m x 20 m, 80 obstacles; rocks are convex 5- to
9-gons 0.3 to 1.2 m across (vertices on an ellipse), a tenth are walls 1 to 2.5 m long.
"""

from __future__ import annotations

import math

import numpy as np

from fftnav.errors import FftnavError
from fftnav.validate import check_integer, check_number
from fftnav.world.kinds import Params, max_obstacle_radius, register_world_kind, scatter_obstacles
from fftnav.world.obstacles import Obstacle, Polygon


def _check(params: Params) -> None:
    low, high = params["rock_sides"]
    check_integer("rock_sides[0]", low, low=3)
    check_integer("rock_sides[1]", high, low=low)
    check_number("wall_fraction", params["wall_fraction"], low=0, high=1)
    fit = max_obstacle_radius(params)
    tops = {"rock_size_m": 2 * fit, "rock_aspect": 1.0}
    for key in ("rock_size_m", "rock_aspect", "wall_length_m", "wall_thickness_m"):
        low, high = params[key]  # each end within the bounds first, then their order
        check_number(f"{key}[0]", low, low=0, low_open=True, high=tops.get(key))
        check_number(f"{key}[1]", high, low=low, high=tops.get(key))
    wall = math.hypot(params["wall_length_m"][1], params["wall_thickness_m"][1]) / 2
    if wall > fit:
        raise FftnavError(f"wall_length_m[1] must leave walls (bounding radius {wall:g} m) "
                          f"room between the strips (<= {fit:g} m), got wall_length_m[1]="
                          f"{params['wall_length_m'][1]!r}")


def _rock_or_wall(params: Params, rng: np.random.Generator) -> tuple[Obstacle, float]:
    if rng.random() < params["wall_fraction"]:  # a thin rectangular wall fragment
        half = np.array([rng.uniform(*params["wall_length_m"]),
                         rng.uniform(*params["wall_thickness_m"])]) / 2
        local = half * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    else:  # a rock: 5 to 9 points on an ellipse, always in convex position
        sides = int(rng.integers(params["rock_sides"][0], params["rock_sides"][1] + 1))
        gaps = 1.0 + rng.random(sides)  # irregular angular gaps, none below 1/2 of the mean
        angles = 2 * math.pi * (np.cumsum(gaps) - gaps[0]) / gaps.sum()
        # Both ends of the major axis are vertices (angles 0 and pi: the vertex nearest to pi
        # moves there, by less than half a gap), so the rock is exactly as wide as drawn.
        angles[1 + np.argmin(np.abs(angles[1:] - math.pi))] = math.pi
        axes = rng.uniform(*params["rock_size_m"]) / 2 * np.array(
            [1.0, rng.uniform(*params["rock_aspect"])])
        local = axes * np.c_[np.cos(angles), np.sin(angles)]
    yaw = rng.uniform(0, 2 * math.pi)
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    verts = local @ rot.T
    return (Polygon(tuple(map(tuple, verts.tolist())), params["obstacle_height_m"]),
            float(np.hypot(*verts.T).max()))


@register_world_kind("rocky", check=_check)
def draw(params: Params, rng: np.random.Generator) -> list[Obstacle] | None:
    """Convex rocks and wall fragments (paper: rocky ruins)."""
    return scatter_obstacles(params, rng, _rock_or_wall)
