"""``fftnav episode``'s last line names the robots that failed, why, and when a robot collided
(the start of the control period in which it touched), on a world made by hand whose outcome is
known: robot 0 drives straight into a trunk, robot 1 stands still until the time limit, robot 2
drives straight to its goal."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fftnav.episode.recording import read_recording
from fftnav.states import Status
from fftnav.world import Circle, World

ROOT = Path(__file__).resolve().parents[2]
#: Robot 0 at (1.5, 1) heading +y toward a trunk of radius 0.5 at (1.5, 3.5); robot 1 at
#: (4, 1); robot 2 at (6.5, 1) heading +y toward its goal 1.5 m ahead.
WORLD = World("forest", 0, (8.0, 8.0), (Circle((1.5, 3.5), 0.5, 1.0),),
              np.array([[1.5, 1.0, math.pi / 2], [4.0, 1.0, math.pi / 2],
                        [6.5, 1.0, math.pi / 2]]),
              np.array([[1.5, 7.0], [4.0, 7.0], [6.5, 2.5]]))
CONTROLLER = """\
from fftnav.navigation.controllers import Controller


class Scripted(Controller):
    uses_pipeline = False

    def act(self, obs):
        return (0.0, 0.0) if obs.robot == 1 else (self.v_max_mps, 0.0)
"""
TIME_LIMIT_S = 6.0


def fftnav(*args, cwd):
    return subprocess.run([sys.executable, "-m", "fftnav", *map(str, args)], capture_output=True,
                          text=True, timeout=300, cwd=cwd,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})


@pytest.fixture(scope="module")
def episode(tmp_path_factory):
    where = tmp_path_factory.mktemp("summary")
    (where / "w.json").write_text(WORLD.to_json())
    (where / "scripted.py").write_text(CONTROLLER)
    done = fftnav("episode", "--world", "w.json", "--policy", "scripted.py:Scripted",
                  "--set", f"time_limit_s={TIME_LIMIT_S}", "--out", "e.csv", "--record", "r.npz",
                  cwd=where)
    assert done.returncode == 0, done.stderr
    return done, pd.read_csv(where / "e.csv"), read_recording(where / "r.npz")


def test_the_summary_line_names_each_failed_robot_its_cause_and_when_it_collided(episode):
    done, rows, recording = episode
    assert rows.arrived.tolist() == [False, False, True]
    assert rows.collided.tolist() == [True, False, False]
    assert rows.failure.fillna("").tolist() == ["collision", "stuck", ""]
    # the collision: the tick during whose control period robot 0 touched the trunk (its
    # contact), the one before the recording first shows it collided
    touched = int(np.flatnonzero(recording.contact_obstacle[:, 0])[0])
    assert recording.status[touched, 0] == Status.MOVING
    assert recording.status[touched + 1, 0] == Status.COLLIDED
    collided_at = recording.time_s[touched]
    # by hand: 3.5 - 0.5 (trunk) - 0.15 (r0) - 1.0 = 1.85 m at up to 0.5 m/s: after 3.7 s,
    # touching at y = 2.85
    assert 3.6 <= collided_at <= 4.5
    assert recording.pose[touched + 1, 0, :2] == pytest.approx((1.5, 2.85), abs=0.03)
    assert done.stderr.splitlines()[-1] == (
        f"1/3 arrived, SPL {rows.spl.mean():.2f}, 1 collided, 1 timed out; "
        f"failed: 0 (collision at {collided_at:.1f} s), 1 (stuck)")
    assert done.stderr.count("\n") == 1
