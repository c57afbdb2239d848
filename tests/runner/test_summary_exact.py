"""Exact Wilcoxon signed-rank p-values on few maps: hand-worked cases and a brute-force
enumeration of every sign assignment written here, independently of the library."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from fftnav.runner.summary import (
    EXACT,
    NORMAL_APPROX,
    WILCOXON_EXACT_MAX,
    noninferiority_p,
    paired_gain,
    paired_tests,
    signed_rank_test,
    wilcoxon_method,
)


def average_ranks(values):
    """1-based ranks of ``values``, ties sharing the mean of their positions, by sorting."""
    order = sorted(range(len(values)), key=lambda i: values[i])
    ranks = [0.0] * len(values)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and values[order[j + 1]] == values[order[i]]:
            j += 1
        for k in range(i, j + 1):
            ranks[order[k]] = (i + j) / 2 + 1
        i = j + 1
    return ranks


def brute_force_p(diff, alternative="two-sided"):
    """The p-value over all 2**n sign assignments of the non-zero differences, one by one."""
    d = [x for x in diff if x != 0]
    ranks = average_ranks([abs(x) for x in d])
    observed = sum(r for r, x in zip(ranks, d, strict=True) if x > 0)
    sums = [sum(r for r, s in zip(ranks, signs, strict=True) if s)
            for signs in itertools.product((False, True), repeat=len(d))]
    upper = sum(s >= observed for s in sums) / len(sums)
    lower = sum(s <= observed for s in sums) / len(sums)
    return {"greater": upper, "less": lower,
            "two-sided": min(1.0, 2 * min(upper, lower))}[alternative]


def test_five_positive_differences_give_two_in_thirty_two():
    test = signed_rank_test([0.01, 0.02, 0.03, 0.04, 0.05])
    assert (test.p_value, test.statistic, test.method, test.n) == (2 / 32, 0.0, EXACT, 5)
    assert signed_rank_test([0.01, 0.02, 0.03, 0.04, 0.05], alternative="greater").p_value \
        == 1 / 32
    assert signed_rank_test([0.01, 0.02, 0.03, 0.04, 0.05], alternative="less").p_value == 1.0


def test_six_differences_with_a_tie_by_hand():
    # |d| 1, 2, 2, 3, 4, 5 -> ranks 1, 2.5, 2.5, 4, 5, 6; the negative one has rank 5, so
    # T- = 5 and T+ = 16. Subsets of the ranks summing to 5 or less: {}, {1}, {2.5} x2, {4},
    # {5}, {1, 2.5} x2, {2.5, 2.5}, {1, 4}: 10 of 64.
    test = signed_rank_test([1.0, 2.0, 2.0, 3.0, -4.0, 5.0])
    assert (test.statistic, test.p_value, test.method) == (5.0, 20 / 64, EXACT)
    assert signed_rank_test([1.0, 2.0, 2.0, 3.0, -4.0, 5.0],
                            alternative="greater").p_value == 10 / 64


def test_zeros_are_dropped_and_all_zeros_is_no_test():
    test = signed_rank_test([0.0, 0.3, 0.0, 0.1, 0.2, 0.5, 0.4])
    assert (test.p_value, test.n, test.method) == (2 / 32, 5, EXACT)
    none = signed_rank_test(np.zeros(7))
    assert np.isnan(none.p_value) and np.isnan(none.statistic) and none.method == ""
    assert np.isnan(signed_rank_test([]).p_value)


@pytest.mark.parametrize("n", [1, 2, 3, 7, 10, 12])
def test_exact_p_is_the_brute_force_enumeration_with_ties_and_zeros(n):
    rng = np.random.default_rng(n)
    for _ in range(5):
        diff = rng.integers(-3, 6, n).astype(float) / 100  # many ties, some zeros
        if not np.any(diff):
            continue
        for alternative in ("two-sided", "greater", "less"):
            assert signed_rank_test(diff, alternative=alternative).p_value == pytest.approx(
                brute_force_p(diff.tolist(), alternative), rel=1e-12)


def test_twenty_differences_with_ties_against_a_vectorised_enumeration():
    """n = 20, the largest exact case: all 2**20 sign assignments as bit patterns."""
    diff = np.array([3, -1, 4, 1, -5, 9, 2, 6, 5, 3, 5, 8, 9, -7, 9, 3, 2, 3, 8, 4]) / 100
    ranks = np.array(average_ranks(np.abs(diff).tolist()))
    bits = (np.arange(2 ** 20)[:, None] >> np.arange(20)) & 1
    sums = bits @ ranks
    observed = ranks[diff > 0].sum()
    expected = min(1.0, 2 * min(np.mean(sums >= observed - 1e-9),
                                np.mean(sums <= observed + 1e-9)))
    test = signed_rank_test(diff)
    assert test.method == EXACT and test.n == WILCOXON_EXACT_MAX
    assert test.p_value == pytest.approx(expected, rel=1e-12)
    # scipy's default falls back to the normal approximation here (ties, n > 13)
    assert stats.wilcoxon(diff).pvalue != pytest.approx(expected, rel=1e-3)


def test_no_ties_agrees_with_scipys_exact_distribution():
    rng = np.random.default_rng(2)
    for n in range(1, WILCOXON_EXACT_MAX + 1):
        diff = rng.normal(0.2, 1.0, n)
        for alternative in ("two-sided", "greater", "less"):
            ours = signed_rank_test(diff, alternative=alternative)
            theirs = stats.wilcoxon(diff, alternative=alternative, method="exact")
            assert ours.p_value == pytest.approx(theirs.pvalue, rel=1e-12)
            assert ours.statistic == theirs.statistic


def test_beyond_twenty_differences_it_is_scipys_default_and_says_which():
    rng = np.random.default_rng(5)
    distinct = rng.normal(0.1, 1.0, 25)
    test = signed_rank_test(distinct)
    assert test.method == EXACT and test.n == 25  # scipy's exact distribution: no ties
    assert test.p_value == stats.wilcoxon(distinct).pvalue
    tied = np.round(distinct, 1)
    tied[0] = 0.0
    test = signed_rank_test(tied)
    assert test.method == NORMAL_APPROX
    assert test.p_value == stats.wilcoxon(tied).pvalue
    many = rng.normal(0.1, 1.0, 60)
    assert signed_rank_test(many).method == NORMAL_APPROX  # more than 50


def test_paired_gain_and_noninferiority_use_the_exact_p():
    diff = np.array([0.02, 0.02, 0.01, -0.01, 0.03, 0.02, 0.04, 0.02, 0.0, 0.01, 0.05, 0.02,
                     0.01, 0.03, 0.02])  # ties and a zero: scipy would approximate
    assert paired_gain(diff)[3] == pytest.approx(brute_force_p(diff.tolist()), rel=1e-12)
    assert noninferiority_p(np.zeros(20), margin=0.001) == 1 / 2 ** 20
    shifted = diff + 0.005
    assert noninferiority_p(diff, margin=0.005) == pytest.approx(
        brute_force_p(shifted.tolist(), "greater"), rel=1e-12)


def test_paired_tests_record_how_each_p_was_computed():
    rows = []
    for seed in range(15):
        for policy, spl in (("fusion", 0.9 + 0.01 * (seed % 3)), ("bug-left", 0.9),
                            ("random", 0.9 + 0.01 * (seed % 3))):
            rows.append({"env": "forest", "map_seed": seed, "policy": policy, "spl": spl})
    table = paired_tests(pd.DataFrame(rows)).set_index("policy")
    diff = [0.01 * (seed % 3) for seed in range(15)]  # 10 non-zero, tied in pairs of 5
    assert table.loc["bug-left", "p_method"] == EXACT
    assert table.loc["bug-left", "p_value"] == pytest.approx(brute_force_p(diff), rel=1e-9)
    assert table.loc["random", "p_method"] == "" and np.isnan(table.loc["random", "p_value"])


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"diff": [0.1, 0.2], "alternative": "both"},
     r"alternative must be one of \['two-sided', 'greater', 'less'\], got alternative='both'"),
    ({"diff": [0.1, float("nan")]}, r"diff must be finite, got diff\[1\]=nan"),
    ({"diff": [[0.1, 0.2]]}, r"diff must be 1-D, got diff of shape \(1, 2\)"),
])
def test_bad_input_is_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        signed_rank_test(**kwargs)


def test_wilcoxon_method_names_the_computation_of_each_p():
    assert wilcoxon_method([0.01, 0.02, 0.02, -0.03]) == EXACT
    assert wilcoxon_method(np.zeros(5)) == ""
    tied = np.round(np.random.default_rng(3).normal(0.1, 1.0, 30), 1)
    assert wilcoxon_method(tied) == signed_rank_test(tied).method == NORMAL_APPROX
