"""The ``failure`` column of an episode: each robot's cause, from its trajectory in the
simulator, with the other robots aligned by tick across departures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.config import EpisodeConfig, SwarmConfig
from fftnav.episode import EPISODE_COLUMNS, run_episode
from fftnav.episode.loop import positions_by_tick
from fftnav.navigation.controllers import Controller
from fftnav.world import Circle, World

UP = math.pi / 2


def _world(obstacles, starts, goals, size=(12.0, 14.0)):
    return World("test", 0, size, tuple(obstacles), np.array(starts, float), np.array(goals, float))


class Scripted(Controller):
    """Robot 0 drives at its goal, 1 drives at its goal (a trunk on the way), 2 turns on the
    spot, 3 circles (radius 1 m), 4 drives across the goal line (+x)."""

    uses_pipeline = False

    def act(self, obs):
        turn = 2.0 * obs.goal_bearing_rad
        return [(0.5, turn), (0.5, turn), (0.0, 1.0), (0.5, 0.5),
                (0.5, 2.0 * math.remainder(-obs.pose[2], 2 * math.pi))][obs.robot]


def test_each_robot_gets_the_cause_of_what_it_did():
    world = _world([Circle((3.0, 3.0), 0.3, 1.0)],
                   [[1, 1, UP], [3, 1, UP], [5, 6, UP], [8, 6, UP], [1, 12, 0.0]],
                   [[1, 2], [3, 13], [5, 13], [8, 13], [1, 13.5]])
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=25.0))
    rows = run_episode(world, f"{__name__}:Scripted", seed=0, config=cfg).rows
    assert EPISODE_COLUMNS[-1] == "failure"
    assert [(r.arrived, r.collided) for r in rows][:2] == [(True, False), (False, True)]
    assert [r.failure for r in rows] == ["", "collision", "stuck", "loop", "detour"]


def test_slow_a_robot_still_closing_in_when_time_is_up():
    world = _world([], [[1, 1, UP]], [[1, 13]])
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=6.0))
    (row,) = run_episode(world, f"{__name__}:Scripted", seed=0, config=cfg).rows
    assert not row.arrived and row.failure == "slow"


class Standing(Controller):
    """Every robot stands still."""

    uses_pipeline = False

    def act(self, obs):
        return 0.0, 0.0


@pytest.mark.parametrize(("departure", "failures"), [
    ("together", ["jam", "jam"]),
    # robot 1 departs at 20 s: robot 0 (moving from 0 to 25 s) has it beside it, waiting at its
    # start, all the time; robot 1's last 20 s (45 to 65 s) see robot 0 only at 45 s (parked
    # after): stuck. Without aligning by departure tick it would see robot 0 the whole window.
    ("waves", ["jam", "stuck"]),
])
def test_jam_beside_another_robot_with_departures_aligned_by_tick(departure, failures):
    world = _world([], [[4, 1, UP], [4, 1.5, UP]], [[4, 13], [6, 13]])
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=25.0, departure=departure, waves=2,
                                            wave_interval_s=20.0))
    rows = run_episode(world, f"{__name__}:Standing", seed=0, config=cfg).rows
    assert [r.failure for r in rows] == failures


def test_positions_by_tick_against_an_independent_walk_over_ticks():
    rng = np.random.default_rng(1)
    departure = np.array([0, 3, 7])
    trajectories = [rng.normal(size=(n, 3)) for n in (12, 4, 6)]
    got = positions_by_tick(trajectories, departure)
    assert got.shape == (13, 3, 2)
    for tick in range(13):
        for j, (d, t) in enumerate(zip(departure, trajectories, strict=True)):
            if tick < d:
                expected = t[0, :2]  # waiting at its start
            elif tick - d < len(t):
                expected = t[tick - d, :2]
            else:
                expected = [np.nan, np.nan]  # parked
            np.testing.assert_array_equal(got[tick, j], expected)
