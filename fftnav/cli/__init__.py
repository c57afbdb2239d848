"""The ``fftnav`` command line: a thin argparse layer, one function per subcommand.

Each module in this package exposes ``register(subparsers)``, which adds its
subcommand(s) and sets ``func`` on each parser. ``main`` turns every library
``ValueError`` / ``OSError`` (and argparse usage errors) into one line on stderr
and exit status 2, with no traceback; anything else is a bug and keeps its traceback.

``entry`` (the console script) adds the process life: Ctrl-C exits 130 and SIGTERM 143 after
the command cleaned up (``fftnav run`` keeps its finished episodes and stops its workers); a
second Ctrl-C or SIGTERM during that cleanup exits at once, with one line.
"""

from __future__ import annotations

import _thread
import argparse
import importlib
import os
import signal
import sys
import threading
import time
import warnings
from collections.abc import Sequence
from typing import Any

#: Subcommand modules, in the order ``fftnav --help`` lists them.
_MODULES = ("scan", "scan3d", "fly3d", "world", "episode", "replay", "run", "suites", "evaluate",
            "learn",
            "leaderboard", "figure", "bench")

EXIT_USAGE = 2
#: Exit statuses of a command stopped by Ctrl-C (128 + SIGINT) and by SIGTERM (128 + SIGTERM).
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143


class Terminated(BaseException):
    """Raised in the main thread when the process receives SIGTERM (like KeyboardInterrupt for
    SIGINT), so that the command cleans up on the way out."""


class CliError(Exception):
    """A user error detected by the CLI layer itself (exit status 2)."""


def workers_count(text: str) -> int:
    """argparse type of ``--workers``: an integer >= 1."""
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return int(text)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(EXIT_USAGE)


#: What ``fftnav --help`` says the command is.
DESCRIPTION = ("FFT-filtered swarm navigation: process lidar scans, generate worlds, run episodes "
               "and experiments on the PyBullet swarm benchmark, and draw the figures.")


def build_parser() -> argparse.ArgumentParser:
    """Build the full ``fftnav`` parser from the subcommand modules."""
    from fftnav import __version__

    parser = _Parser(prog="fftnav", description=DESCRIPTION)
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
    # a plugin importing a moved module gets one line naming the new path (fftnav.moved)
    warnings.filterwarnings("default", message=r"fftnav\.\S+ moved to ",
                            category=DeprecationWarning)
    if warnings.showwarning is not _one_line_warning:
        _one_line_warning.shown_by = warnings.showwarning  # type: ignore[attr-defined]
        warnings.showwarning = _one_line_warning
    stopped_before = _stopped_by
    try:
        status = args.func(args)
    except BrokenPipeError:  # e.g. `fftnav scan ... | head`
        return 0
    except KeyboardInterrupt:
        return _stopped(args.command, signal.SIGINT)
    except Terminated:
        return _stopped(args.command, signal.SIGTERM)
    except Exception as exc:
        if stopped_before is None and _stopped_by is not None:
            # the stop's exception, replaced by code that caught it (matplotlib's C++ drawing
            # raises a ValueError in its place)
            return _stopped(args.command, _stopped_by)
        if not isinstance(exc, (CliError, ValueError, OSError)):
            raise
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        sys.stderr.write(f"fftnav {args.command}: error: {msg}\n")
        return EXIT_USAGE
    return int(status or 0)


def _stopped(command: str, signum: int) -> int:
    """One line for a command stopped by ``signum``; its exit status (130 or 143)."""
    terminated = signum == signal.SIGTERM
    sys.stderr.write(f"fftnav {command}: {'terminated' if terminated else 'interrupted'}\n")
    return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED


def _one_line_warning(message: Warning | str, category: type[Warning],  # noqa: PLR0917
                      filename: str, lineno: int, file: Any = None,
                      line: str | None = None) -> None:  # warnings.showwarning's signature
    """A moved module's warning on stderr as one line, ``fftnav: DeprecationWarning: ...``;
    any other warning as Python shows it."""
    if issubclass(category, DeprecationWarning) and " moved to " in str(message):
        sys.stderr.write(f"fftnav: {category.__name__}: {message}\n")
    else:
        _one_line_warning.shown_by(message, category, filename, lineno, file, line)


