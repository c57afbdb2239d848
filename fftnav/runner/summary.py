"""Tables of an experiment: per (env, policy) metrics with bootstrap intervals, paired tests.

Metrics (paper Sec. IV; Anderson et al. 2018 for SPL): AR = fraction of robots that arrived,
APL = mean path length of the robots that arrived (metres), SPL = mean over all robots of
``S_i l_i / max(p_i, l_i)`` (the episode's ``spl`` column). Rates are fractions, not percent.
Intervals: 95% percentile bootstrap over *maps* (a map's robots share obstacles, so they are
not independent): maps are resampled with replacement and the pooled statistic recomputed.
The p-values of a sweep report are Holm-Bonferroni adjusted over all its comparisons, one
family (:func:`holm`, :func:`sweep_table`).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from fftnav.errors import FftnavError
from fftnav.metrics import MEASURES
from fftnav.validate import check_integer, check_number

__all__ = ["PAIRED_COLUMNS", "SWEEP_COLUMNS", "bootstrap_ratio_ci", "gain_table", "holm",
           "in_order", "noninferiority_p", "paired_gain", "paired_tests", "summarize",
           "summary_columns", "sweep_table"]

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
    "statistic", "p_value",
)


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
        (NaN when every difference is zero or no map is paired). Empty if ``reference`` is absent.
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
                statistic = p_value = np.nan
                if np.any(diff != 0):
                    test = stats.wilcoxon(diff)
                    statistic, p_value = float(test.statistic), float(test.pvalue)
                rows.append((env, reference, policy, len(pair), pair[reference].mean(),
                             pair[policy].mean(), np.median(diff) if len(diff) else np.nan,
                             statistic, p_value))
    return pd.DataFrame(rows, columns=list(PAIRED_COLUMNS))


#: Columns of ``sweep_summary.csv``.
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


def _mean_ci(diff: np.ndarray) -> tuple[float, float]:
    if len(diff) < 2 or np.all(diff == diff[0]):
        return (float(diff[0]), float(diff[0])) if len(diff) else (np.nan, np.nan)
    res = stats.bootstrap((diff,), np.mean, confidence_level=0.95, n_resamples=2000,
                          method="percentile", rng=np.random.default_rng(0))
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def _wilcoxon(diff: np.ndarray) -> float:
    if not np.any(diff != 0):
        return float("nan")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(stats.wilcoxon(diff).pvalue)


def paired_gain(diff: Sequence[float] | np.ndarray) -> tuple[float, float, float, float]:
    """Mean of paired per-map differences ``diff``, its 95% bootstrap interval and the
    two-sided Wilcoxon signed-rank p (NaN when every difference is 0): what
    :func:`gain_table` reports for each comparison.

    >>> gain, low, high, p = paired_gain(np.array([0.1, 0.2, 0.15, 0.05, 0.12, 0.3, 0.2, 0.1]))
    >>> round(gain, 4), low < gain < high, round(p, 4)
    (0.1525, True, 0.0078)
    """
    d = np.asarray(diff, dtype=float)
    low, high = _mean_ci(d)
    return (float(d.mean()) if len(d) else float("nan")), low, high, _wilcoxon(d)


def noninferiority_p(diff: Sequence[float] | np.ndarray, *, margin: float) -> float:
    """One-sided Wilcoxon signed-rank p of the per-map differences ``diff`` against "the
    policy is worse than its reference by ``margin`` or more" (H1: the differences plus
    ``margin`` lie above 0); NaN when every shifted difference is 0.

    Identical on 20 maps: within a margin of 0.1 points; a point worse on every map: not.

    >>> noninferiority_p(np.zeros(20), margin=0.001) < 1e-5
    True
    >>> noninferiority_p(np.full(20, -0.01), margin=0.001) > 0.5
    True
    """
    shifted = np.asarray(diff, dtype=float) + margin
    if not np.any(shifted != 0):
        return float("nan")
    return float(stats.wilcoxon(shifted, alternative="greater").pvalue)


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
