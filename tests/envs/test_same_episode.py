"""SwarmNavEnv driven by a controller's actions is run_episode: the same trajectories, bit for bit,
the same arrivals and collisions, the same messages and decisions, for the same world and seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pettingzoo", reason="the optional extra fftnav[marl] is not installed")

from fftnav.config import CommsConfig, EpisodeConfig, SwarmConfig  # noqa: E402
from fftnav.envs import Observations, SwarmNavEnv  # noqa: E402
from fftnav.episode import run_episode  # noqa: E402
from fftnav.navigation.controllers import Controller  # noqa: E402
from fftnav.states import Status  # noqa: E402
from fftnav.world import Circle, Polygon, World  # noqa: E402

UP = math.pi / 2


class Headlong(Controller):
    """Drives straight at its goal, whatever is in the way."""

    uses_pipeline = False

    def act(self, obs):
        return self.v_max_mps, 2.0 * obs.goal_bearing_rad


def _box(x0, x1, y0, y1):
    return Polygon(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), 1.0)


# Robot 0 has a trunk on its straight line, robot 1 a wide wall, robot 2 a clear way to a goal
# close by, robot 3 a trunk beside its line; robots 1 and 2 start near each other.
WORLD = World("test", 0, (10.0, 12.0),
              (Circle((1.5, 5.0), 0.4, 1.0), _box(3.2, 6.0, 6.0, 6.3), Circle((8.7, 6.0), 0.3, 1.0)),
              np.array([[1.5, 1.0, UP], [4.5, 1.0, UP], [5.6, 1.3, UP], [8.4, 1.0, UP]]),
              np.array([[1.5, 10.0], [4.5, 10.5], [5.6, 4.0], [8.4, 10.0]]))


def _config(departure="together", loss=0.0):
    return SwarmConfig(episode=EpisodeConfig(time_limit_s=20.0, departure=departure,
                                             stagger_s=1.5),
                       comms=CommsConfig(packet_loss=loss, comm_range_m=6.0))


def _drive(policy, seed, config, observations=None):
    """Run the environment with the controller ``policy`` computing every step's actions and
    messages from the swarm the environment exposes; each robot's poses while it moves (as
    run_episode samples them: its pose at departure, then after every step it drove), how it
    ended, and the environment."""
    env = SwarmNavEnv(WORLD, config=config, observations=observations)
    env.reset(seed=seed, options={"controller": policy})
    paths = [[pose.copy()] for pose in env.core.swarm.poses]
    ended: dict[int, tuple[bool, bool]] = {}
    while env.agents:
        moving = [i for i, s in enumerate(env.statuses()) if s == Status.MOVING]
        commands, outgoing = env.controller.step(env.core.swarm)
        _, _, term, trunc, info = env.step(
            {a: commands[env.index(a)] for a in env.agents},
            messages={env.possible_agents[i]: m for i, m in outgoing.items()})
        for agent, item in info.items():
            i = env.index(agent)
            if i in moving:
                paths[i].append(item["pose"])
            if term[agent] or trunc[agent]:
                ended[i] = (item["arrived"], item["collided"])
    return [np.array(p) for p in paths], ended, env


@pytest.mark.parametrize(("policy", "departure", "loss"), [
    ("bug-left", "together", 0.0),  # the Bug planner with a decision policy; a time-out
    ("fusion", "staggered", 0.3),  # messages through a lossy channel, robots departing apart
    ("random", "waves", 0.0),  # the episode's generator drawn by the policy
    ("vfh", "together", 0.0),  # a registered controller
    (f"{__name__}:Headlong", "together", 0.2),  # a plugin controller that collides
])
def test_the_environment_driven_by_a_controller_is_its_episode(policy, departure, loss):
    config = _config(departure, loss)
    episode = run_episode(WORLD, policy, seed=3, config=config)
    paths, ended, env = _drive(policy, 3, config)
    assert len(paths) == len(episode.trajectories) == 4
    for mine, theirs in zip(paths, episode.trajectories, strict=True):
        assert mine.shape == theirs.shape and np.array_equal(mine, theirs)
    assert ended == {row.robot: (row.arrived, row.collided) for row in episode.rows}
    for row in episode.rows:
        assert (row.bytes_sent, row.messages_sent) == (
            env.core.channel.bytes_sent[row.robot], env.core.channel.messages_sent[row.robot])
        counters = env.controller.counters(row.robot)
        assert {k: getattr(row, k) for k in counters} == counters
    env.close()


def test_the_episodes_compared_are_not_trivial():
    """The world above gives arrivals, time-outs, collisions, decisions and messages."""
    config = _config(loss=0.3)
    rows = {policy: run_episode(WORLD, policy, seed=3, config=config).rows
            for policy in ("bug-left", "fusion", f"{__name__}:Headlong")}
    left, fusion, headlong = rows.values()
    assert [(r.arrived, r.collided) for r in left] == [(True, False), (False, False),
                                                       (True, False), (True, False)]
    assert sum(r.decisions_left + r.decisions_right for r in fusion) >= 2
    assert sum(r.messages_sent for r in fusion) > 0
    assert [(r.arrived, r.collided) for r in headlong] == [(False, True), (False, True),
                                                           (True, False), (False, True)]


def test_a_different_seed_gives_a_different_episode():
    """The comparison can fail: with sensor noise, another seed drives other paths."""
    config = _config().replace({"sensor.noise_std_m": 0.02})
    episode = run_episode(WORLD, "fusion", seed=3, config=config)
    paths, _, env = _drive("fusion", 4, config)
    env.close()
    assert not all(np.array_equal(a, b) for a, b in zip(paths, episode.trajectories,
                                                        strict=True))


def test_its_own_messages_and_observations_do_not_change_the_episode():
    """Observing the safe mask and neighbours' messages (the environment's own broadcasts,
    replaced by the controller's) leaves the controller's episode as it was."""
    config = _config(loss=0.3)
    episode = run_episode(WORLD, "fusion", seed=5, config=config)
    paths, _, env = _drive("fusion", 5, config, Observations(safe_mask=True, max_neighbours=3))
    env.close()
    for mine, theirs in zip(paths, episode.trajectories, strict=True):
        assert np.array_equal(mine, theirs)


def test_with_odometry_the_environment_is_its_episode_and_observes_the_estimates():
    """In odometry mode too the environment driven by a controller is run_episode (the true
    paths, bit for bit; lost robots end the same way), and an agent's ``goal`` observation is
    its goal seen from its estimate, not from its true pose."""
    config = _config().replace({"localization.mode": "odometry", "localization.drift": "high"})
    episode = run_episode(WORLD, "collab", seed=3, config=config)
    paths, ended, env = _drive("collab", 3, config)
    for mine, theirs in zip(paths, episode.trajectories, strict=True):
        assert np.array_equal(mine, theirs)
    assert ended == {row.robot: (row.arrived, row.collided) for row in episode.rows}
    env.reset(seed=3, options={"controller": "collab"})
    for _ in range(30):
        commands, outgoing = env.controller.step(env.core.swarm)
        obs, *_ = env.step({a: commands[env.index(a)] for a in env.agents})
    core = env.core
    for agent, o in obs.items():
        i = env.index(agent)
        est, true = core.localizer.estimates[i], core.obs.poses[i]
        assert not np.allclose(est, true)
        d = core.goals[i] - est[:2]
        c, s = np.cos(est[2]), np.sin(est[2])
        assert np.allclose(o["goal"], [c * d[0] + s * d[1], -s * d[0] + c * d[1]], atol=1e-5)
