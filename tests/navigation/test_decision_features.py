"""The decision-v1 features element by element on constructed decisions, and the learned decider
that reads them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.navigation.decision_features import N_FEATURES, decision_features, feature_names
from fftnav.navigation.learned_decider import (
    learned_decider_policy,
    untrained_decider,
)
from fftnav.navigation.mlp import MLP
from fftnav.navigation.policies import (
    LEFT,
    POLICIES,
    RIGHT,
    DecisionContext,
    DecisionObservation,
)

SQ = math.sqrt(0.5)


def _obs(*, p_s=0.6, sigma=((0.0, 2.0),), p=(), rel=(), range_m=4.0, comm_range_m=5.0):
    return DecisionObservation(p_s, np.array(sigma, float).reshape(-1, 2), np.array(p, float),
                               np.array(rel, float).reshape(-1, 3), range_m, comm_range_m)


def test_length_and_names():
    names = feature_names()
    assert len(names) == N_FEATURES == 1 + 4 * 5 + 8 * 4 == 53
    assert names[0] == "p_s" and names[1:6] == ["n0_present", "n0_p", "n0_dist", "n0_cos",
                                                "n0_sin"]
    assert names[16:21] == ["n3_present", "n3_p", "n3_dist", "n3_cos", "n3_sin"]
    assert names[21:25] == ["e0_present", "e0_dist", "e0_cos", "e0_sin"]
    assert names[-1] == "e7_sin"


def test_neighbours_nearest_four_by_distance_with_bearing():
    # five senders at distances 5, 1, 3, 2 (x2: a tie kept in inbox order) ... by hand:
    rel = [(0.0, -5.0, 0.0),   # 5 m, bearing -90 deg: dropped (the farthest)
           (1.0, 0.0, 1.0),    # 1 m ahead
           (-3.0, 0.0, 0.0),   # 3 m behind
           (1.0, 1.0, 0.0),    # sqrt 2 m, bearing 45 deg
           (-1.0, -1.0, 0.0)]  # sqrt 2 m, bearing -135 deg (tie with the one before: after it)
    f = decision_features(_obs(p_s=0.25, p=[0.1, 0.2, 0.3, 0.4, 0.5], rel=rel,
                               comm_range_m=4.0))
    assert f[0] == 0.25
    slots = f[1:21].reshape(4, 5)
    expected = [[1, 0.2, 1 / 4, 1.0, 0.0],
                [1, 0.4, math.sqrt(2) / 4, SQ, SQ],
                [1, 0.5, math.sqrt(2) / 4, -SQ, -SQ],
                [1, 0.3, 3 / 4, -1.0, 0.0]]
    np.testing.assert_allclose(slots, expected, atol=1e-12)


def test_empty_neighbour_slots_are_zeros_and_far_senders_clipped():
    f = decision_features(_obs(p=[0.9], rel=[(0.0, 12.0, 0.0)], comm_range_m=5.0))
    np.testing.assert_allclose(f[1:6], [1, 0.9, 2.0, 0.0, 1.0], atol=1e-12)  # 12/5 -> 2
    assert not f[6:21].any()


def test_extrema_eight_nearest_the_goal_direction_by_angle():
    angles = [-3.0, -2.0, -1.5, -0.5, -0.2, 0.0, 0.3, 0.5, 1.0, 2.5]
    dists = [1.0, 2.0, 3.0, 4.0, 1.0, 2.0, 3.0, 4.0, 2.0, 1.0]
    f = decision_features(_obs(sigma=list(zip(angles, dists, strict=True)), range_m=4.0))
    slots = f[21:].reshape(8, 4)
    # |angle| order: 0, .2, .3, .5 (-0.5 before 0.5), .5, 1, 1.5, 2 -> drops -3.0 and 2.5
    kept = [-2.0, -1.5, -0.5, -0.2, 0.0, 0.3, 0.5, 1.0]
    kept_d = [2.0, 3.0, 4.0, 1.0, 2.0, 3.0, 4.0, 2.0]
    expected = [[1, d / 4.0, math.cos(a), math.sin(a)] for a, d in zip(kept, kept_d, strict=True)]
    np.testing.assert_allclose(slots, expected, atol=1e-12)


def test_few_extrema_leave_zero_slots():
    f = decision_features(_obs(sigma=[(math.pi / 2, 1.0), (-math.pi / 2, 3.0)], range_m=2.0))
    np.testing.assert_allclose(f[21:29], [1, 1.5, 0, -1, 1, 0.5, 0, 1], atol=1e-12)
    assert not f[29:].any() and not f[1:21].any()


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match=r"obs must be a DecisionObservation, got obs=3"):
        decision_features(3)
    with pytest.raises(ValueError, match=r"p_neighbours must have one value per row of "
                                         r"rel_poses \(1\), got p_neighbours=\[0.1, 0.2\]"):
        decision_features(_obs(p=[0.1, 0.2], rel=[(1.0, 0.0, 0.0)]))


def test_existing_policies_do_not_need_the_observation():
    ctx = DecisionContext(0, lambda: 0.7, lambda: 0.2, np.random.default_rng(0))
    assert ctx.observation() is None
    assert POLICIES["own-only"].decide(ctx) == LEFT
    assert POLICIES["fusion"].decide(ctx) == RIGHT


# -- the learned decider ---------------------------------------------------------------------

def _ps_net(scale=10.0, meta=None):
    """A decider whose logit is scale * (P_s - 0.5): own-only's rule."""
    w = np.zeros((N_FEATURES, 1))
    w[0, 0] = scale
    return MLP(weights=[w], biases=[np.array([-scale / 2])],
               meta=meta or {"kind": "decider", "observation": "decision-v1", "version": 1})


