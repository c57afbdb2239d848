"""Every writer removes its temporary file or folder when it is stopped: under SIGTERM (``kill
PID``: exit 143) and under Ctrl-C (SIGINT to the process group, as a terminal sends it, ffmpeg
included: exit 130), ``fftnav episode --bag``, ``fftnav scan --out-bag`` and ``fftnav replay``
to a GIF and an MP4 leave their output folder empty: no hidden ``.NAME.PID.tmp``, no partial
output under the real name.

Each command runs as ``python -m fftnav`` (``fftnav/__main__.py`` calls the console script's
``entry``, which installs the signal handling) on an input that keeps it writing for several
seconds more (a slow robot, thousands of scans, a slowed replay), and is signalled as soon as its
temporary holds bytes; a command that is no longer running then fails the test. Children start
with SIGINT restored to its default (a test run in the background ignores it, and children
would inherit that).

A signal that lands inside code catching every exception (matplotlib's C++ argument conversion
turns the handler's exception into "Invalid affine transformation matrix") still exits 143 or
130 with its one line: a stopping process reports any error as the stop.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.report.recordings import make_recording
from tests.ros.bagmaker import scans_bag

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]

#: The commands, each writing into ``{out}``: an episode whose robots drive at 2 cm/s (about
#: 50 s of wall time unstopped), 4,000 full-turn scans to annotate (about 5 s), the recording's
#: 6 s replayed at a quarter speed (241 frames, about 13 s).
COMMANDS = {
    "episode --bag": ["episode", "--world", "{inp}/w.json", "--policy", "fusion", "--set",
                      "time_limit_s=600", "--set", "robot.v_max_mps=0.02", "--bag",
                      "{out}/e.mcap"],
    "scan --out-bag": ["scan", "{inp}/b.mcap", "--out-bag", "{out}/a.mcap"],
    "replay .gif": ["replay", "{inp}/r.npz", "--out", "{out}/r.gif", "--speed", "0.25"],
    "replay .mp4": ["replay", "{inp}/r.npz", "--out", "{out}/r.mp4", "--speed", "0.25"],
}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    from fftnav.world import generate_world, save_world

    inp = tmp_path_factory.mktemp("inputs")
    save_world(generate_world("forest", 3, size_m=[8.0, 8.0], goal_y_m=7.0, robots=2),
               inp / "w.json")
    beams = 360
    scans_bag(inp / "b.mcap", np.full((4000, beams), 5.0), angle_min=-np.pi,
              angle_max=np.pi - 2 * np.pi / beams, angle_increment=2 * np.pi / beams)
    make_recording(inp / "r.npz")
    return inp


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _holds_bytes(path: Path) -> bool:
    """A temporary file with bytes in it, or a temporary folder holding such a file."""
    try:
        if path.is_dir():
            return any(p.is_file() and p.stat().st_size > 0 for p in path.rglob("*"))
        return path.stat().st_size > 0
    except FileNotFoundError:  # removed or renamed meanwhile
        return False


def _wait_for_temporary(proc: subprocess.Popen, out: Path, timeout_s: float = 60.0) -> Path:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"exited {proc.returncode} before its temporary held bytes: "
                        f"{proc.stderr.read()}")
        found = [p for p in out.iterdir() if p.name.startswith(".") and ".tmp" in p.name]
        if found and _holds_bytes(found[0]):
            return found[0]
        time.sleep(0.01)
    pytest.fail(f"no temporary with bytes in {out} after {timeout_s:g} s")


@pytest.mark.parametrize("how", ["SIGTERM", "Ctrl-C"])
@pytest.mark.parametrize("writer", list(COMMANDS))
def test_a_stopped_writer_leaves_nothing_in_its_output_folder(inputs, tmp_path, writer, how):
    if writer.endswith(".mp4"):
        pytest.importorskip("imageio_ffmpeg", reason="the optional extra fftnav[video]")
    out = tmp_path / "out"
    out.mkdir()
    argv = [a.format(inp=inputs, out=out) for a in COMMANDS[writer]]
    proc = subprocess.Popen([sys.executable, "-m", "fftnav", *argv], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_default_sigint, start_new_session=True)
    try:
        tmp = _wait_for_temporary(proc, out)
        name = next(Path(a).name for a in COMMANDS[writer] if a.startswith("{out}"))
        assert tmp.name.startswith(f".{name}.{proc.pid}.tmp")  # atomic_path's, BagFile's
        if how == "SIGTERM":
            proc.send_signal(signal.SIGTERM)
        else:
            os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    word, status = ("terminated", 143) if how == "SIGTERM" else ("interrupted", 130)
    assert (proc.returncode, err) == (status, f"fftnav {argv[0]}: {word}\n")
    assert list(out.iterdir()) == []


#: ``fftnav replay`` whose third frame is drawn by code that catches the stop's exception and
#: raises a ValueError instead, as matplotlib's C++ argument conversion does when the signal
#: handler runs inside it ("Invalid affine transformation matrix", "Invalid bounding box").
_SWALLOWED = """
import os, signal, sys, time
from fftnav.cli import entry
from fftnav.report import replay

stop = getattr(signal, sys.argv.pop(1))  # the signal, before the command's arguments
drawn, draw = [0], replay._pixels

def pixels(fig):
    drawn[0] += 1
    if drawn[0] == 3:
        try:
            os.kill(os.getpid(), stop)
            time.sleep(30)
        except BaseException:
            raise ValueError("Invalid affine transformation matrix")
    return draw(fig)

replay._pixels = pixels
entry()
"""


@pytest.mark.parametrize(("sig", "status", "word"), [("SIGTERM", 143, "terminated"),
                                                      ("SIGINT", 130, "interrupted")])
def test_a_stop_whose_exception_other_code_replaced_still_exits_as_stopped(inputs, tmp_path, sig,
                                                                           status, word):
    out = tmp_path / "out"
    out.mkdir()
    proc = subprocess.run([sys.executable, "-c", _SWALLOWED, sig, "replay",
                           str(inputs / "r.npz"), "--out", str(out / "r.gif")], cwd=ROOT,
                          capture_output=True, text=True, timeout=120, preexec_fn=_default_sigint)
    assert (proc.returncode, proc.stderr) == (status, f"fftnav replay: {word}\n")
    assert list(out.iterdir()) == []
