"""``fftnav bench {pipeline,sim,scale,env,optimal,worlds,drift,bag}``: measured latency,
simulation speed, scale, the PettingZoo environment, the optimal-path reference, large worlds,
the odometry drift presets, the cost of an episode's bag."""

from __future__ import annotations

import argparse
import json

from fftnav.world.kinds import world_kinds


def _report(result: dict, args: argparse.Namespace, table: str,
            match: tuple[str, ...] = ()) -> int:
    """Record ``result`` in ``--csv`` if asked, then print it as JSON or as a table followed by
    the comparison with the paper and with the previous record (``--previous``, read before
    ``--csv`` is written; rows of the same ``match`` keys)."""
    from fftnav.bench.compare import format_comparison, previous_row
    from fftnav.bench.pipeline import record_csv

    source = args.previous or args.csv or _DEFAULT_PREVIOUS[args.bench]
    previous = previous_row(source, {k: result[k] for k in match})
    if args.csv:
        record_csv(result, args.csv, append=args.append)
    print(json.dumps(result) if args.json else
          f"{table}\n{format_comparison(result, previous, source)}")
    return 0


#: The committed results each bench compares itself with by default (if present).
_DEFAULT_PREVIOUS = {"pipeline": "results/pipeline_latency.csv", "sim": "results/sim_speed.csv",
                     "env": "results/env_speed.csv", "bag": "results/bag_speed.csv",
                     "optimal": "results/optimal.csv", "scale": "results/scale.csv"}


def cmd_bench_pipeline(args: argparse.Namespace) -> int:
    """Time the observation pipeline per scan (single and batch of 15) and its alternatives."""
    from fftnav.bench.pipeline import bench_pipeline, format_pipeline

    result = bench_pipeline(repeats=args.repeats, runs=args.runs)
    return _report(result, args, format_pipeline(result))


def cmd_bench_sim(args: argparse.Namespace) -> int:
    """Real-time factor of the 15-robot swarm and lidar cost per tick."""
    from fftnav.bench.sim import bench_sim, format_sim

    result = bench_sim(env=args.env, seconds=args.seconds, seed=args.seed, robots=args.robots,
                       size_m=args.size, runs=args.runs)
    return _report(result, args, format_sim(result), match=("env", "robots"))


def cmd_bench_scale(args: argparse.Namespace) -> int:
    """Real-time factor and cost per robot-second for growing swarms on grown maps."""
    from fftnav.bench.compare import previous_row
    from fftnav.bench.scale import bench_scale, format_scale, growth, write_scale_csv
    from fftnav.report.scale_figure import draw_scale_figure

    previous = args.previous or args.csv
    rows = bench_scale(envs=args.env, robots=args.robots, seconds=args.seconds, seed=args.seed,
                       runs=args.runs)
    before = {(r["env"], r["robots"]): previous_row(previous, {"env": r["env"],
                                                               "robots": r["robots"]})
              for r in rows}
    write_scale_csv(rows, args.csv)
    figure = draw_scale_figure(rows, args.figure)
    if args.json:
        print(json.dumps({"rows": rows, "growth": {env: growth(rows, env) for env in args.env}}))
        return 0
    print(format_scale(rows))
    for r in rows:
        old = before[r["env"], r["robots"]]
        if old is not None:
            print(f"  {r['env']} N={r['robots']}: {r['ms_per_robot_s']:g} ms per robot-second, "
                  f"previous {float(old['ms_per_robot_s']):g} in {previous} "
                  f"(new/old x{r['ms_per_robot_s'] / float(old['ms_per_robot_s']):.2f})")
    print(f"table: {args.csv}; figure: {figure}")
    return 0


def cmd_bench_env(args: argparse.Namespace) -> int:
    """Random-rollout speed of the PettingZoo environment beside ``fftnav bench sim``."""
    from fftnav.bench.env import bench_env, format_env

    result = bench_env(env=args.env, seconds=args.seconds, seed=args.seed)
    return _report(result, args, format_env(result))


