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
    """collab's Bug controller, keeping every pose it is given and every packet's sender
    pose, by tick."""

    given: list[tuple[int, np.ndarray]] = []
    placed: list[tuple[int, int, int, np.ndarray]] = []

    def __init__(self, setup):
        super().__init__(setup)
        self.inner = resolve("collab").make(setup)

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


def _spy(config):
    Spy.given, Spy.placed = [], []
    truth: dict[int, np.ndarray] = {}
    known: dict[int, np.ndarray] = {}

    def hook(step, scans, commands, outgoing, true_poses):
        truth[step.tick] = true_poses.copy()
        known[step.tick] = step.poses.copy()

    result = run_episode(WORLD, f"{__name__}:Spy", seed=4, config=config, on_tick=hook)
    return result, truth, known


def test_with_odometry_no_controller_ever_sees_a_true_pose():
    _, truth, known = _spy(_config(mode="odometry", drift="typical"))
    seen = [(t, poses) for t, poses in Spy.given if t >= 1]
    assert len(seen) > 100 and len(Spy.placed) > 20  # it drove and heard its neighbours
    for t, poses in seen:
        # no pose it was given equals any robot's true pose at that tick ...
        gap = np.abs(poses[:, None, :] - truth[t][None, :, :]).max(axis=2)
        assert gap.min() > 1e-9, (t, poses, truth[t])
        # ... and the poses it was given are the estimates the episode kept
        assert np.isin(poses, known[t]).all()
    for t, receiver, sender, pose in Spy.placed:
        sent = [truth[k][sender] for k in truth if k <= t]
        assert min(np.abs(pose - s).max() for s in sent) > 1e-9, (t, receiver, sender)


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
    for t in truth:
        moving = ~np.isnan(known[t]).any(axis=1)
        assert np.allclose(known[t][moving], truth[t][moving], atol=1e-9)
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


def test_the_localizer_draws_from_its_own_generator():
    cfg = _config(mode="odometry", drift="high")
    start = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    moved = start + [0.05, 0.0, 0.0]
    a = Localizer(cfg, start, localization_rng(3))
    b = Localizer(cfg, start, localization_rng(3))
    for loc in (a, b):
        loc.moved(start, moved, np.array([0, 1]))
    assert (a.poses(moved) == b.poses(moved)).all() and (a.poses(moved) != moved).any()
    placed = a.locate(0, np.array([1]), moved)
    assert placed.shape == (1, 3) and not np.allclose(placed[0], moved[0])
    exact = Localizer(_config(mode="exact"), start, localization_rng(3))
    assert exact.poses(moved) is moved
    assert (exact.locate(0, np.array([1]), moved) == moved[0]).all()


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
