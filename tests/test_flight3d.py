"""Quadrotor controller and flight loop (low-resolution sensor, short flights)."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from fftnav.flight3d import FLIGHT_COLUMNS, FlightConfig, FlightResult, _command, fly, summarize
from fftnav.sim.drone import Forest3D
from fftnav.spherical import DiscFilterBank, SphericalGrid

LOW_RES = {"rows": 30, "cols": 120}


def _unit(el: float, az: float) -> np.ndarray:
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def test_command_takes_the_safe_direction_nearest_the_target() -> None:
    grid = SphericalGrid(30, 120)
    bank = DiscFilterBank(grid)
    depth = np.full((30, 120), np.inf)
    depth[10:20, 55:66] = 1.5  # a wall straight ahead (azimuth -15..18 deg), beyond r
    v = _command(bank, grid.directions(), depth, _unit(0.0, 0.0), 0.0, 3.0)
    assert np.linalg.norm(v) == pytest.approx(3.0)
    mask = bank.safe_mask(depth)
    el, az = bank.nearest_direction(mask, 0.0, 0.0)
    np.testing.assert_allclose(v, 3.0 * _unit(el, az), atol=1e-12)
    assert not mask[14, 60] and math.degrees(math.acos(_unit(el, az)[0])) > 20  # around the wall
    # with yaw = 90 deg the same image is seen rotated: the command rotates with it
    v_yawed = _command(bank, grid.directions(), depth, _unit(0.0, math.pi / 2), math.pi / 2, 3.0)
    np.testing.assert_allclose(v_yawed, 3.0 * _unit(el, az + math.pi / 2), atol=1e-12)


def test_command_never_heads_towards_readings_inside_the_protective_radius() -> None:
    grid = SphericalGrid(30, 120)
    bank = DiscFilterBank(grid)
    depth = np.full((30, 120), np.inf)
    depth[14:16, 80] = 0.4  # a branch 0.4 m < r = 0.65 m away at azimuth +60 deg
    dirs = grid.directions()
    v = _command(bank, dirs, depth, _unit(0.0, math.radians(40)), 0.0, 3.0)
    assert v @ dirs[14:16, 80].sum(axis=0) <= 0.0
    # and with nothing safe at all, it creeps (a quarter speed) towards the largest y1
    boxed = np.full((30, 120), 1.0)
    boxed[15, 30] = 5.0
    v = _command(bank, dirs, boxed, _unit(0.0, 0.0), 0.0, 3.0)
    i, j = np.unravel_index(np.argmax(bank.filter(boxed)), boxed.shape)
    np.testing.assert_allclose(v, 0.75 * dirs[i, j], atol=1e-12)


def _sphere_clearance(traj: np.ndarray, spheres: np.ndarray) -> float:
    centres, radii = spheres[:, :3], spheres[:, 3]
    return float(np.min(np.linalg.norm(traj[:, None] - centres[None], axis=2) - radii))


def test_short_flight_goes_around_a_blocking_canopy() -> None:
    spheres = np.array([[6.0, 0.0, 2.0, 1.5], [9.0, 2.5, 2.5, 1.0]])
    forest = Forest3D(trunks=np.zeros((0, 4)), canopies=spheres,
                      start=np.array([0.0, 0.0, 2.0]), goal=np.array([12.0, 0.0, 2.0]))
    result = fly(3, FlightConfig(**LOW_RES, max_time_s=20.0), forest=forest)
    assert result.arrived and not result.collided and result.seed == 3
    traj = result.trajectory
    assert np.linalg.norm(traj[-1] - forest.goal) <= 0.5
    assert _sphere_clearance(traj, spheres) > 0.15  # never touched a canopy (r0 = 0.15 m)
    assert traj[:, 2].min() > 0.15  # nor the ground
    length = np.sum(np.linalg.norm(np.diff(traj, axis=0), axis=1))
    assert result.path_length_m == pytest.approx(length)
    assert result.straight_line_m == pytest.approx(11.5)
    assert result.ratio > 1.02  # the straight line runs through the canopy: it had to deviate
    assert result.time_s == pytest.approx(length / 3.0, rel=0.02)


def test_summarize_and_config_errors() -> None:
    rows = [FlightResult(seed=i, arrived=a, collided=c, path_length_m=p, straight_line_m=10.0,
                         time_s=t, trajectory=np.zeros((2, 3)), forest=None)  # type: ignore[arg-type]
            for i, (a, c, p, t) in enumerate([(True, False, 12.0, 4.0), (True, False, 14.0, 5.0),
                                              (False, True, 3.0, 1.0)])]
    s = summarize(rows)
    assert s["arrival_rate"] == pytest.approx(2 / 3) and s["collisions"] == 1
    assert s["mean_ratio_arrived"] == pytest.approx(1.3) and s["max_ratio_arrived"] == 1.4
    assert s["mean_time_s_arrived"] == pytest.approx(4.5)
    assert list(rows[0].row()) == list(FLIGHT_COLUMNS)
    with pytest.raises(ValueError, match=r"results must hold at least one flight"):
        summarize([])
    with pytest.raises(ValueError, match=r"speed_mps must be a finite number > 0, got speed_mps=0"):
        FlightConfig(speed_mps=0)
    with pytest.raises(ValueError, match=r"step_s must be <= control_period_s=0.2, got step_s=0.5"):
        FlightConfig(step_s=0.5)


def test_cli_fly3d_writes_rows_and_summary(tmp_path) -> None:
    out = tmp_path / "f.csv"
    png = tmp_path / "f.png"
    proc = subprocess.run(
        [sys.executable, "-m", "fftnav", "fly3d", "--seeds", "1", "--first", "4", "--rows", "18",
         "--cols", "72", "--out", str(out), "--plot", str(png), "--plot-seed", "4"],
        capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    rows = list(csv.DictReader(out.open()))
    assert [r["seed"] for r in rows] == ["4"] and list(rows[0]) == list(FLIGHT_COLUMNS)
    assert summary["flights"] == 1
    assert summary["arrival_rate"] == (1.0 if rows[0]["arrived"] == "True" else 0.0)
    assert float(rows[0]["ratio"]) == pytest.approx(
        float(rows[0]["path_length_m"]) / float(rows[0]["straight_line_m"]))
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("args", "match"),
    [(["--seeds", "0"], "--seeds must be an integer >= 1, got --seeds=0"),
     (["--seeds", "x"], "invalid int value"),
     (["--rows", "1"], "rows must be an integer >= 2, got rows=1")],
)
def test_cli_fly3d_bad_input(tmp_path, args: list[str], match: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "fftnav", "fly3d", "--out",
                           str(tmp_path / "x.csv"), *args], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and match in lines[0] and "Traceback" not in proc.stderr
