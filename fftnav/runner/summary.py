"""Tables of an experiment: per (env, policy) metrics with bootstrap intervals, paired tests.

Metrics (paper Sec. IV; Anderson et al. 2018 for SPL): AR = fraction of robots that arrived,
APL = mean path length of the robots that arrived (metres), SPL = mean over all robots of
``S_i l_i / max(p_i, l_i)`` (the episode's ``spl`` column). Rates are fractions, not percent.
Intervals: 95% percentile bootstrap over *maps* (a map's robots share obstacles, so they are
not independent): maps are resampled with replacement and the pooled statistic recomputed.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
from scipy import stats

from fftnav.metrics import MEASURES
from fftnav.validate import check_integer, check_number

__all__ = ["PAIRED_COLUMNS", "bootstrap_ratio_ci", "paired_tests", "summarize",
           "summary_columns"]

#: Columns of a summary before the measures: the group and its size.
_KEYS: tuple[str, ...] = ("env", "policy", "episodes", "robots")


def summary_columns() -> tuple[str, ...]:
    """Columns of :func:`summarize`: env, policy, episodes, robots, then the columns of every
    registered measure (:data:`fftnav.metrics.MEASURES`) in registration order."""
    return _KEYS + tuple(c for m in MEASURES.values() for c in m.columns)


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
        raise ValueError(f"numerators and denominators must be 1-D of equal length, "
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


def summarize(episodes: pd.DataFrame, *, n_resamples: int = 2000, seed: int = 0) -> pd.DataFrame:
    """One row per (env, policy): counts, then every registered measure.

    Parameters
    ----------
    episodes : DataFrame
        ``episodes.csv`` rows (env, map_seed, policy and the episode columns).
    n_resamples, seed
        Bootstrap resamples and seed (see :func:`bootstrap_ratio_ci`).

    Returns
    -------
    DataFrame
        Columns :func:`summary_columns`, sorted by env, policy. Each measure's value is
        ``measure(table)`` of the group's robots; measures with ``terms`` (AR, APL, SPL) get a
        95% bootstrap interval over maps of the ratio of their per-map sums.
    """
    rows = []
    for (env, policy), g in episodes.groupby(["env", "policy"], sort=True):
        maps = g.groupby("map_seed")
        row: list[object] = [env, policy, maps.ngroups, len(g)]
        for measure in MEASURES.values():
            row.append(measure(g))
            if measure.terms is not None:
                num, den = measure.terms(g)
                sums = pd.DataFrame({"num": num, "den": den, "map": g["map_seed"].to_numpy()}
                                    ).groupby("map").sum()
                row += bootstrap_ratio_ci(sums["num"].to_numpy(), sums["den"].to_numpy(),
                                          n_resamples=n_resamples, seed=seed)
        rows.append(row)
    return pd.DataFrame(rows, columns=list(summary_columns()))


def paired_tests(episodes: pd.DataFrame, *, reference: str = "fusion") -> pd.DataFrame:
    """Wilcoxon signed-rank tests of per-map SPL: ``reference`` against every other policy.

    Maps are paired by ``(env, map_seed)``: the same map and episode seed for both policies. Only
    maps where both policies have results are used.

    Parameters
    ----------
    episodes : DataFrame
        ``episodes.csv`` rows.
    reference : str
        The policy compared with all others (the paper's proposed method, ``fusion``).

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
        for env, table in per_map.groupby(level="env", sort=True):
            for policy in sorted(c for c in per_map.columns if c != reference):
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
