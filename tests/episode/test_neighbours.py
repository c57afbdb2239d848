"""Neighbour accounting of fused decisions: why each other robot was or was not fused (the
channel says why a robot was not heard, the decider why a heard one was not fused)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav import metrics
from fftnav.config import CommsConfig, EpisodeConfig, SwarmConfig
from fftnav.episode import EPISODE_COLUMNS, run_episode
from fftnav.episode.comms import Channel
from fftnav.navigation.controllers import SwarmStep
from fftnav.navigation.decider import Decider
from fftnav.world import Polygon, World

UP = math.pi / 2


class _Coin:
    """A generator stand-in whose draws are all 0: every packet sent while loss > 0 is lost."""

    def random(self, n):
        return np.zeros(n)

    def normal(self, *args):  # pragma: no cover - pose noise is 0 here
        raise AssertionError


def _observe(decider, ch, poses, goals, res, *, present):
    """The decider sees the swarm at tick 100 through a SwarmStep, as in an episode."""
    k = len(poses)
    decider.observe(SwarmStep(
        tick=100, time_s=10.0, poses=poses, goals=goals, active=np.arange(k),
        ranges_m=np.zeros((k, 1)), angles_rad=np.zeros(1), safe=None, y1=None,
        messages=res.messages, sigma=res.sigma, present=present,
        inbox=lambda i: ch.inbox(i, tick=100, max_age_ticks=10),
        unheard=lambda i: ch.unheard(i, tick=100, max_age_ticks=10, present=present)))


def _scene():
    cfg = SwarmConfig()
    pipe = cfg.pipeline()
    poses = np.array([[5.0, 5.0, UP],   # 0: the decider, goal straight ahead
                      [4.0, 7.0, UP],   # 1: ahead-left, sends: fused
                      [5.3, 5.2, UP],   # 2: 0.36 m away (< 2 r = 0.6 m), sends: too close
                      [5.0, 3.0, UP],   # 3: behind, sends: behind
                      [5.0, 12.0, UP],  # 4: 7 m ahead (comm range 6 m), sends: out of range
                      [6.0, 7.0, UP],   # 5: never sends: no message
                      [3.0, 6.0, UP],   # 6: sends, its packet is lost: lost
                      [9.0, 5.0, UP]])  # 7: sent 2 s ago (stale): no message
    goals = poses[:, :2] + [0.0, 10.0]
    scans = np.full((len(poses), cfg.sensor.beams), 1.5)
    res = pipe.process(scans, with_p_s=False)
    ch = Channel(len(poses), range_m=cfg.comms.comm_range_m, rng=_Coin())
    active = np.ones(len(poses), dtype=bool)
    ch.broadcast(7, res.messages[7], tick=80, poses=poses, active=active)
    for j in (1, 2, 3, 4):
        ch.broadcast(j, res.messages[j], tick=99, poses=poses, active=active)
    ch.loss = 0.5
    ch.broadcast(6, res.messages[6], tick=99, poses=poses, active=active)
    ch.deliver(100)
    decider = Decider(cfg, np.random.default_rng(0), full_circle=True)
    everyone = np.ones(len(poses), dtype=bool)
    _observe(decider, ch, poses, goals, res, present=everyone)
    return decider, ch, (poses, goals, res)


def test_the_channel_says_why_a_robot_was_not_heard():
    _, ch, _ = _scene()
    everyone = np.ones(8, dtype=bool)
    assert ch.unheard(0, tick=100, max_age_ticks=10, present=everyone) == {
        4: "out_of_range", 5: "no_message", 6: "lost", 7: "no_message"}
    assert ch.unheard(0, tick=100, max_age_ticks=25, present=everyone) == {
        4: "out_of_range", 5: "no_message", 6: "lost"}  # 7's packet of tick 80 is heard now
    gone = everyone & ~np.isin(np.arange(8), [4, 6])
    assert ch.unheard(0, tick=100, max_age_ticks=10, present=gone) == {
        5: "no_message", 7: "no_message"}


def test_each_neighbour_gets_its_reason_and_the_counts_add_up():
    decider, ch, (poses, goals, res) = _scene()
    decider.fused_probability(0)
    counts = decider.neighbour_reasons[0]
    assert dict(counts) == {"fused": 1, "too_close": 1, "behind": 1, "out_of_range": 1,
                            "no_message": 2, "lost": 1}
    assert sum(counts.values()) == 7  # every other robot, once per decision
    assert decider.with_neighbours[0] == 1
    decider.fused_probability(0)
    assert sum(decider.neighbour_reasons[0].values()) == 14
    # a robot that is gone (arrived) is no candidate
    _observe(decider, ch, poses, goals, res, present=np.array([True] * 7 + [False]))
    decider.fused_probability(0)
    assert sum(decider.neighbour_reasons[0].values()) == 20
    assert set(metrics.NEIGHBOUR_REASONS) == set(counts)


def test_episode_columns_add_up_to_decisions_times_other_robots():
    """Five robots meet a wall 2 m ahead together, long before any can arrive: every fused
    decision counts the four others (each decision is one call of the fused probability)."""
    wall = Polygon(((1.0, 3.0), (9.0, 3.0), (9.0, 3.3), (1.0, 3.3)), 1.0)
    xs = [3.0, 4.0, 5.0, 6.0, 7.0]
    world = World("t", 0, (10.0, 12.0), (wall,), np.array([[x, 1.0, UP] for x in xs]),
                  np.array([[x, 11.0] for x in xs]))
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=12.0),
                      comms=CommsConfig(packet_loss=0.3))
    rows = run_episode(world, "fusion", seed=1, config=cfg).rows
    reasons = [f"neighbours_{r}" for r in metrics.NEIGHBOUR_REASONS]
    assert set(reasons) <= set(EPISODE_COLUMNS)
    decisions = 0
    for row in rows:
        d = row.as_dict()
        assert not d["arrived"]  # nobody left the world: four others at every decision
        n = row.decisions_left + row.decisions_right
        decisions += n
        assert sum(d[r] for r in reasons) == 4 * n
        assert row.neighbours_fused >= row.decisions_with_neighbours
    assert decisions >= 5
    table = {c: [r.as_dict()[c] for r in rows] for c in EPISODE_COLUMNS}
    shares = [metrics.evaluate(table, [f"share_neighbours_{r}"])[f"share_neighbours_{r}"]
              for r in metrics.NEIGHBOUR_REASONS]
    assert sum(shares) == pytest.approx(1.0)
    own = run_episode(world, "own-only", seed=1, config=cfg).rows
    assert all(sum(r.as_dict()[c] for c in reasons) == 0 for r in own)