def _ctx(p_s):
    obs = _obs(p_s=p_s)
    return DecisionContext(0, lambda: p_s, lambda: p_s, np.random.default_rng(0),
                           observation=lambda: obs)


def test_learned_decider_left_iff_logit_positive(tmp_path):
    path = _ps_net().save(tmp_path / "d.npz")
    policy = learned_decider_policy(path)
    assert policy.name == "learned-decider-d"
    assert policy.messages is not None  # it broadcasts, as fusion does
    assert [policy.decide(_ctx(p)) for p in (0.2, 0.49, 0.5, 0.51, 0.9)] == [
        RIGHT, RIGHT, RIGHT, LEFT, LEFT]


def test_learned_decider_normalises_by_its_meta(tmp_path):
    # (P_s - 0.8) / 0.1 with weight 1 and bias 0: left iff P_s > 0.8
    mean, std = [0.8] + [0.0] * (N_FEATURES - 1), [0.1] + [1.0] * (N_FEATURES - 1)
    net = _ps_net(1.0, meta={"kind": "decider", "observation": "decision-v1", "version": 1,
                             "mean": mean, "std": std})
    net = MLP(weights=list(net.weights), biases=[np.zeros(1)], meta=net.meta)
    policy = learned_decider_policy(net.save(tmp_path / "n.npz"))
    assert [policy.decide(_ctx(p)) for p in (0.7, 0.79, 0.81)] == [RIGHT, RIGHT, LEFT]


def test_learned_decider_refuses_other_networks(tmp_path):
    controller = _ps_net(meta={"kind": "controller", "observation": "decision-v1", "version": 1})
    with pytest.raises(ValueError, match=r"c.npz: meta\['kind'\] must be 'decider', got "
                                         r"kind='controller'"):
        learned_decider_policy(controller.save(tmp_path / "c.npz"))
    other = _ps_net(meta={"kind": "decider", "observation": "raw", "version": 1})
    with pytest.raises(ValueError, match=r"meta\['observation'\] must be 'decision-v1', got "
                                         r"observation='raw'"):
        learned_decider_policy(other.save(tmp_path / "o.npz"))
    small = MLP(weights=[np.ones((3, 1))], biases=[np.zeros(1)],
                meta={"kind": "decider", "observation": "decision-v1", "version": 1})
    with pytest.raises(ValueError, match=r"must map 53 inputs to 1 output .*sizes=\(3, 1\)"):
        learned_decider_policy(small.save(tmp_path / "s.npz"))
    bad_std = _ps_net(meta={"kind": "decider", "observation": "decision-v1", "version": 1,
                            "std": [0.0] * N_FEATURES})
    with pytest.raises(ValueError, match=r"meta\['std'\] must be > 0"):
        learned_decider_policy(bad_std.save(tmp_path / "b.npz"))


def test_untrained_decider_is_seeded():
    a, b, c = untrained_decider(1), untrained_decider(1), untrained_decider(2)
    assert a == b and a != c
    assert a.sizes == (53, 64, 64, 1) and untrained_decider(0, hidden=(8,)).sizes == (53, 8, 1)
    assert a.meta == {"kind": "decider", "observation": "decision-v1", "version": 1}
    # N(0, 1/n_in): the first layer's spread is about 1/sqrt(53)
    assert np.std(a.weights[0]) == pytest.approx(1 / math.sqrt(53), rel=0.05)
    with pytest.raises(ValueError, match=r"seed"):
        untrained_decider(-1)


def test_learned_decider_runs_an_episode_as_own_only(tmp_path):
    """A network with own-only's rule drives like own-only (its robots also broadcast)."""
    from fftnav.config import EpisodeConfig, SwarmConfig
    from fftnav.episode import run_episode
    from fftnav.world import Circle, Polygon, World

    up = math.pi / 2
    world = World("test", 0, (8.0, 8.0),  # each robot meets an obstacle across its way
                  (Polygon(((0.6, 3.8), (2.2, 3.8), (2.2, 4.1), (0.6, 4.1)), 1.0),
                   Polygon(((3.3, 3.0), (4.9, 3.0), (4.9, 3.3), (3.3, 3.3)), 1.0),
                   Circle((6.3, 4.5), 0.5, 1.0)),
                  np.array([[1.5, 1.0, up], [4.0, 1.0, up], [6.6, 1.0, up]]),
                  np.array([[1.7, 7.0], [4.2, 7.0], [6.5, 7.0]]))
    net_path = _ps_net().save(tmp_path / "d.npz")
    plugin = tmp_path / "plugin.py"
    plugin.write_text("from fftnav.navigation.learned_decider import learned_decider_policy\n"
                      f"decider = learned_decider_policy({str(net_path)!r})\n"
                      "decider = decider.__class__('net', decider.decide, decider.messages, "
                      "decider.description)\n")
    config = SwarmConfig(episode=EpisodeConfig(time_limit_s=30.0))
    learned = run_episode(world, f"{plugin}:decider", seed=1, config=config).rows
    own = run_episode(world, "own-only", seed=1, config=config).rows
    assert [r.path_length_m for r in learned] == [r.path_length_m for r in own]
    assert [(r.decisions_left, r.decisions_right) for r in learned] == [
        (r.decisions_left, r.decisions_right) for r in own]
    assert sum(r.messages_sent for r in learned) > 0 == sum(r.messages_sent for r in own)
