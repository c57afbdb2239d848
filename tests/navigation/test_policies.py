import numpy as np
import pytest

from fftnav.navigation.policies import (
    LEFT,
    POLICIES,
    RIGHT,
    DecisionContext,
    get_policy,
    register_policy,
)


def _ctx(p_s=0.5, p=0.5, seed=0):
    return DecisionContext(0, lambda: p_s, lambda: p, np.random.default_rng(seed))


def test_registry_has_the_six_policies():
    assert set(POLICIES) == {"bug-left", "bug-right", "fusion", "own-only", "random", "collab"}
    assert [n for n, p in POLICIES.items() if p.uses_messages] == ["fusion", "collab"]
    assert POLICIES["fusion"].messages == "observation" and not POLICIES["fusion"].reconsiders
    assert POLICIES["collab"].messages == "walls" and not POLICIES["collab"].reconsiders


def test_collab_takes_the_side_of_the_shorter_way_through_its_map_else_its_own_view():
    def ctx(p_s, shared):
        return DecisionContext(0, lambda: p_s, lambda: 0.5, np.random.default_rng(0),
                               lambda: shared)

    collab = get_policy("collab").decide
    assert collab(ctx(0.6, RIGHT)) == RIGHT and collab(ctx(0.4, LEFT)) == LEFT
    assert collab(ctx(0.9, RIGHT)) == RIGHT and collab(ctx(0.1, LEFT)) == LEFT  # the map wins
    assert collab(ctx(0.6, None)) == LEFT and collab(ctx(0.4, None)) == RIGHT  # as own-only
    with pytest.raises(ValueError, match=r"messages must be one of \[None, 'observation', "
                                         r"'walls'\], got messages='gossip'"):
        register_policy("x", messages="gossip")


def test_baselines_ignore_probabilities():
    for p in (0.0, 1.0):
        assert get_policy("bug-left").decide(_ctx(p, p)) == LEFT
        assert get_policy("bug-right").decide(_ctx(p, p)) == RIGHT


def test_own_only_uses_p_s_and_fusion_uses_fused_p():
    assert get_policy("own-only").decide(_ctx(p_s=0.7, p=0.2)) == LEFT
    assert get_policy("own-only").decide(_ctx(p_s=0.3, p=0.9)) == RIGHT
    assert get_policy("fusion").decide(_ctx(p_s=0.7, p=0.2)) == RIGHT
    assert get_policy("fusion").decide(_ctx(p_s=0.3, p=0.9)) == LEFT
    assert get_policy("fusion").decide(_ctx(p=0.5)) == RIGHT  # left iff P > 0.5


def test_random_is_seeded_and_fair():
    ctx = _ctx(seed=3)
    draws = [get_policy("random").decide(ctx) for _ in range(2000)]
    ctx2 = _ctx(seed=3)
    assert draws == [get_policy("random").decide(ctx2) for _ in range(2000)]
    assert abs(np.mean(np.array(draws) == LEFT) - 0.5) < 0.04


def test_unknown_policy_names_the_value():
    with pytest.raises(ValueError, match=r"unknown policy 'bug-up'; known policies: \["):
        get_policy("bug-up")
