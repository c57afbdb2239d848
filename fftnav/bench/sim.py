"""Speed of the PyBullet swarm: real-time factor and lidar cost (``fftnav bench sim``).

Any number of robots on a map of any size: :func:`bench_world` grows the preset's square map
so that obstacles per m^2 (the preset's ``density_per_m2`` counts the whole area) and robots
per m^2 (15 on 20 m x 20 m by default) stay those of the preset, and lines the robots up on the
start strip in as many rows as they need (a row holds robots at least ``2.5 r0`` apart).
"""

from __future__ import annotations

import math
import os
import time
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.validate import check_integer, check_number
from fftnav.world import World, generate_world
from fftnav.world.kinds import load_preset

__all__ = ["ROW_GAP_M", "bench_sim", "bench_world", "format_sim"]

#: Distance between two rows of starts (m), in the clear start strip.
ROW_GAP_M = 0.5


def default_size_m(env: str, robots: int) -> float:
    """Side (m) of the square map that holds ``robots`` at the preset's robots per m^2."""
    preset = load_preset(env)
    w, h = preset["size_m"]
    return round(math.sqrt(robots * w * h / preset["robots"]), 2)


def bench_world(env: str, seed: int, *, robots: int = 15, size_m: float | None = None) -> World:
    """A seeded ``size_m`` x ``size_m`` world of kind ``env`` with ``robots`` robots.

    The preset's own world when ``robots`` and ``size_m`` are the preset's (15 robots,
    20 m); otherwise obstacles at the preset's density over the grown map (``generate_world``
    with ``size_m`` and ``goal_y_m = size_m - 1``), and the robots in ``rows`` rows
    ``ROW_GAP_M`` apart centred on the start line (as few rows as keep ``2.5 r0`` between
    neighbours), goals straight across at the same offsets. Only the starts of a single row
    are checked for reachable goals (``generate_world``); the bench drives robots at random.
    """
    check_integer("robots", robots, low=1)
    preset = load_preset(env)
    size = default_size_m(env, robots) if size_m is None else check_number(
        "size_m", size_m, low=4.0)
    if robots == preset["robots"] and size == preset["size_m"][0] == preset["size_m"][1]:
        return generate_world(env, seed)
    spacing = 2.5 * preset["robot_radius_m"]
    per_row = max(1, min(robots, math.floor(size / spacing)))
    rows = math.ceil(robots / per_row)
    half = preset["strip_half_width_m"] - preset["robot_radius_m"]
    if (rows - 1) * ROW_GAP_M / 2 > half:
        raise FftnavError(f"robots={robots} do not fit on the start strip of a {size:g} m map "
                          f"({rows} rows of {per_row}); choose a larger size_m")
    world = generate_world(env, seed, size_m=[size, size], goal_y_m=size - 1.0,
                           robots=min(robots, per_row))
    if rows == 1 and per_row == robots:
        return world
    per_row = math.ceil(robots / rows)
    i = np.arange(robots)
    row, col = np.divmod(i, per_row)
    x = (col + 0.5) * size / per_row
    dy = (row - (rows - 1) / 2) * ROW_GAP_M
    starts = np.c_[x, preset["start_y_m"] + dy, np.full(robots, math.pi / 2)]
    goals = np.c_[x, size - 1.0 + dy]
    return World(env, seed, world.size_m, world.obstacles, starts, goals)


def bench_sim(*, env: str = "forest", seconds: float = 20.0, seed: int = 0, robots: int = 15,
              size_m: float | None = None, runs: int = 1,
              compare_lidar: bool = True) -> dict[str, Any]:
    """Drive a swarm with random commands and time it.

    Parameters
    ----------
    env : {"forest", "rocky"}
        World kind, generated with ``seed`` (:func:`bench_world`).
    seconds : float
        Simulated seconds to run (> 0); default config: physics 240 Hz, control and lidar
        10 Hz, 360 beams per robot.
    seed : int
        Seed of the world and of the random commands (v uniform in [0, v_max], w uniform in
        [-w_max, w_max], redrawn every control tick).
    robots : int
        Number of robots (default 15, the paper's).
    size_m : float, optional
        Side of the square map (m); default: the preset's robots per m^2.
    runs : int
        Independent runs; the one with the best real-time factor is reported.
    compare_lidar : bool
        After every tick also scan the same poses with every ray cast in the full client
        (untimed in the real-time factor), to report both lidar costs side by side and check
        that the scans are identical.

    Returns
    -------
    dict
        ``real_time_factor`` (simulated / wall seconds), ``ms_per_robot_s`` (wall ms per
        simulated robot-second), ``lidar_ms_per_tick`` (wall ms of one swarm scan),
        ``lidar_full_client_ms_per_tick`` (the same scans with every culled ray cast by Bullet
        in the full client, timed on the same poses) and ``lidar_identical``,
        ``physics_ms_per_s`` (wall ms of physics and control per simulated second), ``wall_s``,
        ``rays_per_tick`` (live beams of the swarm), ``rays_cast_per_tick`` (those left after
        culling, mean), ``rays_static_per_tick`` (of those, the ones outside every robot's
        sector: answered by the compiled obstacle test, or by Bullet's static client without
        numba), ``load_avg_1min`` (the machine's load average at the end: the bench shares the
        CPU with whatever else runs)
        and the setting.
    """
    check_number("seconds", seconds, low=0, high=3600, low_open=True)
    check_integer("runs", runs, low=1)
    world = bench_world(env, seed, robots=robots, size_m=size_m)
    best = None
    for _ in range(runs):
        result = _run(world, env, seconds, seed, compare_lidar)
        if best is None or result["real_time_factor"] > best["real_time_factor"]:
            best = result
    return best


