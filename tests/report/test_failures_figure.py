"""plot_failures: a PNG of the robots of an episode that did not arrive."""

from __future__ import annotations

import shutil

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


def test_figure_failures_draws_kept_paths_and_reruns_the_others(tmp_path):
    """``fftnav figure failures`` on a results folder: the paths of a map that keeps them, and
    the same figure, pixel for pixel, once they are gone (a clone keeps none): the episode is
    rerun, checked against the folder's rows; an episode the folder lacks is one line."""
    from PIL import Image

    from tests.report.small_results import fftnav, make_small_results

    results = make_small_results(tmp_path)
    config = tmp_path / "small.toml"
    args = ["figure", "failures", config, "--results", results, "--env", "forest", "--policy",
            "fusion"]
    done = fftnav(*args, "--map", "7", "--out", tmp_path / "kept.png")
    assert done.returncode == 0, done.stderr
    shutil.rmtree(results / "trajectories")
    done = fftnav(*args, "--map", "7", "--out", tmp_path / "rerun.png")
    assert done.returncode == 0, done.stderr
    kept, rerun = (np.asarray(Image.open(tmp_path / f"{n}.png")) for n in ("kept", "rerun"))
    np.testing.assert_array_equal(kept, rerun)
    done = fftnav(*args, "--map", "8", "--out", tmp_path / "other.png")  # kept no paths
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "other.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    done = fftnav(*args, "--map", "5", "--out", tmp_path / "none.png")
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "task must be an episode of" in done.stderr and "forest-7-fusion" in done.stderr
