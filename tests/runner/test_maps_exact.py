"""Exact Spearman p-values on few maps: hand-worked cases and a brute-force enumeration of every
ordering written here, independently of the library."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import stats

from fftnav.runner.maps import SPEARMAN_EXACT_MAX, T_APPROX, spearman_test
from tests.runner.test_summary_exact import average_ranks


def pearson(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    a, b = a - a.mean(), b - b.mean()
    return float(a @ b / math.sqrt((a @ a) * (b @ b)))


def brute_force_spearman_p(x, y):
    """Two-sided p over all n! orderings of ``y`` against ``x``: twice the smaller tail of the
    rank correlations at least and at most the observed one."""
    rx, ry = average_ranks(list(x)), average_ranks(list(y))
    observed = pearson(rx, ry)
    rhos = [pearson(rx, [ry[i] for i in perm])
            for perm in itertools.permutations(range(len(ry)))]
    upper = sum(r >= observed - 1e-12 for r in rhos) / len(rhos)
    lower = sum(r <= observed + 1e-12 for r in rhos) / len(rhos)
    return min(1.0, 2 * min(upper, lower))


def test_four_maps_in_order_give_two_in_twenty_four():
    rho, p, method = spearman_test([1, 2, 3, 4], [0.1, 0.5, 0.7, 0.9])
    assert (rho, method) == (1.0, "exact") and p == pytest.approx(2 / 24, rel=1e-12)
    rho, p, _ = spearman_test([1, 2, 3, 4], [0.9, 0.7, 0.5, 0.1])
    assert rho == -1.0 and p == pytest.approx(2 / 24, rel=1e-12)


def test_three_maps_by_hand():
    # the six orderings of 3 ranks have rho 1, 0.5, 0.5, -0.5, -0.5, -1: rho = 0.5 is
    # reached or exceeded by 3 of 6, so p = min(1, 2 * 3/6) = 1
    rho, p, method = spearman_test([1, 2, 3], [1, 3, 2])
    assert (rho, p, method) == (pytest.approx(0.5), 1.0, "exact")


def test_nine_maps_in_order_is_exact():
    rho, p, method = spearman_test(np.arange(9), np.arange(9) ** 2)
    assert (rho, method) == (pytest.approx(1.0), "exact")
    assert p == pytest.approx(2 / math.factorial(9), rel=1e-12)


@pytest.mark.parametrize("n", [3, 4, 5, 6, 7])
def test_exact_p_is_the_brute_force_enumeration_with_ties(n):
    rng = np.random.default_rng(n)
    for _ in range(4):
        x = rng.integers(0, 4, n).astype(float)  # ties
        y = rng.random(n).round(1)
        if np.ptp(x) == 0 or np.ptp(y) == 0:
            continue
        rho, p, method = spearman_test(x, y)
        assert method == "exact"
        assert rho == pytest.approx(pearson(average_ranks(x.tolist()),
                                            average_ranks(y.tolist())), abs=1e-12)
        assert p == pytest.approx(brute_force_spearman_p(x, y), rel=1e-12)


def test_beyond_nine_maps_it_is_the_t_approximation():
    rng = np.random.default_rng(1)
    x, y = rng.random(SPEARMAN_EXACT_MAX + 1), rng.random(SPEARMAN_EXACT_MAX + 1)
    rho, p, method = spearman_test(x, y)
    expected = stats.spearmanr(x, y)
    assert (rho, p, method) == (expected.statistic, expected.pvalue, T_APPROX)


def test_no_ranking_is_no_test_and_bad_input_is_refused():
    assert spearman_test([1, 2], [2, 1])[2] == ""
    rho, p, method = spearman_test([1, 1, 1, 1], [1, 2, 3, 4])
    assert np.isnan(rho) and np.isnan(p) and method == ""
    with pytest.raises(ValueError, match=r"x and y must be 1-D of one length, got shapes "
                                         r"\(3,\) and \(4,\)"):
        spearman_test([1, 2, 3], [1, 2, 3, 4])
    with pytest.raises(ValueError, match=r"y must be finite, got y\[2\]=nan"):
        spearman_test([1, 2, 3], [1, 2, float("nan")])
