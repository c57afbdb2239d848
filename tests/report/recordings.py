"""A recording made by hand (through the recorder's own ``Tape``), whose every pose and state is
known: the oracle of the replay tests.

World 10 m x 8 m, one trunk at (8, 6). 60 ticks of 0.1 s (6 s), then the end tick:

- robot 0 drives up x = 2 from y = 1 at 0.5 m/s in state ``GOAL`` and arrives at tick 40
  (y = 3), where it stays (status ``ARRIVED`` from tick 41);
- robot 1 drives along y = 5 from x = 1 at 0.5 m/s in state ``FOLLOW``;
- robot 2 drives along y = 2 from x = 4 at 0.5 m/s in state ``ESCAPE``, times out at the end;
- robot 3 stands at (8, 4) in state ``GUIDED`` and collides at tick 30: its
  ``contact_obstacle`` is set at tick 30 (a touch during the tick's control period), its
  status ``COLLIDED`` from tick 31, as the episode judges it after the period.

Each failed robot is drawn failed from its failure tick on (:data:`FAILURE_TICKS`): robot 3
from the tick it touched (30), robot 2 from the tick its time ran out (the end tick).

States and statuses are the codes of :mod:`fftnav.states` (the recording's ``state/mode`` and
``status`` columns).

Robot 1's scan returns 1.0 m on every beam ahead (|angle| < 90 degrees), nothing behind, and
its safe mask is the beams behind. Every tick robot 0 delivers a message to robot 1.

With ``estimates`` (:func:`make_recording`), every robot's estimated pose (odometry) drifts from
its true one by 0.01 m per tick along +x and by 0.1 rad in yaw (:func:`estimate`): 0.42 m off at
tick 42.
"""

from __future__ import annotations

import math

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.episode.recording import Tape, write_recording
from fftnav.states import State, Status
from fftnav.world import Circle, World

TICKS = 60
DT = 0.1
WORLD = World("forest", 7, (10.0, 8.0), (Circle((8.0, 6.0), 0.5, 1.0),),
              np.array([[2.0, 1.0, math.pi / 2], [1.0, 5.0, 0.0], [4.0, 2.0, 0.0],
                        [8.0, 4.0, math.pi]]),
              np.array([[2.0, 3.0], [9.0, 5.0], [9.5, 2.0], [8.0, 7.5]]))
CONFIG = SwarmConfig()


def pose(robot: int, tick: int) -> tuple[float, float, float]:
    """Robot ``robot``'s pose at tick ``tick`` as recorded (the oracle): a robot that left the
    world (arrived, collided, timed out) keeps its last pose in it."""
    x, y, yaw = WORLD.starts[robot]
    d = 0.5 * DT * min(tick, TICKS - 1)
    if robot == 0:
        return x, y + min(d, 2.0), yaw
    if robot in (1, 2):
        return x + d, y, yaw
    return x, y, yaw


def status(robot: int, tick: int) -> Status:
    if robot == 0 and tick > 40:
        return Status.ARRIVED
    if robot == 3 and tick > 30:
        return Status.COLLIDED
    if robot == 2 and tick == TICKS:
        return Status.TIMED_OUT
    return Status.MOVING


#: Each robot's planner state while it moves.
MODES = (State.GOAL, State.FOLLOW, State.ESCAPE, State.GUIDED)
#: How each robot is drawn while it moves, by the story above (the replays' oracle).
MOVING_KINDS = ("moving", "following", "escaping", "guided")


#: The tick at which each failed robot failed, by the story above: robot 3 touched the trunk
#: during tick 30, robot 2 ran out of time at the end tick.
FAILURE_TICKS = {2: TICKS, 3: 30}
#: The tick during whose control period robot 3 touched the trunk (its ``contact_obstacle``).
TOUCH_TICK = 30


def expected_kind(robot: int, tick: int) -> str:
    """How robot ``robot`` is drawn at ``tick``: failed from its failure tick on
    (:data:`FAILURE_TICKS`), arrived once it arrived, else by its state
    (:data:`MOVING_KINDS`)."""
    if tick >= FAILURE_TICKS.get(robot, TICKS + 1):
        return "failed"
    return "arrived" if status(robot, tick) == Status.ARRIVED else MOVING_KINDS[robot]


def angles() -> np.ndarray:
    m = CONFIG.sensor.beams
    return -math.pi + np.arange(m) * 2 * math.pi / m


def estimate(robot: int, tick: int) -> tuple[float, float, float]:
    """Robot ``robot``'s estimated pose at tick ``tick`` in a recording with estimates (the
    oracle): its pose shifted by 0.01 m per tick along +x, its yaw turned by 0.1 rad."""
    x, y, yaw = pose(robot, tick)
    return x + 0.01 * tick, y, yaw + 0.1


def make_recording(path, *, estimates: bool = False) -> None:
    """Write the recording to ``path``; with ``estimates``, the estimated poses of
    :func:`estimate` too."""
    a = angles()
    ahead = np.abs(a) < math.pi / 2
    tape = Tape(WORLD, CONFIG, "by-hand", 5, a)
    n = len(WORLD.starts)
    for g in range(TICKS):
        poses = np.array([pose(i, g) for i in range(n)])
        st = np.array([status(i, g) for i in range(n)])
        moving = st == Status.MOVING
        ranges = np.zeros((n, len(a)))
        ranges[1] = np.where(ahead, 1.0, CONFIG.sensor.range_m)
        safe = np.zeros((n, len(a)), bool)
        safe[1] = ~ahead
        tape.tick(g * DT, poses, st, commands=np.tile([0.5, 0.0], (n, 1)), ranges_m=ranges,
                  safe=safe, state={i: {"mode": float(MODES[i]), "side": 1.0, "decisions": float(g // 10)}
                                    for i in np.flatnonzero(moving).tolist()},
                  **_estimates(estimates, n, g))
        tape.contacts(np.arange(n) == 3 if g == TOUCH_TICK else np.zeros(n, bool),
                      np.zeros(n, bool))
        tape.delivery(g, 0, 1, g)
    tape.end(TICKS * DT, np.array([pose(i, TICKS) for i in range(n)]),
             np.array([status(i, TICKS) for i in range(n)]), **_estimates(estimates, n, TICKS))
    rows = [{"robot": i, "policy": "by-hand", "arrived": i == 0,
             "failure": {2: "slow", 3: "collision"}.get(i, "")} for i in range(n)]
    write_recording(path, tape.to_bytes(rows))


def _estimates(on: bool, n: int, tick: int) -> dict[str, np.ndarray]:
    """The ``estimates`` keyword of a tick of the tape (none without estimates)."""
    return {"estimates": np.array([estimate(i, tick) for i in range(n)])} if on else {}
