"""``fftnav episode``: one episode of every robot of a world file under one policy."""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from collections import Counter
from collections.abc import Sequence
from typing import TYPE_CHECKING

from fftnav.cli import CliError
from fftnav.files import check_target, write_atomic
from fftnav.navigation.resolve import registered_names, resolve

if TYPE_CHECKING:
    from fftnav.episode.record import EpisodeRow


def _overrides(pairs: list[str]) -> dict[str, str]:
    """``--set KEY=VALUE`` pairs as a mapping (checked by :meth:`SwarmConfig.replace`)."""
    out: dict[str, str] = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or not key:
            raise CliError(f"--set expects KEY=VALUE, e.g. time_limit_s=60; got {pair!r}")
        out[key] = text
    return out


def outcome_line(rows: Sequence[EpisodeRow]) -> str:
    """How an episode went, in one line: robots arrived, mean SPL, collided, lost (stopped at a
    goal only their odometry believed in, when there are any), timed out (the others), and the
    failures by cause (``failure`` column).

    >>> from fftnav.episode.record import EpisodeRow
    >>> def row(arrived, collided, spl, failure=""):
    ...     return EpisodeRow(0, "p", arrived, collided, 1, 1, 1, spl, 1, *[0] * 7,
    ...                       failure=failure)
    >>> outcome_line([row(True, False, 0.9), row(False, True, 0, "collision"),
    ...               row(False, False, 0, "stuck")])
    '1/3 arrived, SPL 0.30, 1 collided, 1 timed out; failures: collision 1, stuck 1'
    >>> outcome_line([row(True, False, 0.9), row(False, False, 0, "lost")])
    '1/2 arrived, SPL 0.45, 0 collided, 1 lost, 0 timed out; failures: lost 1'
    """
    arrived = sum(bool(r.arrived) for r in rows)
    collided = sum(bool(r.collided) for r in rows)
    spl = sum(r.spl for r in rows) / len(rows) if rows else float("nan")
    causes = Counter(r.failure for r in rows if r.failure)
    why = ("; failures: " + ", ".join(f"{c} {n}" for c, n in sorted(causes.items()))
           if causes else "")
    lost = causes.get("lost", 0)
    return (f"{arrived}/{len(rows)} arrived, SPL {spl:.2f}, {collided} collided, "
            f"{f'{lost} lost, ' if lost else ''}{len(rows) - arrived - collided - lost} "
            f"timed out{why}")


def cmd_episode(args: argparse.Namespace) -> int:
    """Run the episode, write the per-robot CSV (stdout without --out), trajectories, plot;
    then one line on stderr (:func:`outcome_line`)."""
    import numpy as np

    from fftnav.episode import SwarmConfig, episode_csv, run_episode
    from fftnav.world import load_world

    resolve(args.policy)  # an unknown name or a plugin that does not load: refused first
    config = SwarmConfig().replace(_overrides(args.set or []))
    if args.bag:
        from fftnav.ros.episode import EpisodeBag, check_episode_bag

        check_episode_bag(args.bag)
    for flag in ("--out", "--record", "--trajectories", "--plot", "--bag"):  # before the episode
        if getattr(args, flag[2:]):
            check_target(getattr(args, flag[2:]), flag=flag, make_folder=True,
                         image=flag == "--plot")
    world = load_world(args.world)
    with EpisodeBag(args.bag, world, config) if args.bag else contextlib.nullcontext() as bag:
        result = run_episode(world, args.policy, seed=args.seed, config=config, gui=args.gui,
                             record=bool(args.record), on_tick=bag)
    text = episode_csv(result.rows)
    if args.out:
        write_atomic(args.out, text)
    else:
        sys.stdout.write(text)
    if args.record:
        from fftnav.episode.recording import write_recording

        write_recording(args.record, result.recording())
    if args.trajectories:
        buffer = io.BytesIO()  # np.savez_compressed(path) would append .npz to another name
        np.savez_compressed(buffer, *result.trajectories)
        write_atomic(args.trajectories, buffer.getvalue())
    if args.plot:
        from fftnav.report.trajectories import plot_episode

        plot_episode(world, result.trajectories, result.rows, args.plot, r0_m=config.robot.r0_m)
    sys.stderr.write(outcome_line(result.rows) + "\n")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("episode", help="run one episode of all robots of a world file")
    p.add_argument("--world", required=True, metavar="W.json", help="world file")
    p.add_argument("--policy", required=True, metavar="NAME",
                   help=f"decision policy or controller: {', '.join(registered_names())}, "
                   "or module:attr, path/to/file.py:attr, an entry point of 'fftnav.policies'")
    p.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    p.add_argument("--out", metavar="E.csv", help="per-robot CSV (default: stdout)")
    p.add_argument("--trajectories", metavar="T.npz",
                   help="trajectories, one (T, 3) array of x, y, yaw per robot: arr_0, arr_1, ...")
    p.add_argument("--plot", metavar="P.png", help="draw the trajectories over the map")
    p.add_argument("--record", metavar="R.npz",
                   help="write the episode's recording to exactly this path (what every robot "
                   "saw, decided and sent per tick; view it with 'fftnav replay')")
    p.add_argument("--bag", metavar="B.mcap",
                   help="write the episode as a ROS bag (.mcap, .db3 or ROS 1 .bag; extra "
                   "fftnav[ros]): /world, /tf, /robot_i/scan, odom, cmd_vel, messages")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a parameter, e.g. --set time_limit_s=60 or "
                   "--set comms.packet_loss=0.2 (repeatable; keys of docs/experiments.md)")
    p.add_argument("--gui", action="store_true", help="watch the episode in the PyBullet GUI")
    p.set_defaults(func=cmd_episode)
