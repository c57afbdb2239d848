"""Message kinds: the registry holds their classes, the Bug controller makes one instance per
episode from its setup, so what a kind keeps (held packets, neighbours, its gate, counters) is
that episode's alone; no module the controller imports imports it back."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fftnav.config import SwarmConfig
from fftnav.episode import run_episode
from fftnav.navigation import bugcontrol
from fftnav.navigation.controllers import ControllerSetup
from fftnav.navigation.messages import (
    MESSAGE_KINDS,
    MessageKind,
    Observations,
    Walls,
    register_message_kind,
)
from fftnav.navigation.policies import POLICIES, get_policy
from fftnav.world.generate import generate_world
from tests.navigation.corridor import headon


def test_the_registry_holds_classes_and_a_policy_names_one():
    assert dict(MESSAGE_KINDS) == {"observation": Observations, "walls": Walls}
    assert Walls.name == "walls" and Walls.description.startswith("Wall segments")
    assert get_policy("collab").messages is Walls
    assert get_policy("fusion").messages is Observations
    with pytest.raises(ValueError, match="register_message_kind expects a MessageKind "
                                         "subclass, got <object"):
        register_message_kind("thing")(object())
    with pytest.raises(ValueError, match="message kind 'walls' is already registered"):
        register_message_kind("walls")(type("Other", (MessageKind,), {}))
    assert MESSAGE_KINDS["walls"] is Walls and Walls.name == "walls"


def test_each_controller_makes_its_own_kind_from_its_setup():
    """Two controllers of one policy hold two kinds: a wall one robot's scan shows opens that
    robot's gate in its own episode only."""
    config = SwarmConfig()
    setups = [ControllerSetup(2, config, np.random.default_rng(0)) for _ in range(2)]
    a, b = (bugcontrol.BugController(s, POLICIES["collab"]) for s in setups)
    assert isinstance(a.messages, Walls) and a.messages is not b.messages
    assert a.messages.setup is setups[0] and b.messages.setup is setups[1]
    a.messages.gate[0] = True
    a.messages.neighbours[1][0] = (1.0, 2.0, 3, 4.0)
    assert not b.messages.gate.any() and b.messages.neighbours == [{}, {}]
    assert bugcontrol.BugController(setups[0], POLICIES["own-only"]).messages is None


def test_a_second_episode_does_not_see_the_first_episodes_message_state(monkeypatch):
    """A collab episode whose robots open their gates, meet their neighbours and draw their
    walls, then one on rocky ruins (no wall longer than R: nobody's gate opens): the second
    episode's kind starts empty and its rows are those of the same episode run first."""
    kinds = []
    init = bugcontrol.BugController.__init__

    def keep(self, *args, **kwargs):
        init(self, *args, **kwargs)
        kinds.append((self.messages, self.messages.gate.copy(),
                      [dict(d) for d in self.messages.neighbours]))

    rocky = generate_world("rocky", 1003, robots=4, size_m=(10.0, 10.0), goal_y_m=9.0)
    alone = run_episode(rocky, "collab", seed=1).rows
    monkeypatch.setattr(bugcontrol.BugController, "__init__", keep)
    run_episode(headon(1.2), "collab", seed=0)
    after = run_episode(rocky, "collab", seed=1).rows
    (first, _, _), (second, gate, neighbours) = kinds
    assert first.gate.all() and first.read(0) > 0 and first.neighbours[0]
    assert second is not first and not gate.any() and neighbours == [{}] * 4
    assert not second.gate.any() and [second.read(i) for i in range(4)] == [0] * 4
    assert [dataclasses.asdict(r) for r in after] == [dataclasses.asdict(r) for r in alone]


def test_the_controller_asks_its_kind_through_methods_only():
    """The planner's hooks and the reconsidering rule ask the kind (waits, guides, read); a
    kind that says yes to ``guides`` and counts messages read is asked per robot."""
    asked = []

    class Asked(MessageKind):
        """Says yes to guides for robot 1 only, and has read 7 messages."""

        def guides(self, swarm, robot):
            asked.append(("guides", robot))
            return robot == 1

        def read(self, robot):
            return 7

    policy = dataclasses.replace(POLICIES["collab-reconsider"], messages=Asked)
    control = bugcontrol.BugController(ControllerSetup(2, SwarmConfig(),
                                                       np.random.default_rng(0)), policy)
    control._swarm = object()
    assert control.planner.guide(0) is False and control.planner.guide(1) is True
    assert asked == [("guides", 0), ("guides", 1)]
    assert control.planner.wait(0) is False  # the default: never waits
    calls = []
    control._decide = lambda i: calls.append(i) or -1
    assert control._reconsider(0, 1) == -1 and calls == [0]  # 7 read since the decision (0)
