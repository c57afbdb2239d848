"""Localization in the episode: with odometry a controller sees only the robots' estimates and
the senders where its robots measure them, never a true pose; the benchmark judges the truth,
and a robot that stops at a goal only its estimate believes in is lost."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.config import EpisodeConfig, SwarmConfig
from fftnav.episode import run_episode
from fftnav.episode.localize import Localizer, localization_rng
from fftnav.navigation.controllers import Controller
from fftnav.navigation.resolve import resolve
from fftnav.states import Status
from fftnav.world import Circle, Polygon, World

UP = math.pi / 2

# Three robots side by side, 2 m apart (each hears the others), a trunk and a wall on the way.
WORLD = World("test", 0, (10.0, 12.0),
              (Circle((2.0, 5.0), 0.4, 1.0),
               Polygon(((4.0, 6.0), (7.0, 6.0), (7.0, 6.3), (4.0, 6.3)), 1.0)),
              np.array([[2.0, 1.0, UP], [4.5, 1.0, UP], [6.5, 1.0, UP]]),
              np.array([[2.0, 10.0], [5.5, 10.5], [7.0, 10.0]]))


def _config(**localization):
    return SwarmConfig(episode=EpisodeConfig(time_limit_s=25.0)).replace(
        {f"localization.{k}": v for k, v in localization.items()})


class Spy(Controller):
    """The controller of :attr:`policy` (a built-in), keeping every pose it is given (of the
    robots driving) and every packet's sender pose, by tick."""

    policy = "collab"
    given: list[tuple[int, np.ndarray]] = []
    placed: list[tuple[int, int, int, np.ndarray]] = []

    def __init__(self, setup):
        super().__init__(setup)
        self.inner = resolve(Spy.policy).make(setup)

    def step(self, swarm):
        Spy.given.append((swarm.tick, swarm.poses[swarm.active].copy()))
        for i in swarm.active.tolist():
            Spy.placed += [(swarm.tick, i, p.sender, np.array(p.sender_pose))
                           for p in swarm.inbox(i)]
        return self.inner.step(swarm)

    def hold(self, robot):
        self.inner.hold(robot)

    def release(self, robot):
        self.inner.release(robot)

    def finish(self, robot):
        self.inner.finish(robot)


def _spy(config, policy="collab"):
    Spy.given, Spy.placed, Spy.policy = [], [], policy
    truth: dict[int, np.ndarray] = {}
    known: dict[int, np.ndarray] = {}

    def hook(step, scans, commands, outgoing, true_poses):
        truth[step.tick] = true_poses.copy()
        known[step.tick] = step.poses.copy()

    result = run_episode(WORLD, f"{__name__}:Spy", seed=4, config=config, on_tick=hook)
    return result, truth, known


BUILT_INS = ["bug-left", "bug-right", "fusion", "own-only", "collab", "vfh", "ftg", "fft-go"]


@pytest.mark.parametrize("policy", BUILT_INS)
def test_with_odometry_no_controller_ever_sees_a_true_pose(policy):
    """No component (x, y or yaw) of a pose a controller is given equals that component of
    any robot's true pose at that tick, once the robots have moved; the poses it is given are
    the estimates the episode keeps; no packet places its sender at a true pose."""
    _, truth, known = _spy(_config(mode="odometry", drift="typical"), policy)
    start = truth[0]
    checked = 0
    for t, poses in Spy.given:
        moved = (truth[t] != start).all(axis=1)  # robots whose every component changed
        if t < 1 or not moved.any():
            continue
        for row in poses:
            if not np.isin(row, known[t]).all():
                raise AssertionError(f"tick {t}: {row} is not an estimate")
            same = row[None, :] == truth[t][moved]
            assert not same.any(), (t, row, truth[t][moved])
            checked += 1
    assert checked > 100
    if policy in ("fusion", "collab"):
        assert len(Spy.placed) > 5  # they heard their neighbours
    for t, receiver, sender, pose in Spy.placed:
        for k in (k for k in truth if k <= t):
            assert not (pose == truth[k][sender]).any(), (t, receiver, sender)


def test_with_exact_poses_the_same_spy_sees_the_truth():
    _, truth, _ = _spy(_config(mode="exact"))
    for t, poses in Spy.given:
        assert (np.abs(poses[:, None, :] - truth[t][None, :, :]).max(axis=2).min(axis=1)
                == 0).all()
    assert Spy.placed and all(
        any((pose == truth[k][sender]).all() for k in truth) for _, _, sender, pose in Spy.placed)


