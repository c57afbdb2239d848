"""World kind ``forest``: tree trunks (circles) scattered between the start and goal strips.

Preset ``worlds/forest.toml`` (paper Sec. IV-B): 20 m x 20 m, 80 trunks of radius 0.1-0.3 m.
"""

from __future__ import annotations

import numpy as np

from fftnav.validate import check_number
from fftnav.world.kinds import (
    DECIMALS,
    Params,
    max_obstacle_radius,
    register_world_kind,
    scatter_obstacles,
)
from fftnav.world.obstacles import Circle, Obstacle


def check_trunks(params: Params) -> None:
    """``trunk_radius_m`` is a range of positive radii."""
    low, high = params["trunk_radius_m"]
    fit = max_obstacle_radius(params)  # each end within the bounds first, then their order
    check_number("trunk_radius_m[0]", low, low=0, low_open=True, high=fit)
    check_number("trunk_radius_m[1]", high, low=low, high=fit)


def trunk(params: Params, rng: np.random.Generator) -> tuple[Obstacle, float]:
    """One trunk at the origin, radius uniform in ``trunk_radius_m``, and its radius (shared
    with the kinds that scatter trunks among their own obstacles)."""
    r = round(float(rng.uniform(*params["trunk_radius_m"])), DECIMALS)
    return Circle((0.0, 0.0), r, params["obstacle_height_m"]), r


@register_world_kind("forest", check=check_trunks)
def draw(params: Params, rng: np.random.Generator) -> list[Obstacle] | None:
    """Trunks of radius uniform in ``trunk_radius_m`` (paper: forest)."""
    return scatter_obstacles(params, rng, trunk)
