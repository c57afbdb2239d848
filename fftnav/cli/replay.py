"""``fftnav replay``: watch an episode as an HTML player, a GIF, an MP4 or one PNG frame
(docs/analysis.md), several side by side on one clock: a recording (``fftnav episode
--record``, an experiment's ``records/``), or an episode of a results folder made on demand
(``fftnav replay RESULTS_DIR --task TASK``: rerun from the folder's config and seeds, recorded,
its rows checked against the folder's ``episodes.csv``), or a reference episode of a suite
(``fftnav replay --suite SUITE --task TASK``, its rows checked against the shipped ones)."""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from fftnav.cli import CliError

#: Output formats, by the suffix of --out.
FORMATS = (".html", ".gif", ".mp4", ".png")


#: The library's parameter names in messages -> the flags a user typed.
FLAGS = {"from_s": "--from", "to_s": "--to", "at_s": "--at", "robot": "--robot",
         "speed": "--speed", "task": "--task", "results_dir": "RESULTS_DIR", "suite": "--suite"}


def cmd_replay(args: argparse.Namespace) -> int:
    """Read the recordings (or make them: ``--task``), write --out in the format of its suffix,
    say what was written; a refused value is named by its flag (a parameter's name where it
    is the subject or the value of a message: ``robot must ...``, ``robot=4``)."""
    try:
        return _replay(args)
    except CliError:
        raise
    except ValueError as exc:
        text = str(exc)
        for name, flag in FLAGS.items():
            text = re.sub(rf"(?<![\w-]){name}\b(?=\s*must\b|=|,)", flag, text)
        raise CliError(text) from None


def _check_options(args: argparse.Namespace, suffix: str) -> None:
    """Refuse what the output format or the sources cannot take, before anything runs."""
    if suffix not in FORMATS:
        raise CliError(f"--out must end in one of {', '.join(FORMATS)}, got --out={args.out!r}")
    if suffix == ".mp4":
        from fftnav.errors import import_extra

        import_extra("imageio_ffmpeg", extra="video", needed_for="MP4 videos")
    if suffix != ".png" and args.at is not None:
        raise CliError("--at picks the frame of a .png; use --from and --to for a window")
    if suffix == ".png" and (args.start is not None or args.stop is not None):
        raise CliError("a .png is one frame: pick it with --at S")
    if args.suite and not args.task:
        raise CliError("--suite needs --task: the reference episode to rerun")
    if args.suite and args.recording:
        raise CliError(f"--suite reruns the suite's reference episodes: give no PATH, got "
                       f"{' '.join(args.recording)}")
    if not args.suite and not args.recording:
        raise CliError("give a recording, a results folder with --task, or --suite with --task")
    if args.task and not args.suite and len(args.recording) != 1:
        raise CliError(f"--task names episodes of one results folder, got "
                       f"{len(args.recording)} paths: {' '.join(args.recording)}")


def _recordings(args: argparse.Namespace) -> tuple[list, str]:
    """The recordings to draw and what to add to the closing line: read from the paths, or
    each ``--task`` rerun from the results folder (checked against its rows)."""
    if not args.task:
        from fftnav.episode.recording import read_recording

        return [read_recording(path) for path in args.recording], ""
    if args.suite:
        from fftnav.suites import find_suite
        from fftnav.suites import rerun_task as rerun_reference

        suite = find_suite(args.suite)
        recs = [rerun_reference(suite, task).recording() for task in args.task]
        return recs, (f" (rerun of {', '.join(args.task)}: the shipped reference rows of "
                      f"{suite.name})")
    from fftnav.runner.rerun import rerun_task

    folder = args.recording[0]
    recs = [rerun_task(folder, task).recording() for task in args.task]
    return recs, (f" (rerun of {', '.join(args.task)}: the rows of "
                  f"{Path(folder) / 'episodes.csv'})")


def _replay(args: argparse.Namespace) -> int:
    suffix = Path(args.out).suffix.lower()
    _check_options(args, suffix)
    from fftnav.files import atomic_path, check_target
    from fftnav.report import replay

    check_target(args.out, flag="--out", make_folder=True)
    (rec, *beside), made = _recordings(args)
    with atomic_path(args.out, keep_suffix=True) as tmp:  # no partial file on any failure
        if suffix == ".png":
            replay.write_image(rec, tmp, at_s=args.at or 0.0, robot=args.robot, beside=beside)
        elif suffix == ".html":
            from fftnav.report.replay_html import write_html

            write_html(rec, tmp, robot=args.robot, from_s=args.start, to_s=args.stop,
                       speed=args.speed, beside=beside)
        else:
            replay.write_video(rec, tmp, robot=args.robot, from_s=args.start, to_s=args.stop,
                               speed=args.speed, beside=beside)
    out = Path(args.out)
    sys.stderr.write(f"{out}: {out.stat().st_size / 1e6:.2f} MB{made}\n")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", help="watch an episode (a recording, or one of a results "
                       "folder made on demand): HTML player, GIF, MP4 or PNG")
    p.add_argument("recording", metavar="PATH", nargs="*",
                   help="a recording (fftnav episode --record, an experiment's records/); "
                   "more than one: drawn side by side at the same times (one HTML page of "
                   "synchronized panes, or GIF, MP4, PNG frames), the window and the robot "
                   "those of the first. With --task: one results folder (RESULTS_DIR, written "
                   "by fftnav run)")
    p.add_argument("--task", action="append", metavar="ENV-MAP_SEED-POLICY",
                   help="an episode of RESULTS_DIR (e.g. rocky-1014-bug-left; report.md lists "
                   "the failures): rerun from the folder's config and seeds, recorded, and "
                   "refused unless its rows are the folder's episodes.csv rows; repeated: "
                   "side by side")
    p.add_argument("--suite", metavar="NAME",
                   help="with --task: rerun a reference episode of a suite (e.g. --suite "
                   "walls-v1 --task walls-61-vfh; fftnav suites), refused unless its rows are "
                   "the shipped reference rows")
    p.add_argument("--out", required=True, metavar="X.html|X.gif|X.mp4|X.png",
                   help="what to write, by its suffix: a self-contained HTML player (open it "
                   "at X.html#robot=R&t=S: robot R picked, paused at S s), a GIF, an MP4 "
                   "(needs the extra 'video': imageio-ffmpeg) or one PNG frame")
    p.add_argument("--robot", type=int, metavar="I",
                   help="the robot whose scan and safe sectors are drawn (and whose state the "
                   "HTML player plots); default: the first that did not arrive, else 0")
    p.add_argument("--from", dest="start", type=float, metavar="S",
                   help="start of the window (s; default the episode's start)")
    p.add_argument("--to", dest="stop", type=float, metavar="S",
                   help="end of the window (s; default the episode's end)")
    p.add_argument("--speed", type=float, default=1.0, metavar="K",
                   help="playback speed: K s of the episode per second (default 1; GIF and MP4 "
                   "at 10 frames per second; the HTML player's initial speed)")
    p.add_argument("--at", type=float, metavar="S", help="the time of the PNG's frame (s; "
                   "default 0)")
    p.set_defaults(func=cmd_replay)
