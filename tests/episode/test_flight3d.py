"""Quadrotor controller and flight loop (low-resolution sensor, short flights)."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from fftnav.episode.flight3d import (
    FLIGHT_COLUMNS,
    FlightConfig,
    FlightResult,
    _command,
    collides_along,
    fly,
    summarize,
    swept_clear,
)
from fftnav.observe.geometry import DRONE
from fftnav.observe.spherical import DiscFilterBank, SphericalGrid
from fftnav.sim.drone import DroneSim, Forest3D

LOW_RES = {"rows": 30, "cols": 120}


def _unit(el: float, az: float) -> np.ndarray:
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def test_command_takes_the_safe_direction_nearest_the_target() -> None:
    grid = SphericalGrid(30, 120)
    bank = DiscFilterBank(grid)
    depth = np.full((30, 120), np.inf)
    depth[10:20, 55:66] = 1.5  # a wall straight ahead (azimuth -15..18 deg), beyond r
    v = _command(bank, grid.directions(), depth, _unit(0.0, 0.0), yaw=0.0, speed=3.0)
    assert np.linalg.norm(v) == pytest.approx(3.0)
    mask = bank.safe_mask(depth)
    el, az = bank.nearest_direction(mask, 0.0, 0.0)
    np.testing.assert_allclose(v, 3.0 * _unit(el, az), atol=1e-12)
    assert not mask[14, 60] and math.degrees(math.acos(_unit(el, az)[0])) > 20  # around the wall
    # with yaw = 90 deg the same image is seen rotated: the command rotates with it
    v_yawed = _command(bank, grid.directions(), depth, _unit(0.0, math.pi / 2), yaw=math.pi / 2, speed=3.0)
    np.testing.assert_allclose(v_yawed, 3.0 * _unit(el, az + math.pi / 2), atol=1e-12)


def _miss_distance(u: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance (m) from each point (n, 3) to the ray t u, t >= 0, for each direction u (..., 3)."""
    t = np.maximum(u @ points.T, 0.0)
    return np.linalg.norm(points[None] - t[..., None] * u[..., None, :], axis=-1)


def _close_image(grid: SphericalGrid, readings: list[tuple[int, int, float]]) -> np.ndarray:
    depth = np.full((grid.rows, grid.cols), np.inf)
    for i, j, d in readings:
        depth[i, j] = d
    return depth


def test_swept_clear_tests_each_close_reading_on_its_own() -> None:
    grid = SphericalGrid(30, 120)  # 3.1 x 3 deg pixels
    dirs = grid.directions()
    # a 0.4 m gap: readings 0.2 m away on opposite sides (azimuth +60 and -120 deg), which a
    # test on their sum would let cancel out, and two random ones
    rng = np.random.default_rng(4)
    readings = [(15, 80, 0.2), (15, 20, 0.2), *[(rng.integers(30), rng.integers(120),
                                               rng.uniform(0.16, 0.64)) for _ in range(2)]]
    depth = _close_image(grid, readings)
    clear = swept_clear(dirs, depth, r_m=0.65, r0_m=0.15, margin_rad=0.0)
    points = np.array([d * dirs[i, j] for i, j, d in readings])
    miss = _miss_distance(dirs, points).min(axis=-1)
    np.testing.assert_array_equal(clear, miss >= 0.15 - 1e-12)  # the swept-cylinder oracle
    assert not clear[15, 80] and not clear[15, 20] and clear[15, 60]  # through the gap
    # the margin widens each blocking cone by that angle
    wide = swept_clear(dirs, depth, r_m=0.65, r0_m=0.15, margin_rad=math.radians(10))
    angle = np.degrees(np.arccos(np.clip(dirs @ points.T / np.linalg.norm(points, axis=1), -1, 1)))
    cone = np.degrees(np.arcsin(0.15 / np.linalg.norm(points, axis=1))) + 10
    np.testing.assert_array_equal(wide, ~np.any(angle < cone, axis=-1))
    # readings at r or beyond, and NaN/inf, are the disc test's business
    far = _close_image(grid, [(15, 60, 0.65), (10, 10, np.nan)])
    assert swept_clear(dirs, far, r_m=0.65, r0_m=0.15, margin_rad=0.0).all()


