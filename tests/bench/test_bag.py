"""``fftnav bench bag``: an episode without and with its bag, side by side (fftnav.bench.bag)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

pytest.importorskip("rosbags", reason="the optional extra fftnav[ros] is not installed")


def test_bench_bag_reports_both_times_their_ratio_and_the_bags_size(tmp_path):
    csv = tmp_path / "bag.csv"
    run = subprocess.run([sys.executable, "-m", "fftnav", "bench", "bag", "--seconds", "0.5",
                          "--repeats", "1", "--json", "--csv", str(csv)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    r = json.loads(run.stdout)
    assert (r["robots"], r["repeats"], r["suffix"]) == (15, 1, ".mcap")
    assert r["robot_ticks"] == 15 * 5  # 0.5 s at 10 Hz, every robot driving throughout
    assert r["ratio"] == pytest.approx(r["bag_wall_s"] / r["plain_wall_s"], abs=2e-3)
    added = 1000 * (r["bag_wall_s"] - r["plain_wall_s"]) / r["robot_ticks"]
    assert r["bag_ms_per_robot_tick"] == pytest.approx(added, abs=0.05)
    assert r["bag_mb"] > 0
    header, row = csv.read_text().splitlines()[:2]
    assert "bag_ms_per_robot_tick" in header.split(",") and row.startswith("bag,forest,1000,15")


def test_bench_bag_refuses_a_bad_repeat_count():
    run = subprocess.run([sys.executable, "-m", "fftnav", "bench", "bag", "--repeats", "0"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and run.stderr.count("\n") == 1
    assert "repeats" in run.stderr and "got repeats=0" in run.stderr
