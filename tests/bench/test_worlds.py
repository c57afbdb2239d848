"""``fftnav bench worlds``: the trunk fields, one case measured, another source tree
against this one (fftnav.bench.worlds)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fftnav.bench import worlds
from fftnav.bench.worlds import bench_large_world, side_by_side, trunk_field


def test_trunk_field_holds_its_trunks_apart_inside_the_world_clear_of_the_robots():
    world = trunk_field(2_000, 40.0, seed=1)
    assert len(world.obstacles) == 2_000 and world.size_m == (40.0, 40.0)
    xy = np.array([o.center for o in world.obstacles])
    r = np.array([o.radius for o in world.obstacles])
    assert r.min() >= 0.05 and r.max() <= 0.1
    assert (xy - r[:, None] >= 0).all() and (xy + r[:, None] <= 40.0).all()
    assert (xy[:, 1] - r >= 2.0).all() and (xy[:, 1] + r <= 38.0).all()  # clear strips
    gap = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1)) - r[:, None] - r[None]
    np.fill_diagonal(gap, np.inf)
    assert gap.min() >= 0.1 - 1e-9
    assert world.to_json() == trunk_field(2_000, 40.0, seed=1).to_json()  # seeded
    assert world.to_json() != trunk_field(2_000, 40.0, seed=2).to_json()
    with pytest.raises(ValueError, match="trunks: 9000 do not fit 20 m x 20 m"):
        trunk_field(9_000, 20.0)


def test_one_case_reports_time_to_first_scan_an_episode_and_tiles(monkeypatch):
    monkeypatch.setitem(worlds.LARGE_WORLDS, "tiny",
                        {"trunks": 1_500, "side_m": 40.0, "episode_s": 1.0})
    row = bench_large_world("tiny")
    assert row["obstacles"] == 1_500 and row["robots"] == 15
    assert row["tiles"] == 16 and 4 <= row["tiles_built"] < 16  # the starts' row of tiles
    assert 0 < row["ready_s"] < 60 and 0 < row["episode_wall_s"] < 120
    assert row["episode_s"] == 1.0 and len(row["rows_sha256"]) == 16
    assert row["max_rss_mb"] > 0


def test_side_by_side_against_this_tree_gives_identical_rows_and_ratios(monkeypatch):
    monkeypatch.setitem(worlds.LARGE_WORLDS, "tiny",
                        {"trunks": 800, "side_m": 30.0, "episode_s": 0.5})
    tree = Path(worlds.__file__).resolve().parents[2]
    rows = side_by_side(tree, case="tiny", repeats=1)
    assert [r["code"] for r in rows] == ["old", "new", "new/old"]
    assert rows[0]["rows_sha256"] == rows[1]["rows_sha256"]
    assert rows[-1]["rows_sha256"] == "identical" and rows[-1]["ready_s"] > 0
    assert list(rows[-1]) == list(rows[0])  # one CSV header for every row
    with pytest.raises(ValueError, match="against must be a source tree holding fftnav/"):
        side_by_side(tree / "docs")
    with pytest.raises(ValueError, match="repeats must be"):
        side_by_side(tree, repeats=0)


def test_unknown_case_exits_2_with_one_line():
    run = subprocess.run([sys.executable, "-m", "fftnav", "bench", "worlds", "--case", "huge"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert "case must be one of ['trunks-20k', 'largest'], got case='huge'" in run.stderr
