"""``fftnav run CONFIG [--out DIR] [--workers N] [--executor local|dask] [--scheduler ADDR]
[--fresh] [--quiet]``: run or resume an experiment, then write its summary and report."""

from __future__ import annotations

import argparse
import sys
from typing import Any


def cmd_run(args: argparse.Namespace) -> int:
    """Run (or resume) an experiment, then write its summary, report and figures.

    Exit status 0 when every episode finished, 1 when some raised (see ``DIR/errors.csv``),
    130 when interrupted (Ctrl-C), 143 when terminated (SIGTERM): rerun the same command to
    resume.
    """
    from fftnav.runner import load_config

    config = load_config(args.config)
    if config.cells:
        return _run_sweep(args, config)
    return _run_one(args, config)


def _run_one(args: argparse.Namespace, config: Any) -> int:
    """Run one experiment (a config or a sweep cell) and write its report."""
    from fftnav.cli import EXIT_INTERRUPTED, EXIT_TERMINATED, Terminated
    from fftnav.report.experiment import write_report
    from fftnav.runner import run_experiment

    out = args.out or config.out
    try:
        outcome = run_experiment(config, out, workers=args.workers, executor=args.executor,
                                 scheduler=args.scheduler, progress=not args.quiet,
                                 fresh=args.fresh)
    except (KeyboardInterrupt, Terminated) as exc:
        term = isinstance(exc, Terminated)
        sys.stderr.write(f"fftnav run: {'terminated' if term else 'interrupted'}; finished "
                         f"episodes are kept in {out}, rerun the same command to resume\n")
        return EXIT_TERMINATED if term else EXIT_INTERRUPTED
    report = write_report(config, out)
    print(f"{outcome.completed} episodes run, {outcome.skipped} already done, "
          f"{len(outcome.failed)} failed, {outcome.wall_time_s:.1f} s; report: {report}")
    for task, error in outcome.failed:
        sys.stderr.write(f"fftnav run: {task.task_id} failed: {error.error_type}: "
                         f"{error.message}\n")
    return 1 if outcome.failed else 0


def _run_sweep(args: argparse.Namespace, config: Any) -> int:
    """Run (or resume) every cell of a ``[sweep]`` config into ``OUT/<cell>``, then write the
    sweep report ``OUT/report.md`` (gains against own-only per axis)."""
    from pathlib import Path

    from fftnav.cli import EXIT_INTERRUPTED, EXIT_TERMINATED
    from fftnav.report.sweep import write_sweep_report

    root = Path(args.out or config.out)
    status = 0
    for name, cell in config.cells:
        print(f"fftnav run: sweep cell {name} -> {root / name}")
        sub = argparse.Namespace(**{**vars(args), "out": str(root / name)})
        code = _run_one(sub, cell)
        if code in (EXIT_INTERRUPTED, EXIT_TERMINATED):
            return code
        status = max(status, code)
    report = write_sweep_report(config, root)
    print(f"sweep report: {report}")
    return status


def register(sub: argparse._SubParsersAction) -> None:
    from fftnav.cli import workers_count

    p = sub.add_parser("run", help="run an experiment config (resumable) and write its report")
    p.add_argument("config", metavar="CONFIG", help="experiment TOML, e.g. experiments/smoke.toml")
    p.add_argument("--out", metavar="DIR", help="output folder (default: experiment.out)")
    p.add_argument("--workers", type=workers_count, metavar="N",
                   help="worker processes (default: all cores; 1 runs in-process)")
    p.add_argument("--executor", choices=("local", "dask"), default="local",
                   help="local process pool (default) or a Dask cluster")
    p.add_argument("--scheduler", metavar="ADDR",
                   help="Dask scheduler address, e.g. tcp://host:8786 (default: a LocalCluster)")
    p.add_argument("--fresh", action="store_true",
                   help="rerun every episode from scratch instead of resuming; results of another "
                   "config in DIR are deleted first")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_run)