def _exit_now(signum: int, frame: object) -> None:
    """A second Ctrl-C / SIGTERM during cleanup: one line, remove this process's temporary
    files, exit at once (pool workers die with this process)."""
    from fftnav.files import remove_pending_temporaries

    remove_pending_temporaries()
    status = EXIT_TERMINATED if signum == signal.SIGTERM else EXIT_INTERRUPTED
    os.write(2, b"fftnav: interrupted again; exiting now (finished episodes are kept)\n")
    os._exit(status)


#: Set by the first Ctrl-C or SIGTERM: the process is stopping.
_stopping = False
#: The first stop signal (SIGINT or SIGTERM) the process received; None while it runs. Code
#: that catches the stop's exception and raises its own (matplotlib's C++ drawing turns an
#: interrupt into a ValueError) still ends the command as stopped.
_stopped_by: int | None = None


def _stop(signum: int) -> None:
    """A first Ctrl-C or SIGTERM: the process is stopping; the next one of either exits now."""
    global _stopping, _stopped_by
    _stopping, _stopped_by = True, signum
    signal.signal(signal.SIGINT, _exit_now)
    signal.signal(signal.SIGTERM, _exit_now)


def _on_sigint(signum: int, frame: object) -> None:
    _stop(signum)
    raise KeyboardInterrupt


def _on_sigterm(signum: int, frame: object) -> None:
    _stop(signum)
    raise Terminated


def _interrupt_main_later(signum: int) -> None:
    time.sleep(0.02)
    _thread.interrupt_main(signum)


def _redeliver(unraisable: Any) -> None:
    """``sys.unraisablehook``: a first Ctrl-C or SIGTERM whose exception landed where Python
    ignores exceptions (a finaliser, logging's at-fork hook) would be printed as a traceback and
    lost; deliver it again to the main thread instead, where it stops the run as usual. Once
    stopping, the other exceptions Python would print while ignoring them (a multiprocessing
    finaliser cut short by the interrupt) are consequences of it: not printed either."""
    if unraisable.exc_type is not None and issubclass(unraisable.exc_type,
                                                      (KeyboardInterrupt, Terminated)):
        signum = signal.SIGTERM if issubclass(unraisable.exc_type, Terminated) else signal.SIGINT
        signal.signal(signum, _on_sigterm if signum == signal.SIGTERM else _on_sigint)
        # From another thread, a moment later: called here (or as soon as the thread starts),
        # the handler would run before this hook returns, and its exception would be ignored
        # again, and printed. Should it land in a finaliser again, this hook sends it again.
        try:
            threading.Thread(target=_interrupt_main_later, args=(signum,), daemon=True).start()
        except RuntimeError:  # interpreter shutting down: nothing left to stop
            pass
        return
    if not _stopping:
        sys.__unraisablehook__(unraisable)


def install_signal_handlers() -> None:
    """First Ctrl-C raises KeyboardInterrupt, first SIGTERM :class:`Terminated`; the next one
    of either exits at once. A SIGINT ignored at start (a background job) stays ignored."""
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _on_sigint)
    signal.signal(signal.SIGTERM, _on_sigterm)
    sys.unraisablehook = _redeliver


def entry() -> None:
    """The ``fftnav`` console script: :func:`main` with the signal handling above."""
    install_signal_handlers()
    status = main()
    if status in (EXIT_INTERRUPTED, EXIT_TERMINATED):
        from fftnav.files import remove_pending_temporaries

        remove_pending_temporaries()  # any whose own cleanup the signal cut short
        # Already stopping and cleaned up: skip the interpreter's teardown (about half a second
        # with pandas and Dask loaded), during which a further Ctrl-C would kill the process by
        # signal instead of exiting with the status.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)
