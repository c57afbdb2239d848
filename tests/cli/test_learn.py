"""fftnav learn as a subprocess: bad configs and a missing extra are one line and exit 2,
before any work (the training itself: tests/learn/test_train.py, with the extra)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _learn(*args, cwd):
    return subprocess.run([sys.executable, "-m", "fftnav", "learn", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("text, match", [
    ('[learn]\nobservation = "lidar"\n', "learn.observation must be one of"),
    ('[learn]\nobservation = "ranges"\n[train]\nmap_seeds = [1000, 1010]\n'
     '[validation]\nmap_seeds = [7000, 7100]\n', "overlaps Table I's maps"),
    ("[learn\n", "t.toml"),
])
def test_bad_configs_exit_2_with_one_line(tmp_path, text, match):
    (tmp_path / "t.toml").write_text(text)
    res = _learn("t.toml", cwd=tmp_path)
    assert res.returncode == 2
    assert match in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "learned").exists()


def test_a_bad_seed_exits_2(tmp_path):
    res = _learn(str(ROOT / "experiments" / "learn" / "decider.toml"), "--seed", "-3",
                 cwd=tmp_path)
    assert res.returncode == 2 and "--seed must be an integer >= 0" in res.stderr


@pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is not None,
                    reason="the extra learn is installed")
def test_without_the_extra_the_pip_line_is_named(tmp_path):
    res = _learn(str(ROOT / "experiments" / "learn" / "controller-extrema.toml"), cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.strip() == ("fftnav learn: error: training runs need the stable_baselines3 "
                                  "package: pip install 'fftnav[learn]'")
    assert not (tmp_path / "learned").exists()


def test_figure_learning_writes_the_report_or_names_what_is_missing(tmp_path):
    import numpy as np

    from tests.report.test_learning import _episodes, _run

    runs = [_run(tmp_path / f"r{s}", seed=s) for s in range(2)]
    table1 = tmp_path / "t1"
    table1.mkdir()
    _episodes(np.random.default_rng(0), {"random": 0.8, "learned-decider-x": 0.9}).to_csv(
        table1 / "episodes.csv", index=False)
    fig = [sys.executable, "-m", "fftnav", "figure", "learning"]
    res = subprocess.run([*fig, *map(str, runs), "--table1", str(table1), "--out", "out",
                          "--threshold", "0.5"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    text = (tmp_path / "out" / "learning.md").read_text()
    assert "| controller/extrema | 2 | 1,000 [1,000, 1,000] |" in text and "learned-decider-x | random" in text
    res = subprocess.run([*fig, str(tmp_path / "nothing"), "--out", "out"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and "nothing/config.json" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    res = subprocess.run([*fig, str(runs[0]), "--out", "out", "--threshold", "2"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and "--threshold must be in (0, 1]" in res.stderr