def _run(world: World, env: str, seconds: float, seed: int, compare: bool) -> dict[str, Any]:
    config = SimConfig()
    rng = np.random.default_rng(seed)
    ticks = max(1, round(seconds * config.control_hz))
    old_s, identical = 0.0, True
    with SwarmSim(world, config=config) as sim:
        obs = sim.reset(seed=seed)
        k = sim.num_robots
        lidar = sim.lidar
        lidar.seconds_spent = 0.0
        cast, static = lidar.rays_cast, lidar.rays_cast_static
        wall = 0.0
        for _ in range(ticks):
            commands = np.c_[rng.uniform(0, config.robot.v_max_mps, k),
                             rng.uniform(-1, 1, k) * config.robot.w_max_radps]
            tic = time.perf_counter()
            obs = sim.step(commands)
            wall += time.perf_counter() - tic
            if compare:
                spent, counts = lidar.seconds_spent, (lidar.rays_cast, lidar.rays_cast_static)
                # the same poses with every culled ray cast by Bullet in the full client
                client, mesh = lidar._static_client, lidar.static_mesh
                lidar._static_client = lidar.static_mesh = None
                tic = time.perf_counter()
                old = lidar.scan(obs.poses)
                old_s += time.perf_counter() - tic
                lidar._static_client, lidar.static_mesh = client, mesh
                lidar.seconds_spent, (lidar.rays_cast, lidar.rays_cast_static) = spent, counts
                identical &= old.tobytes() == obs.scans.tobytes()
        lidar_s = lidar.seconds_spent
        rays = k * int(lidar.live.sum())
        cast, static = lidar.rays_cast - cast, lidar.rays_cast_static - static
    simulated = ticks / config.control_hz
    return {
        "bench": "sim",
        "env": env,
        "seed": seed,
        "robots": k,
        "size_m": float(world.size_m[0]),
        "simulated_s": simulated,
        "physics_hz": config.physics_hz,
        "control_hz": config.control_hz,
        "beams": config.sensor.beams,
        "rays_per_tick": rays,
        "rays_cast_per_tick": round(cast / ticks, 1),
        "rays_static_per_tick": round(static / ticks, 1),
        "wall_s": round(wall, 4),
        "real_time_factor": round(simulated / wall, 2),
        "ms_per_robot_s": round(1e3 * wall / (simulated * k), 4),
        "lidar_ms_per_tick": round(1e3 * lidar_s / ticks, 3),
        "lidar_full_client_ms_per_tick": round(1e3 * old_s / ticks, 3) if compare else None,
        "lidar_identical": identical if compare else None,
        "physics_ms_per_s": round(1e3 * (wall - lidar_s) / simulated, 2),
        "load_avg_1min": round(os.getloadavg()[0], 2),
    }


def format_sim(result: dict[str, Any]) -> str:
    """Human-readable summary of :func:`bench_sim`'s result."""
    lines = [
        f"sim bench: env={result['env']} seed={result['seed']} robots={result['robots']} "
        f"map {result['size_m']:g} m x {result['size_m']:g} m, "
        f"simulated {result['simulated_s']:g} s in {result['wall_s']:.2f} s wall",
        f"  real-time factor     {result['real_time_factor']:8.2f} x",
        f"  per robot-second     {result['ms_per_robot_s']:8.3f} ms",
        f"  lidar per tick       {result['lidar_ms_per_tick']:8.3f} ms "
        f"({result['rays_cast_per_tick']:g} of {result['rays_per_tick']} rays cast, "
        f"{result['rays_static_per_tick']:g} of them in the static client, "
        f"{result['beams']} beams per robot)",
    ]
    if result["lidar_full_client_ms_per_tick"] is not None:
        lines.append(f"  same, all in the full client {result['lidar_full_client_ms_per_tick']:.3f}"
                     f" ms (same poses; scans identical: {result['lidar_identical']})")
    lines += [
        f"  physics + control    {result['physics_ms_per_s']:8.2f} ms per simulated s "
        f"({result['physics_hz']:g} Hz physics, {result['control_hz']:g} Hz control)",
        f"  load average (1 min) {result['load_avg_1min']:8.2f}",
    ]
    return "\n".join(lines)
