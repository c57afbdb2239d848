"""``fftnav bench {pipeline,sim,planning,worlds}``: measured latency, simulation speed, large
worlds."""

from __future__ import annotations

import argparse
import json

from fftnav.world.kinds import world_kinds


def _report(result: dict, args: argparse.Namespace, table: str) -> int:
    """Record ``result`` in ``--csv`` if asked, then print it as JSON or as a table."""
    if args.csv:
        from fftnav.bench.pipeline import record_csv

        record_csv(result, args.csv, append=args.append)
    print(json.dumps(result) if args.json else table)
    return 0


def cmd_bench_pipeline(args: argparse.Namespace) -> int:
    """Time the observation pipeline per scan (single and batch of 15) and its alternatives."""
    from fftnav.bench.pipeline import bench_pipeline, format_pipeline

    result = bench_pipeline(repeats=args.repeats)
    return _report(result, args, format_pipeline(result))


def cmd_bench_sim(args: argparse.Namespace) -> int:
    """Real-time factor of the 15-robot swarm and lidar cost per tick."""
    from fftnav.bench.sim import bench_sim, format_sim

    result = bench_sim(env=args.env, seconds=args.seconds, seed=args.seed)
    return _report(result, args, format_sim(result))


def cmd_bench_env(args: argparse.Namespace) -> int:
    """Random-rollout speed of the PettingZoo environment beside ``fftnav bench sim``."""
    from fftnav.bench.env import bench_env, format_env

    result = bench_env(env=args.env, seconds=args.seconds, seed=args.seed)
    return _report(result, args, format_env(result))


def cmd_bench_planning(args: argparse.Namespace) -> int:
    """Time the optimal-path reference (heapq A* vs batched Dijkstra) on a generated world."""
    from fftnav.bench.planning import bench_optimal_paths, format_optimal_paths

    result = bench_optimal_paths(env=args.env, seed=args.seed, r0_m=args.r0)
    return _report(result, args, format_optimal_paths(result))


def cmd_bench_worlds(args: argparse.Namespace) -> int:
    """Large worlds: a 60 m x 60 m forest and a 10,000-obstacle forest run an episode."""
    from fftnav.bench.pipeline import record_csv
    from fftnav.bench.worlds import bench_worlds, format_worlds

    results = bench_worlds(args.case or None, seed=args.seed, drive_s=args.drive,
                           episode_s=args.episode)
    for i, result in enumerate(results):
        if args.csv:
            record_csv(result, args.csv, append=args.append or i > 0)
    print("\n".join(json.dumps(r) for r in results) if args.json else format_worlds(results))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="measure latency and simulation speed")
    benches = p.add_subparsers(dest="bench", metavar="BENCH", parser_class=type(p))
    benches.required = True

    b = benches.add_parser("pipeline", help="latency of the FFT observation pipeline")
    b.add_argument("--repeats", type=int, default=2000, help="timed repetitions (default 2000)")
    b.set_defaults(func=cmd_bench_pipeline)

    s = benches.add_parser("sim", help="real-time factor of the PyBullet swarm")
    s.add_argument("--env", choices=world_kinds(), default="forest")
    s.add_argument("--seconds", type=float, default=20.0, help="simulated seconds (default 20)")
    s.add_argument("--seed", type=int, default=0)
    s.set_defaults(func=cmd_bench_sim)

    e = benches.add_parser("env", help="speed of the PettingZoo environment beside bench sim "
                           "(needs fftnav[marl])")
    e.add_argument("--env", choices=world_kinds(), default="forest")
    e.add_argument("--seconds", type=float, default=60.0, help="simulated seconds (default 60)")
    e.add_argument("--seed", type=int, default=0)
    e.set_defaults(func=cmd_bench_env)

    g = benches.add_parser("planning", help="time of the optimal-path reference (A*, geodesic)")
    g.add_argument("--env", choices=world_kinds(), default="forest")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--r0", type=float, default=0.15, help="inflation radius r0, m (default 0.15)")
    g.set_defaults(func=cmd_bench_planning)

    w = benches.add_parser("worlds", help="large worlds: build, speed, memory, one episode each")
    w.add_argument("--case", action="append", metavar="NAME",
                   help="forest-60m or forest-10k (repeatable; default: all)")
    w.add_argument("--seed", type=int, default=0)
    w.add_argument("--drive", type=float, default=5.0,
                   help="simulated seconds of random driving for the real-time factor")
    w.add_argument("--episode", type=float, default=20.0,
                   help="time limit of the fusion episode, simulated seconds (default 20)")
    w.set_defaults(func=cmd_bench_worlds)

    for q in (b, s, g, w):
        q.add_argument("--json", action="store_true", help="print one JSON object")
        q.add_argument("--csv", metavar="PATH", help="also record the run in this CSV")
        q.add_argument("--append", action="store_true", help="append to --csv instead of replacing")
