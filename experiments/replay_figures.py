"""The replay figures of the docs, from recordings made on demand (``make replays``).

Every recording here is an episode of a committed results folder rerun from the folder's config
and seeds, its rows checked against the folder's ``episodes.csv`` first
(:func:`fftnav.runner.rerun.rerun_task`, what ``fftnav replay RESULTS_DIR --task TASK`` does):
the repository keeps no recording.

- ``results/figures/replay_rocky-1014.gif`` (README): ``bug-left`` on rocky map 1014 of
  ``results/table1``, where robot 9 ends ``stuck``, beside ``fusion`` on the same map and
  episode seed, where every robot arrives; 12 times real time, :data:`GIF_WIDTH_PX` pixels a
  panel (the file stays under 1 MB).
- ``results/figures/causes/<cause>.png`` (docs/analysis.md): one frame per cause of failure,
  the failed robot picked, at the tick it failed (``failure_ticks``), from the first episode
  with that cause in the ``episodes.csv`` of ``results/table1``, ``results/collab/core`` and
  ``results/collab/fresh`` (in that order, each in its rows' order).
  No committed result has a ``collision`` (the planner's clearance guard keeps the robots off
  the obstacles), so its frame is of a scripted robot driving straight at a rock. Where none
  of those folders has a ``jam`` (the squeezed plan parts them, docs/planner.md), its
  frame is of fresh traps map 71 under ``collab`` with the squeeze switched off, its robots
  mapping each other as obstacles (``OwnMaps.set_robots`` switched off), its guided way
  switched off (``Walls.guides``) and the paper's motion (``PAPER_MOTION``: straight, or
  rotation in place beyond 3 degrees of heading error), where robots 2 and 3 jam. ``lost``
  (robots that know only their odometry) is forest map 1000 of Table I under ``bug-left`` at
  the ``high`` drift preset, robot 1.

Run from the repository root: ``python experiments/replay_figures.py``.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd

from fftnav.config import PAPER_MOTION, SwarmConfig
from fftnav.episode import read_recording, run_episode
from fftnav.metrics import FAILURE_CAUSES
from fftnav.navigation.controllers import Controller
from fftnav.navigation.messages import Walls
from fftnav.navigation.ownmap import OwnMaps
from fftnav.report.replay import failure_ticks, write_image, write_video
from fftnav.runner.rerun import rerun_task
from fftnav.runner.tasks import task_id
from fftnav.world import Circle, World

ROOT = Path(__file__).resolve().parents[1]
SOURCES = (ROOT / "results" / "table1", ROOT / "results" / "collab" / "core",
           ROOT / "results" / "collab" / "fresh")
#: The README GIF's width per panel (pixels).
GIF_WIDTH_PX = 400


def readme_gif(out: Path) -> Path:
    """``bug-left`` beside ``fusion`` on rocky map 1014 of ``results/table1``."""
    table1 = ROOT / "results" / "table1"
    bug = rerun_task(table1, "rocky-1014-bug-left").recording()
    fusion = rerun_task(table1, "rocky-1014-fusion").recording()
    return write_video(bug, out, speed=12, beside=[fusion], width_px=GIF_WIDTH_PX)


class _AtTheRock(Controller):
    """Drives straight ahead at half speed."""

    uses_pipeline = False

    def act(self, obs):
        return 0.5 * self.v_max_mps, 0.0


def _collision_recording():
    world = World("scripted", 0, (6.0, 8.0), (Circle((3.0, 4.0), 0.5, 1.0),),
                  np.array([[3.0, 1.0, math.pi / 2]]), np.array([[3.0, 7.0]]))
    config = SwarmConfig().replace({"time_limit_s": 30})
    result = run_episode(world, f"{__file__}:_AtTheRock", seed=0, config=config, record=True)
    assert result.rows[0].failure == "collision"
    return read_recording(io.BytesIO(result.recording()))


def _jam_recording():
    from fftnav.navigation import bug
    from fftnav.runner.tasks import episode_seed
    from fftnav.world.generate import generate_world

    for_swarm = vars(bug.PlannerParams)["for_swarm"].__func__
    clearance = bug.PlannerParams().map_clearance_m

    def no_squeeze(cls, config, **constants):
        return for_swarm(cls, config, map_squeeze_m=clearance, **constants)

    with (mock.patch.object(bug.PlannerParams, "for_swarm", classmethod(no_squeeze)),
          mock.patch.object(OwnMaps, "set_robots", lambda *args: None),
          mock.patch.object(Walls, "guides", lambda *args: False)):
        paper = SwarmConfig().replace(PAPER_MOTION)
        result = run_episode(generate_world("traps", 71, robots=15), "collab",
                             seed=episode_seed("traps", 71), record=True, config=paper)
    jammed = [(r.robot, r.failure) for r in result.rows if not r.arrived]
    if jammed != [(2, "jam"), (3, "jam")]:
        raise RuntimeError(f"fresh traps map 71 without the squeeze no longer jams: {jammed}")
    return read_recording(io.BytesIO(result.recording()))


def _lost_recording():
    """Forest map 1000 of Table I under ``bug-left`` with only odometry at the ``high`` drift
    preset (the task forest-1000-bug-left of results/drift/table1/drift=high, whose
    episodes.csv git does not keep): robot 1 stops where its estimate puts its goal."""
    from fftnav.runner.tasks import episode_seed
    from fftnav.world.generate import generate_world

    config = SwarmConfig().replace({"localization.mode": "odometry", "localization.drift": "high"})
    result = run_episode(generate_world("forest", 1000, robots=15), "bug-left",
                         seed=episode_seed("forest", 1000), record=True, config=config)
    if result.rows[1].failure != "lost":
        raise RuntimeError(f"robot 1 of forest-1000-bug-left at high drift is no longer lost: "
                           f"{result.rows[1].failure!r}")
    return read_recording(io.BytesIO(result.recording()))


def first_failures() -> dict[str, tuple[Path, str, int]]:
    """Each cause's first failure in :data:`SOURCES`: (folder, task, robot)."""
    found: dict[str, tuple[Path, str, int]] = {}
    for source in SOURCES:
        episodes = pd.read_csv(source / "episodes.csv", keep_default_na=False)
        for r in episodes[episodes["failure"] != ""].itertuples(index=False):
            found.setdefault(r.failure, (source, task_id(r.env, r.map_seed, r.policy), r.robot))
    return found


