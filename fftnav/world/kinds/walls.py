"""World kind ``walls``: barriers longer than the sensing range, with gaps, among trunks.

Preset ``worlds/walls.toml``: 20 m x 20 m with boundary walls, ``barrier_rows`` barriers across
the robots' way (along x), each a row of wall segments ``wall_length_m`` long (2-3 R for
R = 3 m) separated by gaps ``barrier_gap_m`` wide at random places (two rows make zigzags), and
trunks. A robot at a barrier cannot see from where it stands which way the nearest gap is;
robots elsewhere can.
"""

from __future__ import annotations

import numpy as np

from fftnav.validate import check_integer, check_number
from fftnav.world.kinds import DECIMALS, Params, register_world_kind, scatter_obstacles
from fftnav.world.kinds.forest import check_trunks, trunk
from fftnav.world.obstacles import Obstacle, Polygon, rectangle

#: Wall segments clipped at the map edge to less than this (m) are dropped.
MIN_SEGMENT_M = 0.3


def check_range(params: Params, key: str) -> None:
    """``params[key]`` is a range ``[low, high]`` of positive numbers."""
    low, high = params[key]
    check_number(f"{key}[0]", low, low=0, low_open=True)
    check_number(f"{key}[1]", high, low=low)


def _check(params: Params) -> None:
    check_trunks(params)
    for key in ("wall_length_m", "barrier_gap_m", "wall_thickness_m"):
        check_range(params, key)
    check_integer("barrier_rows", params["barrier_rows"], low=0)
    check_number("row_jitter_m", params["row_jitter_m"], low=0)


def _rounded(polygon: Polygon) -> Polygon:
    return polygon.moved(np.zeros(2), decimals=DECIMALS)


def _barrier(params: Params, rng: np.random.Generator, y: float) -> list[Obstacle]:
    """One row at height ``y``: segments and gaps from a random phase, clipped to the map."""
    w = float(params["size_m"][0])
    half = rng.uniform(*params["wall_thickness_m"]) / 2
    x = -rng.uniform(0.0, params["wall_length_m"][1])
    walls: list[Obstacle] = []
    while x < w:
        end = x + rng.uniform(*params["wall_length_m"])
        x0, x1 = max(x, 0.0), min(end, w)
        if x1 - x0 >= MIN_SEGMENT_M:
            walls.append(_rounded(rectangle(x0, y - half, x1, y + half,
                                            params["obstacle_height_m"])))
        x = end + rng.uniform(*params["barrier_gap_m"])
    return walls


@register_world_kind("walls", check=_check)
def draw(params: Params, rng: np.random.Generator) -> list[Obstacle] | None:
    """Barriers of walls longer than R with gaps, and trunks."""
    clear = params["strip_half_width_m"]
    low, high = params["start_y_m"] + clear, params["goal_y_m"] - clear  # between the strips
    rows = params["barrier_rows"]
    margin = params["wall_thickness_m"][1] / 2 + params["min_gap_m"]
    walls: list[Obstacle] = []
    for k in range(rows):
        y = low + (high - low) * (k + 1) / (rows + 1) + rng.uniform(-1, 1) * params["row_jitter_m"]
        walls += _barrier(params, rng, float(np.clip(y, low + margin, high - margin)))
    trunks = scatter_obstacles(params, rng, trunk, avoid=walls)
    return None if trunks is None else walls + trunks
