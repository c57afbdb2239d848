"""``fftnav bench sim`` as a subprocess (fftnav.bench.sim)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


def _fftnav(*args):
    return subprocess.run([sys.executable, "-m", "fftnav", *args], capture_output=True, text=True,
                          timeout=120)


def test_bench_sim_json_reports_speed_and_lidar_cost(tmp_path):
    csv = tmp_path / "speed.csv"
    run = _fftnav("bench", "sim", "--env", "rocky", "--seconds", "0.5", "--json", "--csv", str(csv))
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    assert result["env"] == "rocky" and result["robots"] == 15 and result["simulated_s"] == 0.5
    # wall_s is rounded to 0.1 ms and the factor to 0.01: the factor lies within what the
    # rounded wall time allows
    wall = result["wall_s"]
    assert 0.5 / (wall + 5e-5) - 0.005 <= result["real_time_factor"] <= 0.5 / (wall - 5e-5) + 0.005
    assert 0 < result["lidar_ms_per_tick"] < 1e3 * result["wall_s"] / 5
    assert 0 < result["rays_cast_per_tick"] < result["rays_per_tick"] == 15 * 345
    assert result["load_avg_1min"] >= 0
    header, row = csv.read_text().splitlines()[:2]
    assert "real_time_factor" in header.split(",") and row.startswith("sim,rocky,0,15")


def test_bench_sim_bad_seconds_exit_2_with_one_line():
    run = _fftnav("bench", "sim", "--seconds", "-1")
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.count("\n") == 1 and "Traceback" not in run.stderr
    assert run.stderr.strip().endswith("error: seconds must be a finite number in (0, 3600], got seconds=-1.0")


def test_bench_world_keeps_densities_and_lines_robots_up_in_rows():
    import math

    import numpy as np

    from fftnav.bench.sim import bench_world, default_size_m

    assert default_size_m("forest", 15) == 20.0
    assert default_size_m("forest", 100) == pytest.approx(math.sqrt(100 * 400 / 15), abs=0.01)
    world = bench_world("forest", 1, robots=40, size_m=10.0)
    assert world.size_m == (10.0, 10.0) and len(world.obstacles) == round(0.2 * 100)
    starts = world.starts
    assert len(starts) == 40 and len(np.unique(starts[:, 1])) == 2  # two rows
    gaps = np.hypot(*(starts[:, None, :2] - starts[None, :, :2]).transpose(2, 0, 1))
    assert gaps[~np.eye(40, dtype=bool)].min() >= 2.5 * 0.15
    assert np.all(np.abs(starts[:, 1] - 1.0) <= 1.0 - 0.15)  # inside the clear start strip
    np.testing.assert_array_equal(world.goals[:, 0], starts[:, 0])
    np.testing.assert_allclose(world.goals[:, 1] - starts[:, 1], 8.0)
    # the clear strip: no obstacle reaches a start
    assert world.obstacle_distance(starts[:, :2]).min() > 0.15
    with pytest.raises(ValueError, match="robots=200 do not fit on the start strip"):
        bench_world("forest", 1, robots=200, size_m=5.0)


def test_bench_scale_writes_the_table_and_the_figure(tmp_path):
    import csv as csvlib

    table, figure = tmp_path / "scale.csv", tmp_path / "fig" / "scale.png"
    run = _fftnav("bench", "scale", "--env", "forest", "--robots", "3", "12", "--seconds", "0.3",
                  "--csv", str(table), "--figure", str(figure))
    assert run.returncode == 0, run.stderr
    rows = list(csvlib.DictReader(table.open()))
    assert [(r["env"], r["robots"]) for r in rows] == [("forest", "3"), ("forest", "12")]
    for r in rows:  # ms per robot-second is the wall time over simulated robot-seconds
        # (wall_s is rounded to 0.1 ms, a few percent of these tiny runs)
        wall = float(r["wall_s"])
        assert float(r["ms_per_robot_s"]) == pytest.approx(
            1e3 * wall / (float(r["simulated_s"]) * int(r["robots"])), rel=1e-4 / wall + 1e-3)
    growth = float(rows[1]["ms_per_robot_s"]) / float(rows[0]["ms_per_robot_s"])
    assert f"grows x{growth:.2f} from 3 to 12 robots" in run.stdout
    assert figure.read_bytes()[:4] == b"\x89PNG"
