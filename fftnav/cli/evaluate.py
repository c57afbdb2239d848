"""``fftnav evaluate METHOD [--suite NAME ...] [--out DIR] [--workers N] [--dask ADDRESS]
[--no-rerun] [--quiet]``: rank one method on versioned suites beside every built-in
(:mod:`fftnav.suites.evaluate`)."""

from __future__ import annotations

import argparse
import re
import sys


def _default_out(method: str) -> str:
    """``evaluations/<method>`` with the characters a folder name cannot hold replaced."""
    name = method.rpartition(":")[2] or method
    return f"evaluations/{re.sub(r'[^A-Za-z0-9_.+-]', '_', name)}"


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Run METHOD on each suite, check and join the references, print the ranked tables and
    write the folder; 130/143 when interrupted (rerun the same command to resume)."""
    from fftnav.cli import EXIT_INTERRUPTED, EXIT_TERMINATED, Terminated
    from fftnav.navigation.resolve import resolve
    from fftnav.report.leaderboard import terminal_table, write_evaluation
    from fftnav.suites import resolve_suites
    from fftnav.suites.evaluate import Options, evaluate

    suites = resolve_suites(args.suite or ["paper"])  # unknown names refused before any run
    name = resolve(args.method).name
    out = args.out or _default_out(name)
    options = Options(workers=args.workers, executor="dask" if args.dask else "local",
                      scheduler=args.dask, progress=not args.quiet, rerun=not args.no_rerun)
    try:
        evaluation = evaluate(args.method, [s.name for s in suites], out, options=options,
                              say=lambda text: print(f"fftnav evaluate: {text}", flush=True))
    except (KeyboardInterrupt, Terminated) as exc:
        term = isinstance(exc, Terminated)
        sys.stderr.write(f"fftnav evaluate: {'terminated' if term else 'interrupted'}; "
                         f"finished episodes are kept in {out}, rerun the same command to "
                         "resume\n")
        return EXIT_TERMINATED if term else EXIT_INTERRUPTED
    report = write_evaluation(evaluation)
    for result in evaluation.suites:
        print(f"\n{result.suite.name}: {result.suite.description}")
        print(terminal_table(result.table, highlight=evaluation.method))
    print(f"\nreport: {report}; leaderboard.csv, tests.csv, evaluation.json in {out}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    from fftnav.cli import workers_count

    p = sub.add_parser("evaluate", help="rank a method on versioned suites beside every "
                       "built-in (docs/experiments.md)")
    p.add_argument("method", metavar="METHOD",
                   help="a built-in name, module:attr, path/to/file.py:attr or an entry point")
    p.add_argument("--suite", action="append", metavar="NAME",
                   help="a suite or family (repeatable; default: paper); see fftnav suites")
    p.add_argument("--out", metavar="DIR",
                   help="output folder (default: evaluations/<method>); a rerun resumes it")
    p.add_argument("--workers", type=workers_count, metavar="N",
                   help="worker processes (default: all cores; 1 runs in-process)")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="run the episodes on this Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--no-rerun", action="store_true",
                   help="refuse, instead of rerunning them, references that do not reproduce "
                   "on this machine")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_evaluate)
