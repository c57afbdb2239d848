"""``fftnav figure {filters,depth3d,sweep,report,failures}``: draw the paper's figures and the
reports of results folders."""

from __future__ import annotations

import argparse
from pathlib import Path

from fftnav.cli import workers_count
from fftnav.errors import FftnavError


def cmd_figure_filters(args: argparse.Namespace) -> int:
    """Draw the panels of the paper's Fig. 3 and Fig. 5 into ``args.out``."""
    from fftnav.report.filters_figure import draw_filter_figures

    for path in draw_filter_figures(Path(args.out)):
        print(path)
    return 0


def cmd_figure_depth3d(args: argparse.Namespace) -> int:
    """Draw the paper's Fig. 4 (depth image and safe domain) into ``args.out``."""
    from fftnav.report.depth3d import draw_depth3d_figure

    if args.seed < 0:
        raise FftnavError(f"--seed must be an integer >= 0, got --seed={args.seed}")
    for path in draw_depth3d_figure(Path(args.out), seed=args.seed):
        print(path)
    return 0


def cmd_figure_sweep(args: argparse.Namespace) -> int:
    """The sweep report (gains over own-only, collab against fusion) of a results folder."""
    from fftnav.report.sweep import write_sweep_report
    from fftnav.runner import load_config

    config = load_config(args.config)
    print(write_sweep_report(config, args.out or config.out))
    return 0


def cmd_figure_drift(args: argparse.Namespace) -> int:
    """SPL and AR of every method against the odometry's drift (docs/localization.md)."""
    from fftnav.report.drift import write_drift_report
    from fftnav.runner import load_config

    configs = [load_config(c) for c in args.config]
    roots = [c.out for c in configs]
    print(write_drift_report(configs, roots, args.out, exact=args.exact, sources=args.config))
    return 0


def cmd_figure_report(args: argparse.Namespace) -> int:
    """``maps.csv`` (if missing or stale) and the report of a finished results folder, running
    no episode."""
    from fftnav.report.experiment import report_folder
    from fftnav.runner import load_config

    config = load_config(args.config)
    print(report_folder(config, args.out or config.out, workers=args.workers))
    return 0


def cmd_figure_failures(args: argparse.Namespace) -> int:
    """The robots of one episode of a results folder that did not arrive (docs/planner.md);
    an episode whose paths the folder does not keep is rerun, checked against its rows."""
    from fftnav.files import check_target
    from fftnav.report.experiment import draw_failures
    from fftnav.runner import load_config

    check_target(args.out, flag="--out", make_folder=True, image=True)
    config = load_config(args.config)
    draw_failures(config, args.results or config.out, env=args.env, map_seed=args.map,
                  policy=args.policy, path=args.out)
    print(args.out)
    return 0


def cmd_figure_learning(args: argparse.Namespace) -> int:
    """Learning curves over seeds and the learned methods beside the built-ins
    (:mod:`fftnav.report.learning`)."""
    from fftnav.cli import CliError
    from fftnav.files import check_input
    from fftnav.report.learning import write_learning_report

    for folder in args.runs:
        for name in ("config.json", "curve.csv", "run.json"):
            check_input(f"{folder}/{name}")
    for folder in args.table1 or []:
        check_input(f"{folder}/episodes.csv")
    if not 0 < args.threshold <= 1:
        raise CliError(f"--threshold must be in (0, 1], got --threshold={args.threshold}")
    print(write_learning_report(args.runs, args.out, table1=args.table1,
                                threshold=args.threshold, order=args.policies))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("figure", help="draw the paper's figures")
    figs = p.add_subparsers(dest="figure", metavar="FIGURE", parser_class=type(p))
    figs.required = True
    f = figs.add_parser("filters", help="Fig. 3 and Fig. 5: filters, safe directions, extrema")
    f.add_argument("--out", required=True, metavar="DIR", help="output folder for the PNGs")
    f.set_defaults(func=cmd_figure_filters)
    d = figs.add_parser("depth3d", help="Fig. 4: spherical depth image and safe flight domain")
    d.add_argument("--out", required=True, metavar="DIR", help="output folder for the PNGs")
    d.add_argument("--seed", type=int, default=0, help="seed of the 3D forest (default 0)")
    d.set_defaults(func=cmd_figure_depth3d)
    w = figs.add_parser("sweep", help="sweep report: gains over own-only per cell and axis")
    w.add_argument("config", help="experiment TOML (with or without [sweep])")
    w.add_argument("--out", metavar="DIR", help="results folder (default: experiment.out)")
    w.set_defaults(func=cmd_figure_sweep)
    dr = figs.add_parser("drift", help="SPL and AR of every method against odometry drift")
    dr.add_argument("config", nargs="+", help="drift experiment TOMLs (experiments/drift/)")
    dr.add_argument("--exact", nargs="*", default=[], metavar="DIR",
                    help="results folders of the same maps with exact localization")
    dr.add_argument("--out", required=True, metavar="DIR", help="output folder")
    dr.set_defaults(func=cmd_figure_drift)
    r = figs.add_parser("report", help="maps.csv and report.md of a finished results folder "
                        "(no episode run, its CSVs and run_info.json untouched)")
    r.add_argument("config", help="experiment TOML of the results folder")
    r.add_argument("--out", metavar="DIR", help="results folder (default: experiment.out)")
    r.add_argument("--workers", type=workers_count, default=1, metavar="N",
                   help="processes computing maps.csv (default 1)")
    r.set_defaults(func=cmd_figure_report)
    x = figs.add_parser("failures", help="paths of the robots of one episode that failed")
    x.add_argument("config", help="experiment TOML of the results folder")
    x.add_argument("--results", metavar="DIR", help="results folder (default: experiment.out)")
    x.add_argument("--env", required=True)
    x.add_argument("--map", type=int, required=True, help="map seed")
    x.add_argument("--policy", required=True)
    x.add_argument("--out", required=True, metavar="PNG")
    x.set_defaults(func=cmd_figure_failures)
    lr = figs.add_parser("learning", help="learning curves over seeds and the learned methods "
                         "on Table I's maps (docs/learning.md)")
    lr.add_argument("runs", nargs="+", metavar="RUN", help="training folders of fftnav learn")
    lr.add_argument("--table1", nargs="+", metavar="DIR",
                    help="results folders of the same maps: the learned methods' and the "
                    "built-ins' rows (each method in one of them)")
    lr.add_argument("--policies", nargs="+", metavar="NAME",
                    help="the methods of --table1 shown, in this order (default: all)")
    lr.add_argument("--threshold", type=float, default=0.8,
                    help="validation AR whose first crossing is reported (default 0.8)")
    lr.add_argument("--out", required=True, metavar="DIR", help="output folder")
    lr.set_defaults(func=cmd_figure_learning)
