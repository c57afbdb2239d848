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
    assert result["real_time_factor"] == pytest.approx(0.5 / result["wall_s"], rel=0.01)
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
