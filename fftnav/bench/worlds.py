"""Large worlds (``fftnav bench worlds``): generation, build, speed and memory of big maps.

Each case runs in a fresh process (its peak memory is its own): generate the world, build the
simulator (obstacles tiled into several static meshes when Bullet's per-mesh limits require,
:mod:`fftnav.sim.mesh`), drive the swarm with random commands for a few simulated seconds (the
real-time factor), then run one full episode of the ``fusion`` policy, A* reference included.
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import time
from typing import Any

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.episode import run_episode
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.world import generate_world, load_preset

__all__ = ["LARGE_WORLDS", "bench_large_world", "bench_worlds", "format_worlds"]

#: The cases: a 60 m x 60 m forest (720 trunks: beyond one Bullet mesh) and a 10,035-obstacle
#: forest of 224 m x 224 m (the paper's density of 0.2 per m^2).
LARGE_WORLDS: dict[str, dict[str, Any]] = {
    "forest-60m": {"env": "forest", "size_m": [60.0, 60.0]},
    "forest-10k": {"env": "forest", "size_m": [224.0, 224.0]},
}


def bench_large_world(name: str, *, seed: int = 0, drive_s: float = 5.0,
                      episode_s: float = 20.0) -> dict[str, Any]:
    """Measure one case of :data:`LARGE_WORLDS` in this process.

    Returns
    -------
    dict
        ``obstacles``, ``meshes`` (static meshes built), ``generate_s``, ``build_s`` (simulator
        build), ``real_time_factor`` (simulated / wall seconds of driving the swarm),
        ``episode_wall_s`` (one ``fusion`` episode of ``episode_s`` simulated seconds, A*
        reference included), ``robots_arrived``, ``max_rss_mb`` (peak resident memory of the
        process) and the load average.
    """
    case = LARGE_WORLDS[name]
    size = case["size_m"]
    tic = time.perf_counter()
    world = generate_world(case["env"], seed, size_m=size,
                           goal_y_m=size[1] - load_preset(case["env"])["start_y_m"])
    generate_s = time.perf_counter() - tic
    swarm = SwarmConfig().replace({"time_limit_s": episode_s})
    config = SimConfig.for_swarm(swarm)
    tic = time.perf_counter()
    with SwarmSim(world, config=config) as sim:
        build_s = time.perf_counter() - tic
        meshes = sim.static_meshes
        rng = np.random.default_rng(seed)
        sim.reset(seed=seed)
        ticks = max(1, round(drive_s * config.control_hz))
        tic = time.perf_counter()
        for _ in range(ticks):
            sim.step(np.c_[rng.uniform(0, 0.5, sim.num_robots),
                           rng.uniform(-1.5, 1.5, sim.num_robots)])
        drive_wall = time.perf_counter() - tic
    tic = time.perf_counter()
    result = run_episode(world, "fusion", seed=seed, config=swarm)
    episode_wall = time.perf_counter() - tic
    return {
        "bench": "worlds",
        "case": name,
        "env": case["env"],
        "size_m": f"{size[0]:g}x{size[1]:g}",
        "seed": seed,
        "obstacles": len(world.obstacles),
        "robots": len(world.starts),
        "meshes": meshes,
        "generate_s": round(generate_s, 2),
        "build_s": round(build_s, 3),
        "real_time_factor": round(ticks / config.control_hz / drive_wall, 2),
        "episode_simulated_s": episode_s,
        "episode_wall_s": round(episode_wall, 2),
        "robots_arrived": int(sum(row.arrived for row in result.rows)),
        "max_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "load_avg_1min": round(os.getloadavg()[0], 2),
    }


def bench_worlds(cases: list[str] | None = None, **kwargs: Any) -> list[dict[str, Any]]:
    """Run :func:`bench_large_world` for each case, each in a fresh process."""
    names = list(LARGE_WORLDS) if cases is None else cases
    for name in names:
        if name not in LARGE_WORLDS:
            raise ValueError(f"case must be one of {list(LARGE_WORLDS)}, got case={name!r}")
    context = multiprocessing.get_context("spawn")
    results = []
    for name in names:
        with context.Pool(1) as pool:
            results.append(pool.apply(bench_large_world, (name,), kwargs))
    return results


def format_worlds(results: list[dict[str, Any]]) -> str:
    """One line per case."""
    return "\n".join(
        f"{r['case']}: {r['size_m']} m, {r['obstacles']} obstacles in {r['meshes']} meshes; "
        f"generate {r['generate_s']:.1f} s, build {r['build_s']:.2f} s, real-time factor "
        f"{r['real_time_factor']:.2f}, episode of {r['episode_simulated_s']:g} s in "
        f"{r['episode_wall_s']:.1f} s ({r['robots_arrived']}/{r['robots']} arrived), peak "
        f"{r['max_rss_mb']:.0f} MB" for r in results)
