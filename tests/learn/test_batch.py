"""What is trained is what runs: the observations SwarmBatch gives a learner are the learned
controller's, and a network driving the batch drives the episode that `learned:PATH` runs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("pettingzoo", reason="the optional extra fftnav[marl] is not installed")

from fftnav.config import EpisodeConfig, SwarmConfig  # noqa: E402
from fftnav.envs.swarm_env import Rewards  # noqa: E402
from fftnav.episode import run_episode  # noqa: E402
from fftnav.episode.loop import episode_rows  # noqa: E402
from fftnav.learn.batch import SwarmBatch  # noqa: E402
from fftnav.learn.config import MapRange  # noqa: E402
from fftnav.navigation.learned import OBSERVATIONS, untrained  # noqa: E402
from fftnav.world import generate_world  # noqa: E402

CONFIG = SwarmConfig(episode=EpisodeConfig(time_limit_s=12.0))
ROBOTS = 4


def _batch(observation, *, map_seed=5003, seed=0, speeds=None, min_live=1):
    return SwarmBatch(observation, schedule=MapRange(("forest",), map_seed, map_seed + 1),
                      robots=ROBOTS, config=CONFIG, rewards=Rewards(),
                      rng=np.random.default_rng(seed), speeds=speeds, min_live=min_live)


@pytest.mark.parametrize("observation, speeds", [("extrema", (0.0, 1.0)), ("ranges", None),
                                                 ("safe", None)])
def test_a_network_driving_the_batch_is_the_learned_controllers_episode(tmp_path, observation,
                                                                        speeds):
    net = untrained(observation, seed=3)
    if speeds is not None:
        net = dataclasses.replace(net, meta={**net.meta, "v_range": list(speeds)})
    path = net.save(tmp_path / "net.npz")
    batch = _batch(observation, speeds=speeds)
    obs = batch.reset()
    kind, map_seed, seed = batch.episode
    assert (kind, map_seed) == ("forest", 5003)
    assert obs.shape == (ROBOTS, OBSERVATIONS[observation].size(CONFIG)) and obs.dtype == np.float64
    ended, steps = False, 0
    while not ended:
        obs, rewards, dones, truncated, ended = batch.step(net(obs))
        steps += 1
        assert not truncated.any()
    rows = episode_rows(batch.env.core, "learned-net")
    world = generate_world("forest", 5003, robots=ROBOTS, robot_radius_m=CONFIG.robot.r0_m)
    expected = run_episode(world, f"learned:{path}", seed=seed, config=CONFIG).rows
    assert [repr(r) for r in rows] == [repr(r) for r in expected]  # NaN fields compare as text
    assert steps >= 1
    assert batch.tally.episodes == 1 and batch.tally.robots == ROBOTS
    assert batch.tally.arrived == sum(r.arrived for r in expected)


def test_ended_robots_see_zeros_and_the_schedule_is_seeded():
    a, b = _batch("extrema", seed=7), _batch("extrema", seed=7)
    a.reset(), b.reset()
    assert a.episode == b.episode
    c = SwarmBatch("extrema", schedule=MapRange(("forest", "rocky"), 5000, 6000), robots=ROBOTS,
                   config=CONFIG, rewards=Rewards(), rng=np.random.default_rng(1))
    episodes = set()
    for _ in range(6):
        c.reset()
        episodes.add(c.episode[:2])
        assert 5000 <= c.episode[1] < 6000
    assert len({k for k, _ in episodes}) == 2
    # full speed ahead: robots collide and leave; their slots read zeros from then on
    a.reset()
    gone = np.zeros(ROBOTS, bool)
    ended = False
    while not ended:
        obs, rewards, dones, truncated, ended = a.step(np.tile([1.0, 0.0], (ROBOTS, 1)))
        if not ended:
            assert not obs[gone].any() and not rewards[gone].any()
        gone |= dones


def test_min_live_cuts_the_episode_short_and_truncates_the_rest():
    batch = _batch("ranges", min_live=ROBOTS)  # cut as soon as one robot has left
    batch.reset()
    ended = False
    while not ended:
        obs, rewards, dones, truncated, ended = batch.step(np.tile([1.0, 0.0], (ROBOTS, 1)))
    assert dones.all() and 0 < truncated.sum() < ROBOTS
    assert obs[truncated].any(axis=1).all()  # a truncated robot's last observation, to bootstrap
