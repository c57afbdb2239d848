"""A small real experiment written by ``fftnav run`` (a subprocess), whose every episode has a
failure and keeps the runner's own recording (``[record] episodes = "all"``): the oracle of the
tests of recordings made on demand (``fftnav replay RESULTS_DIR --task TASK``).

Forest, maps 7 and 8 of 8 m x 8 m, 3 robots, ``bug-left`` and ``fusion``, 8 s: no robot arrives
in time, so ``report.md`` lists all four episodes as failures (about 10 s with a warm cache).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TOML = """[experiment]
name = "small"
envs = ["forest"]
maps = 2
map_seed = 7
robots = 3
policies = ["bug-left", "fusion"]
trajectory_maps = 1

[world]
size_m = [8.0, 8.0]
goal_y_m = 7.0

[episode]
time_limit_s = 8.0

[record]
episodes = "all"
"""
#: The tasks of the experiment, in the order of its report.
TASKS = ("forest-7-bug-left", "forest-8-bug-left", "forest-7-fusion", "forest-8-fusion")


def fftnav(*args, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """``python -m fftnav ARGS`` in ``cwd`` with this checkout first on the path."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "fftnav", *map(str, args)], capture_output=True,
                          text=True, timeout=600, env=env, cwd=cwd)


def make_small_results(folder: Path) -> Path:
    """Run the experiment into ``folder / "small"`` (its config beside it); returns the
    results folder."""
    (folder / "small.toml").write_text(TOML)
    done = fftnav("run", folder / "small.toml", "--out", folder / "small", "--workers", "1",
                  "--quiet")
    assert done.returncode == 0, done.stderr
    return folder / "small"
