"""fftnav.states: one vocabulary of a robot's state, with one code table, that the planner,
the episode, the recordings and the replays all use (and nothing keeps a copy of)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import fftnav
from fftnav.errors import FftnavError
from fftnav.navigation.bug import BugPlanner
from fftnav.report.frames import KINDS, STATE_KINDS, STATUS_KINDS, kinds_of
from fftnav.states import State, Status

PACKAGE = Path(fftnav.__file__).parent


def test_the_code_tables():
    """The codes recordings of version 1 already hold (state 0-4, status 0-4) keep their
    meaning; guided is new at 5, and so is lost."""
    assert {s.label: int(s) for s in State} == {
        "goal": 0, "follow": 1, "escape": 2, "done": 3, "wait": 4, "guided": 5}
    assert {s.label: int(s) for s in Status} == {
        "waiting": 0, "moving": 1, "arrived": 2, "collided": 3, "timed_out": 4, "lost": 5}
    assert [s for s in State if s.moving] == [State.GOAL, State.FOLLOW, State.ESCAPE,
                                              State.GUIDED]
    assert [s for s in Status if s.gone] == [Status.ARRIVED, Status.COLLIDED, Status.TIMED_OUT,
                                            Status.LOST]
    assert Status.from_label("timed_out") is Status.TIMED_OUT
    with pytest.raises(FftnavError, match=r"^status must be one of \['waiting', .*got 'gone'$"):
        Status.from_label("gone")


def test_every_state_and_status_is_drawn():
    """The replays, the HTML player and env.render() draw every code of the two tables."""
    # a robot done with its planner is drawn by its status (arrived, or failed)
    assert set(STATUS_KINDS) == set(Status) and set(STATE_KINDS) == set(State) - {State.DONE}
    status = np.array([int(s) for s in Status] + [int(Status.MOVING)] * len(State))
    mode = np.array([np.nan] * len(Status) + [int(s) for s in State])
    drawn = [KINDS[k] for k in kinds_of(status, mode)]
    assert drawn[:len(Status)] == ["waiting", "moving", "arrived", "failed", "failed", "lost"]
    assert drawn[len(Status):] == ["moving", "following", "escaping", "moving", "waiting",
                                   "guided"]


def _copies(tree: ast.Module) -> list[str]:
    """Names and literals of ``tree`` that would be a second vocabulary: a ``STATUS`` or
    ``STATE_MODES``, a class ``Mode``, or a tuple or list of the status labels."""
    labels = set(Status.labels())
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef) and node.name in {"Mode", "Status", "State"}:
            found.append(f"class {node.name}")
        elif isinstance(node, ast.Assign):
            found += [t.id for t in node.targets
                      if isinstance(t, ast.Name) and t.id in {"STATUS", "STATE_MODES"}]
        elif isinstance(node, (ast.Tuple, ast.List)):
            words = {e.value for e in node.elts if isinstance(e, ast.Constant)}
            if len(words & labels) >= 4:  # the drawn KINDS share three
                found.append(f"literal at line {node.lineno}")
    return found


def test_nothing_keeps_a_copy_of_the_vocabulary():
    copies = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "states.py" and path.parent == PACKAGE:
            continue
        found = _copies(ast.parse(path.read_text()))
        if found:
            copies[str(path.relative_to(PACKAGE))] = found
    assert copies == {}


def test_the_copy_finder_finds_copies():
    source = 'STATUS = ("waiting", "moving", "arrived", "collided")\nclass Mode: pass\n'
    assert sorted(_copies(ast.parse(source))) == ["STATUS", "class Mode", "literal at line 1"]


@pytest.mark.parametrize("name", ["step", "_target"])
def test_the_planner_s_step_and_target_are_short(name):
    """BugPlanner.step and BugPlanner._target: at most 40 lines each (the states are methods
    of their own)."""
    source = (PACKAGE / "navigation" / "bug.py").read_text()
    planner = next(n for n in ast.parse(source).body
                   if isinstance(n, ast.ClassDef) and n.name == BugPlanner.__name__)
    method = next(n for n in planner.body if isinstance(n, ast.FunctionDef) and n.name == name)
    assert method.end_lineno - method.lineno + 1 <= 40