def test_noise_free_odometry_keeps_the_estimates_on_the_truth():
    result, truth, known = _spy(_config(mode="odometry", drift="none", range_noise_m=0.0,
                                        bearing_noise_deg=0.0, heading_noise_deg=0.0))
    for t, poses in Spy.given:  # the robots driving: their estimates are their true poses
        assert all(np.abs(truth[t] - row).max(axis=1).min() < 1e-9 for row in poses)
    for t, _, sender, pose in Spy.placed:  # senders placed where they stood
        assert any(np.allclose(pose, truth[k][sender], atol=1e-9) for k in truth if k <= t)
    assert [r.arrived for r in result.rows] == [r.arrived for r in run_episode(
        WORLD, "collab", seed=4, config=_config(mode="exact")).rows]


def test_a_robot_that_stops_at_the_goal_its_estimate_believes_in_is_lost():
    """A gyro bias turns every estimate left of the truth: each robot believes it reached its
    goal while it is a metre or more from it, and stops there."""
    world = World("open", 0, (12.0, 14.0), (), np.array([[6.0, 1.0, UP]]), np.array([[6.0, 11.0]]))
    biased = _config(mode="odometry", drift="none", gyro_bias_degps=4.0)
    result = run_episode(world, "own-only", seed=0, config=biased, record=True)
    row = result.rows[0]
    end = result.trajectories[0][-1]
    assert not row.arrived and row.failure == "lost"
    assert math.hypot(*(end[:2] - world.goals[0])) > 1.0
    assert result.tape is not None
    # the exact robot arrives
    exact = run_episode(world, "own-only", seed=0, config=_config(mode="exact")).rows[0]
    assert exact.arrived and exact.failure == ""


def test_each_robots_odometry_noise_is_its_own_whatever_the_others_do():
    """Robot 0's estimate after two ticks is the same whether robot 1 moved, stood still or
    was measured in between: its noise is drawn ahead from a generator of its own."""
    cfg = _config(mode="odometry", drift="high")
    start = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    step = start + [0.05, 0.0, 0.0]
    finals = []
    for moving, measure in [([0, 1], False), ([0], True), ([0], False)]:
        loc = Localizer(cfg, start, localization_rng(3), ticks=5)
        given = loc.poses(start)
        loc.moved(start, step, np.array(moving))
        if measure:
            loc.locate(1, np.array([0]), step)
        loc.moved(step, step + [0.05, 0.0, 0.0], np.array(moving))
        finals.append(loc.poses(step)[0].copy())
        assert (given == start).all()  # the poses handed out before did not change
    assert (finals[0] == finals[1]).all() and (finals[1] == finals[2]).all()
    assert not np.allclose(finals[0], [0.1, 0.0, 0.0])


def test_the_localizer_places_senders_by_measurement():
    cfg = _config(mode="odometry", drift="high")
    start = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    loc = Localizer(cfg, start, localization_rng(3), ticks=5)
    placed = loc.locate(0, np.array([1]), start)
    assert placed.shape == (1, 3) and not np.allclose(placed[0], start[0])
    assert np.allclose(placed[0], start[0], atol=0.5)
    exact = Localizer(_config(mode="exact"), start, localization_rng(3), ticks=5)
    assert exact.poses(start) is start
    assert (exact.locate(0, np.array([1]), start) == start[0]).all()


@pytest.mark.parametrize(("key", "value", "message"), [
    ("localization.mode", "gps", r"localization.mode must be one of \['exact', 'odometry'\]"),
    ("localization.drift", "huge", r"localization.drift must be one of \['none', 'low'"),
    ("localization.alpha1", -1, r"localization.alpha1 must be a finite number in \[0, 1e\+06\]"),
    ("localization.alpha2", 0.1, r"alpha1 to alpha4 need drift = \"custom\""),
])
def test_bad_localization_settings_are_refused(key, value, message):
    with pytest.raises(ValueError, match=message):
        SwarmConfig().replace({key: value})


def test_custom_alphas_and_the_bias_make_the_noise():
    cfg = SwarmConfig().replace({"localization.drift": "custom", "localization.alpha3": 0.2,
                                 "localization.gyro_bias_degps": 1.0})
    noise = cfg.localization.noise
    assert noise.alphas == (0.0, 0.0, 0.2, 0.0)
    assert noise.gyro_bias_radps == pytest.approx(math.radians(1.0))
    assert Status.LOST.gone


def test_a_hook_of_four_arguments_is_called_without_the_truth():
    seen = []
    world = World("open", 0, (12.0, 14.0), (), np.array([[6.0, 1.0, UP]]), np.array([[6.0, 4.0]]))
    run_episode(world, "own-only", seed=0, config=_config(mode="odometry"),
                on_tick=lambda step, scans, commands, outgoing: seen.append(step.tick))
    assert seen[:3] == [0, 1, 2]
