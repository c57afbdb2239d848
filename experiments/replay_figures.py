"""The replay figures of the docs, from the committed recordings (``make replays``).

- ``results/figures/replay_rocky-1014.gif`` (README): ``bug-left`` on rocky map 1014,
  where robot 9 ends ``stuck``, beside ``fusion`` on the same map and episode seed, where every
  robot arrives. ``fusion``'s episode has no failure, so ``records/`` does not keep it: it is
  rerun here from the world, config and seed of the ``bug-left`` recording, and its rows are
  checked against ``results/table1/episodes.csv`` first.
- ``results/figures/causes/<cause>.png`` (docs/analysis.md): one frame per cause of failure,
  the failed robot picked, at the last tick of its episode, from the first
  recording with that cause in the ``records`` of ``results/table1``, ``results/collab/core``
  and ``results/collab/fresh``.
  No committed result has a ``collision`` (the planner's clearance guard keeps the robots off
  the obstacles), so its frame is of a scripted robot driving straight at a rock. Where none
  of those recordings has a ``jam`` (the squeezed plan parts them, docs/planner.md), its
  frame is of fresh traps map 71 under ``collab`` with the squeeze switched off, its robots
  mapping each other as obstacles (``OwnMaps.set_robots`` switched off), its guided way
  switched off (``Walls.guides``) and the paper's motion (``PAPER_MOTION``: straight, or
  rotation in place beyond 3 degrees of heading error), where robots 2 and 3 jam.

Run from the repository root: ``python experiments/replay_figures.py``.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd

from fftnav.config import PAPER_MOTION, SwarmConfig
from fftnav.episode import read_recording, run_episode
from fftnav.episode.recording import write_recording
from fftnav.metrics import FAILURE_CAUSES
from fftnav.navigation.controllers import Controller
from fftnav.navigation.messages import Walls
from fftnav.navigation.ownmap import OwnMaps
from fftnav.report.replay import write_image, write_video
from fftnav.world import Circle, World

ROOT = Path(__file__).resolve().parents[1]
SOURCES = (ROOT / "results" / "table1", ROOT / "results" / "collab" / "core",
           ROOT / "results" / "collab" / "fresh")


def readme_gif(out: Path) -> Path:
    table1 = ROOT / "results" / "table1"
    bug = read_recording(table1 / "records" / "rocky-1014-bug-left.npz")
    fusion = run_episode(bug.world, "fusion", seed=bug.seed, config=bug.config, record=True)
    episodes = pd.read_csv(table1 / "episodes.csv")
    rows = episodes[(episodes.env == "rocky") & (episodes.map_seed == 1014)
                    & (episodes.policy == "fusion")]
    np.testing.assert_allclose([r.path_length_m for r in fusion.rows], rows.path_length_m,
                               atol=1e-6)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_recording(Path(tmp) / "fusion.npz", fusion.recording())
        return write_video(bug, out, speed=12, beside=[read_recording(path)])


class _AtTheRock(Controller):
    """Drives straight ahead at half speed."""

    uses_pipeline = False

    def act(self, obs):
        return 0.5 * self.v_max_mps, 0.0


def _collision_recording(folder: Path) -> Path:
    world = World("scripted", 0, (6.0, 8.0), (Circle((3.0, 4.0), 0.5, 1.0),),
                  np.array([[3.0, 1.0, math.pi / 2]]), np.array([[3.0, 7.0]]))
    config = SwarmConfig().replace({"time_limit_s": 30})
    result = run_episode(world, f"{__file__}:_AtTheRock", seed=0, config=config, record=True)
    assert result.rows[0].failure == "collision"
    return write_recording(folder / "collision.npz", result.recording())


def _jam_recording(folder: Path) -> Path:
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
    return write_recording(folder / "jam.npz", result.recording())


def cause_frames(folder: Path) -> list[Path]:
    """One PNG per registered cause, in the registry's order."""
    folder.mkdir(parents=True, exist_ok=True)
    found: dict[str, tuple[Path, int]] = {}
    for source in SOURCES:
        for path in sorted((source / "records").glob("*.npz")):
            for row in read_recording(path).rows:
                if row["failure"] and row["failure"] not in found:
                    found[row["failure"]] = (path, int(row["robot"]))
    written = []
    with tempfile.TemporaryDirectory() as tmp:
        if "collision" not in found:
            found["collision"] = (_collision_recording(Path(tmp)), 0)
        if "jam" not in found:
            found["jam"] = (_jam_recording(Path(tmp)), 2)
        for cause in FAILURE_CAUSES:
            path, robot = found[cause]
            rec = read_recording(path)
            at_s = float(rec.time_s[-2])  # the last tick with scans
            out = write_image(rec, folder / f"{cause}.png", at_s=at_s, robot=robot)
            print(f"{cause}: {path.relative_to(ROOT) if path.is_relative_to(ROOT) else 'scripted'}"
                  f" robot {robot} at {at_s:.1f} s -> {out.relative_to(ROOT)}")
            written.append(out)
    return written


if __name__ == "__main__":
    print(readme_gif(ROOT / "results" / "figures" / "replay_rocky-1014.gif"))
    cause_frames(ROOT / "results" / "figures" / "causes")
