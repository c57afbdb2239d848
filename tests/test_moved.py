"""Moved modules keep their old import path for one minor release: the same module object, a
DeprecationWarning naming the new path; CHANGELOG.md lists every move; a plugin written against
an old path runs under the CLI with one line on stderr."""

from __future__ import annotations

import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

import fftnav
from fftnav.moved import MOVED, REMOVED_IN

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("old, new", sorted(MOVED.items()))
def test_the_old_path_is_the_new_module_with_a_warning_naming_it(old, new):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=rf"^{re.escape(old)} moved to {re.escape(new)} "
                      rf".*goes in fftnav {re.escape(REMOVED_IN)}\)$"):
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)
    assert not Path(fftnav.__file__).with_name(old.split(".")[1] + ".py").exists()


def test_names_that_never_existed_still_fail():
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("fftnav.planning.nothing")
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("fftnav.nothing")


def test_the_changelog_lists_every_move():
    text = (ROOT / "CHANGELOG.md").read_text()
    for old, new in MOVED.items():
        assert re.search(rf"`{re.escape(old)}`[^\n]*`{re.escape(new)}`", text), old


def test_a_plugin_on_an_old_path_runs_with_one_line_naming_the_new(tmp_path):
    (tmp_path / "old_plugin.py").write_text(
        "from fftnav.planning.controllers import Controller\n\n\n"
        "class Straight(Controller):\n    uses_pipeline = False\n\n"
        "    def act(self, obs):\n        return self.v_max_mps, 2.0 * obs.goal_bearing_rad\n")
    from fftnav.world import generate_world, save_world

    save_world(generate_world("forest", 3, robots=2), tmp_path / "w.json")
    res = subprocess.run([sys.executable, "-m", "fftnav", "episode", "--world", "w.json",
                          "--policy", "old_plugin.py:Straight", "--set", "time_limit_s=1",
                          "--out", "e.csv"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    warned = [line for line in res.stderr.splitlines() if "moved to" in line]
    assert warned == ["fftnav: DeprecationWarning: fftnav.planning.controllers moved to "
                      "fftnav.navigation.controllers in fftnav 0.2; import it from there (the "
                      f"old path goes in fftnav {REMOVED_IN})"]
