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
from fftnav.files import check_distinct, check_target, write_atomic
from fftnav.navigation.resolve import registered_names, resolve

if TYPE_CHECKING:
    import numpy as np

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


#: Failed robots an outcome line names one by one (:func:`outcome_line`); the others are
#: counted by cause.
NAMED_FAILURES = 20


def outcome_line(rows: Sequence[EpisodeRow], *,
                 failed_at_s: Sequence[float] | None = None) -> str:
    """How an episode went, in one line: robots arrived, mean SPL, collided, lost (stopped at a
    goal only their odometry believed in, when there are any), timed out (the others), then
    each robot that did not arrive with its cause (``failure`` column) and, for one that
    collided or was lost, the time it did so (``failed_at_s``, s, indexed by robot: the start of
    the control period in which it touched or stopped, :func:`last_period_s`). The first
    :data:`NAMED_FAILURES` are named, the others counted by cause.

    >>> from fftnav.episode.record import EpisodeRow
    >>> def row(robot, arrived, collided, spl, failure=""):
    ...     return EpisodeRow(robot, "p", arrived, collided, 1, 1, 1, spl, 1, *[0] * 7,
    ...                       failure=failure)
    >>> outcome_line([row(0, True, False, 0.9), row(1, False, True, 0, "collision"),
    ...               row(2, False, False, 0, "stuck")], failed_at_s=[20.0, 41.23, 119.9])
    '1/3 arrived, SPL 0.30, 1 collided, 1 timed out; failed: 1 (collision at 41.2 s), 2 (stuck)'
    >>> outcome_line([row(0, True, False, 0.9), row(1, False, False, 0, "lost")])
    '1/2 arrived, SPL 0.45, 0 collided, 1 lost, 0 timed out; failed: 1 (lost)'
    """
    arrived = sum(bool(r.arrived) for r in rows)
    collided = sum(bool(r.collided) for r in rows)
    spl = sum(r.spl for r in rows) / len(rows) if rows else float("nan")
    lost = sum(r.failure == "lost" for r in rows)
    failed = [r for r in rows if not r.arrived]
    named = [f"{r.robot} ({r.failure or 'no cause'}{_left_at(r, failed_at_s)})"
             for r in failed[:NAMED_FAILURES]]
    rest = Counter(r.failure or "no cause" for r in failed[NAMED_FAILURES:])
    more = (f" and {sum(rest.values())} more ("
            + ", ".join(f"{c} {n}" for c, n in sorted(rest.items())) + ")") if rest else ""
    why = f"; failed: {', '.join(named)}{more}" if failed else ""
    return (f"{arrived}/{len(rows)} arrived, SPL {spl:.2f}, {collided} collided, "
            f"{f'{lost} lost, ' if lost else ''}{len(rows) - arrived - collided - lost} "
            f"timed out{why}")


def _left_at(row: EpisodeRow, failed_at_s: Sequence[float] | None) -> str:
    """`` at T s`` for a robot that collided or was lost, when its failure time is known."""
    if failed_at_s is None or not (row.collided or row.failure == "lost"):
        return ""
    return f" at {failed_at_s[row.robot]:.1f} s"


def last_period_s(trajectories: Sequence[np.ndarray], departure_ticks: Sequence[int],
                  control_hz: float) -> list[float]:
    """When the last control period each robot drove began (s): its trajectory's sample k is
    tick ``departure + k`` (:func:`fftnav.episode.loop.positions_by_tick`) and its last sample
    the pose after that period, in which it arrived, touched an obstacle, stopped (lost) or
    used up its time. For a robot that collided or was lost this is its failure tick, the one
    the replays show it fail at (:func:`fftnav.report.replay.failure_ticks`).

    >>> import numpy as np
    >>> last_period_s([np.zeros((5, 3)), np.zeros((2, 3))], [0, 30], 10.0)
    [0.3, 3.0]
    """
    from fftnav.episode.record import failure_tick

    return [max(failure_tick(t, d, timed_out=False), 0) / control_hz
            for t, d in zip(trajectories, departure_ticks, strict=True)]


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
    outputs = ("--out", "--record", "--trajectories", "--plot", "--bag")
    check_distinct({flag: getattr(args, flag[2:]) for flag in outputs},
                   inputs={"--world": args.world})
    for flag in outputs:  # before the episode
        if getattr(args, flag[2:]):
            check_target(getattr(args, flag[2:]), flag=flag, make_folder=True,
                         image=flag == "--plot")
    world = load_world(args.world)
    with EpisodeBag(args.bag, world, config) if args.bag else contextlib.nullcontext() as bag:
        result = run_episode(world, args.policy, seed=args.seed, config=config, gui=args.gui,
                             record=bool(args.record), on_tick=bag)
        if bag is not None:
            bag.finish(result)
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
    failed_at = last_period_s(result.trajectories,
                              config.episode.departure_ticks(len(world.starts)),
                              config.episode.control_hz)
    sys.stderr.write(outcome_line(result.rows, failed_at_s=failed_at) + "\n")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("episode", help="run one episode of all robots of a world file")
    p.add_argument("--world", required=True, metavar="W.json", help="world file")
    p.add_argument("--policy", required=True, metavar="NAME",
                   help=f"decision policy or controller: {', '.join(registered_names())}, "
                   "or module:attr, path/to/file.py:attr, an entry point of 'fftnav.policies', "
                   "learned:PATH.npz, learned-decider:PATH.npz")
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
