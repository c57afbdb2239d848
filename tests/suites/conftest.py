"""A tiny suite (2 small forest maps, 3 robots, 30 s) with the references of three built-ins,
in a folder laid out like fftnav/suites: for the suites, evaluate and leaderboard tests, in
process (``tiny``) and as ``$FFTNAV_SUITES_HOME`` of a subprocess (``tiny_home``)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

import fftnav.suites as suites
from fftnav.suites.evaluate import Options, run_references

TINY = """\
[suite]
family = "tiny"
version = 1
description = "tiny: two 8 m forest maps, 3 robots"
measures = "nothing: a test suite"

[experiment]
envs = ["forest"]
maps = 2
map_seed = 7
robots = 3

[world]
size_m = [8.0, 8.0]
goal_y_m = 7.0

[episode]
time_limit_s = 30.0
"""
#: The built-ins the tiny suite has references of.
METHODS = ("bug-left", "bug-right", "fusion")


def make_home(root: Path) -> suites.Suite:
    """Write the tiny suite's definition, pins and references under ``root``."""
    for sub in ("defs", "pins", "references"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    (root / "defs" / "tiny-v1.toml").write_text(TINY)
    suite = suites.suite_from_toml(TINY, file="tiny-v1.toml")
    (root / "pins" / "tiny-v1.json").write_text(json.dumps(suite.pins(), indent=1,
                                                           sort_keys=True))
    episodes, timing = run_references(suite, root / "runs", methods=METHODS,
                                      options=Options(workers=1, progress=False))
    suites.write_references(suite, episodes, timing, root / "references" / "tiny-v1")
    shutil.rmtree(root / "runs")
    return suite


@pytest.fixture(scope="session")
def tiny_home(tmp_path_factory) -> Path:
    """A suites folder holding the tiny suite (made once per session)."""
    root = tmp_path_factory.mktemp("suites_home")
    make_home(root)
    return root


@pytest.fixture
def tiny(tiny_home, tmp_path, monkeypatch) -> suites.Suite:
    """The tiny suite registered in this process, its files a fresh copy of ``tiny_home``
    (a test may change them)."""
    home = tmp_path / "home"
    shutil.copytree(tiny_home, home)
    monkeypatch.setattr(suites, "_DATA", home)
    suite = suites.suite_from_toml(TINY, file="tiny-v1.toml")
    monkeypatch.setitem(suites.SUITES, suite.name, suite)
    return suite
