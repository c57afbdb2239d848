"""The drift report against hand-made episodes: per-map sums, the summary's means, the paired
gains and their Holm adjustment, the figure, and the rebuild from drift_maps.csv alone."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fftnav.errors import FftnavError
from fftnav.report.drift import drift_gains, drift_maps, drift_summary, write_drift_report
from fftnav.runner import load_config
from fftnav.runner.summary import holm


def _episodes(rng):
    """Two policies on 8 maps at two drifts, 3 robots each: own-only always arrives with SPL
    0.9; collab too at drift none, and loses one robot per map at typical drift."""
    rows = []
    for drift in ("none", "typical"):
        for m in range(8):
            for policy in ("own-only", "collab"):
                for robot in range(3):
                    lost = policy == "collab" and drift == "typical" and robot == 0
                    spl = 0.0 if lost else 0.9 + (0.05 if policy == "collab" else 0.0)
                    rows.append({"env": "walls", "map_seed": 61 + m, "policy": policy,
                                 "robot": robot, "drift": drift, "arrived": not lost,
                                 "spl": spl, "path_length_m": 10.0 + rng.random(),
                                 "optimal_length_m": 9.0, "failure": "lost" if lost else ""})
    return pd.DataFrame(rows)


def test_sums_summary_and_gains_follow_the_episodes():
    episodes = _episodes(np.random.default_rng(0))
    maps = drift_maps(episodes)
    assert len(maps) == 2 * 8 * 2 and (maps["robots"] == 3).all()
    summary = drift_summary(maps, policies=["own-only", "collab"]).set_index(["policy", "drift"])
    assert summary.loc[("collab", "typical"), "ar"] == pytest.approx(2 / 3)
    assert summary.loc[("collab", "typical"), "ar_believed"] == 1.0
    assert summary.loc[("collab", "typical"), "lost"] == pytest.approx(1 / 3)
    assert summary.loc[("collab", "none"), "spl"] == pytest.approx(0.95)
    # the believed SPL of a lost robot: optimal / max(optimal, path), as for an arrived one
    mine = episodes[(episodes["policy"] == "collab") & (episodes["drift"] == "typical")]
    expected = (9.0 / mine["path_length_m"]).mean()
    assert summary.loc[("collab", "typical"), "spl_believed"] == pytest.approx(expected)
    gains = drift_gains(maps).set_index(["policy", "reference", "drift"])
    none = gains.loc[("collab", "own-only", "none")]
    typical = gains.loc[("collab", "own-only", "typical")]
    # eight maps all in favour: the exact two-sided Wilcoxon p is 2 / 2^8
    assert none["gain"] == pytest.approx(0.05) and none["p_value"] == pytest.approx(2 / 256)
    assert typical["gain"] == pytest.approx((2 * 0.95) / 3 - 0.9)
    assert typical["p_holm"] == pytest.approx(holm(gains["p_value"].to_numpy())[
        list(gains.index).index(("collab", "own-only", "typical"))])
    assert typical["verdict"] == "costs" and not typical["noninferior"]
    assert none["noninferior"]  # 5 points ahead on every map


def test_the_report_is_rebuilt_from_drift_maps_alone(tmp_path):
    config = load_config("experiments/drift/fresh.toml")
    with pytest.raises(FftnavError, match=r"results must hold the episodes.csv of experiment "
                                          r"'drift-fresh', cell 'base'"):
        write_drift_report([config], [tmp_path / "none"], tmp_path / "out")
    out = tmp_path / "out"
    out.mkdir()
    drift_maps(_episodes(np.random.default_rng(1))).to_csv(out / "drift_maps.csv", index=False)
    path = write_drift_report([config], [tmp_path / "none"], out)
    text = path.read_text()
    assert "| collab | own-only | walls | typical | 8 |" in text
    assert (out / "drift.png").stat().st_size > 10_000
    assert set(pd.read_csv(out / "drift_summary.csv")["drift"]) == {"none", "typical"}


def test_the_command_refuses_missing_results_in_one_line(tmp_path):
    config = Path("experiments/drift/fresh.toml").resolve()
    proc = subprocess.run([sys.executable, "-m", "fftnav", "figure", "drift", str(config),
                           "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, cwd=tmp_path)  # no results there
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "episodes.csv" in proc.stderr
