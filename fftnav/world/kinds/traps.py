"""World kind ``traps``: concave obstacles (U-shaped dead-end pockets and L corners) among trunks.

Preset ``worlds/traps.toml``: 20 m x 20 m with boundary walls, ``traps`` concave obstacles made of
thin walls (a U is a back wall and two arms around a pocket ``pocket_width_m`` wide and
``pocket_depth_m`` deep; an L is a back wall and one arm), a share ``open_to_start`` of them with
their pocket opening toward the starts (turned at most 30 degrees), the others at any angle, and
trunks. A robot that walks into a pocket sees three walls; robots beside it can see around it.
"""

from __future__ import annotations

import math

import numpy as np

from fftnav.validate import check_integer, check_number
from fftnav.world.kinds import Params, register_world_kind, scatter_obstacles
from fftnav.world.kinds.forest import check_trunks, trunk
from fftnav.world.kinds.walls import check_range
from fftnav.world.obstacles import Obstacle, rectangle

#: Pockets open toward the starts turn at most this much (rad).
TOWARD_START_TILT_RAD = math.pi / 6


def _check(params: Params) -> None:
    check_trunks(params)
    for key in ("pocket_width_m", "pocket_depth_m", "wall_thickness_m"):
        check_range(params, key)
    check_integer("traps", params["traps"], low=0)
    check_number("u_fraction", params["u_fraction"], low=0, high=1)
    check_number("open_to_start", params["open_to_start"], low=0, high=1)


def _trap(params: Params, rng: np.random.Generator) -> tuple[list[Obstacle], float]:
    """A U (or an L) centred at the origin, its pocket opening toward -y before turning."""
    u = rng.random() < params["u_fraction"]
    half_w = rng.uniform(*params["pocket_width_m"]) / 2
    depth = rng.uniform(*params["pocket_depth_m"])
    t = rng.uniform(*params["wall_thickness_m"])
    if rng.random() < params["open_to_start"]:
        yaw = rng.uniform(-1, 1) * TOWARD_START_TILT_RAD
    else:
        yaw = rng.uniform(-math.pi, math.pi)
    shift = (depth + t) / 2  # centre of the bounding box
    boxes = [(-half_w - t, depth, half_w + t, depth + t),  # back wall
             (-half_w - t, 0.0, -half_w, depth)]  # left arm
    if u:
        boxes.append((half_w, 0.0, half_w + t, depth))  # right arm
    h = params["obstacle_height_m"]
    parts: list[Obstacle] = [rectangle(x0, y0 - shift, x1, y1 - shift, h, yaw_rad=yaw)
                             for x0, y0, x1, y1 in boxes]
    return parts, math.hypot(half_w + t, shift)


@register_world_kind("traps", check=_check)
def draw(params: Params, rng: np.random.Generator) -> list[Obstacle] | None:
    """U-shaped pockets and L corners of thin walls among trunks."""
    traps = scatter_obstacles(params, rng, _trap, count=params["traps"])
    if traps is None:
        return None
    trunks = scatter_obstacles(params, rng, trunk, avoid=traps)
    return None if trunks is None else traps + trunks
