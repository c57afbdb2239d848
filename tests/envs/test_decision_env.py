"""DecisionEnv: each Bug decision one step; its episode is run_episode's, bit for bit, for the same
choices; Gymnasium's API check, seeding, rewards, close and reset, bad actions."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

pytest.importorskip("pettingzoo", reason="the optional extra fftnav[marl] is not installed")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from fftnav.config import EpisodeConfig, SwarmConfig  # noqa: E402
from fftnav.envs import DecisionEnv  # noqa: E402
from fftnav.episode import run_episode  # noqa: E402
from fftnav.episode.record import episode_csv  # noqa: E402
from fftnav.metrics import path_length_m  # noqa: E402
from fftnav.observe.fusion import fuse, neighbour_sides  # noqa: E402
from fftnav.world import Circle, Polygon, World  # noqa: E402

UP = math.pi / 2


def _box(x0, x1, y0, y1):
    return Polygon(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), 1.0)


# Three robots driving up an 8 m square, each with an obstacle across its way: each decides once.
WORLD = World("test", 0, (8.0, 8.0),
              (_box(0.6, 2.2, 3.8, 4.1), _box(3.3, 4.9, 3.0, 3.3), Circle((6.3, 4.5), 0.5, 1.0)),
              np.array([[1.5, 1.0, UP], [4.0, 1.0, UP], [6.6, 1.0, UP]]),
              np.array([[1.7, 7.0], [4.2, 7.0], [6.5, 7.0]]))
CONFIG = SwarmConfig(episode=EpisodeConfig(time_limit_s=30.0))


def _play(env, choose, *, seed=0, episode_seed=1):
    """Run one episode choosing each action with ``choose(obs, info)``; the infos, rewards."""
    obs, info = env.reset(seed=seed, options={"episode_seed": episode_seed})
    infos, rewards = [info], []
    while True:
        obs, reward, terminated, truncated, info = env.step(choose(obs, info))
        assert not truncated
        rewards.append(reward)
        infos.append(info)
        if terminated:
            return infos, rewards


@pytest.mark.parametrize(("choose", "policy"), [
    (lambda obs, info: int(info["p_s"] > 0.5), "own-only"),
    (lambda obs, info: 1, "bug-left"),
    (lambda obs, info: 0, "bug-right"),
])
def test_rows_equal_run_episode_for_the_same_choices(choose, policy):
    env = DecisionEnv(WORLD, config=CONFIG, messages=None)
    try:
        infos, _ = _play(env, choose)
        rows = env.episode_rows()
    finally:
        env.close()
    assert len(infos) == 4  # three decisions, then the end
    expected = run_episode(WORLD, policy, seed=1, config=CONFIG).rows
    assert episode_csv(rows) == episode_csv(expected).replace(policy, "decision-env")


def test_left_and_right_lead_to_different_episodes():
    paths = []
    for action in (0, 1):
        env = DecisionEnv(WORLD, config=CONFIG, messages=None)
        _play(env, lambda obs, info, a=action: a)
        paths.append([row.path_length_m for row in env.episode_rows()])
        env.close()
    assert paths[0] != paths[1]


def test_rewards_are_minus_the_path_after_each_decision_plus_the_bonus():
    env = DecisionEnv(WORLD, config=CONFIG, messages=None, arrival_bonus_m=5.0)
    try:
        infos, rewards = _play(env, lambda obs, info: 1)
        core = env.core
        trajectories = core.trajectories()
        rows = env.episode_rows()
    finally:
        env.close()
    closed = [c for info in infos for c in info["closed"]]
    # each step's reward is the sum of what it closed; every decision closed once
    assert rewards == pytest.approx([sum(r for *_, r in info["closed"]) for info in infos[1:]])
    assert sorted(d for d, _, _ in closed) == [0, 1, 2]
    for decision, robot, reward in closed:
        info = infos[decision]
        assert info["robot"] == robot
        # the robot's path from its decision's tick on (its trajectory starts at tick 0)
        after = path_length_m(trajectories[robot][info["tick"]:, :2])
        assert rows[robot].arrived
        assert reward == pytest.approx(-after + 5.0, abs=1e-9)


def test_features_match_the_fused_probability_of_fusion():
    """With messages, the neighbour slots give back fusion's P: P_i of the senders beside the
    robot, within range, fused by eq. (P)."""
    env = DecisionEnv(WORLD, config=CONFIG)
    obs, info = env.reset(seed=0, options={"episode_seed": 1})
    seen = 0
    try:
        while True:
            decider = env.core.controller.decider
            f = obs.astype(np.float64)
            slots = f[1:21].reshape(4, 5)
            present = slots[:, 0] == 1.0
            dist = slots[present, 2] * CONFIG.comms.comm_range_m
            xy = np.stack([dist * slots[present, 3], dist * slots[present, 4]], axis=1)
            sides = neighbour_sides(xy, r_m=CONFIG.geometry.r_m,
                                    max_range_m=CONFIG.comms.comm_range_m)
            p_i = slots[present, 1]
            expected = fuse(info["p_s"], p_i[sides > 0], p_i[sides < 0])
            assert decider.fused_probability(info["robot"]) == pytest.approx(expected, abs=1e-6)
            seen += int(present.any())
            obs, _, terminated, _, info = env.step(1)
            if terminated:
                break
    finally:
        env.close()
    assert seen >= 1  # some decision had a neighbour's message


def test_gymnasium_api_check():
    env = DecisionEnv(WORLD, config=CONFIG)
    try:
        check_env(env, skip_render_check=True)
    finally:
        env.close()


def test_same_seed_same_sequence_and_another_seed_another_episode():
    def run(seed):
        env = DecisionEnv("forest", map_seeds=(1000, 2000), robots=3, config=CONFIG)
        try:
            obs, info = env.reset(seed=seed)
            seq = [(obs.tobytes(), info["robot"], info["tick"])]
            for _ in range(3):
                obs, reward, terminated, _, info = env.step(int(info.get("p_s", 0) > 0.5))
                seq.append((obs.tobytes(), reward, info.get("robot"), terminated))
                if terminated:
                    break
            return seq, env.world.to_json()
        finally:
            env.close()

    first = run(3)
    assert first == run(3)
    assert first[1] != run(4)[1]  # another map


def _env_threads():
    return [t for t in threading.enumerate() if t.name == "fftnav-decision-env"]


def test_close_and_reset_mid_episode_leave_no_thread():
    before = len(_env_threads())
    env = DecisionEnv(WORLD, config=CONFIG, messages=None)
    first, _ = env.reset(seed=0, options={"episode_seed": 1})
    assert len(_env_threads()) == before + 1
    again, info = env.reset(seed=0, options={"episode_seed": 1})  # abandons the first
    assert len(_env_threads()) == before + 1
    assert np.array_equal(first, again) and info["decision"] == 0
    env.step(1)
    env.close()
    assert len(_env_threads()) == before
    env.close()  # twice is harmless
    with pytest.raises(ValueError, match=r"step\(\) needs a pending decision"):
        env.step(0)


def test_step_after_the_end_is_refused_until_reset():
    env = DecisionEnv(WORLD, config=CONFIG, messages=None)
    try:
        _play(env, lambda obs, info: 0)
        with pytest.raises(ValueError, match=r"call reset\(\) first"):
            env.step(0)
    finally:
        env.close()


@pytest.mark.parametrize("action", [2, -1, 0.5, True, "left", np.array([0, 1])])
def test_bad_actions_are_refused(action):
    env = DecisionEnv(WORLD, config=CONFIG, messages=None)
    try:
        env.reset(seed=0, options={"episode_seed": 1})
        with pytest.raises(ValueError, match=r"action must be 0 \(right\) or 1 \(left\), got action="):
            env.step(action)
        env.step(np.int64(1))  # the pending decision is still there
    finally:
        env.close()


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match=r"messages must be .*got messages='walls'"):
        DecisionEnv(WORLD, messages="walls")
    with pytest.raises(ValueError, match=r"map_seeds\[1\]"):
        DecisionEnv("forest", map_seeds=(5, 5))
    with pytest.raises(ValueError, match=r"failure_penalty_m"):
        DecisionEnv(WORLD, failure_penalty_m=-1.0)
    env = DecisionEnv(WORLD)
    with pytest.raises(ValueError, match=r"options must be among .*\['speed'\]"):
        env.reset(options={"speed": 2})


def test_a_world_without_decisions_is_refused():
    empty = World("empty", 0, (8.0, 8.0), (), np.array([[4.0, 1.0, UP]]), np.array([[4.0, 3.0]]))
    env = DecisionEnv(empty, config=CONFIG)
    with pytest.raises(ValueError, match=r"no robot decided in 1 episode"):
        env.reset(seed=0, options={"episode_seed": 1})
    env.close()
    assert not _env_threads()
