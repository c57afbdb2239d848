"""Figures without global state: importing fftnav.report and drawing (a replay frame, a report
figure, the environment's render) leaves matplotlib's backend as the user set it and never
imports pyplot; robots are drawn by the one state vocabulary (fftnav.states)."""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from fftnav.report.frames import KINDS, kinds_of
from fftnav.states import State, Status

ROOT = Path(__file__).resolve().parents[2]

DRAW = textwrap.dedent("""
    import sys
    import matplotlib
    matplotlib.use("svg")  # a notebook's or a GUI's choice: anything but Agg
    import numpy as np
    import fftnav.report, fftnav.report.frames, fftnav.report.replay, fftnav.report.replay_html
    import fftnav.report.experiment, fftnav.report.sweep, fftnav.report.trajectories
    from fftnav.envs import SwarmNavEnv
    from fftnav.episode.recording import read_recording
    from fftnav.report.replay import write_image
    from fftnav.report.world_plot import render_world
    from tests.report.recordings import make_recording

    out = sys.argv[1]
    make_recording(out + "/r.npz")
    rec = read_recording(out + "/r.npz")
    write_image(rec, out + "/f.png", at_s=2.0)
    render_world(rec.world, out + "/w.png")
    env = SwarmNavEnv("forest", map_seed=0, robots=3, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    env.close()
    print(matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules, frame.shape[2])
""")


def test_drawing_keeps_the_users_backend_and_imports_no_pyplot(tmp_path):
    done = subprocess.run([sys.executable, "-c", DRAW, str(tmp_path)], capture_output=True,
                          text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["svg", "False", "3"]
    for name in ("f.png", "w.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _global_state(path: Path) -> list[str]:
    """The imports of pyplot and the calls of ``matplotlib.use`` in a module."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [f"{node.module}.{a.name}" for a in node.names]
        found += [n for n in names if n == "matplotlib.pyplot"]
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and node.func.attr == "use" and isinstance(node.func.value, ast.Name)
                and node.func.value.id == "matplotlib"):
            found.append("matplotlib.use")
    return found


def test_no_module_imports_pyplot_or_selects_a_backend():
    found = {str(p.relative_to(ROOT)): _global_state(p) for p in (ROOT / "fftnav").rglob("*.py")}
    assert {k: v for k, v in found.items() if v} == {}


#: How a robot is drawn, by status and (while it moves) state: written out by hand.
EXPECTED = {
    (Status.WAITING, State.GOAL): "waiting", (Status.WAITING, None): "waiting",
    (Status.MOVING, None): "moving", (Status.MOVING, State.GOAL): "moving",
    (Status.MOVING, State.FOLLOW): "following", (Status.MOVING, State.ESCAPE): "escaping",
    (Status.MOVING, State.GUIDED): "guided", (Status.MOVING, State.WAIT): "waiting",
    (Status.MOVING, State.DONE): "moving",
    (Status.ARRIVED, State.FOLLOW): "arrived", (Status.ARRIVED, None): "arrived",
    (Status.COLLIDED, State.ESCAPE): "failed", (Status.TIMED_OUT, State.GUIDED): "failed",
    (Status.TIMED_OUT, None): "failed",
}


def test_kinds_follow_the_status_then_the_state():
    pairs = list(EXPECTED)
    status = np.array([int(s) for s, _ in pairs])
    mode = np.array([np.nan if m is None else float(m) for _, m in pairs])
    kinds = kinds_of(status, mode)
    assert [KINDS[k] for k in kinds] == [EXPECTED[p] for p in pairs]
    assert [KINDS[k] for k in kinds_of(status)] == [  # no state at all: moving robots move
        "moving" if s == Status.MOVING else EXPECTED[(s, m)] for s, m in pairs]


@pytest.mark.parametrize("shape", [(5,), (3, 4)])
def test_kinds_keep_the_shape_of_the_codes(shape):
    status = np.full(shape, int(Status.MOVING))
    assert kinds_of(status, np.full(shape, float(State.FOLLOW))).shape == shape
