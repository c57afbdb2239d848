"""plot_failures: a PNG of the robots of an episode that did not arrive."""

from __future__ import annotations

import numpy as np

from fftnav.episode import EpisodeRow
from fftnav.report.trajectories import plot_failures
from fftnav.world import World


def _row(robot, arrived):
    return EpisodeRow(robot=robot, policy="own-only", arrived=arrived, collided=False,
                      path_length_m=1.0, optimal_length_m=1.0, geodesic_length_m=1.0, spl=1.0,
                      time_s=1.0, bytes_sent=0, messages_sent=0, decisions_left=0,
                      decisions_right=0, decisions_with_neighbours=0,
                      decisions_flipped_by_neighbours=0, robot_contacts=0)


def test_failures_figure_is_written(tmp_path):
    world = World("t", 0, (4.0, 4.0), (), np.array([[1.0, 1.0, 0.0], [3.0, 1.0, 0.0]]),
                  np.array([[1.0, 3.0], [3.0, 3.0]]), "walls")
    paths = [np.c_[np.full(30, 1.0), np.linspace(1, 3, 30), np.zeros(30)],
             np.c_[np.full(50, 3.0), np.linspace(1, 2, 50), np.zeros(50)]]
    out = plot_failures(world, paths, [_row(0, True), _row(1, False)], tmp_path / "f.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_figure_failures_cli_reads_a_results_folder(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "f.png"
    args = [sys.executable, "-m", "fftnav", "figure", "failures",
            str(root / "experiments" / "collab" / "core_small.toml"), "--results",
            str(root / "results" / "collab" / "core_small"), "--env", "traps", "--map", "1"]
    res = subprocess.run([*args, "--policy", "collab", "--out", str(out)], capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    res = subprocess.run([*args[:-1], "5", "--policy", "collab", "--out", str(out)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and "no trajectories" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