def cmd_bench_bag(args: argparse.Namespace) -> int:
    """An episode without and with ``--bag``, alternating in one process."""
    from fftnav.bench.bag import bench_bag, format_bag

    result = bench_bag(env=args.env, seed=args.seed, seconds=args.seconds,
                       repeats=args.repeats, suffix=args.suffix)
    return _report(result, args, format_bag(result), match=("env", "suffix"))


def cmd_bench_optimal(args: argparse.Namespace) -> int:
    """Time the optimal-path reference (heapq A* vs batched Dijkstra) on a generated world."""
    from fftnav.bench.optimal import bench_optimal_paths, format_optimal_paths

    result = bench_optimal_paths(env=args.env, seed=args.seed, r0_m=args.r0)
    return _report(result, args, format_optimal_paths(result))


def cmd_bench_worlds(args: argparse.Namespace) -> int:
    """Large worlds: time to the first scan (and a 5 s episode) in a 20,000-trunk world and in
    the largest one the limits allow; with ``--against``, old against new side by side."""
    from fftnav.bench.pipeline import record_csv
    from fftnav.bench.worlds import bench_worlds, format_worlds, side_by_side

    if args.against:
        results = side_by_side(args.against, case=(args.case or ["trunks-20k"])[0],
                               repeats=args.repeats, seed=args.seed)
        text = "\n".join(json.dumps(r) for r in results)
    else:
        results = bench_worlds(args.case or None, seed=args.seed)
        text = format_worlds(results)
    for i, result in enumerate(results):
        if args.csv:
            record_csv(result, args.csv, append=args.append or i > 0)
    print("\n".join(json.dumps(r) for r in results) if args.json else text)
    return 0


def cmd_bench_drift(args: argparse.Namespace) -> int:
    """The drift of each odometry preset, on reference paths and on an episode's paths."""
    from fftnav.bench.drift import bench_drift, format_drift
    from fftnav.bench.pipeline import record_csv

    rows = bench_drift(runs=args.runs, seed=args.seed)
    for i, row in enumerate(rows):
        if args.csv:
            record_csv(row, args.csv, append=i > 0)
    print("\n".join(json.dumps(r) for r in rows) if args.json else format_drift(rows))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="measure latency and simulation speed")
    benches = p.add_subparsers(dest="bench", metavar="BENCH", parser_class=type(p))
    benches.required = True
    for add in (_pipeline_parser, _sim_parser, _env_parser, _scale_parser, _optimal_parser,
                _worlds_parser, _drift_parser, _bag_parser):
        add(benches)


def _drift_parser(benches: argparse._SubParsersAction) -> None:
    d = benches.add_parser("drift", help="drift of the odometry presets (docs/localization.md)")
    d.add_argument("--runs", type=int, default=20_000,
                   help="simulated robots per preset and path (default 20000)")
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--json", action="store_true", help="print one JSON object per preset")
    d.add_argument("--csv", metavar="PATH", help="also record the rows in this CSV")
    d.set_defaults(func=cmd_bench_drift)


def _record_options(q: argparse.ArgumentParser) -> None:
    """``--json``, ``--csv``, ``--append``, ``--previous`` of a bench that :func:`_report`s."""
    q.add_argument("--json", action="store_true", help="print one JSON object")
    q.add_argument("--csv", metavar="PATH", help="also record the run in this CSV")
    q.add_argument("--append", action="store_true", help="append to --csv instead of replacing")
    q.add_argument("--previous", metavar="PATH",
                   help="CSV of the previous result to compare with (default: --csv, else "
                        "the committed file under results/)")


def _pipeline_parser(benches: argparse._SubParsersAction) -> None:
    b = benches.add_parser("pipeline", help="latency of the FFT observation pipeline")
    b.add_argument("--repeats", type=int, default=2000, help="timed repetitions (default 2000)")
    b.add_argument("--runs", type=int, default=1,
                   help="independent runs; each figure is the best of them (default 1)")
    _record_options(b)
    b.set_defaults(func=cmd_bench_pipeline)


