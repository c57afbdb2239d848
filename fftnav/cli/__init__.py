"""The ``fftnav`` command line: a thin argparse layer, one function per subcommand.

Each module in this package exposes ``register(subparsers)``, which adds its
subcommand(s) and sets ``func`` on each parser. ``main`` turns every library
``ValueError`` / ``OSError`` (and argparse usage errors) into one line on stderr
and exit status 2, with no traceback; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

#: Subcommand modules, in the order ``fftnav --help`` lists them.
_MODULES = ("scan", "scan3d", "fly3d", "world", "episode", "run", "figure", "bench")

EXIT_USAGE = 2


class CliError(Exception):
    """A user error detected by the CLI layer itself (exit status 2)."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


def build_parser() -> argparse.ArgumentParser:
    """Build the full ``fftnav`` parser from the subcommand modules."""
    from fftnav import __version__

    parser = _Parser(prog="fftnav", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"fftnav {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in _MODULES:
        importlib.import_module(f"fftnav.cli.{name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``fftnav`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        status = args.func(args)
    except BrokenPipeError:  # e.g. `fftnav scan ... | head`
        return 0
    except (CliError, ValueError, OSError) as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        sys.stderr.write(f"fftnav {args.command}: error: {msg}\n")
        return EXIT_USAGE
    return int(status or 0)
