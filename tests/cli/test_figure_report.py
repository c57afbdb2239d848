"""``fftnav figure report CONFIG --out DIR``: maps.csv and report.md of a finished folder, no
episode run, nothing else touched; bad folders exit 2 with one line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fftnav.episode import EPISODE_COLUMNS, EpisodeRow
from fftnav.runner import TaskResult, load_config, run_experiment
from fftnav.runner.maps import maps_table

ROOT = Path(__file__).resolve().parents[2]
TOML = """[experiment]
name = "figure-report"
envs = ["forest"]
maps = 2
map_seed = 7
robots = 3
policies = ["bug-left", "fusion"]
out = "unused"

[world]
size_m = [8.0, 8.0]
goal_y_m = 7.0
"""


def fake_task(config, task):
    rows = [EpisodeRow(**{**{c: 1.0 for c in EPISODE_COLUMNS}, "robot": r, "policy": task.policy,
                          "arrived": r != 1, "collided": False,
                          "failure": "" if r != 1 else "stuck"})
            for r in range(config.robots)]
    paths = [np.ones((3, 3))] * config.robots if task.keep_trajectories else None
    return TaskResult(rows, paths)


def figure_report(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fftnav", "figure", "report", *args],
                          capture_output=True, text=True, cwd=ROOT, timeout=300)


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "c.toml").write_text(TOML)
    out = tmp_path / "res"
    run_experiment(load_config(tmp_path / "c.toml"), out, task_fn=fake_task, workers=1,
                   progress=False)
    return out


def test_figure_report_writes_maps_csv_and_the_report_and_nothing_else(folder):
    kept = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    assert "maps.csv" not in kept  # a fake task function writes none
    proc = figure_report(str(folder.parent / "c.toml"), "--out", str(folder), "--workers", "2")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == str(folder / "report.md")
    config = load_config(folder.parent / "c.toml")
    assert (folder / "maps.csv").read_bytes() == maps_table(config).to_csv(
        index=False, float_format="%.6f").encode()
    report = (folder / "report.md").read_text()
    assert "![spl_vs_difficulty](figures/spl_vs_difficulty.png)" in report
    assert ("| forest | fusion | 6 | 2 | 0 | 0 | 2 | 0 | 0 | 0 | `forest-7-fusion`, "
            "`forest-8-fusion` |") in report
    for name, data in kept.items():
        if name != "report.md":
            assert (folder / name).read_bytes() == data, name
    maps = (folder / "maps.csv").stat().st_mtime_ns
    assert figure_report(str(folder.parent / "c.toml"), "--out", str(folder)).returncode == 0
    assert (folder / "maps.csv").stat().st_mtime_ns == maps  # current: kept


def test_figure_report_refuses_a_folder_without_results_or_of_another_config(folder, tmp_path):
    proc = figure_report(str(folder.parent / "c.toml"), "--out", str(tmp_path / "empty"))
    assert proc.returncode == 2
    assert proc.stderr == (f"fftnav figure: error: --out must be a finished results folder of "
                           f"fftnav run, got --out='{tmp_path / 'empty'}' without episodes.csv\n")
    (tmp_path / "d.toml").write_text(TOML.replace("maps = 2", "maps = 3"))
    proc = figure_report(str(tmp_path / "d.toml"), "--out", str(folder))
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1
    assert "whose config.json differs: experiment.maps" in proc.stderr
    assert not (folder / "maps.csv").exists()
    proc = figure_report(str(folder.parent / "c.toml"), "--out", str(folder), "--workers", "0")
    assert proc.returncode == 2 and "--workers" in proc.stderr


def _damaged(folder, name, change):
    path = folder / name
    if change is None:
        path.unlink()
    else:
        path.write_bytes(change(path.read_bytes()))


@pytest.mark.parametrize("name, change, message", [
    ("episodes.csv", lambda b: b[:b.rindex(b"\n", 0, len(b) - 1) + 12],
     r"episodes\.csv holds 11 robot rows, its last row cut short, expected 12 \(4 episodes x 3 "
     r"robots\): the run has not finished"),
    ("episodes.csv", lambda b: b[:b.rindex(b"\n", 0, len(b) - 1) + 1],
     r"episodes\.csv holds 11 robot rows, expected 12"),
    ("config.json", None, r"without config\.json$"),
    ("config.json", lambda b: b[:20], r"config\.json"),
    ("run_info.json", lambda b: b"{", r"run_info\.json"),
    ("summary.csv", None, r"without summary\.csv$"),
    ("paired_tests.csv", lambda b: b'"a\n', r"paired_tests\.csv: damaged CSV"),
])
def test_figure_report_refuses_a_damaged_or_partial_folder_naming_the_file(folder, name, change,
                                                                           message):
    import re

    _damaged(folder, name, change)
    before = sorted(p.name for p in folder.rglob("*"))
    proc = figure_report(str(folder.parent / "c.toml"), "--out", str(folder))
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert re.search(message, proc.stderr.strip()), proc.stderr
    assert sorted(p.name for p in folder.rglob("*")) == before  # nothing written


def test_a_folder_that_cannot_be_locked_is_named_not_its_lock_file(tmp_path, monkeypatch):
    import os
    import re

    from fftnav.runner.resume import FolderLock

    real = os.open

    def refuse(path, *args, **kwargs):  # what a read-only folder does to a non-root user
        if str(path).endswith(".lock"):
            raise PermissionError(13, "Permission denied", str(path))
        return real(path, *args, **kwargs)

    monkeypatch.setattr(os, "open", refuse)
    with pytest.raises(ValueError, match=rf"^{re.escape(str(tmp_path))} cannot be written "
                                         r"\(Permission denied\): a results folder must be "
                                         r"writable$"):
        with FolderLock(tmp_path):
            pass
