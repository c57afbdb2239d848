"""Summary tables: bootstrap intervals and paired tests against hand-computed cases."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from fftnav.runner import bootstrap_ratio_ci, paired_tests, summarize
from fftnav.runner.summary import holm, in_order


def test_bootstrap_two_maps_hand_computed():
    # per-map means 0 and 1: resampled means are 0, 0.5, 1 with probability 1/4, 1/2, 1/4, so
    # the 2.5% and 97.5% percentiles are 0 and 1
    assert bootstrap_ratio_ci([0.0, 3.0], [3.0, 3.0]) == (0.0, 1.0)


def test_bootstrap_is_of_the_pooled_ratio_not_the_mean_of_ratios():
    den = np.array([1.0, 5.0, 20.0, 3.0])
    assert bootstrap_ratio_ci(0.25 * den, den) == pytest.approx((0.25, 0.25))


def test_bootstrap_matches_normal_theory_for_many_maps():
    rng = np.random.default_rng(3)
    x = rng.normal(0.8, 0.1, size=400)
    low, high = bootstrap_ratio_ci(x, np.ones_like(x), n_resamples=4000, seed=1)
    half = 1.96 * x.std() / np.sqrt(x.size)
    assert (low + high) / 2 == pytest.approx(x.mean(), abs=0.1 * half)
    assert (high - low) / 2 == pytest.approx(half, rel=0.1)
    assert bootstrap_ratio_ci(x, np.ones_like(x), seed=1) == bootstrap_ratio_ci(
        x, np.ones_like(x), seed=1)


def test_bootstrap_one_map_has_no_interval_and_bad_options_are_refused():
    assert np.isnan(bootstrap_ratio_ci([1.0], [2.0])).all()
    with pytest.raises(ValueError, match=r"confidence must be a finite number in \(0, 1\), got confidence=1\.0"):
        bootstrap_ratio_ci([1.0, 2.0], [1.0, 1.0], confidence=1.0)
    with pytest.raises(ValueError, match=r"n_resamples must be an integer >= 1, got n_resamples=0"):
        bootstrap_ratio_ci([1.0, 2.0], [1.0, 1.0], n_resamples=0)
    with pytest.raises(ValueError, match=r"numerators and denominators must be 1-D"):
        bootstrap_ratio_ci([1.0, 2.0], [1.0])


def episodes(rows):
    cols = ["env", "map_seed", "policy", "robot", "arrived", "collided", "path_length_m",
            "optimal_length_m", "spl", "bytes_sent", "messages_sent"]
    frame = pd.DataFrame(rows, columns=cols)
    return frame.assign(geodesic_length_m=8.5, decisions_left=1, decisions_right=1,
                        decisions_with_neighbours=1,
                        decisions_flipped_by_neighbours=[1] + [0] * (len(frame) - 1),
                        time_s=np.where(frame.arrived, frame.path_length_m / 0.5, np.nan),
                        robot_contacts=[2] + [0] * (len(frame) - 1))


def test_summary_metrics_hand_computed():
    df = episodes([
        ("forest", 1, "fusion", 0, True, False, 10.0, 9.0, 0.9, 100, 2),
        ("forest", 1, "fusion", 1, False, True, 99.0, 9.0, 0.0, 300, 4),
        ("forest", 2, "fusion", 0, True, False, 12.0, 9.0, 0.75, 0, 0),
        ("forest", 2, "fusion", 1, True, False, 14.0, 9.0, 9 / 14, 0, 0),
        ("forest", 1, "random", 0, False, False, 5.0, 9.0, 0.0, 0, 0),
    ])
    s = summarize(df).set_index("policy")
    f = s.loc["fusion"]
    assert (f.env, f.episodes, f.robots) == ("forest", 2, 4)
    assert f.ar == pytest.approx(0.75) and f.apl_m == pytest.approx(12.0)
    assert f.spl == pytest.approx((0.9 + 0 + 0.75 + 9 / 14) / 4)
    assert f.spl_geodesic == pytest.approx((8.5 / 10 + 0 + 8.5 / 12 + 8.5 / 14) / 4)
    assert f.collision_rate == pytest.approx(0.25)
    assert f.decisions_per_robot == 2 and f.share_with_neighbours == pytest.approx(0.5)
    assert f.share_flipped_by_neighbours == pytest.approx(0.25)
    assert f.bytes_per_robot == pytest.approx(100) and f.messages_per_robot == pytest.approx(1.5)
    assert f.time_to_goal_s == pytest.approx(24.0) and f.robot_contacts_per_robot == 0.5
    # maps: SPL 0.45 and (0.75 + 9/14)/2 -> the interval spans exactly these two (two maps)
    assert (f.spl_ci_low, f.spl_ci_high) == pytest.approx((0.45, (0.75 + 9 / 14) / 2))
    r = s.loc["random"]
    assert r.ar == 0 and np.isnan(r.apl_m) and np.isnan(r.spl_ci_low)  # one map: no interval


def test_paired_tests_align_maps_not_rows():
    rng = np.random.default_rng(0)
    baseline = rng.uniform(0.2, 0.9, size=7)  # per-map SPL, very different across maps
    rows = []
    for i, b in enumerate(baseline):
        for robot, jitter in enumerate((-0.05, 0.05)):  # per-map mean = b
            rows.append(("rocky", 100 + i, "bug-left", robot, True, False, 1.0, 1.0, b + jitter,
                         0, 0))
            if i != 3:  # map 103 has no fusion result: it must be left out of the pairing
                rows.append(("rocky", 100 + i, "fusion", robot, True, False, 1.0, 1.0,
                             b + 0.1 + jitter, 0, 0))
    df = episodes(rows).sample(frac=1.0, random_state=1)  # completion order is arbitrary
    test = paired_tests(df).iloc[0]
    assert (test.env, test.reference, test.policy, test.maps) == ("rocky", "fusion", "bug-left", 6)
    assert test.median_diff == pytest.approx(0.1)
    # all six differences positive: W- = 0 and the exact two-sided p-value is 2 / 2**6
    assert test.statistic == 0 and test.p_value == pytest.approx(2 / 2**6)
    assert test.p_method == "exact"
    assert test.spl_reference - test.spl_policy == pytest.approx(0.1)


def test_paired_tests_without_reference_or_differences():
    df = episodes([("forest", m, p, 0, True, False, 1.0, 1.0, 0.5, 0, 0)
                   for m in (1, 2) for p in ("bug-left", "fusion")])
    equal = paired_tests(df).iloc[0]
    assert equal.maps == 2 and equal.median_diff == 0 and np.isnan(equal.p_value)
    assert equal.p_method == ""
    assert paired_tests(df[df.policy != "fusion"]).empty


def test_rows_keep_the_given_env_and_policy_order_and_their_values():
    policies = ("own-only", "mine", "bug-left", "fusion")
    df = episodes([(env, m, p, 0, True, False, 10.0, 9.0, 0.1 * (1 + i) + 0.01 * m, 0, 0)
                   for env in ("forest", "rocky") for m in (1, 2)
                   for i, p in enumerate(policies)]).sample(frac=1.0, random_state=2)
    ordered = summarize(df, envs=["rocky", "forest"], policies=policies, n_resamples=10)
    assert list(zip(ordered.env, ordered.policy, strict=True)) == [
        (env, p) for env in ("rocky", "forest") for p in policies]
    alphabetical = summarize(df, n_resamples=10)
    assert list(zip(alphabetical.env, alphabetical.policy, strict=True)) == [
        (env, p) for env in ("forest", "rocky") for p in sorted(policies)]
    key = ["env", "policy"]  # the same rows, only their order differs
    pd.testing.assert_frame_equal(ordered.sort_values(key, ignore_index=True),
                                  alphabetical.sort_values(key, ignore_index=True))
    tests = paired_tests(df, envs=["rocky", "forest"], policies=policies)
    assert list(zip(tests.env, tests.policy, strict=True)) == [
        (env, p) for env in ("rocky", "forest") for p in ("own-only", "mine", "bug-left")]
    assert list(paired_tests(df).policy[:3]) == ["bug-left", "mine", "own-only"]


def test_names_missing_from_the_order_come_last_sorted():
    assert in_order(["b", "z", "a", "c"], ["c", "x", "a"]) == ["c", "a", "b", "z"]
    assert in_order(["b", "a", "b"], None) == ["a", "b"]


def test_holm_hand_worked():
    # sorted: 0.005 x 4 = 0.02, 0.01 x 3 = 0.03, 0.03 x 2 = 0.06, 0.04 x 1 = 0.04 -> 0.06 (the
    # step-down never lowers an adjusted p below that of a smaller raw p)
    assert holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert holm([0.5, 0.6]).tolist() == [1.0, 1.0]  # 2 x 0.5 = 1, capped at 1
    assert holm([0.02, 0.02]).tolist() == [0.04, 0.04]  # ties share the larger adjustment
    assert holm([0.3]).tolist() == [0.3]  # a family of one is not adjusted


def test_holm_leaves_nan_out_of_the_family():
    # two tests, not four: 0.01 x 2 = 0.02, 0.02 x 1 -> 0.02
    adjusted = holm([np.nan, 0.01, np.nan, 0.02])
    assert np.isnan(adjusted[[0, 2]]).all() and adjusted[[1, 3]].tolist() == [0.02, 0.02]
    assert np.isnan(holm([np.nan, np.nan])).all() and holm([]).shape == (0,)


def _step_down_rejections(p, alpha):
    """Holm's procedure as he stated it: walk up the sorted p while p_(k) <= alpha / (m - k + 1)."""
    rejected, m = set(), len(p)
    for k, i in enumerate(np.argsort(p)):
        if p[i] > alpha / (m - k):
            break
        rejected.add(int(i))
    return rejected


