"""Message kinds: what the robots of a decision policy broadcast, and how they read it.

A :class:`~fftnav.navigation.policies.Policy` names its message kind (``messages="walls"``).
The registry (:data:`MESSAGE_KINDS`) holds the kinds' classes; the Bug controller
(:class:`~fftnav.navigation.bugcontrol.BugController`) makes one instance per episode from its
:class:`~fftnav.navigation.controllers.ControllerSetup`, so everything a kind keeps (the packets
it holds, what the robots know of their neighbours, its gate, its counters) is that episode's
alone. The controller asks its kind, every tick, to :meth:`~MessageKind.receive` what arrived
(before the planner decides) and to :meth:`~MessageKind.send` the robots' messages (after it),
both with the robots' own maps; the planner asks it whether a robot :meth:`~MessageKind.waits`
for the robots in its way and whether it :meth:`~MessageKind.guides` it along its way through
its map; and the controller asks how many messages a robot has :meth:`~MessageKind.read` (a
policy that reconsiders asks again only when that grew). Registered kinds:

``observation``
    The paper's messages (``fusion``): a robot whose goal direction is blocked broadcasts its
    compressed observation (every tick with ``comms.broadcast = "every_tick"``); receivers read
    their inboxes when they decide (the fused P, :class:`~fftnav.navigation.decider.Decider`).
``walls``
    ``collab``'s messages: every :data:`~fftnav.navigation.collab.PERIOD_TICKS` ticks a robot
    broadcasts the longest wall segments of its current scan; each packet is drawn into its
    receiver's own map (:meth:`fftnav.navigation.ownmap.OwnMaps.add_segments`) when it arrives,
    once the receiver has itself seen a wall longer than R
    (:func:`~fftnav.navigation.collab.long_wall`, its gate); until then packets are held, and
    drawn at their arrival ticks when that happens. From then on the receiver's map also knows
    where its neighbours stood when they sent
    (:meth:`~fftnav.navigation.ownmap.OwnMaps.set_robots`): a robot is not a wall.

A new kind is one :class:`MessageKind` subclass registered with :func:`register_message_kind`.

>>> from fftnav.config import SwarmConfig
>>> from fftnav.navigation.controllers import ControllerSetup
>>> setup = ControllerSetup(3, SwarmConfig(), np.random.default_rng(0))
>>> kind = MESSAGE_KINDS["walls"](setup)
>>> kind, kind.read(2), kind.gate.tolist()
(<message kind 'walls'>, 0, [False, False, False])
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import numpy as np

from fftnav.errors import FftnavError
from fftnav.localization.relative import from_frame, to_frame
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
from fftnav.navigation.controllers import ControllerSetup, SwarmStep
from fftnav.navigation.ownmap import OwnMaps
from fftnav.registry import Registry, first_line

__all__ = ["MESSAGE_KINDS", "MessageKind", "Observations", "Walls", "register_message_kind"]


class MessageKind:
    """What the robots of a policy broadcast in one episode; the default receives and sends
    nothing.

    Parameters
    ----------
    setup : ControllerSetup
        The episode's swarm size, configuration and world facts (kept as ``self.setup`` and
        ``self.config``).

    Attributes
    ----------
    name : str
        The kind's registered name (``Policy(..., messages=name)``).
    description : str
        One line.
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""

    def __init__(self, setup: ControllerSetup) -> None:
        self.setup = setup
        self.config = setup.config

    def receive(self, swarm: SwarmStep, maps: OwnMaps | None) -> None:
        """Read what arrived at this tick, before the planner decides (``maps``: the robots'
        own maps, None before the planner's first step)."""

    def send(self, swarm: SwarmStep, blocked: np.ndarray,
             maps: OwnMaps | None) -> dict[int, bytes]:
        """The messages of the robots that broadcast this tick (robot -> bytes), after the
        planner decided (``blocked``: whose goal direction was blocked, one per robot)."""
        return {}

    def waits(self, swarm: SwarmStep, robot: int) -> bool:
        """Whether robot ``robot``, whose goal direction is blocked, waits this tick for the
        robots in its way (it has the right of way); the default never waits."""
        return False

    def guides(self, swarm: SwarmStep, robot: int) -> bool:
        """Whether robot ``robot``, heading for its goal, steers along its way through its own
        map (the planner's ``guide``); the default never does."""
        return False

    def read(self, robot: int) -> int:
        """How many messages robot ``robot`` has read so far; the default counts none."""
        return 0

    def __repr__(self) -> str:
        return f"<message kind {self.name!r}>"


