"""``fftnav evaluate``, ``fftnav suites`` and ``fftnav leaderboard`` as subprocesses: the README's
controller ranked on a suite (the tiny test suite through ``$FFTNAV_SUITES_HOME``), a
submission added, and every refusal in one line with exit status 2."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from tests.suites.conftest import make_home

ROOT = Path(__file__).resolve().parents[2]
SECTION = re.search(r"## Benchmark your own method\n(.*?)\n## ",
                    (ROOT / "README.md").read_text(), re.S).group(1)


def fftnav(*args: str, cwd: Path, home: Path | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    if home is not None:
        env["FFTNAV_SUITES_HOME"] = str(home)
    return subprocess.run([sys.executable, "-m", "fftnav", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=600, env=env)


@pytest.fixture(scope="module")
def home(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("home")
    make_home(root)
    return root


@pytest.fixture(scope="module")
def evaluated(home, tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """The README's controller, in a folder outside the repository, evaluated on tiny."""
    where = tmp_path_factory.mktemp("mine")
    (where / "my_controller.py").write_text(re.search(r"```python\n(.*?)```", SECTION, re.S)[1])
    proc = fftnav("evaluate", "my_controller.py:SafeGreedy", "--suite", "tiny", "--out", "ev",
                  "--workers", "1", "--quiet", cwd=where, home=home)
    return where, proc


def _one_line_error(proc: subprocess.CompletedProcess, pattern: str) -> None:
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert re.search(pattern, proc.stderr), proc.stderr


def test_evaluate_prints_the_ranked_table_beside_every_builtin(evaluated):
    where, proc = evaluated
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "references of tiny-v1 reproduce here" in out
    assert re.search(r"^>\s+\d+\s+safe-greedy\s", out, re.M), out
    for builtin in ("bug-left", "bug-right", "fusion"):
        assert re.search(rf"^\s+\d+\s+{builtin}\s", out, re.M), out
    assert "SPL % [95% CI]" in out and "compute ms/robot-tick" in out
    board = pd.read_csv(where / "ev" / "leaderboard.csv")
    assert set(board["method"]) == {"bug-left", "bug-right", "fusion", "safe-greedy"}
    report = (where / "ev" / "report.md").read_text()
    assert "| **safe-greedy** |" in report and "against every built-in" in report
    assert "fftnav replay" in report  # the failed robots' replays, made on demand


def test_a_rerun_resumes(evaluated, home):
    where, _ = evaluated
    proc = fftnav("evaluate", "my_controller.py:SafeGreedy", "--suite", "tiny", "--out", "ev",
                  "--workers", "1", "--quiet", cwd=where, home=home)
    assert proc.returncode == 0, proc.stderr
    info = (where / "ev" / "runs" / "tiny-v1" / "run_info.json").read_text()
    assert '"tasks_completed": 0' in info


def test_leaderboard_add_checks_and_merges_the_evaluation(evaluated, home):
    where, _ = evaluated
    proc = fftnav("leaderboard", "add", "ev", "--out", "board", cwd=where, home=home)
    assert proc.returncode == 0, proc.stderr
    assert "added safe-greedy" in proc.stdout
    table = pd.read_csv(where / "board" / "leaderboard.csv")
    assert "safe-greedy" in set(table["method"])
    assert (where / "board" / "index.html").exists()
    assert "safe-greedy" in (where / "board" / "leaderboard.md").read_text()


@pytest.mark.parametrize(("args", "pattern"), [
    (["evaluate", "bug-left", "--suite", "tiny-v2"],
     r"^fftnav evaluate: error: suite must be a registered suite .*did you mean"),
    (["evaluate", "fusoin", "--suite", "tiny"],
     r"^fftnav evaluate: error: .*did you mean 'fusion'"),
    (["evaluate", "nofile.py:X", "--suite", "tiny"], r"^fftnav evaluate: error: .*nofile.py"),
    (["evaluate", "bug-left", "--workers", "0"],
     r"^fftnav evaluate: error: argument --workers: must be an integer >= 1, got '0'"),
    (["leaderboard", "add", "."],
     r"^fftnav leaderboard: error: evaluation_dir must be a folder written by fftnav evaluate"),
    (["leaderboard"], r"^fftnav leaderboard: error: the following arguments are required"),
    (["suites", "--runs", "x"], r"^fftnav suites: error: --runs and --suite go with --references"),
])
def test_bad_input_is_one_line_and_exit_2(home, tmp_path, args, pattern):
    _one_line_error(fftnav(*args, cwd=tmp_path, home=home), pattern)
    assert not any(tmp_path.iterdir())  # nothing written


