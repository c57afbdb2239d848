"""What the Bug planner remembers of each robot, and what it counts.

:class:`RobotMemory` is one robot's place in the planner's state machine (its
:class:`~fftnav.states.State`, docs/planner.md) with what the states need, grouped by what it is
for:

- :class:`Follow`: going round an obstacle, from the decision to the leave rule: the side, the
  goal distance at the hit point, the best goal distance of the follow and when it was reached,
  the loop detections, whether the side was reconsidered;
- :class:`Ways`: steering along a way to the goal through the robot's own map: the escape's
  way and the guided way (each a :class:`Way`: when it was last planned, its shortest length
  so far and since when), whether the guided way leads round walls, where guidance gave up,
  and the side kept while the way's bearing is unsafe;
- :class:`Still`: where the robot last got more than 2 r0 from the previous such point, and
  when (the timer of the right of way and of the squeezed plan);
- its hit points (:class:`Hit`), the tried-sides memory.

:class:`PlannerStats` holds the planner's diagnostic counters of every robot and gives a
robot's row counters (:meth:`PlannerStats.row`).

>>> memory = RobotMemory()
>>> memory.state, memory.side
(<State.GOAL: 0>, 0)
>>> memory.follow = Follow.start(-1, dist_m=8.0, time_s=2.0)
>>> memory.state = State.ESCAPE
>>> memory.side, memory.follow.hit_m
(-1, 8.0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from fftnav.states import State

__all__ = ["FOLLOWING", "HEADING", "Follow", "Hit", "PlannerStats", "RobotMemory", "Still",
           "Way", "Ways"]

#: The states in which the planner heads for the robot's goal: on the way there it may be
#: guided, stand for the robots in its way, or meet an obstacle and decide a side ...
HEADING = frozenset({State.GOAL, State.GUIDED, State.WAIT})
#: ... and those in which it goes round an obstacle on the side it decided.
FOLLOWING = frozenset({State.FOLLOW, State.ESCAPE})


@dataclass
class Follow:
    """Going round one obstacle, from the decision to the leave rule.

    Attributes
    ----------
    side : int
        +1 left, -1 right (0 before the first decision).
    hit_m : float
        Goal distance at the hit point (m): the leave rule needs progress below it.
    best_m, best_s : float
        The best goal distance of this follow (m) and when it was reached (s; also when the
        side was reconsidered): the loop detection's timer.
    flips : int
        Loop detections in this follow.
    reconsidered : bool
        Whether ``reconsider`` changed the side in this follow (at most once).
    """

    side: int = 0
    hit_m: float = math.inf
    best_m: float = math.inf
    best_s: float = 0.0
    flips: int = 0
    reconsidered: bool = False

    @classmethod
    def start(cls, side: int, *, dist_m: float, time_s: float) -> Follow:
        """The follow that begins with a decision for ``side`` at goal distance ``dist_m``."""
        return cls(side, hit_m=dist_m, best_m=dist_m, best_s=time_s)

    def progress(self, dist_m: float, time_s: float, *, progress_m: float) -> None:
        """A new best goal distance when ``dist_m`` beats the best by ``progress_m``."""
        if dist_m < self.best_m - progress_m:
            self.best_m, self.best_s = dist_m, time_s


@dataclass
class Way:
    """A way to the goal through the robot's own map, as it is replanned.

    Attributes
    ----------
    planned_s : float
        When it was last planned (s; -inf: never).
    best_m, best_s : float
        Its shortest length so far (m) and since when (s).
    """

    planned_s: float = -math.inf
    best_m: float = math.inf
    best_s: float = 0.0

    def due(self, time_s: float, replan_s: float) -> bool:
        """Whether the way is ``replan_s`` old at ``time_s``."""
        return time_s - self.planned_s >= replan_s - 1e-9

    def stale(self, time_s: float, bound_s: float) -> bool:
        """Whether the way has not become shorter for more than ``bound_s`` at ``time_s``."""
        return time_s - self.best_s > bound_s

    def shortened(self, length_m: float, time_s: float, *, progress_m: float) -> bool:
        """Whether the way, now ``length_m`` long, beats its shortest by ``progress_m`` (it
        then becomes the shortest, from ``time_s``)."""
        if length_m < self.best_m - progress_m:
            self.best_m, self.best_s = length_m, time_s
            return True
        return False


@dataclass
class Ways:
    """Steering along a way to the goal through the robot's own map (escape, guided).

    Attributes
    ----------
    escape, guide : Way
        The escape's way (planned while it escapes) and the guided way (planned while it heads
        for its goal and the planner may guide it).
    guided : bool
        Whether the guided way's last plan leads round walls across the straight line: the
        robot steers along it when it next heads for its goal.
    quit_m : float
        The goal distance (m) at which guidance last gave up a way that led nowhere (inf:
        never).
    turn : int
        The side turned to while the way's bearing is unsafe (+1 left, -1 right, 0 none),
        kept until it is safe again.
    """

    escape: Way = field(default_factory=Way)
    guide: Way = field(default_factory=Way)
    guided: bool = False
    quit_m: float = math.inf
    turn: int = 0

    def start_escape(self, time_s: float) -> None:
        """A new escape at ``time_s``: its way is planned at once and timed from now."""
        self.escape, self.turn = Way(best_s=time_s), 0


@dataclass
class Still:
    """Where a robot last got more than a radius from the previous such point, and when.

    >>> still = Still()
    >>> still.update(1.0, 2.0, 5.0, radius_m=0.3)  # the first point: it starts here
    >>> still.update(1.1, 2.0, 6.0, radius_m=0.3)
    >>> still.since_s, still.update(1.5, 2.0, 7.0, radius_m=0.3), still.since_s
    (5.0, None, 7.0)
    """

    xy: tuple[float, float] = (math.nan, math.nan)
    since_s: float = 0.0

    def update(self, x: float, y: float, time_s: float, *, radius_m: float) -> None:
        """The robot at ``(x, y)`` at ``time_s``: a new point when it is more than
        ``radius_m`` from the last one (or there is none yet)."""
        if not math.hypot(x - self.xy[0], y - self.xy[1]) <= radius_m:
            self.xy, self.since_s = (x, y), time_s


class Hit(NamedTuple):
    """Where a robot decided a side: ``x_m, y_m``, its goal distance there and the side."""

    x_m: float
    y_m: float
    dist_m: float
    side: int


@dataclass
class RobotMemory:
    """One robot in the planner (module docstring).

    Attributes
    ----------
    state : State
        Its state after its last tick (``DONE`` and ``WAIT`` get zero commands).
    held : bool
        Held at its start until released (``WAIT`` for the whole time).
    follow : Follow
        The current (or last) follow.
    ways : Ways
        The escape's and the guided way.
    still : Still
        The still timer.
    hits : list of Hit
        Its decisions so far.
    """

    state: State = State.GOAL
    held: bool = False
    follow: Follow = field(default_factory=Follow)
    ways: Ways = field(default_factory=Ways)
    still: Still = field(default_factory=Still)
    hits: list[Hit] = field(default_factory=list)

    @property
    def side(self) -> int:
        """The side it goes round an obstacle on while it follows or escapes; 0 otherwise."""
        return self.follow.side if self.state in FOLLOWING else 0

    def tried_side(self, xy: np.ndarray, dist_m: float, *, radius_m: float,
                   progress_m: float) -> int | None:
        """The side not taken at the latest earlier hit point within ``radius_m`` of ``xy``
        from which the robot has not got ``progress_m`` closer to the goal (it came back);
        None if there is none.

        >>> memory = RobotMemory(hits=[Hit(2.0, 3.0, 10.0, 1)])
        >>> memory.tried_side(np.array([2.5, 3.2]), 10.0, radius_m=1.0, progress_m=0.05)
        -1
        """
        for hit in reversed(self.hits):
            if (math.hypot(xy[0] - hit.x_m, xy[1] - hit.y_m) < radius_m
                    and dist_m > hit.dist_m - progress_m):
                return -hit.side
        return None


class PlannerStats:
    """The planner's diagnostic counters, one per robot (docs/planner.md).

    Attributes
    ----------
    decisions : ndarray of int, shape (n, 2)
        Sides decided: ``[left, right]``.
    follow_ticks, stall_ticks : ndarray of int, shape (n,)
        Control ticks following or escaping, and in the stall fallback (no safe heading on the
        side).
    loop_flips : ndarray of int
        Loop detections, and escape ways closed because they led nowhere.
    reconsidered, sides_remembered : ndarray of int
        Side changes by ``reconsider``; decisions taken from the tried-sides memory.
    escape_ticks, guided_ticks, wait_ticks : ndarray of int
        Ticks steering along the escape's way, along the guided way, and standing for the robots
        in the way (the right of way).
    guides_quit : ndarray of int
        Guided ways given up because they led nowhere.
    """

    def __init__(self, n_robots: int) -> None:
        self.decisions = np.zeros((n_robots, 2), dtype=np.int64)
        self.follow_ticks = np.zeros(n_robots, dtype=np.int64)
        self.stall_ticks = np.zeros(n_robots, dtype=np.int64)
        self.loop_flips = np.zeros(n_robots, dtype=np.int64)
        self.reconsidered = np.zeros(n_robots, dtype=np.int64)
        self.escape_ticks = np.zeros(n_robots, dtype=np.int64)
        self.sides_remembered = np.zeros(n_robots, dtype=np.int64)
        self.wait_ticks = np.zeros(n_robots, dtype=np.int64)
        self.guided_ticks = np.zeros(n_robots, dtype=np.int64)
        self.guides_quit = np.zeros(n_robots, dtype=np.int64)

    def decided(self, robot: int) -> int:
        """Sides ``robot`` decided so far."""
        return int(self.decisions[robot, 0] + self.decisions[robot, 1])

    def row(self, robot: int, *, control_hz: float) -> dict[str, int | float]:
        """The counters of ``robot``'s row (``episodes.csv``), times in seconds at the control
        rate ``control_hz``.

        >>> stats = PlannerStats(2)
        >>> stats.follow_ticks[1] += 25
        >>> stats.row(1, control_hz=10.0)["follow_time_s"]
        2.5
        """
        dt = 1.0 / control_hz
        return {
            "decisions_left": int(self.decisions[robot, 0]),
            "decisions_right": int(self.decisions[robot, 1]),
            "follow_time_s": float(self.follow_ticks[robot] * dt),
            "stall_time_s": float(self.stall_ticks[robot] * dt),
            "loop_flips": int(self.loop_flips[robot]),
            "escape_time_s": float(self.escape_ticks[robot] * dt),
            "sides_remembered": int(self.sides_remembered[robot]),
            "sides_reconsidered": int(self.reconsidered[robot]),
        }
