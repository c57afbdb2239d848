"""Scale-out as users run it: ``fftnav run --executor dask --scheduler tcp://...`` against an
external ``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1, byte-identical to
the local executor, also when one worker is SIGKILLed while it holds an episode; no process
is left behind."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "experiments" / "smoke.toml"
CSVS = ("episodes.csv", "summary.csv", "paired_tests.csv")


def _dask(*args: str, log: Path) -> subprocess.Popen:
    """``dask scheduler`` or ``dask worker`` in its own process group (killed as a group)."""
    cli = {"scheduler": "dask_scheduler", "worker": "dask_worker"}[args[0]]
    return subprocess.Popen([sys.executable, "-m", f"distributed.cli.{cli}", *args[1:]],
                            stdout=log.open("w"), stderr=subprocess.STDOUT,
                            start_new_session=True, cwd=log.parent)


def _fftnav_run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fftnav", "run", str(SMOKE), "--quiet", *args],
                          capture_output=True, text=True, cwd=ROOT, timeout=300)


@pytest.fixture(scope="module")
def local_run(tmp_path_factory) -> Path:
    """The smoke experiment on the local executor (one worker)."""
    out = tmp_path_factory.mktemp("local")
    proc = _fftnav_run("--out", str(out), "--workers", "1")
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture
def cluster(tmp_path):
    """An external scheduler on a free port of 127.0.0.1 and two single-thread workers (no
    nanny: a killed worker stays dead), each in its own process group; the teardown kills the
    groups and checks that no process of them is left."""
    info = tmp_path / "scheduler.json"
    procs = [_dask("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                   "--scheduler-file", str(info), log=tmp_path / "scheduler.log")]
    try:
        deadline = time.monotonic() + 60
        while not (info.exists() and info.read_text().strip()):
            assert procs[0].poll() is None and time.monotonic() < deadline, \
                (tmp_path / "scheduler.log").read_text()
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        for i in range(2):
            procs.append(_dask("worker", address, "--host", "127.0.0.1", "--nthreads", "1",
                               "--no-nanny", "--no-dashboard", log=tmp_path / f"worker{i}.log"))
        client = distributed.Client(address, timeout=60)
        client.wait_for_workers(2, timeout=60)
        yield address, client
        client.close()
    finally:
        for proc in procs:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        for proc in procs:
            proc.wait(timeout=30)
            with pytest.raises(ProcessLookupError):
                os.killpg(proc.pid, 0)  # nothing of the group is left


def _same_csvs(out: Path, reference: Path) -> None:
    for name in CSVS:
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name


def test_external_scheduler_and_two_workers_give_the_local_csvs(cluster, local_run, tmp_path):
    address, client = cluster
    proc = _fftnav_run("--out", str(tmp_path / "out"), "--executor", "dask",
                       "--scheduler", address)
    assert proc.returncode == 0, proc.stderr
    assert "4 episodes run, 0 already done, 0 failed" in proc.stdout
    _same_csvs(tmp_path / "out", local_run)
    assert len(client.scheduler_info()["workers"]) == 2  # the cluster outlives the run


def test_a_worker_killed_while_it_holds_an_episode_changes_nothing(cluster, local_run,
                                                                   tmp_path):
    address, client = cluster
    pids = client.run(os.getpid)  # worker address -> process id
    run = subprocess.Popen([sys.executable, "-m", "fftnav", "run", str(SMOKE), "--quiet",
                            "--out", str(tmp_path / "out"), "--executor", "dask",
                            "--scheduler", address], cwd=ROOT, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    try:
        deadline, victim = time.monotonic() + 120, None
        while victim is None:
            assert run.poll() is None and time.monotonic() < deadline, run.communicate()
            busy = [w for w, keys in client.processing().items() if keys]
            if busy:
                victim = busy[0]
            else:
                time.sleep(0.05)
        time.sleep(0.3)  # well inside its episode (each takes seconds)
        assert client.processing()[victim], "the worker finished its episode too soon"
        os.kill(pids[victim], signal.SIGKILL)
        stdout, stderr = run.communicate(timeout=240)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 0, stderr
    assert "4 episodes run, 0 already done, 0 failed" in stdout
    _same_csvs(tmp_path / "out", local_run)
    deadline = time.monotonic() + 30
    while victim in client.scheduler_info()["workers"]:  # the scheduler saw it go
        assert time.monotonic() < deadline
        time.sleep(0.1)
    assert len(client.scheduler_info()["workers"]) == 1
