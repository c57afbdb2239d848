"""Controllers in the episode loop: rows carry their name, messages go through the channel,
bad commands are refused, the baselines reach a goal behind an obstacle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.config import CommsConfig, EpisodeConfig, SensorConfig, SwarmConfig
from fftnav.episode import run_episode
from fftnav.episode.core import episode_seeds
from fftnav.navigation.controllers import Action, Controller
from fftnav.plugins import PluginError
from fftnav.world import Circle, World

UP = math.pi / 2


def _world(obstacles, starts, goals, size=(8.0, 14.0)):
    return World("test", 0, size, tuple(obstacles), np.array(starts, float), np.array(goals, float))


class Talker(Controller):
    """Robot 0 says hello every tick; every robot stands still and logs its inbox."""

    uses_pipeline = False
    heard: list[tuple[int, int, int, bytes]] = []

    def act(self, obs):
        Talker.heard += [(obs.tick, obs.robot, p.sender, p.payload) for p in obs.inbox]
        return Action(0.0, 0.0, b"hello" if obs.robot == 0 else None)


class Wrong(Controller):
    uses_pipeline = False

    def act(self, obs):
        return "fast"


def test_messages_of_a_controller_travel_through_the_channel():
    Talker.heard = []
    world = _world([], [[1, 1, UP], [4, 1, UP], [1, 12, UP]], [[1, 5], [4, 5], [7, 12]])
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=2.0),
                      comms=CommsConfig(comm_range_m=6.0, delay_ticks=2))
    res = run_episode(world, f"{__name__}:Talker", seed=0, config=cfg)
    assert [r.policy for r in res.rows] == ["Talker"] * 3
    assert [r.bytes_sent for r in res.rows] == [20 * 5, 0, 0]  # 20 ticks of 5 bytes
    assert [r.messages_sent for r in res.rows] == [20, 0, 0]
    # robot 1 (3 m away) hears robot 0 from tick 0 + 1 + delay on; robot 2 (11 m) never
    ticks = sorted(t for t, robot, sender, payload in Talker.heard if robot == 1)
    assert ticks == list(range(3, 20))
    assert {(r, s, p) for _, r, s, p in Talker.heard} == {(1, 0, b"hello")}


class Dict(Controller):
    uses_pipeline = False

    def act(self, obs):
        return {"v": 0.1, "w": 0.0}


class CrashInInit(Controller):
    def __init__(self, setup):
        super().__init__(setup)
        raise RuntimeError("no map\nat all")  # CrashInInit raises here


class CrashInAct(Controller):
    uses_pipeline = False

    def act(self, obs):
        return 0.1, 1 / (obs.tick - obs.tick)  # CrashInAct raises here


def crash_in_decide(ctx):
    raise KeyError("side")  # crash_in_decide raises here


def _line(marker: str) -> int:
    """The line of this file that holds ``marker``."""
    lines = open(__file__).read().splitlines()
    return next(i for i, text in enumerate(lines, 1) if marker in text and "lines" not in text)


@pytest.mark.parametrize(("name", "match"), [
    ("Wrong", r"Wrong\.act raised FftnavError: Wrong\.act must return a pair of numbers "
              r"\(v_mps, w_radps\) or an Action, got str 'fast' for robot 0"),
    ("Dict", r"Dict\.act raised FftnavError: Dict\.act must return a pair of numbers \(v_mps, "
             r"w_radps\) or an Action, got dict \{'v': 0\.1, 'w': 0\.0\} for robot 0"),
])
def test_a_controller_returning_no_command_is_refused_saying_what_act_must_return(name, match):
    world = _world([], [[1, 1, UP]], [[1, 5]])
    where = rf" \(at {__file__}:{_line(f'class {name}(') + 3}\)$"  # where its act is defined
    with pytest.raises(PluginError, match=rf"^plugin '{__name__}:{name}': {match}{where}"):
        run_episode(world, f"{__name__}:{name}", seed=0,
                    config=SwarmConfig(episode=EpisodeConfig(time_limit_s=1.0)))


@pytest.mark.parametrize(("name", "call", "error"), [
    ("CrashInInit", "CrashInInit.__init__", "RuntimeError: no map at all"),
    ("CrashInAct", "CrashInAct.act", "ZeroDivisionError: division by zero"),
    ("crash_in_decide", "crash_in_decide", "KeyError: 'side'"),
])
def test_what_a_plugin_raises_is_one_line_naming_it_the_call_and_its_line(name, call, error):
    world = _world([Circle((1.0, 3.0), 0.3, 1.0)], [[1, 1, UP]], [[1, 5]])  # a trunk: bug decides
    line = _line(f"# {name} raises here")
    with pytest.raises(PluginError) as info:
        run_episode(world, f"{__name__}:{name}", seed=0,
                    config=SwarmConfig(episode=EpisodeConfig(time_limit_s=10.0)))
    assert str(info.value) == (f"plugin '{__name__}:{name}': {call} raised {error} "
                               f"(at {__file__}:{line})")


class Straight(Controller):
    """Drives straight at its goal and logs every finish() call with its tick."""

    uses_pipeline = False
    finished: list[int] = []

    def act(self, obs):
        return self.v_max_mps, 2.0 * obs.goal_bearing_rad

    def finish(self, robot):
        Straight.finished.append(robot)


@pytest.mark.parametrize("departure", ["together", "staggered"])
def test_finish_is_called_once_for_every_robot_arrived_collided_or_timed_out(departure):
    """Robot 0 arrives after 1 m, robot 1 drives into a trunk, robot 2's goal is 11 m away:
    out of time after 6 s; with ``together`` it is still driving when the tick loop ends."""
    Straight.finished = []
    world = _world([Circle((4.0, 3.0), 0.3, 1.0)], [[1, 1, UP], [4, 1, UP], [7, 1, UP]],
                   [[1, 2], [4, 6], [7, 12]])
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=6.0, departure=departure,
                                            stagger_s=0.5))
    rows = run_episode(world, f"{__name__}:Straight", seed=0, config=cfg).rows
    assert [(r.arrived, r.collided) for r in rows] == [(True, False), (False, True),
                                                       (False, False)]
    assert sorted(Straight.finished) == [0, 1, 2]


def test_finish_is_called_for_a_robot_timed_out_while_another_still_drives():
    """Staggered departures: robot 0 runs out of time at 6 s while robot 1 (departed 2 s later)
    still drives, so robot 0's time-out happens inside the tick loop, robot 1's at its end."""
    Straight.finished = []
    world = _world([], [[1, 1, UP], [4, 1, UP]], [[1, 14], [4, 14]])
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=6.0, departure="staggered",
                                            stagger_s=2.0))
    rows = run_episode(world, f"{__name__}:Straight", seed=0, config=cfg).rows
    assert [(r.arrived, r.collided) for r in rows] == [(False, False), (False, False)]
    assert Straight.finished == [0, 1]


def _facts(setup):
    """The world's facts and the episode's generator, as a controller is given them."""
    return (setup.n_robots, setup.config, setup.area_m, setup.walled, setup.full_circle,
            setup.rng.bit_generator.state)


class Facts(Controller):
    """Stands still and keeps what it was made from."""

    uses_pipeline = False
    seen: list[tuple] = []

    def __init__(self, setup):
        super().__init__(setup)
        Facts.seen.append(_facts(setup))

    def act(self, obs):
        return 0.0, 0.0


def test_a_plugin_controller_gets_exactly_the_world_facts_the_bug_controller_uses(monkeypatch):
    """A walled 8 m x 14 m world seen by a 270-degree lidar: the Bug controller (run by a
    decision policy) and a plugin controller are made from the same facts, those of the world,
    and the episode's generator as the seed makes it, before any draw."""
    from fftnav.navigation import resolve as resolve_module
    from fftnav.navigation.bugcontrol import BugController

    bug = []

    class Recorded(BugController):
        def __init__(self, setup, policy):
            bug.append(_facts(setup))
            super().__init__(setup, policy)

    monkeypatch.setattr(resolve_module, "BugController", Recorded)
    world = World("test", 0, (8.0, 14.0), (), np.array([[2.0, 1.0, UP], [6.0, 1.0, UP]]),
                  np.array([[2.0, 12.0], [6.0, 12.0]]), boundary="walls")
    cfg = SwarmConfig(sensor=SensorConfig(fov_deg=270.0),
                      episode=EpisodeConfig(time_limit_s=0.5))
    Facts.seen = []
    run_episode(world, f"{__name__}:Facts", seed=2, config=cfg)
    run_episode(world, "bug-left", seed=2, config=cfg)
    expected = (2, cfg, (8.0, 14.0), True, False, episode_seeds(2)[1].bit_generator.state)
    assert Facts.seen == [expected] and bug == [expected]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["vfh", "ftg", "fft-go"])
def test_each_baseline_passes_a_trunk_on_its_straight_line(name):
    """A trunk of radius 0.5 m at the middle of the straight start-goal line: the robot arrives
    without collision, on a path at most 20 % longer than the straight line."""
    world = _world([Circle((4.0, 7.0), 0.5, 1.0)], [[4, 1, UP]], [[4, 13]])
    res = run_episode(world, name, seed=0,
                      config=SwarmConfig(episode=EpisodeConfig(time_limit_s=60.0)))
    row, path = res.rows[0], res.trajectories[0]
    assert row.policy == name and row.arrived and not row.collided
    assert row.path_length_m < 1.2 * 12.0
    assert np.hypot(path[:, 0] - 4.0, path[:, 1] - 7.0).min() > 0.5 + 0.15