#: The registered message kinds, by name: their classes.
MESSAGE_KINDS: Registry[type[MessageKind]] = Registry("message kind", parameter="messages")


def register_message_kind(name: str) -> Callable[[type[MessageKind]], type[MessageKind]]:
    """Class decorator registering a :class:`MessageKind` subclass as ``name`` (its
    ``description``: the first line of its docstring)."""

    def wrap(cls: type[MessageKind]) -> type[MessageKind]:
        if not (isinstance(cls, type) and issubclass(cls, MessageKind)):
            raise FftnavError(f"register_message_kind expects a MessageKind subclass, got {cls!r}")
        MESSAGE_KINDS.add(name, cls)
        cls.name, cls.description = name, first_line(cls.__doc__)
        return cls

    return wrap


@register_message_kind("observation")
class Observations(MessageKind):
    """The compressed observation (Sigma), from robots whose goal direction is blocked."""

    def send(self, swarm: SwarmStep, blocked: np.ndarray,
             maps: OwnMaps | None) -> dict[int, bytes]:
        assert swarm.messages is not None  # the Bug controller runs the pipeline
        every_tick = self.config.comms.broadcast == "every_tick"
        return {i: swarm.messages[j] for j, i in enumerate(swarm.active.tolist())
                if every_tick or blocked[i]}


