"""Tables of an experiment: per (env, policy) metrics with bootstrap intervals, paired tests.

Metrics (paper Sec. IV; Anderson et al. 2018 for SPL): AR = fraction of robots that arrived,
APL = mean path length of the robots that arrived (metres), SPL = mean over all robots of
``S_i l_i / max(p_i, l_i)`` (the episode's ``spl`` column). Rates are fractions, not percent.
Intervals: 95% percentile bootstrap over *maps* (a map's robots share obstacles, so they are
not independent): maps are resampled with replacement and the pooled statistic recomputed.
Paired tests: the Wilcoxon signed-rank test of per-map differences (:func:`signed_rank_test`),
exact up to :data:`WILCOXON_EXACT_MAX` non-zero differences, whatever their ties.
The p-values of a sweep report are Holm-Bonferroni adjusted over all its comparisons, one
family (:func:`holm`, :func:`sweep_table`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from fftnav.errors import FftnavError
from fftnav.metrics import MEASURES
from fftnav.validate import check_choice, check_integer, check_number

__all__ = ["EXACT", "NORMAL_APPROX", "PAIRED_COLUMNS", "SWEEP_COLUMNS", "WILCOXON_EXACT_MAX",
           "SignedRankTest", "bootstrap_ratio_ci", "gain_table", "holm", "in_order",
           "noninferiority_p", "paired_gain", "paired_tests", "signed_rank_test", "summarize",
           "summary_columns", "sweep_table", "t_interval", "wilcoxon_method"]

#: Columns of a summary before the measures: the group and its size.
_KEYS: tuple[str, ...] = ("env", "policy", "episodes", "robots")


def summary_columns(conditions: Iterable[str] = ()) -> tuple[str, ...]:
    """Columns of :func:`summarize`: env, policy, episodes, robots, then the columns of every
    registered measure (:data:`fftnav.metrics.MEASURES`) in registration order, but those of a
    measure that requires a condition not in ``conditions``
    (:attr:`fftnav.config.SwarmConfig.conditions`, e.g. ``"odometry"``)."""
    kept = [m for m in MEASURES.values() if m.applies(conditions)]
    return _KEYS + tuple(c for m in kept for c in m.columns)


PAIRED_COLUMNS: tuple[str, ...] = (
    "env", "reference", "policy", "maps", "spl_reference", "spl_policy", "median_diff",
    "statistic", "p_value", "p_method",
)

#: ``p_method`` of a p-value computed from its exact null distribution.
EXACT = "exact"
#: ``p_method`` of a p-value from the normal approximation (scipy's default: no continuity
#: correction, the variance corrected for ties).
NORMAL_APPROX = "normal approx."
#: Non-zero paired differences up to which :func:`signed_rank_test` enumerates the null
#: distribution (2**20 sign assignments, counted in a fraction of a millisecond).
WILCOXON_EXACT_MAX = 20
_ALTERNATIVES = ("two-sided", "greater", "less")


@dataclass(frozen=True)
class SignedRankTest:
    """A Wilcoxon signed-rank test (:func:`signed_rank_test`).

    Attributes
    ----------
    statistic : float
        Two-sided: the smaller of the rank sums of the positive and of the negative
        differences; one-sided: the rank sum of the positive ones (scipy's convention). NaN
        without a test.
    p_value : float
        NaN when every difference is 0 (or there is none): no test.
    method : str
        :data:`EXACT` or :data:`NORMAL_APPROX`; ``""`` without a test.
    n : int
        The non-zero differences the test ranks.
    """

    statistic: float
    p_value: float
    method: str
    n: int


def _signed_rank_counts(doubled_ranks: np.ndarray) -> np.ndarray:
    """How many of the ``2**n`` sign assignments give each doubled rank sum of the positive
    differences: ``counts[s]`` for ``s`` in ``0..sum(doubled_ranks)`` (exact integers).

    Doubled, so that the average ranks of ties (``k + 0.5``) are integers; counted one
    difference at a time (each either adds its rank to the sum or not), which is the
    enumeration of all ``2**n`` assignments grouped by their sum.

    >>> _signed_rank_counts(np.array([2, 4, 6])).tolist()  # ranks 1, 2, 3
    [1, 0, 1, 0, 1, 0, 2, 0, 1, 0, 1, 0, 1]
    """
    counts = np.zeros(int(doubled_ranks.sum()) + 1, dtype=np.int64)
    counts[0] = 1
    for w in doubled_ranks.tolist():
        counts[w:] = counts[w:] + counts[:len(counts) - w]
    return counts


def signed_rank_test(diff: Sequence[float] | np.ndarray, *,
                     alternative: str = "two-sided") -> SignedRankTest:
    """The Wilcoxon signed-rank test of paired differences ``diff`` (H0: symmetric about 0).

    Zero differences are dropped (Wilcoxon's convention, scipy's ``zero_method="wilcox"``), the
    others ranked by absolute value with ties given their average rank. With at most
    :data:`WILCOXON_EXACT_MAX` of them the p-value is **exact**: the fraction of the ``2**n``
    equally likely sign assignments whose rank sum of positives is at least as extreme as the
    observed one, ties and all (two-sided: twice the smaller tail, at most 1). Beyond,
    ``scipy.stats.wilcoxon``'s default on ``diff``: its exact distribution without ties or zeros
    up to 50 differences, else the normal approximation (no continuity correction, the
    variance corrected for ties).

    Parameters
    ----------
    diff : (n,) array_like
        Paired differences (e.g. per-map SPL of a policy minus its reference), finite.
    alternative : {"two-sided", "greater", "less"}
        "greater": the differences lie above 0.

    Returns
    -------
    SignedRankTest
        Statistic, p-value, how it was computed and the number of non-zero differences.

    Raises
    ------
    ValueError
        ``diff`` not 1-D or not finite, ``alternative`` unknown.

    Examples
    --------
    Five positive differences: only 1 of the 32 sign assignments puts every rank on the
    positive side, and 1 every rank on the negative one: p = 2/32.

    >>> signed_rank_test([0.1, 0.2, 0.3, 0.4, 0.5])
    SignedRankTest(statistic=0.0, p_value=0.0625, method='exact', n=5)

    Six differences with a tie (ranks 1, 2.5, 2.5, 4, 5, 6), one negative (rank 5): the
    negative rank sum is 5, and 10 of the 64 subsets of the ranks sum to 5 or less ({},
    {1}, {2.5} twice, {4}, {5}, {1, 2.5} twice, {2.5, 2.5}, {1, 4}): p = 2 x 10/64.

    >>> signed_rank_test([1, 2, 2, 3, -4, 5]).p_value
    0.3125
    >>> signed_rank_test([0, 0, 0]).method  # no test
    ''
    """
    check_choice("alternative", alternative, _ALTERNATIVES)
    d = np.asarray(diff, dtype=float)
    if d.ndim != 1:
        raise FftnavError(f"diff must be 1-D, got diff of shape {d.shape}")
    bad = np.flatnonzero(~np.isfinite(d))
    if bad.size:
        raise FftnavError(f"diff must be finite, got diff[{bad[0]}]={d[bad[0]]}")
    nonzero = d[d != 0]
    n = len(nonzero)
    if n == 0:
        return SignedRankTest(float("nan"), float("nan"), "", 0)
    if n > WILCOXON_EXACT_MAX:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            test = stats.wilcoxon(d, alternative=alternative)
        ties = len(np.unique(np.abs(nonzero))) < n
        exact = len(d) <= 50 and not ties and n == len(d)  # scipy's choice of method
        return SignedRankTest(float(test.statistic), float(test.pvalue),
                              EXACT if exact else NORMAL_APPROX, n)
    doubled = np.rint(2 * stats.rankdata(np.abs(nonzero))).astype(np.int64)
    plus = int(doubled[nonzero > 0].sum())
    counts = _signed_rank_counts(doubled)
    total = 2 ** n
    upper, lower = int(counts[plus:].sum()), int(counts[:plus + 1].sum())
    tail = {"greater": upper, "less": lower,
            "two-sided": min(total, 2 * min(upper, lower))}[alternative]
    r_plus = plus / 2
    r_minus = int(doubled.sum()) / 2 - r_plus
    statistic = min(r_plus, r_minus) if alternative == "two-sided" else r_plus
    return SignedRankTest(float(statistic), tail / total, EXACT, n)


def bootstrap_ratio_ci(
    numerators: np.ndarray,
    denominators: np.ndarray,
    *,
    confidence: float = 0.95,
    n_resamples: int = 2000,
    seed: int = 0,
) -> tuple[float, float]:
    """Percentile bootstrap interval of ``sum(num) / sum(den)`` resampling clusters (maps).

    Parameters
    ----------
    numerators, denominators : (n_maps,) array
        Per-map sums, e.g. sum of SPL and number of robots of each map.
    confidence : float
        Confidence level in (0, 1).
    n_resamples : int
        Bootstrap resamples (>= 1).
    seed : int
        Seed of the ``numpy.random.Generator`` that draws the resamples.

    Returns
    -------
    (low, high) : tuple of float
        NaN, NaN with fewer than two maps, or when some resample has a zero denominator (e.g.
        APL when a resample holds only maps where no robot arrived).
    """
    check_number("confidence", confidence, low=0, high=1, low_open=True, high_open=True)
    check_integer("n_resamples", n_resamples, low=1)
    num = np.asarray(numerators, dtype=float)
    den = np.asarray(denominators, dtype=float)
    if num.shape != den.shape or num.ndim != 1:
        raise FftnavError(f"numerators and denominators must be 1-D of equal length, "
                          f"got shapes {num.shape} and {den.shape}")
    if num.size < 2:
        return float("nan"), float("nan")

    def ratio(n: np.ndarray, d: np.ndarray, axis: int = -1) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            return n.sum(axis=axis) / d.sum(axis=axis)

    with warnings.catch_warnings():  # a resample with a zero denominator makes the CI NaN
        warnings.simplefilter("ignore", stats.DegenerateDataWarning)
        res = stats.bootstrap((num, den), ratio, paired=True, vectorized=True,
                              confidence_level=confidence, n_resamples=n_resamples,
                              method="percentile", rng=np.random.default_rng(seed))
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def in_order(present: Iterable[Any], order: Sequence[Any] | None) -> list[Any]:
    """The distinct values of ``present`` in the order of ``order``, then those ``order`` lacks
    sorted (all sorted without ``order``).

    >>> in_order(["fusion", "bug-left", "mine", "own-only"], ["own-only", "mine", "bug-left"])
    ['own-only', 'mine', 'bug-left', 'fusion']
    """
    values, given = set(present), list(order or ())
    return [v for v in dict.fromkeys(given) if v in values] + sorted(values - set(given))


def _groups(episodes: pd.DataFrame, envs: Sequence[str] | None,
            policies: Sequence[str] | None) -> Iterator[tuple[str, str, pd.DataFrame]]:
    """``(env, policy, rows)`` of every (env, policy) present, in :func:`in_order` order."""
    groups = dict(iter(episodes.groupby(["env", "policy"], sort=True)))
    for env in in_order((e for e, _ in groups), envs):
        for policy in in_order((p for e, p in groups if e == env), policies):
            yield env, policy, groups[env, policy]


def summarize(episodes: pd.DataFrame, *, envs: Sequence[str] | None = None,
              policies: Sequence[str] | None = None, n_resamples: int = 2000,
              seed: int = 0, conditions: Iterable[str] = ()) -> pd.DataFrame:
    """One row per (env, policy): counts, then every registered measure.

    Parameters
    ----------
    episodes : DataFrame
        ``episodes.csv`` rows (env, map_seed, policy and the episode columns).
    envs, policies : sequence of str, optional
        The order of the rows (the config's; see :func:`in_order`); default alphabetical.
    n_resamples, seed
        Bootstrap resamples and seed (see :func:`bootstrap_ratio_ci`).
    conditions : iterable of str
        The experiment's conditions (:attr:`fftnav.config.SwarmConfig.conditions`): the
        measures that require another are left out.

    Returns
    -------
    DataFrame
        Columns :func:`summary_columns` of ``conditions``, ordered by env, then policy. Each
        measure's value is ``measure(table)`` of the group's robots; measures with ``terms``
        (AR, APL, SPL) get a 95% bootstrap interval over maps of the ratio of their per-map
        sums.
    """
    rows = []
    conditions = tuple(conditions)
    for env, policy, g in _groups(episodes, envs, policies):
        maps = g.groupby("map_seed")
        row: list[object] = [env, policy, maps.ngroups, len(g)]
        for measure in (m for m in MEASURES.values() if m.applies(conditions)):
            row.append(measure(g))
            if measure.terms is not None:
                num, den = measure.terms(g)
                sums = pd.DataFrame({"num": num, "den": den, "map": g["map_seed"].to_numpy()}
                                    ).groupby("map").sum()
                row += bootstrap_ratio_ci(sums["num"].to_numpy(), sums["den"].to_numpy(),
                                          n_resamples=n_resamples, seed=seed)
        rows.append(row)
    return pd.DataFrame(rows, columns=list(summary_columns(conditions)))


def paired_tests(episodes: pd.DataFrame, *, reference: str = "fusion",
                 envs: Sequence[str] | None = None,
                 policies: Sequence[str] | None = None) -> pd.DataFrame:
    """Wilcoxon signed-rank tests of per-map SPL: ``reference`` against every other policy.

    Maps are paired by ``(env, map_seed)``: the same map and episode seed for both policies. Only
    maps where both policies have results are used.

    Parameters
    ----------
    episodes : DataFrame
        ``episodes.csv`` rows.
    reference : str
        The policy compared with all others (the paper's proposed method, ``fusion``).
    envs, policies : sequence of str, optional
        The order of the rows (the config's; see :func:`in_order`); default alphabetical.

    Returns
    -------
    DataFrame
        Columns ``PAIRED_COLUMNS``: number of paired maps, mean per-map SPL of both, median of
        the per-map differences (reference - policy), the two-sided test statistic and p-value
        of :func:`signed_rank_test` (NaN when every difference is zero or no map is paired) and
        how the p-value was computed (``p_method``: :data:`EXACT` or :data:`NORMAL_APPROX`,
        empty without a p-value). Empty if ``reference`` is absent.
    """
    per_map = episodes.pivot_table(index=["env", "map_seed"], columns="policy", values="spl",
                                   aggfunc="mean")
    rows = []
    if reference in per_map.columns:
        tables = dict(iter(per_map.groupby(level="env", sort=True)))
        for env in in_order(tables, envs):
            table = tables[env]
            for policy in in_order((c for c in per_map.columns if c != reference), policies):
                pair = table[[reference, policy]].dropna()
                diff = (pair[reference] - pair[policy]).to_numpy()
                test = signed_rank_test(diff)
                rows.append((env, reference, policy, len(pair), pair[reference].mean(),
                             pair[policy].mean(), np.median(diff) if len(diff) else np.nan,
                             test.statistic, test.p_value, test.method))
    return pd.DataFrame(rows, columns=list(PAIRED_COLUMNS))


#: Columns of :func:`gain_table` and :func:`sweep_table` (``sweep_summary.csv`` adds
#: ``p_method``, :data:`fftnav.report.sweep.SUMMARY_COLUMNS`).
SWEEP_COLUMNS: tuple[str, ...] = (
    "cell", "env", "policy", "maps", "ar", "ar_ci_low", "ar_ci_high", "spl", "spl_ci_low",
    "spl_ci_high", "bytes_per_robot", "reference", "gain", "gain_ci_low", "gain_ci_high",
    "p_value", "p_holm",
)


def holm(p_values: Sequence[float] | np.ndarray) -> np.ndarray:
    """Holm-Bonferroni adjusted p-values of one family of tests (Holm 1979).

    With the family's m p-values sorted, ``p_(1) <= ... <= p_(m)``, the k-th is adjusted to
    ``max(min(1, (m - j + 1) p_(j)) for j <= k)``. Rejecting the tests whose adjusted p is below
    ``alpha`` keeps the probability of any false rejection in the family at most ``alpha``,
    whatever the dependence between the tests; it rejects every test that Bonferroni (``m p``)
    rejects, and often more.

    Parameters
    ----------
    p_values : (n,) array_like
        Raw p-values in [0, 1]. NaN (no test made, e.g. every paired difference 0) is left out
        of the family, so m counts the others, and stays NaN.

    Returns
    -------
    (n,) ndarray of float
        The adjusted p-values in the order given: each at least its raw p, in the same rank
        order as the raw p, the smallest equal to Bonferroni's ``min(1, m p_(1))``.

    Examples
    --------
    >>> holm([0.01, 0.04, 0.03, 0.005, float("nan")]).round(6).tolist()
    [0.03, 0.06, 0.06, 0.02, nan]
    """
    p = np.asarray(p_values, dtype=float)
    if p.ndim != 1:
        raise FftnavError(f"p_values must be 1-D, got p_values of shape {p.shape}")
    bad = np.flatnonzero(~np.isnan(p) & ~((p >= 0) & (p <= 1)))
    if bad.size:
        raise FftnavError(f"p_values must be in [0, 1] or NaN, got p_values[{bad[0]}]={p[bad[0]]}")
    tested = np.flatnonzero(~np.isnan(p))
    order = tested[np.argsort(p[tested], kind="stable")]
    factors = np.arange(order.size, 0, -1)  # m, m - 1, ..., 1
    adjusted = np.full(p.shape, np.nan)
    adjusted[order] = np.minimum(1.0, np.maximum.accumulate(factors * p[order]))
    return adjusted


def sweep_table(tables: Iterable[pd.DataFrame]) -> pd.DataFrame:
    """The tables of :func:`gain_table` of the cells of one report as one table
    (:data:`SWEEP_COLUMNS`), its ``p_holm`` recomputed over all their rows: every comparison
    of one report is one family (:func:`holm`)."""
    parts = [t for t in tables if len(t)]
    if not parts:
        return pd.DataFrame(columns=list(SWEEP_COLUMNS))
    table = pd.concat(parts, ignore_index=True)
    return table.assign(p_holm=holm(table["p_value"].to_numpy(dtype=float)))


def t_interval(values: Sequence[float] | np.ndarray, *,
               confidence: float = 0.95) -> tuple[float, float, float]:
    """Mean of ``values`` (NaN ignored) and its Student-t interval, ``mean +- t s / sqrt(n)``
    with ``n - 1`` degrees of freedom (NaN bounds with fewer than 2 values): for a few seeds.

    >>> [round(v, 3) for v in t_interval([1.0, 2.0, 3.0])]
    [2.0, -0.484, 4.484]
    """
    x = np.asarray(values, dtype=float)
    x = x[~np.isnan(x)]
    if len(x) == 0:
        return math.nan, math.nan, math.nan
    mean = float(x.mean())
    if len(x) < 2:
        return mean, math.nan, math.nan
    half = float(stats.t.ppf(0.5 + confidence / 2, len(x) - 1) * x.std(ddof=1)
                 / math.sqrt(len(x)))
    return mean, mean - half, mean + half


def _mean_ci(diff: np.ndarray) -> tuple[float, float]:
    if len(diff) < 2 or np.all(diff == diff[0]):
        return (float(diff[0]), float(diff[0])) if len(diff) else (np.nan, np.nan)
    res = stats.bootstrap((diff,), np.mean, confidence_level=0.95, n_resamples=2000,
                          method="percentile", rng=np.random.default_rng(0))
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def wilcoxon_method(diff: Sequence[float] | np.ndarray, *, alternative: str = "two-sided") -> str:
    """How :func:`signed_rank_test` (and so :func:`paired_gain`, :func:`noninferiority_p`)
    computes the p-value of ``diff``: :data:`EXACT`, :data:`NORMAL_APPROX`, or ``""`` when
    every difference is 0 (no test).

    >>> wilcoxon_method([0.1, -0.2, 0.3]), wilcoxon_method([0.0, 0.0])
    ('exact', '')
    """
    return signed_rank_test(diff, alternative=alternative).method


def paired_gain(diff: Sequence[float] | np.ndarray) -> tuple[float, float, float, float]:
    """Mean of paired per-map differences ``diff``, its 95% bootstrap interval and the
    two-sided Wilcoxon signed-rank p of :func:`signed_rank_test` (NaN when every difference is
    0): what :func:`gain_table` reports for each comparison.

    >>> gain, low, high, p = paired_gain(np.array([0.1, 0.2, 0.15, 0.05, 0.12, 0.3, 0.2, 0.1]))
    >>> round(gain, 4), low < gain < high, round(p, 4)
    (0.1525, True, 0.0078)
    """
    d = np.asarray(diff, dtype=float)
    low, high = _mean_ci(d)
    return (float(d.mean()) if len(d) else float("nan")), low, high, signed_rank_test(d).p_value


def noninferiority_p(diff: Sequence[float] | np.ndarray, *, margin: float) -> float:
    """One-sided Wilcoxon signed-rank p (:func:`signed_rank_test`) of the per-map differences
    ``diff`` against "the policy is worse than its reference by ``margin`` or more" (H1: the
    differences plus ``margin`` lie above 0); NaN when every shifted difference is 0.

    Identical on 20 maps: within a margin of 0.1 points (exact p = 1/2**20, the one sign
    assignment with every shifted difference positive); a point worse on every map: not (p = 1).

    >>> noninferiority_p(np.zeros(20), margin=0.001) == 1 / 2**20
    True
    >>> noninferiority_p(np.full(20, -0.01), margin=0.001)
    1.0
    """
    shifted = np.asarray(diff, dtype=float) + margin
    return signed_rank_test(shifted, alternative="greater").p_value


def gain_table(episodes: pd.DataFrame, cell: str, *, envs: Sequence[str] | None = None,
               policies: Sequence[str] | None = None) -> pd.DataFrame:
    """Rows :data:`SWEEP_COLUMNS` of one sweep cell's ``episodes.csv``: each (env, policy)
    with AR and SPL and their 95% bootstrap intervals over maps, bytes per robot, and its gain
    against ``own-only`` (per-map SPL difference: mean, 95% bootstrap interval of the mean,
    two-sided Wilcoxon signed-rank p, and that p Holm-adjusted over the rows of this table as
    one family, :func:`holm`; :func:`sweep_table` readjusts over several cells); ``collab``
    gets a second row against ``fusion``. Rows in the order of ``envs`` and ``policies``
    (:func:`in_order`; default alphabetical)."""
    per_map = episodes.pivot_table(index=["env", "map_seed"], columns="policy", values="spl",
                                   aggfunc="mean")
    rows: list[tuple[Any, ...]] = []
    for env, policy, g in _groups(episodes, envs, policies):
        sums = g.groupby("map_seed").agg(arr=("arrived", "sum"), spl=("spl", "sum"),
                                         n=("robot", "count"))
        ar = g["arrived"].mean()
        spl = g["spl"].mean()
        ar_ci = bootstrap_ratio_ci(sums["arr"].to_numpy(), sums["n"].to_numpy())
        spl_ci = bootstrap_ratio_ci(sums["spl"].to_numpy(), sums["n"].to_numpy())
        refs = [r for r in ("own-only", "fusion") if r != policy and r in per_map.columns
                and (r == "own-only" or policy == "collab")] or [""]
        for ref in refs:
            gain = lo = hi = p = np.nan
            if ref:
                pair = per_map.loc[env][[policy, ref]].dropna()
                gain, lo, hi, p = paired_gain((pair[policy] - pair[ref]).to_numpy())
            rows.append((cell, env, policy, g["map_seed"].nunique(), ar, *ar_ci, spl, *spl_ci,
                         g["bytes_sent"].mean(), ref, gain, lo, hi, p, np.nan))
    return sweep_table([pd.DataFrame(rows, columns=list(SWEEP_COLUMNS))])