def _sim_parser(benches: argparse._SubParsersAction) -> None:
    s = benches.add_parser("sim", help="real-time factor of the PyBullet swarm")
    s.add_argument("--env", choices=world_kinds(), default="forest")
    s.add_argument("--seconds", type=float, default=20.0, help="simulated seconds (default 20)")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--robots", type=int, default=15, help="number of robots (default 15)")
    s.add_argument("--size", type=float, default=None, metavar="M",
                   help="side of the square map, m (default: the preset's robots per m^2, "
                        "20 m for 15 robots)")
    s.add_argument("--runs", type=int, default=1,
                   help="independent runs; the best real-time factor is reported (default 1)")
    _record_options(s)
    s.set_defaults(func=cmd_bench_sim)


def _env_parser(benches: argparse._SubParsersAction) -> None:
    e = benches.add_parser("env", help="speed of the PettingZoo environment beside bench sim "
                           "(needs fftnav[marl])")
    e.add_argument("--env", choices=world_kinds(), default="forest")
    e.add_argument("--seconds", type=float, default=60.0, help="simulated seconds (default 60)")
    e.add_argument("--seed", type=int, default=0)
    _record_options(e)
    e.set_defaults(func=cmd_bench_env)


def _bag_parser(benches: argparse._SubParsersAction) -> None:
    g = benches.add_parser("bag", help="an episode without and with --bag (needs fftnav[ros])")
    g.add_argument("--env", choices=world_kinds(), default="forest")
    g.add_argument("--seed", type=int, default=1000, help="world seed (default 1000)")
    g.add_argument("--seconds", type=float, default=20.0,
                   help="the episode's time limit (default 20)")
    g.add_argument("--repeats", type=int, default=3, help="runs of each (default 3)")
    g.add_argument("--suffix", choices=(".mcap", ".db3", ".bag"), default=".mcap",
                   help="the bag's kind (default .mcap)")
    _record_options(g)
    g.set_defaults(func=cmd_bench_bag)


def _scale_parser(benches: argparse._SubParsersAction) -> None:
    c = benches.add_parser("scale", help="cost per robot-second for N = 15 ... 200 robots")
    c.add_argument("--env", choices=world_kinds(), nargs="+", default=["forest", "rocky"])
    c.add_argument("--robots", type=int, nargs="+", default=[15, 50, 100, 200])
    c.add_argument("--seconds", type=float, default=20.0, help="simulated seconds (default 20)")
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--runs", type=int, default=1, help="best of this many runs (default 1)")
    c.add_argument("--csv", default="results/scale.csv", help="table (default results/scale.csv)")
    c.add_argument("--figure", default="results/figures/scale.png",
                   help="plot (default results/figures/scale.png)")
    c.add_argument("--json", action="store_true", help="print one JSON object")
    c.add_argument("--previous", metavar="PATH",
                   help="CSV of the previous result to compare with (default: --csv)")
    c.set_defaults(func=cmd_bench_scale)


def _optimal_parser(benches: argparse._SubParsersAction) -> None:
    g = benches.add_parser("optimal", help="time of the optimal-path reference (A*, geodesic)")
    g.add_argument("--env", choices=world_kinds(), default="forest")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--r0", type=float, default=0.15, help="inflation radius r0, m (default 0.15)")
    _record_options(g)
    g.set_defaults(func=cmd_bench_optimal)


def _worlds_parser(benches: argparse._SubParsersAction) -> None:
    w = benches.add_parser("worlds", help="large worlds: time to the first scan, an episode, "
                                          "memory")
    w.add_argument("--case", action="append", metavar="NAME",
                   help="trunks-20k or largest (repeatable; default: all)")
    w.add_argument("--seed", type=int, default=0)
    w.add_argument("--against", metavar="DIR",
                   help="another fftnav source tree (e.g. git archive of an older commit): "
                        "run it and this code alternately on the first case's world")
    w.add_argument("--repeats", type=int, default=2, help="alternations with --against")
    _record_options(w)
    w.set_defaults(func=cmd_bench_worlds)