def test_command_keeps_the_swept_body_clear_of_close_readings() -> None:
    grid = SphericalGrid(30, 120)
    bank = DiscFilterBank(grid)
    dirs = grid.directions()
    readings = [(15, 80, 0.3), (15, 20, 0.3), (14, 80, 0.3), (16, 20, 0.3)]  # gap at +-60 deg
    depth = _close_image(grid, readings)
    points = np.array([d * dirs[i, j] for i, j, d in readings])
    for target_az in (60.0, -120.0, 0.0):  # straight at either side, and along the gap
        v = _command(bank, dirs, depth, _unit(0.0, math.radians(target_az)), yaw=0.0, speed=3.0)
        assert np.linalg.norm(v) == pytest.approx(3.0)
        assert _miss_distance(v / 3.0, points).min() >= DRONE.r0_m
    v = _command(bank, dirs, depth, _unit(0.0, math.radians(60.0)), yaw=0.0, speed=3.0)
    assert math.degrees(math.acos(v[0] / 3.0 * 0.5 + v[1] / 3.0 * math.sqrt(0.75))) < 40


def test_fallback_keeps_the_close_rule_and_breaks_ties_towards_the_target() -> None:
    grid = SphericalGrid(30, 120)
    bank = DiscFilterBank(grid)
    dirs = grid.directions()
    boxed = np.full((30, 120), 1.0)  # nothing safe; y1 ties everywhere
    boxed[15, 70] = 0.3  # a close reading at azimuth +30 deg
    target = _unit(0.1, math.radians(30))
    v = _command(bank, dirs, boxed, target, yaw=0.0, speed=3.0)
    assert np.linalg.norm(v) == pytest.approx(0.75)  # a quarter speed
    y1 = bank.filter(boxed)
    clear = _miss_distance(dirs, 0.3 * dirs[15, 70][None]).min(axis=-1) > 0.15
    clear &= np.degrees(np.arccos(np.clip(dirs @ dirs[15, 70], -1, 1))) > 30 + 3.1
    best = np.max(y1[clear])
    candidates = clear & (y1 >= best - 1e-9)
    assert (dirs[candidates] @ target).max() == pytest.approx((v / 0.75) @ target, abs=1e-12)
    assert _miss_distance(v / 0.75, 0.3 * dirs[15, 70][None]).min() > 0.15
    # boxed in at 0.2 m all around: every swept cone is blocked, so it hovers
    assert not _command(bank, dirs, np.full((30, 120), 0.2), target, yaw=0.0, speed=3.0).any()


def test_collisions_are_checked_along_the_path() -> None:
    # a 2 cm trunk 0.14 m from the segment's midpoint, 0.157 m from both of its ends (r0 = 0.15)
    forest = Forest3D(trunks=np.array([[0.075, 0.16, 0.02, 4.0]]), canopies=np.zeros((0, 4)),
                      start=np.array([0.0, 0.0, 2.0]), goal=np.array([9.0, 0.0, 2.0]))
    a, b = np.array([0.0, 0.0, 2.0]), np.array([0.15, 0.0, 2.0])
    with DroneSim(forest, grid=SphericalGrid(4, 8), r0_m=0.15) as sim:
        assert not sim.collides(a) and not sim.collides(b)
        assert collides_along(sim, a, b)
        assert not collides_along(sim, a + [0, -0.02, 0], b + [0, -0.02, 0])  # 0.16 m away
        assert collides_along(sim, b, a) and not collides_along(sim, a, a)


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
    with pytest.raises(ValueError, match=r"control_period_s must be an integer multiple of "
                                         r"step_s=0.05, got control_period_s=0.12"):
        FlightConfig(control_period_s=0.12)
    assert FlightConfig(control_period_s=0.3, step_s=0.1).substeps == 3
    for bad in (math.nan, -0.5, math.inf):
        with pytest.raises(ValueError, match=rf"momentum must be a finite number >= 0, "
                                             rf"got momentum={bad}"):
            FlightConfig(momentum=bad)


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
     (["--rows", "1"], "rows must be an integer >= 2, got rows=1"),
     (["--first", "-1"], "--first must be an integer >= 0, got --first=-1"),
     (["--seeds", "2", "--first", "3", "--plot", "p.png", "--plot-seed", "5"],
      "--plot-seed must be one of the flown seeds 3..4, got --plot-seed=5"),
     (["--seeds", "2", "--first", "3", "--plot", "p.png", "--plot-seed", "2"],
      "--plot-seed must be one of the flown seeds 3..4, got --plot-seed=2")],
)
def test_cli_fly3d_bad_input(tmp_path, args: list[str], match: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "fftnav", "fly3d", "--out",
                           str(tmp_path / "sub" / "x.csv"), *args], capture_output=True,
                          text=True, timeout=60, cwd=tmp_path)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and match in lines[0] and "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []  # refused before any file or folder is made
