"""Seeded world generation: a kind's obstacles, the robots' starts and goals, reachability.

:func:`generate_world` is the same for every kind (:mod:`fftnav.world.kinds`): it validates the
parameters (the kind's preset with overrides), asks the kind for obstacles, lines the robots up on
the start strip facing their goals across the map, and redraws until every goal is reachable.
Pure numpy + scipy.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.limits import MAX_GRID_CELLS, MAX_MAP_SIDE_M, MAX_OBSTACLES, check_limit, grid_cells
from fftnav.validate import check_choice, check_integer, check_number, check_vector
from fftnav.world.grid import unreachable_robots
from fftnav.world.kinds import DECIMALS, Params, get_world_kind, load_preset
from fftnav.world.model import BOUNDARIES, World

__all__ = ["generate_world", "world_parameters"]


def _check_common(p: Params) -> None:
    """The parameters every kind shares, checked together."""
    w, h = (check_number(f"size_m[{i}]", v, low=0, low_open=True, high=MAX_MAP_SIDE_M)
            for i, v in enumerate(p["size_m"]))
    density = check_number("density_per_m2", p["density_per_m2"], low=0, high=1)
    check_limit("obstacles (density_per_m2 x area)", round(density * w * h), MAX_OBSTACLES,
                hint="lower density_per_m2 or size_m")
    resolution = check_number("reachability_resolution_m", p["reachability_resolution_m"],
                              low=0, low_open=True, high=min(w, h))
    check_limit("reachability grid cells (size_m / reachability_resolution_m)",
                grid_cells(w, h, resolution), MAX_GRID_CELLS,
                hint="raise reachability_resolution_m")
    check_number("obstacle_height_m", p["obstacle_height_m"], low=0, low_open=True)
    check_number("min_gap_m", p["min_gap_m"], low=0)
    check_integer("placement_tries", p["placement_tries"], low=1)
    check_integer("max_attempts", p["max_attempts"], low=1)
    check_choice("boundary", p.get("boundary", "open"), BOUNDARIES)
    n = check_integer("robots", p["robots"], low=1)
    radius = check_number("robot_radius_m", p["robot_radius_m"], low=0)
    if w / n < 2.5 * radius:
        raise FftnavError(f"robots={n} robots of radius {radius} m do not fit side by "
                          f"side in a {w:g} m wide world")
    clear = check_number("strip_half_width_m", p["strip_half_width_m"], low=0)
    if not (clear <= p["start_y_m"] < p["goal_y_m"] - 2 * clear and p["goal_y_m"] + clear <= h):
        raise FftnavError(f"start_y_m={p['start_y_m']} and goal_y_m={p['goal_y_m']} with "
                          f"strip_half_width_m={clear} must leave both strips inside the world")


def _check_like(key: str, value: Any, default: Any) -> None:
    """``value`` has the type of the preset's ``default``: as many finite numbers for a list, an
    integer for an integer, a finite number for a number, the same type otherwise."""
    if isinstance(default, (list, tuple)):
        check_vector(key, value, len(default))
    elif isinstance(default, (bool, str)):
        if type(value) is not type(default):
            raise FftnavError(f"{key} must be {type(default).__name__}, got {key}={value!r}")
    elif isinstance(default, int):
        check_integer(key, value)
    else:
        check_number(key, value)


def world_parameters(env: str, *, preset: Params | None = None, **overrides: Any) -> Params:
    """The preset of ``env`` with ``overrides`` applied, validated.

    Every override must be a preset key and have the preset value's type (a number for a
    number, an integer for an integer, a list of as many numbers for a list); then the shared
    values and the kind's own are checked.
    """
    kind = get_world_kind(env)
    params = dict(load_preset(env) if preset is None else preset)
    unknown = sorted(set(overrides) - set(params))
    if unknown:
        raise FftnavError(f"unknown world parameter(s) {unknown}; "
                          f"expected some of {sorted(params)}")
    for key, value in overrides.items():
        _check_like(key, value, params[key])
    params.update(overrides)
    _check_common(params)
    kind.check(params)
    return params


def _robots(params: Params) -> tuple[np.ndarray, np.ndarray]:
    """Robot i starts at ``((i + 0.5) w / N, start_y_m)`` facing +y; its goal is straight across."""
    n, w = params["robots"], float(params["size_m"][0])
    xs = np.round((np.arange(n) + 0.5) * w / n, DECIMALS)
    starts = np.c_[xs, np.full(n, params["start_y_m"]), np.full(n, round(math.pi / 2, DECIMALS))]
    goals = np.c_[xs, np.full(n, params["goal_y_m"])]
    return starts.astype(float), goals.astype(float)


def generate_world(env: str, seed: int, *, preset: Params | None = None,
                   **overrides: Any) -> World:
    """Generate a seeded world of a registered kind (paper Sec. IV-B: forest, rocky ruins).

    Parameters
    ----------
    env : str
        A registered world kind (:func:`fftnav.world.kinds.world_kinds`), e.g. ``"forest"``
        (trunks) or ``"rocky"`` (rocks and wall fragments).
    seed : int
        Seed of the world's ``numpy.random.Generator``; the same seed gives the same world on
        every machine.
    preset : dict, optional
        Generation parameters; default ``load_preset(env)`` (``worlds/<env>.toml``).
    **overrides
        Replace preset keys, e.g. ``size_m=(30, 30)``, ``density_per_m2=0.1``, ``robots=10``.

    Returns
    -------
    World
        The kind's obstacles (forest and rocky: ``round(density_per_m2 * w * h)``, counted over
        the whole world area, all between the start strip ``|y - start_y_m| <=
        strip_half_width_m`` and the goal strip, which stay clear). Robot i starts at
        ``((i + 0.5) w / N, start_y_m)`` facing +y and drives to ``((i + 0.5) w / N, goal_y_m)``.
        Every goal is reachable from its start for a disc of radius ``robot_radius_m``
        (4-connected free space of the occupancy grid inflated by that radius); if not, or if
        the kind asks for a redraw (an obstacle found no free spot), the world is redrawn from
        the generator seeded ``[seed, attempt]`` for the next attempt, up to ``max_attempts``.
        Its ``boundary`` is the parameter ``boundary`` (``"open"`` if the preset has none);
        with ``"walls"`` the reachability check sees the walls too.

    Examples
    --------
    >>> world = generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=3)
    >>> len(world.obstacles), world.starts.shape, world.goals.shape
    (13, (3, 3), (3, 2))
    """
    seed = check_integer("seed", seed, low=0)
    kind = get_world_kind(env)
    params = world_parameters(env, preset=preset, **overrides)
    w, h = (float(v) for v in params["size_m"])
    starts, goals = _robots(params)
    for attempt in range(params["max_attempts"]):
        obstacles = kind.draw(params, np.random.default_rng([seed, attempt]))
        if obstacles is None:
            continue
        world = World(env, seed, (w, h), tuple(obstacles), starts, goals,
                      params.get("boundary", "open"))
        if not unreachable_robots(world, radius_m=params["robot_radius_m"],
                                  resolution_m=params["reachability_resolution_m"]):
            return world
    raise FftnavError(f"no world with every obstacle placed and every goal reachable after "
                      f"max_attempts={params['max_attempts']} (seed={seed}); lower density_per_m2="
                      f"{params['density_per_m2']} or min_gap_m={params['min_gap_m']}")
