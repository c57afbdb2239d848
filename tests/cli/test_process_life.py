"""``fftnav run`` under kills: SIGKILL at random moments resumes byte-identically, no process
outlives its parent (SIGKILL, SIGTERM), SIGTERM exits 143, a second Ctrl-C exits 130 at once.

Children are started with SIGINT restored to its default: when the test suite runs as a
background job, SIGINT is ignored and that would be inherited.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "experiments" / "smoke.toml"
CSVS = ("episodes.csv", "summary.csv", "paired_tests.csv")


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(out: Path, workers: int = 2) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "fftnav", "run", str(SMOKE), "--out", str(out),
                             "--workers", str(workers), "--quiet"], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_default_sigint)


def _wait_for_workers(proc: subprocess.Popen, count: int, timeout: float = 120) -> list:
    parent = psutil.Process(proc.pid)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        children = parent.children(recursive=True)
        if len(children) >= count:
            return children
        time.sleep(0.02)
    pytest.fail("the pool workers did not start")


def _assert_gone(processes: list, timeout: float = 10) -> None:
    _, alive = psutil.wait_procs(processes, timeout=timeout)
    assert not alive, f"orphan processes: {[p.pid for p in alive]}"


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("reference")
    proc = _start(out, workers=1)
    assert proc.wait(timeout=300) == 0, proc.stderr.read()
    return out


def test_sigkill_at_random_moments_resumes_byte_identically_without_orphans(reference,
                                                                           tmp_path):
    out = tmp_path / "killed"
    rng = np.random.default_rng(11)
    for _ in range(2):
        proc = _start(out)
        workers = _wait_for_workers(proc, 2)
        time.sleep(rng.uniform(0.0, 2.5))
        proc.kill()
        proc.wait(timeout=30)
        _assert_gone(workers)
    proc = _start(out)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    for name in CSVS:
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    assert not list(out.rglob("*.tmp")) and not (out / ".lock").exists()


def test_sigterm_exits_143_and_stops_the_workers(tmp_path):
    proc = _start(tmp_path / "term")
    workers = _wait_for_workers(proc, 2)
    proc.terminate()
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143
    assert err.strip().splitlines() == [f"fftnav run: terminated; finished episodes are kept in "
                                        f"{tmp_path / 'term'}, rerun the same command to resume"]
    _assert_gone(workers)


@pytest.mark.parametrize("gap_s", [0.1])
def test_double_ctrl_c_exits_130_at_once_in_one_line(tmp_path, gap_s):
    proc = _start(tmp_path / "int")
    workers = _wait_for_workers(proc, 2)
    proc.send_signal(signal.SIGINT)
    time.sleep(gap_s)
    second = time.monotonic()
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert time.monotonic() - second < 2.0
    assert proc.returncode == 130
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("fftnav")
    _assert_gone(workers)


@pytest.mark.parametrize("exc_type", ["KeyboardInterrupt", "Terminated"])
def test_a_swallowed_first_interrupt_is_delivered_again_outside_the_hook(exc_type):
    """A first Ctrl-C / SIGTERM whose exception Python ignored (it landed in a finaliser) is
    raised again in the main thread's own code, not inside the unraisable hook (where it would
    be ignored, and printed, a second time)."""
    import types

    from fftnav import cli

    exc = KeyboardInterrupt if exc_type == "KeyboardInterrupt" else cli.Terminated
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        cli._redeliver(types.SimpleNamespace(exc_type=exc, exc_value=exc(), exc_traceback=None,
                                             err_msg=None, object=None))  # returns normally
        with pytest.raises(exc):
            for _ in range(6000):
                time.sleep(0.01)
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler)
        cli._stopping, cli._stopped_by = False, None


def test_an_error_after_an_earlier_stop_is_still_an_error(tmp_path, capsys):
    """A stop (SIGINT/SIGTERM) that an earlier command of this process received does not turn a
    later command's bad input into "terminated": only a stop during the command does."""
    from fftnav import cli

    saved = cli._stopped_by
    cli._stopped_by = signal.SIGTERM
    try:
        status = cli.main(["scan", str(tmp_path / "missing.npy")])
    finally:
        cli._stopped_by = saved
    assert status == 2
    assert capsys.readouterr().err.startswith("fftnav scan: error: ")
