"""``fftnav bench env``: the PettingZoo rollout and bench sim side by side (fftnav.bench.env)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("pettingzoo", reason="the optional extra fftnav[marl] is not installed")
ROOT = Path(__file__).resolve().parents[2]


def test_bench_env_reports_both_speeds_and_their_ratio(tmp_path):
    csv = tmp_path / "env.csv"
    run = subprocess.run([sys.executable, "-m", "fftnav", "bench", "env", "--seconds", "0.5",
                          "--json", "--csv", str(csv)], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    r = json.loads(run.stdout)
    assert r["robots"] == 15 and r["simulated_s"] == pytest.approx(0.5)
    assert r["env_real_time_factor"] == pytest.approx(0.5 / r["env_wall_s"], rel=0.02)
    assert r["sim_real_time_factor"] == pytest.approx(0.5 / r["sim_wall_s"], rel=0.02)
    assert r["ratio"] == pytest.approx(r["env_real_time_factor"] / r["sim_real_time_factor"],
                                       rel=0.01)
    assert 0 < r["mean_live_agents"] <= 15
    header, row = csv.read_text().splitlines()[:2]
    assert "ratio" in header.split(",") and row.startswith("env,forest,0,15")


def test_bench_env_compares_with_the_committed_speed_by_default(tmp_path):
    """Without --csv or --previous, bench env reads results/env_speed.csv for its comparison
    (as every bench does with its committed file) instead of failing."""
    run = subprocess.run([sys.executable, "-m", "fftnav", "bench", "env", "--seconds", "0.5"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    assert "ratio env / sim" in run.stdout and "comparison:" in run.stdout
