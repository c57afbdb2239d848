"""Speed of the PyBullet swarm: real-time factor and lidar cost (``fftnav bench sim``)."""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.validate import check_number
from fftnav.world import generate_world

__all__ = ["bench_sim", "format_sim"]


def bench_sim(*, env: str = "forest", seconds: float = 20.0, seed: int = 0) -> dict[str, Any]:
    """Drive the default 15-robot swarm with random commands and time it.

    Parameters
    ----------
    env : {"forest", "rocky"}
        World preset, generated with ``seed``.
    seconds : float
        Simulated seconds to run (> 0); default config: physics 240 Hz, control and lidar
        10 Hz, 360 beams per robot.
    seed : int
        Seed of the world and of the random commands (v uniform in [0, v_max], w uniform in
        [-w_max, w_max], redrawn every control tick).

    Returns
    -------
    dict
        ``real_time_factor`` (simulated / wall seconds), ``lidar_ms_per_tick`` (wall ms of one
        swarm scan), ``physics_ms_per_s`` (wall ms of physics and control per simulated second),
        ``wall_s``, ``rays_per_tick`` (live beams of the swarm), ``rays_cast_per_tick`` (those
        left after culling, mean), ``load_avg_1min`` (the machine's load average at the end:
        the bench shares the CPU with whatever else runs) and the setting.
    """
    check_number("seconds", seconds, low=0, high=3600, low_open=True)
    config = SimConfig()
    world = generate_world(env, seed)
    rng = np.random.default_rng(seed)
    ticks = max(1, round(seconds * config.control_hz))
    with SwarmSim(world, config=config) as sim:
        sim.reset(seed=seed)
        k = sim.num_robots
        lidar = sim.lidar
        lidar.seconds_spent = 0.0
        cast = lidar.rays_cast
        tic = time.perf_counter()
        for _ in range(ticks):
            commands = np.c_[rng.uniform(0, config.robot.v_max_mps, k),
                             rng.uniform(-1, 1, k) * config.robot.w_max_radps]
            sim.step(commands)
        wall = time.perf_counter() - tic
        lidar_s = lidar.seconds_spent
        rays = k * int(lidar.live.sum())
        cast = lidar.rays_cast - cast
    simulated = ticks / config.control_hz
    return {
        "bench": "sim",
        "env": env,
        "seed": seed,
        "robots": k,
        "simulated_s": simulated,
        "physics_hz": config.physics_hz,
        "control_hz": config.control_hz,
        "beams": config.sensor.beams,
        "rays_per_tick": rays,
        "rays_cast_per_tick": round(cast / ticks, 1),
        "wall_s": round(wall, 4),
        "real_time_factor": round(simulated / wall, 2),
        "lidar_ms_per_tick": round(1e3 * lidar_s / ticks, 3),
        "physics_ms_per_s": round(1e3 * (wall - lidar_s) / simulated, 2),
        "load_avg_1min": round(os.getloadavg()[0], 2),
    }


def format_sim(result: dict[str, Any]) -> str:
    """Human-readable summary of :func:`bench_sim`'s result."""
    return (
        f"sim bench: env={result['env']} seed={result['seed']} robots={result['robots']} "
        f"simulated {result['simulated_s']:g} s in {result['wall_s']:.2f} s wall\n"
        f"  real-time factor     {result['real_time_factor']:8.2f} x\n"
        f"  lidar per tick       {result['lidar_ms_per_tick']:8.3f} ms "
        f"({result['rays_cast_per_tick']:g} of {result['rays_per_tick']} rays cast, "
        f"{result['beams']} beams per robot)\n"
        f"  physics + control    {result['physics_ms_per_s']:8.2f} ms per simulated s "
        f"({result['physics_hz']:g} Hz physics, {result['control_hz']:g} Hz control)\n"
        f"  load average (1 min) {result['load_avg_1min']:8.2f}"
    )
