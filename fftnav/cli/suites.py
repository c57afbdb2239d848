"""``fftnav suites [--references --runs DIR [--suite NAME ...] [--workers N]]``: list the
versioned benchmark suites, or (maintainers) run every built-in on them and write the
package's reference rows (:mod:`fftnav.suites`)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from fftnav.suites import Suite


def cmd_suites(args: argparse.Namespace) -> int:
    """Print each suite: name, version, maps, what it measures, its references; or make the
    references."""
    from fftnav.suites import ordered_suites

    if args.references:
        return _references(args)
    if args.runs or args.suite:
        from fftnav.cli import CliError

        raise CliError("--runs and --suite go with --references")
    for suite in ordered_suites():
        print(f"{suite.name}  (version {suite.version} of '{suite.family}')")
        print(f"    {suite.description}")
        print(f"    measures {suite.measures}")
        print(f"    {_references_line(suite)}")
    return 0


def _references_line(suite: Suite) -> str:
    from fftnav.suites import ReferenceError, read_references

    try:
        episodes, _ = read_references(suite)
    except ReferenceError as exc:
        return f"references: none ({exc})"
    maps = episodes.groupby(["env", "map_seed"]).ngroups
    return (f"references: {episodes['policy'].nunique()} built-ins x {maps} maps "
            f"({', '.join(sorted(episodes['policy'].unique()))})")


def _references(args: argparse.Namespace) -> int:
    from pathlib import Path

    from fftnav.cli import CliError
    from fftnav.suites import resolve_suites, write_references
    from fftnav.suites.evaluate import Options, run_references

    if not args.runs:
        raise CliError("--references needs --runs DIR, the folder the runs go to (resumable)")
    chosen = resolve_suites(args.suite or ["paper", "walls", "traps"])
    options = Options(workers=args.workers, progress=not args.quiet)
    for part in {p.name: p for s in chosen for p in s.parts}.values():
        part.check()
        episodes, timing = run_references(part, Path(args.runs) / part.name, options=options)
        print(f"{part.name}: references written to {write_references(part, episodes, timing)}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    from fftnav.cli import workers_count

    p = sub.add_parser("suites", help="list the versioned benchmark suites (docs/experiments.md)")
    p.add_argument("--references", action="store_true",
                   help="maintainers: run every built-in on the suites and write the "
                   "package's reference rows")
    p.add_argument("--runs", metavar="DIR", help="with --references: where the runs go")
    p.add_argument("--suite", action="append", metavar="NAME",
                   help="with --references: only these suites (default: all)")
    p.add_argument("--workers", type=workers_count, metavar="N",
                   help="worker processes (default: all cores)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_suites)
