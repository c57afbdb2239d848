"""When a failed robot turns red (fftnav.report.replay.failure_ticks) against a recording made by
hand with every way to fail, and what a frame's key says (the clock over the time limit, the
picked robot's state by the names of fftnav.states, the legend), with the replays' pixels."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.config import SwarmConfig
from fftnav.episode.recording import Tape, read_recording, write_recording
from fftnav.report.frames import (
    KEY_LABELS,
    KINDS,
    RasterRenderer,
    clock_text,
    describe_robot,
    kind_rgb,
    scale_bar_m,
    state_name,
)
from fftnav.report.replay import drawn_status, failure_ticks, recording_frame, robot_kinds
from fftnav.states import State, Status
from fftnav.world import World
from tests.report.recordings import FAILURE_TICKS, TOUCH_TICK

RES = 0.05
TICKS = 20
#: Five robots 2 m apart along y = 2 of a 12 m x 6 m world, standing still, each with its story:
#: 0 arrives in tick 5; 1 touches an obstacle in tick 7; 2 stops in tick 10 where its estimate
#: put its goal (lost); 3 still drives at the end (timed out at the end tick, 20); 4 departs at
#: tick 3 and its time runs out at tick 15.
STARTS = np.array([[1.0 + 2.0 * i, 2.0, 0.0] for i in range(5)])
WORLD = World("forest", 1, (12.0, 6.0), (), STARTS, STARTS[:, :2] + [0.0, 3.0])
#: The ticks of the stories above, worked by hand: a touch or a stop in tick g shows from g + 1
#: in the status column; a time-out from its own tick.
EXPECTED = {1: 7, 2: 10, 3: TICKS, 4: 15}


def _status(robot: int, tick: int) -> Status:
    """The status the episode records at the start of ``tick`` (the stories above)."""
    if robot == 0 and tick > 5:
        return Status.ARRIVED
    if robot == 1 and tick > 7:
        return Status.COLLIDED
    if robot == 2 and tick > 10:
        return Status.LOST
    if robot == 3 and tick == TICKS:
        return Status.TIMED_OUT
    if robot == 4:
        return (Status.WAITING if tick < 3 else Status.TIMED_OUT if tick >= 15
                else Status.MOVING)
    return Status.MOVING


@pytest.fixture(scope="module")
def every_way(tmp_path_factory):
    config = SwarmConfig()
    angles = -math.pi + np.arange(config.sensor.beams) * 2 * math.pi / config.sensor.beams
    tape = Tape(WORLD, config, "by-hand", 0, angles)
    n = len(STARTS)
    for g in range(TICKS):
        status = np.array([_status(i, g) for i in range(n)])
        moving = np.flatnonzero(status == Status.MOVING).tolist()
        tape.tick(g * 0.1, STARTS, status, commands=np.zeros((n, 2)),
                  ranges_m=np.zeros((n, len(angles))), safe=np.zeros((n, len(angles)), bool),
                  state={i: {"mode": float(State.GOAL), "side": 0.0} for i in moving})
        tape.contacts(np.arange(n) == 1 if g == 7 else np.zeros(n, bool), np.zeros(n, bool))
    tape.end(TICKS * 0.1, STARTS, np.array([_status(i, TICKS) for i in range(n)]))
    rows = [{"robot": i, "arrived": i == 0,
             "failure": ["", "collision", "lost", "slow", "stuck"][i]} for i in range(n)]
    path = tmp_path_factory.mktemp("ways") / "ways.npz"
    write_recording(path, tape.to_bytes(rows))
    return read_recording(path)


def test_failure_ticks_of_every_way_to_fail(every_way):
    assert failure_ticks(every_way) == EXPECTED
    # a collision's tick is the tick of its contact
    assert np.flatnonzero(every_way.contact_obstacle[:, 1]).tolist() == [EXPECTED[1]]


def test_the_shared_recordings_failure_ticks(recording):
    assert failure_ticks(recording) == FAILURE_TICKS
    assert np.flatnonzero(recording.contact_obstacle[:, 3]).tolist() == [TOUCH_TICK]


def test_a_failed_robot_is_drawn_failed_from_its_failure_tick(every_way):
    """Each robot's colour before and at its failure tick: its moving colour, then failed (a
    lost robot: its own colour, with the red cross)."""
    kinds = robot_kinds(every_way)
    status = drawn_status(every_way)
    for robot, tick in EXPECTED.items():
        final = Status(int(every_way.status[-1, robot]))
        assert KINDS[kinds[tick - 1, robot]] == "moving", robot
        assert KINDS[kinds[tick, robot]] == ("lost" if final == Status.LOST else "failed")
        assert (status[tick:, robot] == final).all() and status[tick - 1, robot] != final
    assert KINDS[kinds[TICKS, 0]] == "arrived" and KINDS[kinds[2, 4]] == "waiting"
    renderer = RasterRenderer(WORLD, r0_m=0.15, resolution_m=RES)
    h = WORLD.size_m[1]

    def at(frame, x, y):
        return np.asarray(frame[int(round((h - y) / RES - 0.5)), int(round(x / RES - 0.5))],
                          int)

    red = np.array(kind_rgb("failed"))
    for robot, tick in EXPECTED.items():
        x, y, _ = STARTS[robot]
        before = renderer(recording_frame(every_way, tick - 1, None))
        after = renderer(recording_frame(every_way, tick, None))
        assert tuple(at(before, x, y)) == kind_rgb("moving"), robot
        assert tuple(at(after, x, y)) == kind_rgb(KINDS[kinds[tick, robot]]), robot
        arm = (x + 0.2, y + 0.2)  # the cross's arm, beyond the disc
        assert np.abs(at(after, *arm) - red).max() < 40 < np.abs(at(before, *arm) - red).max()


def test_the_key_says_the_time_and_the_picked_robots_state(recording):
    """The clock over the default 120 s limit, robot 1 by its mode and side (FOLLOW, +1),
    robot 3 guided (its side +1 too) until it touched the trunk, then collided, with its
    cause."""
    frame = recording_frame(recording, 42, 1)
    assert (frame.time_s, frame.end_s) == (pytest.approx(4.2), 120.0)
    assert frame.picked_label == "robot 1: follow (left)"
    assert frame.scan.safe_m == pytest.approx(0.3 ** 2 / 0.15)  # l_th = r^2 / r0
    assert recording_frame(recording, 29, 3).picked_label == "robot 3: guided (left)"
    assert recording_frame(recording, 30, 3).picked_label == "robot 3: collided (collision)"
    renderer = RasterRenderer(recording.world, r0_m=0.15, resolution_m=RES, safe_m=0.6)
    renderer(frame)
    key = renderer.painter.key
    assert key.clock.get_text() == "t = 4.2 s / 120 s"
    assert key.robot.get_text() == "robot 1: follow (left)"
    texts = [t.get_text() for t in key.legend.get_texts()]
    labels = {**KEY_LABELS, "safe": "safe (to l_th = 0.60 m)"}
    assert texts == [*KINDS, *labels.values()]


@pytest.mark.parametrize(("value", "text"), [
    (lambda: state_name(int(State.FOLLOW), -1.0), "follow (right)"),
    (lambda: state_name(int(State.GUIDED), 0.0), "guided"),
    (lambda: state_name(int(State.ESCAPE), 1.0), "escape (left)"),
    (lambda: state_name(math.nan, 1.0), ""),
    (lambda: describe_robot(4, Status.MOVING), "robot 4: moving"),
    (lambda: describe_robot(0, Status.ARRIVED, cause="slow"), "robot 0: arrived"),
    (lambda: describe_robot(2, Status.LOST, cause="lost"), "robot 2: lost (lost)"),
    (lambda: clock_text(0.04, 7.5), "t = 0.0 s / 7.5 s"),
    (lambda: clock_text(54.25), "t = 54.2 s"),
    (lambda: scale_bar_m(3.0), 0.5),
    (lambda: scale_bar_m(100.0), 20.0),
    (lambda: scale_bar_m(24.9), 2.0),
])
def test_names_and_numbers_of_the_key(value, text):
    assert value() == text