@register_message_kind("walls")
class Walls(MessageKind):
    """Wall segments fitted to the scan, every PERIOD_TICKS ticks, drawn into the receivers'
    own maps once they have seen a wall longer than R (and where the senders stand is then
    not a wall in those maps, and a robot heading for its goal steers along its way through
    its map where that map blocks the straight line).

    Attributes
    ----------
    held : list of list of (int, ndarray)
        Per robot, the segments that arrived and are not drawn yet, with their arrival ticks.
    gate : ndarray of bool
        Per robot, whether its own scans have shown a wall longer than R (it reads its
        neighbours' segments, waits and is guided only then).
    neighbours : list of dict
        Per robot, each neighbour's position, tick and goal distance from its last message that
        arrived: ``{sender: (x_m, y_m, tick, goal_m)}``.
    announced_m : ndarray
        The goal distance each robot last announced (m, as its neighbours read it; inf before
        its first message).
    drawn : ndarray of int
        Per robot, the messages drawn into its map (:meth:`read`).
    refused : ndarray of int
        Per robot, the messages it did not draw because one of their segments crosses what its
        own scans see free (:data:`CONFLICT_SHARE`; odometry only).
    body_frame : bool
        Whether messages carry their segments in the sender's body frame, placed by the
        receiver through its measurement of the sender (``localization.mode = "odometry"``:
        no two robots share a frame), rather than in the frame all robots share (``exact``).
    """

    #: With odometry, a received message is not drawn when one of its segments has at least
    #: this share of its cells where the receiver's own scans see free space
    #: (:meth:`~fftnav.navigation.ownmap.OwnMaps.free_share`): the sender was placed wrong, or
    #: its wall disagrees with what the receiver sees; the receiver keeps its own map.
    CONFLICT_SHARE: ClassVar[float] = 0.2

    def __init__(self, setup: ControllerSetup) -> None:
        super().__init__(setup)
        n = setup.n_robots
        self.body_frame = setup.config.localization.odometry
        self.refused = np.zeros(n, dtype=np.int64)
        self.held: list[list[tuple[int, np.ndarray]]] = [[] for _ in range(n)]
        self.gate = np.zeros(n, dtype=bool)
        self.neighbours: list[dict[int, tuple[float, float, int, float]]] = [
            {} for _ in range(n)]
        self.announced_m = np.full(n, np.inf)
        self.drawn = np.zeros(n, dtype=np.int64)

    def read(self, robot: int) -> int:
        return int(self.drawn[robot])

    def receive(self, swarm: SwarmStep, maps: OwnMaps | None) -> None:
        if maps is None:
            return
        for r in np.flatnonzero(swarm.present_mask()).tolist():
            for pkt in swarm.arrived(r):
                goal_m, segments = decode_message(pkt.payload)
                if self.body_frame:
                    segments = to_frame(segments, np.asarray(pkt.sender_pose))
                self.held[r].append((swarm.tick, segments))
                x, y = pkt.sender_pose[0], pkt.sender_pose[1]
                self.neighbours[r][pkt.sender] = (float(x), float(y), swarm.tick, goal_m)
            if self.gate[r]:
                self._draw(maps, r)
                maps.set_robots(r, self.near(r, swarm.tick)[:, :2])

    def near(self, robot: int, tick: int) -> np.ndarray:
        """``x_m, y_m, goal_m, index`` of the neighbours robot ``robot`` heard from in the last
        NEIGHBOUR_AGE_TICKS ticks before ``tick`` (their last messages)."""
        return np.array([(x, y, goal_m, j) for j, (x, y, t, goal_m)
                         in self.neighbours[robot].items()
                         if tick - t <= NEIGHBOUR_AGE_TICKS], dtype=float).reshape(-1, 4)

    def waits(self, swarm: SwarmStep, robot: int) -> bool:
        """Once the gate is open: whether a robot whose goal direction is blocked waits for
        the neighbours in its way, having the right of way over them
        (:func:`~fftnav.navigation.collab.waits_for`, on the goal distances of the last
        messages)."""
        if not self.gate[robot]:
            return False
        return waits_for(swarm.poses[robot, :2], swarm.goals[robot], index=robot,
                         goal_m=self.announced_m[robot], neighbours=self.near(robot, swarm.tick))

    def guides(self, swarm: SwarmStep, robot: int) -> bool:
        """Once the gate is open, a robot heading for its goal steers along its way through its
        map (its own scans and its neighbours' walls) where that way leaves the straight line."""
        return bool(self.gate[robot])

    def _draw(self, maps: OwnMaps, robot: int) -> None:
        """Draw robot ``robot``'s held segments into its map, at their arrival ticks (with
        odometry, not those of a message that crosses what its own scans see free)."""
        for tick, segments in self.held[robot]:
            if self.body_frame and len(segments) and (
                    maps.free_share(robot, segments) >= self.CONFLICT_SHARE).any():
                self.refused[robot] += 1
                continue
            maps.add_segments(robot, tick, segments)
            self.drawn[robot] += 1
        self.held[robot].clear()

    def send(self, swarm: SwarmStep, blocked: np.ndarray,
             maps: OwnMaps | None) -> dict[int, bytes]:
        """Robots take turns by index: robot i broadcasts at the ticks t with
        (t + i) % PERIOD_TICKS == 0, when its scan shows segments (with its goal distance);
        the first segment longer than R a robot fits opens its gate."""
        outgoing: dict[int, bytes] = {}
        range_m = self.config.sensor.range_m
        for i in swarm.active.tolist():
            if (swarm.tick + i) % PERIOD_TICKS:
                continue
            segments = scan_segments(swarm.poses[i], swarm.ranges_m[i], swarm.angles_rad,
                                     range_m=range_m)
            if not self.gate[i] and long_wall(segments, range_m=range_m):
                self.gate[i] = True
                if maps is not None:
                    self._draw(maps, i)
            if len(segments):
                if maps is not None:
                    maps.add_walls(i, swarm.tick, segments)
                goal_m = float(np.hypot(*(swarm.goals[i] - swarm.poses[i, :2])))
                sent = segments[:MAX_SEGMENTS_PER_MESSAGE]
                if self.body_frame:
                    sent = from_frame(sent, swarm.poses[i])
                outgoing[i] = encode_message(sent, goal_m=goal_m)
                self.announced_m[i] = decode_message(outgoing[i])[0]  # as neighbours read it
        return outgoing
