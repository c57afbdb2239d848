"""Message kinds: what the robots of a decision policy broadcast, and how they read it.

A :class:`~fftnav.navigation.policies.Policy` names its message kind (``messages="walls"``);
the Bug controller (:class:`~fftnav.navigation.bugcontrol.BugController`) asks the kind, every
tick, to :meth:`~MessageKind.receive` what arrived (before the planner decides) and to
:meth:`~MessageKind.send` the robots' messages (after it). Registered kinds
(:data:`MESSAGE_KINDS`):

``observation``
    The paper's messages (``fusion``): a robot whose goal direction is blocked broadcasts its
    compressed observation (every tick with ``comms.broadcast = "every_tick"``); receivers read
    their inboxes when they decide (the fused P, :class:`~fftnav.navigation.decider.Decider`).
``walls``
    ``collab``'s messages: every :data:`~fftnav.navigation.collab.PERIOD_TICKS` ticks a robot
    broadcasts the longest wall segments of its current scan; each packet is drawn into its
    receiver's own map (:meth:`fftnav.navigation.ownmap.OwnMaps.add_segments`) when it arrives,
    once the receiver has itself seen a wall longer than R
    (:func:`~fftnav.navigation.collab.long_wall`); until then packets are held, and drawn at
    their arrival ticks when that happens. From then on the receiver's map also knows where its
    neighbours stood when they sent (:meth:`~fftnav.navigation.ownmap.OwnMaps.set_robots`):
    a robot is not a wall.

A new kind is a :class:`MessageKind` subclass registered with :func:`register_message_kind`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from fftnav.navigation.collab import (
    MAX_SEGMENTS_PER_MESSAGE,
    NEIGHBOUR_AGE_TICKS,
    PERIOD_TICKS,
    decode_message,
    encode_message,
    long_wall,
    scan_segments,
    waits_for,
)
from fftnav.navigation.controllers import SwarmStep
from fftnav.registry import Registry, first_line

if TYPE_CHECKING:
    from fftnav.navigation.bugcontrol import BugController

__all__ = ["MESSAGE_KINDS", "MessageKind", "register_message_kind"]


class MessageKind:
    """What the robots of a policy broadcast; the default receives and sends nothing.

    Attributes
    ----------
    name : str
        The kind's registered name (``Policy(..., messages=name)``).
    description : str
        One line.
    """

    name: str = ""
    description: str = ""

    def receive(self, control: BugController, swarm: SwarmStep, present: np.ndarray) -> None:
        """Read what arrived at this tick, before the planner decides (``present``: the robots
        in the world)."""

    def send(self, control: BugController, swarm: SwarmStep,
             blocked: np.ndarray) -> dict[int, bytes]:
        """The messages of the robots that broadcast this tick (robot -> bytes), after the
        planner decided (``blocked``: whose goal direction was blocked, one per robot)."""
        return {}

    def waits(self, control: BugController, swarm: SwarmStep, robot: int) -> bool:
        """Whether robot ``robot``, whose goal direction is blocked, waits this tick for the
        robots in its way (it has the right of way); the default never waits."""
        return False

    def guides(self, control: BugController, swarm: SwarmStep, robot: int) -> bool:
        """Whether robot ``robot``, heading for its goal, steers along its way through its own
        map (the planner's ``guide``); the default never does."""
        return False

    def __repr__(self) -> str:
        return f"<message kind {self.name!r}>"


#: The registered message kinds, by name (one instance each).
MESSAGE_KINDS: Registry[MessageKind] = Registry("message kind", parameter="messages")


def register_message_kind(name: str) -> Callable[[type[MessageKind]], type[MessageKind]]:
    """Class decorator registering one instance of a :class:`MessageKind` subclass as ``name``."""

    def wrap(cls: type[MessageKind]) -> type[MessageKind]:
        kind = cls()
        kind.name, kind.description = name, first_line(cls.__doc__)
        MESSAGE_KINDS.add(name, kind)
        return cls

    return wrap


@register_message_kind("observation")
class Observations(MessageKind):
    """The compressed observation (Sigma), from robots whose goal direction is blocked."""

    def send(self, control: BugController, swarm: SwarmStep,
             blocked: np.ndarray) -> dict[int, bytes]:
        assert swarm.messages is not None  # the Bug controller runs the pipeline
        every_tick = control.config.comms.broadcast == "every_tick"
        return {i: swarm.messages[j] for j, i in enumerate(swarm.active.tolist())
                if every_tick or blocked[i]}


@register_message_kind("walls")
class Walls(MessageKind):
    """Wall segments fitted to the scan, every PERIOD_TICKS ticks, drawn into the receivers'
    own maps once they have seen a wall longer than R (and where the senders stand is then
    not a wall in those maps, and a robot heading for its goal steers along its way through
    its map where that map blocks the straight line)."""

    def receive(self, control: BugController, swarm: SwarmStep, present: np.ndarray) -> None:
        maps = control.planner.maps
        if maps is None:
            return
        for r in np.flatnonzero(present).tolist():
            for pkt in swarm.arrived(r):
                goal_m, segments = decode_message(pkt.payload)
                control.held[r].append((swarm.tick, segments))
                x, y = pkt.sender_pose[0], pkt.sender_pose[1]
                control.neighbours[r][pkt.sender] = (float(x), float(y), swarm.tick, goal_m)
            if control.long_wall_seen[r]:
                self._draw(control, r)
                maps.set_robots(r, self._near(control, r, swarm.tick)[:, :2])

    @staticmethod
    def _near(control: BugController, robot: int, tick: int) -> np.ndarray:
        """``x_m, y_m, goal_m, index`` of the neighbours robot ``robot`` heard from in the last
        NEIGHBOUR_AGE_TICKS ticks (their last messages)."""
        return np.array([(x, y, goal_m, j) for j, (x, y, t, goal_m)
                         in control.neighbours[robot].items()
                         if tick - t <= NEIGHBOUR_AGE_TICKS], dtype=float).reshape(-1, 4)

    def waits(self, control: BugController, swarm: SwarmStep, robot: int) -> bool:
        """Once the gate is open: whether a robot whose goal direction is blocked waits for
        the neighbours in its way, having the right of way over them
        (:func:`~fftnav.navigation.collab.waits_for`, on the goal distances of the last
        messages)."""
        if not control.long_wall_seen[robot]:
            return False
        return waits_for(swarm.poses[robot, :2], swarm.goals[robot], index=robot,
                         goal_m=control.announced_m[robot],
                         neighbours=self._near(control, robot, swarm.tick))

    def guides(self, control: BugController, swarm: SwarmStep, robot: int) -> bool:
        """Once the gate is open, a robot heading for its goal steers along its way through its
        map (its own scans and its neighbours' walls) where that way leaves the straight line."""
        return bool(control.long_wall_seen[robot])

    @staticmethod
    def _draw(control: BugController, robot: int) -> None:
        """Draw robot ``robot``'s held segments into its map, at their arrival ticks."""
        maps = control.planner.maps
        assert maps is not None
        for tick, segments in control.held[robot]:
            maps.add_segments(robot, tick, segments)
            control.heard[robot] += 1
        control.held[robot].clear()

    def send(self, control: BugController, swarm: SwarmStep,
             blocked: np.ndarray) -> dict[int, bytes]:
        """Robots take turns by index: robot i broadcasts at the ticks t with
        (t + i) % PERIOD_TICKS == 0, when its scan shows segments (with its goal distance)."""
        outgoing: dict[int, bytes] = {}
        for i in swarm.active.tolist():
            if (swarm.tick + i) % PERIOD_TICKS:
                continue
            range_m = control.config.sensor.range_m
            segments = scan_segments(swarm.poses[i], swarm.ranges_m[i], swarm.angles_rad,
                                     range_m=range_m)
            maps = control.planner.maps
            if not control.long_wall_seen[i] and long_wall(segments, range_m=range_m):
                control.long_wall_seen[i] = True
                if maps is not None:
                    self._draw(control, i)
            if len(segments):
                if maps is not None:
                    maps.add_walls(i, swarm.tick, segments)
                goal_m = float(np.hypot(*(swarm.goals[i] - swarm.poses[i, :2])))
                outgoing[i] = encode_message(segments[:MAX_SEGMENTS_PER_MESSAGE], goal_m=goal_m)
                control.announced_m[i] = decode_message(outgoing[i])[0]  # as neighbours read it
        return outgoing