def test_holm_matches_the_step_down_procedure_and_bounds():
    rng = np.random.default_rng(7)
    for size in (1, 2, 5, 30):
        p = np.concatenate([rng.uniform(0, 0.02, size), rng.uniform(0, 1, size)])
        p[-1] = p[0]  # a tie
        adjusted = holm(p)
        m = p.size
        for alpha in (0.001, 0.01, 0.05, 0.2):
            assert set(np.flatnonzero(adjusted <= alpha)) == _step_down_rejections(p, alpha)
        assert (adjusted >= p).all()
        assert (adjusted <= np.minimum(1, m * p) + 1e-15).all()  # never above Bonferroni
        order = np.argsort(p, kind="stable")
        assert (np.diff(adjusted[order]) >= 0).all()  # same rank order as the raw p
        assert adjusted.min() == pytest.approx(min(1.0, m * p.min()))  # Bonferroni at the top


@pytest.mark.parametrize(("p", "message"), [
    ([0.1, 1.5], r"p_values must be in \[0, 1\] or NaN, got p_values\[1\]=1.5"),
    ([-0.1], r"p_values must be in \[0, 1\] or NaN, got p_values\[0\]=-0.1"),
    ([[0.1, 0.2]], r"p_values must be 1-D, got p_values of shape \(1, 2\)"),
])
def test_holm_refuses_what_is_not_a_list_of_p_values(p, message):
    with pytest.raises(ValueError, match=message):
        holm(p)
