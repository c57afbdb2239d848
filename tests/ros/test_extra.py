"""Without rosbags (the extra ``fftnav[ros]``) every way into a bag refuses with one
MissingExtraError naming the pip line; every function of fftnav.ros that imports rosbags asks
for it first."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import numpy as np
import pytest

import fftnav.ros
from fftnav.errors import MissingExtraError
from fftnav.observe.geometry import REAL_ROBOT
from fftnav.ros import messages as rosmsg
from fftnav.ros.bags import BagFile, open_bag, scan_bag
from fftnav.ros.episode import check_episode_bag
from tests.ros.bagmaker import scans_bag

PIP_LINE = "ROS bags need the rosbags package: pip install 'fftnav[ros]'"


@pytest.fixture
def bag(tmp_path):
    pytest.importorskip("rosbags")  # to write the bag the entries are refused
    return scans_bag(tmp_path / "s.bag", np.full((2, 181), 5.0))


@pytest.mark.parametrize("enter", [
    lambda bag: open_bag(bag).__enter__(),
    lambda bag: scan_bag(bag, topic=None, geometry=REAL_ROBOT, range_m=None,
                         write=lambda line: None),
    lambda bag: check_episode_bag(bag.with_name("episode.mcap")),
    lambda bag: BagFile(bag.with_name("out.bag"), ros1=True, storage=None, single=True),
    lambda bag: rosmsg.typestore(ros1=True),
])
def test_without_rosbags_each_entry_raises_the_missing_extra(bag, monkeypatch, enter):
    monkeypatch.setitem(sys.modules, "rosbags", None)  # as if it were not installed
    with pytest.raises(MissingExtraError) as caught:
        enter(bag)
    assert str(caught.value) == PIP_LINE
    assert isinstance(caught.value, ImportError) and caught.value.name == "rosbags"
    assert sorted(p.name for p in bag.parent.iterdir()) == ["s.bag"]  # nothing written


def _imports_rosbags(node: ast.stmt) -> bool:
    names = ([a.name for a in node.names] if isinstance(node, ast.Import)
             else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
    return any(n.split(".")[0] == "rosbags" for n in names)


def test_every_function_that_imports_rosbags_requires_it_first():
    package = Path(fftnav.ros.__file__).parent
    checked = 0
    for path in sorted(package.glob("*.py")):
        for fn in ast.walk(ast.parse(path.read_text())):
            if not isinstance(fn, ast.FunctionDef) or fn.name == "require_rosbags":
                continue
            first = next((i for i, s in enumerate(fn.body) if _imports_rosbags(s)), None)
            if first is None:
                continue
            checked += 1
            before = [ast.unparse(s) for s in fn.body[:first]]
            assert "require_rosbags()" in before, f"{path.name}: {fn.name}"
    assert checked >= 6
