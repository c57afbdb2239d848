"""The one vocabulary of a robot's state in an episode, as two code tables.

:class:`Status` is where a robot is in the episode, as the episode judges it from the true
poses, whatever controller drives it: waiting at its start, moving, or gone (arrived, collided,
out of time, lost). :class:`State` is what the Bug planner is doing with a moving robot; every
controller reports it through :meth:`fftnav.navigation.controllers.Controller.state` under the
key ``"mode"`` (a controller without such states reports none). Recordings store both as these
codes (the ``status`` column and ``state/mode``), and the replays draw a robot by them.

========  ============  ===========================================================
code      State         the planner ...
========  ============  ===========================================================
0         ``GOAL``      heads straight for its goal (the goal direction is safe, or
                        turns to face it)
1         ``FOLLOW``    follows an obstacle's boundary on the side it decided
2         ``ESCAPE``    steers along its way to the goal through its own map, after a
                        loop or a retreat while following
3         ``DONE``      has let the robot go (arrived, collided or out of time)
4         ``WAIT``      holds the robot at its start, or stands for robots in its way
                        that give way to it
5         ``GUIDED``    heads for its goal along its way through the walls of its own
                        map (``collab``, once its gate is open)
========  ============  ===========================================================

========  ==============  ====================================================
code      Status          the robot ...
========  ==============  ====================================================
0         ``WAITING``     waits at its start to depart (``episode.departure``)
1         ``MOVING``      is on its way
2         ``ARRIVED``     came within ``success_radius_m`` of its goal (parked)
3         ``COLLIDED``    touched an obstacle (parked)
4         ``TIMED_OUT``   ran out of time (parked)
5         ``LOST``        stopped where its estimate said it had arrived, but
                          its true pose was not within ``success_radius_m`` of
                          its goal (``localization.mode = "odometry"``; parked)
========  ==============  ====================================================

>>> State.ESCAPE.label, int(State.ESCAPE), State.from_label("guided")
('escape', 2, <State.GUIDED: 5>)
>>> [s.label for s in Status if s.gone]
['arrived', 'collided', 'timed_out', 'lost']
"""

from __future__ import annotations

from enum import IntEnum

from fftnav.errors import FftnavError

__all__ = ["State", "Status"]


class _Coded(IntEnum):
    """An enum whose members have a lower-case ``label`` (CSV, JSON, recordings' meta)."""

    @property
    def label(self) -> str:
        """The member's name in lower case: ``State.GOAL.label == "goal"``."""
        return self.name.lower()

    @classmethod
    def from_label(cls, label: str):
        """The member whose :attr:`label` is ``label``; ValueError naming the known ones."""
        for member in cls:
            if member.label == label:
                return member
        raise FftnavError(f"{cls.__name__.lower()} must be one of "
                          f"{[m.label for m in cls]}, got {label!r}")

    @classmethod
    def labels(cls) -> tuple[str, ...]:
        """Every member's label, in code order."""
        return tuple(m.label for m in cls)


class State(_Coded):
    """What the Bug planner is doing with a robot (module docstring's first table)."""

    GOAL = 0
    FOLLOW = 1
    ESCAPE = 2
    DONE = 3
    WAIT = 4
    GUIDED = 5

    @property
    def moving(self) -> bool:
        """Whether the planner drives the robot in this state (not ``DONE`` or ``WAIT``)."""
        return self not in (State.DONE, State.WAIT)


class Status(_Coded):
    """Where a robot is in the episode (module docstring's second table)."""

    WAITING = 0
    MOVING = 1
    ARRIVED = 2
    COLLIDED = 3
    TIMED_OUT = 4
    LOST = 5

    @property
    def gone(self) -> bool:
        """Whether the robot has left the episode (arrived, collided, out of time or lost)."""
        return self >= Status.ARRIVED
