import numpy as np
import pytest

from fftnav.navigation.messages import MESSAGE_KINDS
from fftnav.navigation.policies import (
    LEFT,
    POLICIES,
    RIGHT,
    DecisionContext,
    Policy,
    get_policy,
    register_policy,
)


def _ctx(p_s=0.5, p=0.5, seed=0):
    return DecisionContext(0, lambda: p_s, lambda: p, np.random.default_rng(seed))


def test_registry_has_the_seven_policies():
    assert list(POLICIES) == ["bug-left", "bug-right", "random", "own-only", "fusion", "collab",
                              "collab-reconsider"]
    assert [n for n, p in POLICIES.items() if p.uses_messages] == ["fusion", "collab",
                                                                   "collab-reconsider"]
    assert POLICIES["fusion"].messages is MESSAGE_KINDS["observation"]
    assert not POLICIES["fusion"].reconsiders
    assert POLICIES["collab"].messages is MESSAGE_KINDS["walls"]
    assert not POLICIES["collab"].reconsiders
    assert POLICIES["collab-reconsider"].messages is MESSAGE_KINDS["walls"]
    assert POLICIES["collab-reconsider"].reconsiders
    assert POLICIES["fusion"].description == "Left iff the fused P > 0.5 (the paper's method)."


def test_a_policy_names_its_message_kind():
    policy = Policy("talker", lambda ctx: LEFT, "walls", "")
    assert policy.messages is MESSAGE_KINDS["walls"] and policy.uses_messages
    assert Policy("quiet", lambda ctx: LEFT, None, "").messages is None
    with pytest.raises(ValueError, match=r"messages must be a registered message kind "
                                         r"\('observation', 'walls'\), got messages='wals'; "
                                         r"did you mean 'walls'\?"):
        Policy("typo", lambda ctx: LEFT, "wals", "")


def test_a_policy_name_is_registered_once():
    with pytest.raises(ValueError, match="policy 'fusion' is already registered"):
        register_policy("fusion")(lambda ctx: LEFT)


def test_collab_takes_the_side_of_the_shorter_way_through_its_map_else_its_own_view():
    def ctx(p_s, shared):
        return DecisionContext(0, lambda: p_s, lambda: 0.5, np.random.default_rng(0),
                               lambda: shared)

    collab = get_policy("collab").decide
    assert collab(ctx(0.6, RIGHT)) == RIGHT and collab(ctx(0.4, LEFT)) == LEFT
    assert collab(ctx(0.9, RIGHT)) == RIGHT and collab(ctx(0.1, LEFT)) == LEFT  # the map wins
    assert collab(ctx(0.6, None)) == LEFT and collab(ctx(0.4, None)) == RIGHT  # as own-only
    again = get_policy("collab-reconsider").decide
    assert again(ctx(0.9, RIGHT)) == RIGHT and again(ctx(0.6, None)) == LEFT  # collab's rule
    with pytest.raises(ValueError, match=r"messages must be a registered message kind "
                                         r"\('observation', 'walls'\), got messages='gossip'"):
        register_policy("x", messages="gossip")
    assert "x" not in POLICIES


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
    with pytest.raises(ValueError, match=r"policy must be a registered policy \('bug-left', "
                                         r".*\), got policy='bug-up'$"):
        get_policy("bug-up")
