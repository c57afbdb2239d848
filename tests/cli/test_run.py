"""``fftnav run``: real smoke episodes, resume, Dask == local, exit statuses, bad input."""

from __future__ import annotations

import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import fftnav.runner.tasks
from fftnav.cli import main
from fftnav.runner import load_config, run_experiment

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "experiments" / "smoke.toml"
CSVS = ("episodes.csv", "summary.csv", "paired_tests.csv")


def fftnav_run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fftnav", "run", *args], capture_output=True,
                          text=True, cwd=ROOT, timeout=300)


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory) -> Path:
    """The smoke experiment run once through the CLI on 2 local workers."""
    out = tmp_path_factory.mktemp("smoke")
    proc = fftnav_run(str(SMOKE), "--out", str(out), "--workers", "2", "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert "4 episodes run, 0 already done, 0 failed" in proc.stdout
    return out


def test_smoke_run_writes_every_output(smoke_run):
    config = load_config(SMOKE)
    episodes = pd.read_csv(smoke_run / "episodes.csv")
    assert len(episodes) == config.maps * len(config.policies) * config.robots
    assert set(episodes.policy) == set(config.policies) and set(episodes.map_seed) == {7, 8}
    summary = pd.read_csv(smoke_run / "summary.csv")
    assert {"env", "policy", "episodes", "robots", "ar", "apl_m", "spl", "spl_ci_low",
            "spl_ci_high"} <= set(summary.columns)
    assert summary.ar.between(0, 1).all() and summary.spl.between(0, 1).all()
    # the per-robot SPL column and the summary agree (an independent recomputation)
    by_policy = episodes.groupby("policy").spl.mean()
    assert summary.set_index("policy").spl.to_dict() == pytest.approx(by_policy.to_dict(),
                                                                      abs=1e-6)
    report = (smoke_run / "report.md").read_text()
    assert "| forest | fusion |" in report and "paper AR %" not in report and "git `" in report
    for name in ("trajectories_forest.png", "spl_apl.png", "path_lengths.png"):
        assert (smoke_run / "figures" / name).stat().st_size > 1000
        assert f"figures/{name}" in report
    assert (smoke_run / "config.toml").read_text() == SMOKE.read_text()


def test_rerun_skips_finished_episodes_and_resume_gives_the_same_rows(smoke_run, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(smoke_run, out)
    (out / "episodes" / "forest-8-fusion.csv").unlink()  # as if interrupted before this one
    proc = fftnav_run(str(SMOKE), "--out", str(out), "--workers", "1", "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert "1 episodes run, 3 already done, 0 failed" in proc.stdout
    for name in CSVS:
        assert (out / name).read_bytes() == (smoke_run / name).read_bytes()


def test_ctrl_c_then_rerun_ends_with_the_rows_of_an_uninterrupted_run(smoke_run, tmp_path):
    out = tmp_path / "interrupted"
    proc = subprocess.Popen([sys.executable, "-m", "fftnav", "run", str(SMOKE), "--out",
                             str(out), "--workers", "1", "--quiet"], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120
    while not list((out / "episodes").glob("*.csv")) and time.monotonic() < deadline:
        time.sleep(0.005)
    proc.send_signal(signal.SIGINT)  # after the first of 4 episodes
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130 and "rerun the same command to resume" in err
    partial = pd.read_csv(out / "episodes.csv")
    assert 0 < len(partial) < 4 * 3 and len(partial) % 3 == 0  # whole episodes only
    assert fftnav_run(str(SMOKE), "--out", str(out), "--quiet").returncode == 0
    for name in CSVS:
        assert (out / name).read_bytes() == (smoke_run / name).read_bytes()


def test_dask_local_cluster_gives_the_same_csvs(smoke_run, tmp_path):
    outcome = run_experiment(load_config(SMOKE), tmp_path, executor="dask", workers=2,
                             progress=False)
    assert outcome.completed == 4 and not outcome.failed
    for name in CSVS:
        assert (tmp_path / name).read_bytes() == (smoke_run / name).read_bytes()


def test_an_episode_that_raises_gives_exit_status_1(tmp_path, monkeypatch, capsys):
    real = fftnav.runner.tasks.run_episode

    def flaky(world, policy, **kwargs):
        if policy == "fusion":
            raise RuntimeError("planner exploded")
        return real(world, policy, **kwargs)

    monkeypatch.setattr(fftnav.runner.tasks, "run_episode", flaky)
    status = main(["run", str(SMOKE), "--out", str(tmp_path), "--workers", "1", "--quiet"])
    assert status == 1
    err = capsys.readouterr().err
    assert "forest-7-fusion failed: RuntimeError: planner exploded" in err
    assert set(pd.read_csv(tmp_path / "episodes.csv").policy) == {"bug-left"}
    assert len(pd.read_csv(tmp_path / "errors.csv")) == 2
    assert "2 episode(s) failed" in (tmp_path / "report.md").read_text()


@pytest.mark.parametrize("args, match", [
    (["missing.toml"], r"fftnav run: error: \[Errno 2\] No such file"),
    (["CONFIG", "--workers", "0"], r"argument --workers: must be an integer >= 1, got '0'"),
    (["CONFIG", "--executor", "spark"], r"argument --executor: invalid choice: 'spark'"),
    (["CONFIG", "--scheduler", "tcp://127.0.0.1:1"],
     r"fftnav run: error: scheduler needs executor='dask', got executor='local'"),
    (["BAD"], r"fftnav run: error: .*bad\.toml: experiment\.maps must be an integer >= 1, got experiment\.maps=0"),
])
def test_bad_input_is_one_line_and_exit_2(args, match, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SMOKE.read_text().replace("maps = 2", "maps = 0"))
    args = [{"CONFIG": str(SMOKE), "BAD": str(bad)}.get(a, a) for a in args]
    proc = fftnav_run(*args, "--out", str(tmp_path / "out"))
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert re.search(match, lines[0]), lines[0]