def cause_frames(folder: Path) -> list[Path]:
    """One PNG per registered cause, in the registry's order."""
    folder.mkdir(parents=True, exist_ok=True)
    found = first_failures()
    written = []
    for cause in FAILURE_CAUSES:
        if cause in found:
            source, task, robot = found[cause]
            rec, where = rerun_task(source, task).recording(), f"{source.relative_to(ROOT)} {task}"
        elif cause in ("collision", "jam"):
            rec, robot = (_collision_recording(), 0) if cause == "collision" else (
                _jam_recording(), 2)
            where = "scripted" if cause == "collision" else "traps-71-collab, no squeeze"
        elif cause == "lost":
            rec, robot, where = _lost_recording(), 1, "forest-1000-bug-left, high drift"
        else:
            raise RuntimeError(f"no committed result has a {cause!r} failure")
        # the tick the robot failed at (the player's and the frames' red), at most the last
        # tick with scans
        at_s = float(rec.time_s[min(failure_ticks(rec)[int(robot)], len(rec.time_s) - 2)])
        out = write_image(rec, folder / f"{cause}.png", at_s=at_s, robot=int(robot))
        print(f"{cause}: {where} robot {robot} at {at_s:.1f} s -> {out.relative_to(ROOT)}")
        written.append(out)
    return written


if __name__ == "__main__":
    print(readme_gif(ROOT / "results" / "figures" / "replay_rocky-1014.gif"))
    cause_frames(ROOT / "results" / "figures" / "causes")
