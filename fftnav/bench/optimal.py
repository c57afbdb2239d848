"""Timing of the optimal-path reference on a generated world (``fftnav bench optimal``).

Side by side in one run, on the world's 0.05 m grid inflated by r0: the readable heapq A*
(:func:`fftnav.optimal.astar.astar`, one query per robot), the batched compiled Dijkstra
with 8-connected moves (the same lengths, checked) and with 32-connected moves (geodesic), and
the compiled A* of :mod:`fftnav.optimal.gridsearch` (what ``optimal_lengths`` uses when numba
is installed) with both move sets.
"""

from __future__ import annotations

import time

import numpy as np

from fftnav.optimal import gridsearch
from fftnav.optimal.astar import astar
from fftnav.optimal.gridgraph import shortest_paths
from fftnav.optimal.reference import robot_cells
from fftnav.validate import check_number
from fftnav.world import generate_world
from fftnav.world.grid import occupancy_grid

__all__ = ["bench_optimal_paths", "format_optimal_paths"]


def bench_optimal_paths(
    env: str = "forest", seed: int = 0, *, r0_m: float = 0.15, resolution_m: float = 0.05
) -> dict:
    """Time the optimal-path solvers for all robots of ``generate_world(env, seed)``.

    Returns
    -------
    dict
        ``robots``, ``grid_cells``, seconds for all robots (``heapq_astar_s``,
        ``csgraph_8_s``, ``csgraph_32_s``), ``max_length_diff_cells`` between heapq A* and
        8-connected Dijkstra, and mean lengths in metres (``astar_m``, ``geodesic_m``,
        ``euclidean_m``).
    """
    check_number("r0_m", r0_m, low=0)
    world = generate_world(env, seed)
    og = occupancy_grid(world, resolution_m=resolution_m, inflate_m=r0_m)
    starts, goals = robot_cells(og, world)
    t0 = time.perf_counter()
    reference = [astar(og.grid, s, g) for s, g in zip(starts, goals, strict=True)]
    t1 = time.perf_counter()
    fast8 = shortest_paths(og.grid, starts, goals, connectivity=8)
    t2 = time.perf_counter()
    fast32 = shortest_paths(og.grid, starts, goals, connectivity=32)
    t3 = time.perf_counter()
    lengths8 = np.array([p.length_cells for p in fast8])
    lengths32 = np.array([p.length_cells for p in fast32])
    compiled: dict[str, float | None] = {"compiled_astar_8_s": None, "compiled_astar_32_s": None,
                                         "compiled_max_rel_diff": None}
    if gridsearch.AVAILABLE:
        gridsearch.astar_lengths(og.grid, starts[:1], goals[:1])  # compiled or loaded once
        t4 = time.perf_counter()
        a8 = gridsearch.astar_lengths(og.grid, starts, goals, connectivity=8)
        t5 = time.perf_counter()
        a32 = gridsearch.astar_lengths(og.grid, starts, goals, connectivity=32)
        t6 = time.perf_counter()
        compiled = {"compiled_astar_8_s": t5 - t4, "compiled_astar_32_s": t6 - t5,
                    "compiled_max_rel_diff": float(max(np.max(np.abs(a8 / lengths8 - 1)),
                                                       np.max(np.abs(a32 / lengths32 - 1))))}
    return {
        "bench": "optimal",
        "env": env,
        "seed": seed,
        "robots": len(starts),
        "grid_cells": f"{og.grid.shape[0]}x{og.grid.shape[1]}",
        "heapq_astar_s": t1 - t0,
        "csgraph_8_s": t2 - t1,
        "csgraph_32_s": t3 - t2,
        "max_length_diff_cells": float(
            np.max(np.abs(lengths8 - [p.length_cells for p in reference]))
        ),
        "astar_m": float(lengths8.mean() * resolution_m),
        "geodesic_m": float(lengths32.mean() * resolution_m),
        "euclidean_m": float(np.hypot(*(world.goals - world.starts[:, :2]).T).mean()),
        **compiled,
    }


def format_optimal_paths(result: dict) -> str:
    """A short plain-text table of :func:`bench_optimal_paths` results."""
    r = result
    return "\n".join(
        [
            f"{r['env']} seed {r['seed']}: {r['robots']} robots, grid {r['grid_cells']}",
            f"  heapq A* (8-conn, reference)   {r['heapq_astar_s']:.3f} s",
            f"  csgraph Dijkstra 8-conn        {r['csgraph_8_s']:.3f} s"
            f"  (max length diff {r['max_length_diff_cells']:.1e} cells)",
            f"  csgraph Dijkstra 32-conn       {r['csgraph_32_s']:.3f} s",
            *([] if r["compiled_astar_8_s"] is None else [
                f"  compiled A* 8-conn / 32-conn   {r['compiled_astar_8_s']:.3f} s / "
                f"{r['compiled_astar_32_s']:.3f} s  (max relative length diff "
                f"{r['compiled_max_rel_diff']:.1e})"]),
            f"  mean length: A* {r['astar_m']:.3f} m, geodesic {r['geodesic_m']:.3f} m, "
            f"straight line {r['euclidean_m']:.3f} m",
        ]
    )
