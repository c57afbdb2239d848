"""``fftnav leaderboard build [--out DIR]`` and ``fftnav leaderboard add EVAL_DIR [--out DIR]``:
write the leaderboard of every built-in on every suite, and add a method evaluated by
``fftnav evaluate`` to it (:mod:`fftnav.suites.leaderboard`)."""

from __future__ import annotations

import argparse

DEFAULT_OUT = "results/leaderboard"


def cmd_leaderboard(args: argparse.Namespace) -> int:
    """Rebuild the leaderboard folder (after adding a submission, with ``add``)."""
    from fftnav import __version__
    from fftnav.report.leaderboard import write_leaderboard
    from fftnav.suites.leaderboard import add_submission, leaderboard_episodes, rank_suites

    added = None
    if args.action == "add":
        added = add_submission(args.evaluation, args.out)
        print(f"added {added} from {args.evaluation}")
    found = leaderboard_episodes(args.out)
    table = rank_suites(found)
    episodes = {name: rows for name, (rows, _) in found.items()}
    written = write_leaderboard(args.out, table, episodes=episodes, highlight=added,
                                generated=f"fftnav {__version__}")
    print(f"leaderboard: {len(table)} rows over {table['suite'].nunique()} suites; "
          f"{', '.join(str(p) for p in written[:3])}, ...")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("leaderboard", help="write the leaderboard, or add an evaluated method "
                       "to it (docs/experiments.md)")
    actions = p.add_subparsers(dest="action", metavar="ACTION", parser_class=type(p))
    actions.required = True
    build = actions.add_parser("build", help="every built-in on every suite, and the methods "
                               "added before")
    build.add_argument("--out", metavar="DIR", default=DEFAULT_OUT,
                       help=f"the leaderboard folder (default: {DEFAULT_OUT})")
    add = actions.add_parser("add", help="check an fftnav evaluate folder and add its method")
    add.add_argument("evaluation", metavar="EVAL_DIR", help="a folder written by fftnav evaluate")
    add.add_argument("--out", metavar="DIR", default=DEFAULT_OUT,
                     help=f"the leaderboard folder (default: {DEFAULT_OUT})")
    for parser in (build, add):
        parser.set_defaults(func=cmd_leaderboard)