def test_references_that_do_not_reproduce_are_refused_under_no_rerun(home, tmp_path):
    import shutil

    import fftnav.suites as suites

    changed = tmp_path / "home"
    shutil.copytree(home, changed)
    suite = suites.suite_from_toml((changed / "defs" / "tiny-v1.toml").read_text(),
                                   file="tiny-v1.toml")
    folder = changed / "references" / "tiny-v1"
    episodes, timing = suites.read_references(suite, folder=changed / "references")
    episodes.loc[episodes["policy"] == "bug-left", "spl"] *= 0.5
    suites.write_references(suite, episodes, timing, folder)
    proc = fftnav("evaluate", "own-only", "--suite", "tiny", "--no-rerun", "--workers", "1",
                  "--quiet", "--out", "e", cwd=tmp_path, home=changed)
    _one_line_error(proc, r"^fftnav evaluate: error: references of tiny-v1 do not reproduce "
                    r"here \(forest-7-bug-left: robot 0: spl .*--no-rerun refuses")


def test_suites_lists_each_suite_with_its_version_and_references(home, tmp_path):
    proc = fftnav("suites", cwd=tmp_path, home=home)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == "tiny-v1  (version 1 of 'tiny')"
    assert "references: 3 built-ins x 2 maps (bug-left, bug-right, fusion)" in proc.stdout


def test_replay_of_a_suite_s_reference_episode_is_made_on_demand(home, tmp_path):
    proc = fftnav("replay", "--suite", "tiny", "--task", "forest-7-fusion", "--out", "r.html",
                  cwd=tmp_path, home=home)
    assert proc.returncode == 0, proc.stderr
    assert "the shipped reference rows of tiny-v1" in proc.stderr
    assert "window.fftnavPlayer" in (tmp_path / "r.html").read_text()


@pytest.mark.parametrize(("args", "pattern"), [
    (["--suite", "tiny", "--out", "r.html"], r"--suite needs --task"),
    (["x.npz", "--suite", "tiny", "--task", "forest-7-fusion", "--out", "r.html"],
     r"--suite reruns the suite's reference episodes: give no PATH, got x.npz"),
    (["--suite", "tiny", "--task", "forest-9-fusion", "--out", "r.html"],
     r"--task must be a reference episode of tiny-v1"),
    (["--out", "r.html"], r"give a recording, a results folder with --task"),
])
def test_replay_suite_refusals(home, tmp_path, args, pattern):
    _one_line_error(fftnav("replay", *args, cwd=tmp_path, home=home),
                    r"^fftnav replay: error: " + pattern)


def test_leaderboard_build_ranks_every_reference_method(home, tmp_path):
    proc = fftnav("leaderboard", "build", "--out", "board", cwd=tmp_path, home=home)
    assert proc.returncode == 0, proc.stderr
    table = pd.read_csv(tmp_path / "board" / "leaderboard.csv")
    assert sorted(table["method"]) == ["bug-left", "bug-right", "fusion"]
    assert (tmp_path / "board" / "tiny-v1" / "failures.md").exists()
    assert "window.fftnavLeaderboard" in (tmp_path / "board" / "index.html").read_text()


def test_suites_references_runs_every_builtin_and_writes_checked_rows(home, tmp_path):
    import shutil

    own = tmp_path / "home"
    shutil.copytree(home, own)
    proc = fftnav("suites", "--references", "--runs", "runs", "--suite", "tiny", "--workers",
                  "2", "--quiet", cwd=tmp_path, home=own)
    assert proc.returncode == 0, proc.stderr
    assert "tiny-v1: references written to" in proc.stdout
    listed = fftnav("suites", cwd=tmp_path, home=own).stdout
    assert "references: 10 built-ins x 2 maps" in listed
    # the shipped methods' rows are those the first references had, byte for byte
    for method in ("bug-left", "fusion"):
        assert ((own / "references" / "tiny-v1" / f"{method}.csv").read_bytes()
                == (home / "references" / "tiny-v1" / f"{method}.csv").read_bytes())


def test_suites_references_needs_its_runs_folder(home, tmp_path):
    _one_line_error(fftnav("suites", "--references", cwd=tmp_path, home=home),
                    r"^fftnav suites: error: --references needs --runs DIR")
