"""SwarmNavEnv: PettingZoo's own API and seed tests, rewards, terminations, truncation, render."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

pytest.importorskip("pettingzoo", reason="the optional extra fftnav[marl] is not installed")
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

from fftnav.envs import Observations, Rewards, SwarmNavEnv  # noqa: E402
from fftnav.report.frames import kind_rgb  # noqa: E402
from fftnav.world import Circle, World  # noqa: E402

UP = math.pi / 2


def _small(**kwargs):
    return SwarmNavEnv("forest", map_seed=3, robots=4, **kwargs)


@pytest.mark.filterwarnings("ignore:SwarmNavEnv.reset ignores")
def test_pettingzoo_parallel_api_test():
    env = _small(observations=Observations(safe_mask=True, max_neighbours=2),
                 render_mode="rgb_array")
    parallel_api_test(env, num_cycles=60)
    env.close()


def test_pettingzoo_parallel_seed_test():
    parallel_seed_test(lambda: _small(observations=Observations(max_neighbours=2)))


def _world(obstacles, starts, goals):
    return World("test", 0, (8.0, 10.0), tuple(obstacles), np.array(starts, float),
                 np.array(goals, float))


def test_rewards_terminations_and_truncation_by_hand():
    world = _world([Circle((6.0, 5.0), 0.5, 1.0)],
                   [[2, 1, UP], [6, 3.5, UP], [4, 1, 0.0]], [[2, 3], [6, 9], [4, 9]])
    rewards = Rewards(progress=2.0, arrival=7.0, collision=-5.0, step=-0.01)
    env = SwarmNavEnv(world=world, rewards=rewards)
    obs, _ = env.reset(seed=0, options={"time_limit_s": 5.0})
    assert env.agents == ["robot_0", "robot_1", "robot_2"]
    assert obs["robot_0"]["goal"] == pytest.approx([2.0, 0.0], abs=1e-4)  # 2 m straight ahead
    assert obs["robot_2"]["goal"] == pytest.approx([0.0, 8.0], abs=1e-4)  # facing +x: left
    ahead = np.array([0.5, 0.0], np.float32)  # 5 cm per 0.1 s tick
    done = {}
    for tick in range(1, 51):
        _, rew, term, trunc, info = env.step({a: ahead for a in env.agents})
        if tick == 1:
            assert rew["robot_0"] == pytest.approx(2.0 * 0.05 - 0.01, abs=1e-6)
            assert rew["robot_2"] == pytest.approx(-0.01, abs=1e-3)  # sideways: no progress
        for agent in term:
            if term[agent] or trunc[agent]:
                done[agent] = (tick, term[agent], trunc[agent], info[agent], rew[agent])
    # robot 0: 2 m - 0.3 m success radius at 5 cm per tick -> arrives at tick 34
    tick, term, trunc, info, rew = done["robot_0"]
    assert term and info["arrived"] and tick == 34
    assert rew == pytest.approx(2.0 * 0.05 - 0.01 + 7.0, abs=1e-3)
    # robot 1 drives into the trunk: from y = 3.5 to its edge y = 4.5 minus r0 -> ~ tick 17
    tick, term, trunc, info, rew = done["robot_1"]
    assert term and info["collided"] and 15 <= tick <= 18 and rew < -4.0
    tick, term, trunc, info, rew = done["robot_2"]  # 5 s limit: truncated at tick 50
    assert trunc and not term and tick == 50
    assert env.agents == []
    env.close()


def test_reset_options_and_render():
    env = _small(render_mode="rgb_array")
    env.reset(seed=1, options={"world_kind": "rocky", "map_seed": 5, "robots": 2,
                               "sensor.beams": 180})
    assert env.world.env == "rocky" and env.possible_agents == ["robot_0", "robot_1"]
    assert env.observation_space("robot_0")["scan"].shape == (180,)
    frame = env.render()
    w, h = env.world.size_m  # the map's rows, then the key's
    assert frame.shape[1:] == (round(w / 0.05), 3) and frame.shape[0] > round(h / 0.05)
    assert frame.dtype == np.uint8
    x, y = env.world.starts[0, :2]  # a robot is drawn "moving" at its start (first row = top)
    assert tuple(frame[int((h - y) / 0.05), int(x / 0.05)]) == kind_rgb("moving")
    with pytest.raises(ValueError, match=r"sensor\.range_m must be a finite number in \(0, 1000\], got sensor\.range_m=-1"):
        env.reset(seed=1, options={"sensor.range_m": -1})
    env.close()


def test_render_draws_states_trails_and_crosses_like_a_replay():
    """Robot 0 arrives at y = 2.7 (tick 34), robot 1 hits the trunk at y ~ 4.35, robot 2 drives
    along +x from (4, 1) and is truncated at 5 s (x ~ 6.5): arrived green, failed red, a trail."""
    world = _world([Circle((6.0, 5.0), 0.5, 1.0)],
                   [[2, 1, UP], [6, 3.5, UP], [4, 1, 0.0]], [[2, 3], [6, 9], [4, 9]])
    env = SwarmNavEnv(world=world, render_mode="rgb_array")
    env.reset(seed=0, options={"time_limit_s": 5.0})
    while env.agents:
        env.step({a: np.array([0.5, 0.0], np.float32) for a in env.agents})
    frame = env.render()
    h = world.size_m[1]

    def pixel(x, y):
        return tuple(frame[int((h - y) / 0.05), int(x / 0.05)])

    assert pixel(2.0, 2.7) == kind_rgb("arrived")
    column = {tuple(frame[int((h - y) / 0.05), int(6.0 / 0.05)]) for y in np.arange(4.1, 4.6, 0.05)}
    assert kind_rgb("failed") in column  # robot 1's disc and cross below the trunk
    assert pixel(6.5, 1.0) == kind_rgb("failed")  # robot 2 where it was truncated
    r, g, b = (int(c) for c in pixel(5.0, 1.0))  # its trail, half-transparent red
    assert r > g + 40 and r > b + 40
    rows = round(h / 0.05)  # the map (the key below it shows every colour)
    assert not (frame[:rows] == kind_rgb("moving")).all(axis=-1).any()  # nobody drives
    env.close()


def test_collisions_need_not_terminate():
    world = _world([Circle((6.0, 5.0), 0.5, 1.0)], [[6, 3.5, UP]], [[6, 9]])
    env = SwarmNavEnv(world=world, rewards=Rewards(progress=0.0, collision=-1.0),
                      terminate_on_collision=False)
    env.reset(seed=0, options={"time_limit_s": 3.0})
    hits = []
    for _ in range(30):
        _, rew, term, trunc, info = env.step({"robot_0": np.array([0.5, 0.0], np.float32)})
        hits.append(info["robot_0"]["collided"])
        assert rew["robot_0"] == (-1.0 if hits[-1] else 0.0) and not term["robot_0"]
    assert sum(hits) >= 5 and trunc["robot_0"]  # pressed against the trunk until the limit
    env.close()


@pytest.mark.parametrize(("make", "match"), [
    (lambda: Rewards(progress=math.nan), r"progress must be a finite number, got progress=nan"),
    (lambda: Rewards(step="1"), r"step must be a finite number, got step='1'"),
    (lambda: SwarmNavEnv(render_mode="human"),
     r"render_mode must be one of \[None, 'rgb_array'\], got render_mode='human'"),
    (lambda: SwarmNavEnv(None), r"world must be a world kind \(str\) or a World, got world=None"),
    (lambda: Observations(max_neighbours=-1),
     r"max_neighbours must be an integer >= 0, got max_neighbours=-1"),
])
def test_bad_parameters_are_refused_naming_them(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_rewards_are_floats_and_a_step_names_an_unknown_agent():
    assert Rewards(arrival=7) == Rewards(arrival=7.0)
    assert isinstance(Rewards(arrival=7).arrival, float)
    env = _small()
    env.reset(seed=1)
    with pytest.raises(ValueError, match=r"agent must be one of \['robot_0', .*\], "
                                         r"got agent='robot_9'"):
        env.step({"robot_9": [0.0, 0.0]})
    env.close()


@pytest.mark.parametrize(("actions", "match"), [
    ([[0.1, 0.0]] * 4, r"actions must be a dict mapping each agent to an array \(v_mps, "
                       r"w_radps\) of shape \(2,\), got list"),
    ({"robot_2": [math.nan, 0.0]}, r"actions\['robot_2'\] must be finite, got \[nan, 0\.0\]"),
    ({"robot_1": np.array([0.1, -np.inf])},
     r"actions\['robot_1'\] must be finite, got \[0\.1, -inf\]"),
    ({"robot_0": [[0.1], [0.0]]}, r"actions\['robot_0'\] must be an array \(v_mps, w_radps\) "
                                  r"of shape \(2,\), got shape \(2, 1\)"),
    ({"robot_3": [0.1, 0.0, 0.0]}, r"actions\['robot_3'\] .* got shape \(3,\)"),
    ({"robot_0": 0.1}, r"actions\['robot_0'\] .* got shape \(\)"),
    ({"robot_0": {"v": 0.1}}, r"actions\['robot_0'\] .* got no number array: \{'v': 0\.1\}"),
    ({"robot_0": np.array([0.1 + 1j, 0.0])},
     r"actions\['robot_0'\] must be real numbers \(v_mps, w_radps\), got complex values"),
    ({"robot_1": [0.1, 0.0], "robot_2": [0.1 + 0j, 0.0]},
     r"actions\['robot_2'\] must be real numbers .* got complex values: \[\(0\.1\+0j\), 0\.0\]"),
    ({"robot_0": [True, False]}, r"actions\['robot_0'\] .* got no number array: \[True, False\]"),
    ({"robot_0": ["0.1", "0"]}, r"actions\['robot_0'\] .* got no number array"),
])
def test_bad_actions_are_refused_naming_the_agent(actions, match):
    env = _small()
    env.reset(seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # refused, not cast with numpy's ComplexWarning
        with pytest.raises(ValueError, match=match):
            env.step(actions)
    env.close()


def test_finite_actions_outside_the_box_are_clipped_to_it():
    """1e9 m/s and -1e9 rad/s drive exactly as the Box's limits do."""
    poses = []
    for v, w in ((1e9, -1e9), (0.5, -1.5)):
        env = _small()
        env.reset(seed=1)
        high = env.action_space("robot_0").high
        assert high.tolist() == [0.5, 1.5]
        for _ in range(3):
            obs = env.step({a: np.array([v, w]) for a in env.agents})[0]
        poses.append([obs[a]["goal"] for a in sorted(obs)])  # the goal in each robot's frame
        env.close()
    assert np.array_equal(poses[0], poses[1]) and len(poses[0]) == 4
