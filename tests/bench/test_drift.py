"""fftnav bench drift: one row per preset, drift growing with the preset and the distance."""

import pytest

from fftnav.bench.drift import bench_drift, format_drift
from fftnav.localization import DRIFT_PRESETS, reference_path


def test_rows_per_preset_grow_with_the_preset_and_the_distance():
    rows = bench_drift(runs=1000, episode_runs=50, paths=[reference_path(length_m=15.0)])
    assert [r["preset"] for r in rows] == list(DRIFT_PRESETS)
    assert rows[0]["drift_20m_pct"] == rows[0]["drift_episode_pct"] == 0.0
    twenty = [r["drift_20m_pct"] for r in rows]
    assert twenty == sorted(twenty) and twenty[2] == pytest.approx(2.0, rel=0.2)
    for r in rows[1:]:
        assert r["drift_10m_pct"] < r["drift_20m_pct"] < r["drift_40m_pct"]
    assert rows[0]["episode_path_m"] == pytest.approx(15.0, abs=0.01)
    assert "typical" in format_drift(rows).splitlines()[3]
