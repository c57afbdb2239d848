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


def _step(tick, poses, ranges, arrived=lambda i: ()):
    from fftnav.navigation.controllers import SwarmStep

    angles = -np.pi + np.arange(ranges.shape[1]) * 2 * np.pi / ranges.shape[1]
    return SwarmStep(tick=tick, time_s=tick / 10, poses=poses, goals=np.array([[0.0, 20.0]] * 2),
                     active=np.array([0]), ranges_m=ranges, angles_rad=angles, safe=None, y1=None,
                     messages=None, inbox=lambda i: (), present=np.ones(2, bool), arrived=arrived)


def test_with_odometry_walls_travel_in_the_senders_body_frame_and_conflicts_are_refused():
    """A sender at (5, 5) facing +y sees a wall 2 m ahead; its message holds the wall in its
    body frame (2 m ahead: x = 2). A receiver that places the sender at (0, 0) facing +x draws
    the wall at x = 2 in its own frame; one whose own scans see that place free refuses it."""
    from fftnav.localization.relative import to_frame
    from fftnav.navigation.collab import decode_message, scan_segments
    from fftnav.navigation.controllers import Packet
    from fftnav.navigation.ownmap import OwnMaps

    cfg = SwarmConfig().replace({"localization.mode": "odometry"})
    kind = Walls(ControllerSetup(2, cfg, np.random.default_rng(0)))
    assert kind.body_frame and not Walls(ControllerSetup(2, SwarmConfig(),
                                                         np.random.default_rng(0))).body_frame
    angles = -np.pi + np.arange(360) * 2 * np.pi / 360
    ahead = np.where(np.abs(angles) < 0.5, 2.0 / np.cos(angles), 3.0)  # a wall 2 m ahead
    ranges = np.vstack([ahead, np.full(360, 3.0)])
    sender = np.array([[5.0, 5.0, np.pi / 2], [0.0, 0.0, 0.0]])
    sent = kind.send(_step(0, sender, ranges), np.zeros(2, bool), None)
    _, body = decode_message(sent[0])
    world = scan_segments(sender[0], ahead, angles, range_m=3.0)
    assert np.allclose(to_frame(body, sender[0]), world[:len(body)], atol=0.01)
    assert np.allclose(body[0][:, 0], 2.0, atol=0.01)  # 2 m ahead of the sender
    # two receivers place the sender at the origin facing +x
    packet = Packet(sender=0, tick=0, payload=sent[0], sender_pose=(0.0, 0.0, 0.0))
    for sees_free, drawn, refused in [(False, 1, 0), (True, 0, 1)]:
        maps = OwnMaps(2, np.array([-5.0, -5.0]), np.array([5.0, 5.0]), resolution_m=0.2,
                       range_m=3.0, clearance_m=0.3)
        if sees_free:  # robot 1's own scan at (0, 0) sees 3 m of free space all around
            maps.update(1, np.array([1]), np.zeros((2, 3)), np.full((2, 360), 3.0), angles)
        kind = Walls(ControllerSetup(2, cfg, np.random.default_rng(0)))
        kind.gate[1] = True
        kind.receive(_step(1, sender, ranges, arrived=lambda i: (packet,) if i == 1 else ()),
                     maps)
        assert (kind.drawn[1], kind.refused[1]) == (drawn, refused)
        marked = np.argwhere(maps.last_shared[1] >= 0)
        xs = maps.lo[0] + (marked[:, 1] + 0.5) * maps.res
        assert (len(marked) > 0) == (drawn == 1) and np.allclose(xs, 2.1, atol=0.11)
