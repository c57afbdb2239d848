"""Speed of :class:`fftnav.envs.SwarmNavEnv` beside the bare simulator (``fftnav bench env``).

Both run in one process, one after the other, on the same world: ``fftnav bench sim``'s loop
(random commands straight into :class:`~fftnav.sim.swarm.SwarmSim`) and a random-action rollout
of the PettingZoo environment (observations built, rewards computed, robots that arrive parked).
For the same motion in both, the environment's random actions follow bench sim's distribution:
``w`` uniform over the action space, ``v`` uniform over its forward half ``[0, v_max]`` (with
``v`` over the whole space the robots dither around their starts, in the open, where the lidar
is cheaper), and robots that touch an obstacle keep driving (``terminate_on_collision=False``),
as in bench sim. The ratio of their real-time factors is what the environment layer costs.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from fftnav.bench.sim import bench_sim
from fftnav.validate import check_number

__all__ = ["bench_env", "format_env"]


def bench_env(*, env: str = "forest", seconds: float = 60.0, seed: int = 0,
              robots: int = 15) -> dict[str, Any]:
    """Time a random rollout of ``SwarmNavEnv`` and ``bench_sim`` for ``seconds`` simulated.

    Returns
    -------
    dict
        ``env_real_time_factor``, ``sim_real_time_factor`` and their ``ratio``, the wall times,
        ``mean_live_agents`` (agents still driving, averaged over the env's steps) and the
        load average.
    """
    from fftnav.envs import SwarmNavEnv  # the optional extra fftnav[marl]

    check_number("seconds", seconds, low=0, high=3600, low_open=True)
    sim = bench_sim(env=env, seconds=seconds, seed=seed)
    nav = SwarmNavEnv(env, map_seed=seed, robots=robots, terminate_on_collision=False)
    nav.reset(seed=seed, options={"time_limit_s": seconds})
    rng = np.random.default_rng(seed)
    steps, live = 0, 0
    tic = time.perf_counter()
    while nav.agents:
        live += len(nav.agents)
        space = nav.action_space(nav.agents[0])
        low, high = np.maximum(space.low, [0.0, -np.inf]), space.high  # forward half in v
        nav.step({a: rng.uniform(low, high).astype(np.float32) for a in nav.agents})
        steps += 1
    wall = time.perf_counter() - tic
    nav.close()
    simulated = steps / nav.config.episode.control_hz
    env_rtf = simulated / wall
    return {
        "bench": "env",
        "env": env,
        "seed": seed,
        "robots": robots,
        "simulated_s": round(simulated, 3),
        "env_wall_s": round(wall, 4),
        "env_real_time_factor": round(env_rtf, 2),
        "sim_wall_s": sim["wall_s"],
        "sim_real_time_factor": sim["real_time_factor"],
        "ratio": round(env_rtf / sim["real_time_factor"], 3),
        "mean_live_agents": round(live / max(steps, 1), 2),
        "load_avg_1min": round(os.getloadavg()[0], 2),
    }


def format_env(result: dict[str, Any]) -> str:
    """Human-readable summary of :func:`bench_env`'s result."""
    return (
        f"env bench: env={result['env']} seed={result['seed']} robots={result['robots']} "
        f"simulated {result['simulated_s']:g} s each\n"
        f"  SwarmNavEnv random rollout  {result['env_real_time_factor']:8.2f} x real time "
        f"({result['env_wall_s']:.2f} s wall, {result['mean_live_agents']:g} live agents "
        f"on average)\n"
        f"  fftnav bench sim            {result['sim_real_time_factor']:8.2f} x real time "
        f"({result['sim_wall_s']:.2f} s wall)\n"
        f"  ratio env / sim             {result['ratio']:8.3f}\n"
        f"  load average (1 min)        {result['load_avg_1min']:8.2f}"
    )
