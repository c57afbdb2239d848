"""The cost of writing an episode as a bag (``fftnav bench bag``).

One process runs the same episode (``fusion`` on a generated world) without a bag and with
``--bag``'s :class:`fftnav.ros.episode.EpisodeBag`, alternating, ``repeats`` times each, so a
shared machine's load falls on both alike; the ratio of the medians is what the bag costs.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from fftnav.validate import check_integer, check_number

__all__ = ["bench_bag", "format_bag"]


def bench_bag(*, env: str = "forest", seed: int = 1000, robots: int = 15,
              seconds: float = 20.0, repeats: int = 3, suffix: str = ".mcap") -> dict[str, Any]:
    """Time an episode without and with its bag, alternating.

    Parameters
    ----------
    env, seed, robots : str, int, int
        The generated world (``generate_world(env, seed, robots=robots)``).
    seconds : float
        The episode's ``time_limit_s`` (simulated seconds).
    repeats : int
        Runs of each, alternating.
    suffix : str
        The bag's kind: ``.mcap``, ``.db3`` or ``.bag``.

    Returns
    -------
    dict
        The median wall times ``plain_wall_s`` and ``bag_wall_s`` (s), their ``ratio``, the
        added milliseconds per robot per control tick ``bag_ms_per_robot_tick``, the robot-ticks,
        the bag's size ``bag_mb`` (MB) and the load average.
    """
    from fftnav.config import SwarmConfig
    from fftnav.episode import run_episode
    from fftnav.ros.episode import EpisodeBag
    from fftnav.world.generate import generate_world

    check_number("seconds", seconds, low=0, high=600, low_open=True)
    check_integer("repeats", repeats, low=1, high=100)
    world = generate_world(env, seed, robots=robots)
    config = SwarmConfig().replace({"time_limit_s": str(seconds)})
    plain, bagged, size, ticks = [], [], 0, 0
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"episode{suffix}"
        for _ in range(repeats):
            tic = time.perf_counter()
            ticks = run_episode(world, "fusion", seed=0, config=config).robot_ticks
            plain.append(time.perf_counter() - tic)
            tic = time.perf_counter()
            with EpisodeBag(path, world, config) as bag:
                bag.finish(run_episode(world, "fusion", seed=0, config=config, on_tick=bag))
            bagged.append(time.perf_counter() - tic)
            size = path.stat().st_size
    plain_s, bag_s = statistics.median(plain), statistics.median(bagged)
    return {
        "bench": "bag",
        "env": env,
        "seed": seed,
        "robots": robots,
        "suffix": suffix,
        "simulated_s": seconds,
        "repeats": repeats,
        "robot_ticks": ticks,
        "plain_wall_s": round(plain_s, 3),
        "bag_wall_s": round(bag_s, 3),
        "ratio": round(bag_s / plain_s, 3),
        "bag_ms_per_robot_tick": round(1000 * (bag_s - plain_s) / max(ticks, 1), 3),
        "bag_mb": round(size / 1e6, 3),
        "load_avg_1min": round(os.getloadavg()[0], 2),
    }


def format_bag(result: dict[str, Any]) -> str:
    """Human-readable summary of :func:`bench_bag`'s result."""
    return (
        f"bag bench: env={result['env']} seed={result['seed']} robots={result['robots']} "
        f"{result['simulated_s']:g} s simulated, median of {result['repeats']} alternating runs\n"
        f"  episode                     {result['plain_wall_s']:8.3f} s\n"
        f"  episode with --bag {result['suffix']:<8} {result['bag_wall_s']:8.3f} s "
        f"({result['bag_mb']:g} MB)\n"
        f"  ratio bag / plain           {result['ratio']:8.3f}\n"
        f"  added per robot per tick    {result['bag_ms_per_robot_tick']:8.3f} ms "
        f"({result['robot_ticks']} robot-ticks)\n"
        f"  load average (1 min)        {result['load_avg_1min']:8.2f}"
    )
