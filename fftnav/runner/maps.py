"""How hard each map of an experiment is (``maps.csv``), and whether that predicts SPL.

``maps.csv`` holds, per env, map and robot, BARN's five difficulty measures along the robot's
reference path (:func:`fftnav.optimal.difficulty.map_difficulty`, docs/analysis.md), with the
robot's radius from the experiment's config (as ``fftnav world difficulty``). Rows sorted
(env, map_seed, robot), floats ``%.6f``, an undefined measure an empty field: the same config
gives a byte-identical file.

:func:`map_spl` puts each map's SPL (per policy, the mean over its robots) beside the map's
mean measures; :func:`spearman_table` says which measures rank the maps as SPL does, with an
exact p-value on up to :data:`SPEARMAN_EXACT_MAX` maps (:func:`spearman_test`).
"""

from __future__ import annotations

import functools
import itertools
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from fftnav.errors import FftnavError
from fftnav.files import write_atomic
from fftnav.optimal.difficulty import MEASURES, map_difficulty
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.executors import TaskError, execute
from fftnav.runner.tasks import Task, task_world

__all__ = ["MAPS_COLUMNS", "SPEARMAN_COLUMNS", "SPEARMAN_EXACT_MAX", "T_APPROX", "map_measures",
           "map_spl", "maps_current", "maps_table", "spearman_table", "spearman_test",
           "write_maps_csv"]

#: Columns of ``maps.csv``: the map's keys, the robot, then the measures in BARN's order.
MAPS_COLUMNS: tuple[str, ...] = ("env", "map_seed", "robot", *MEASURES)
#: Columns of :func:`spearman_table`.
SPEARMAN_COLUMNS: tuple[str, ...] = ("scope", "policy", "measure", "maps", "rho", "p_value",
                                     "p_method")
#: Maps (pairs) up to which :func:`spearman_test` enumerates every ordering (9! = 362,880).
SPEARMAN_EXACT_MAX = 9
#: ``p_method`` of a Spearman p-value from the t approximation (``scipy.stats.spearmanr``).
T_APPROX = "t approx."
#: Fixed float format of ``maps.csv`` (that of ``episodes.csv``).
FLOAT_FORMAT = "%.6f"


def _map_keys(config: ExperimentConfig) -> list[tuple[str, int]]:
    """Every (env, map_seed) of an experiment, in the order of ``episodes.csv``."""
    return [(env, config.map_seed + i) for env in sorted(config.envs) for i in range(config.maps)]


def map_measures(config: ExperimentConfig, task: Task) -> np.ndarray:
    """The measures of one map (``task.env``, ``task.map_seed``), ``(len(MEASURES), N)``, in
    the order of :data:`~fftnav.optimal.difficulty.MEASURES`; r0 is ``config.swarm.robot.r0_m``.

    A map whose reference paths do not exist (a start or goal inside the inflated map, an
    unreachable goal: its episodes fail with the same error) gets NaN.
    """
    world = task_world(config, task.env, task.map_seed)
    try:
        measures = map_difficulty(world, r0_m=config.swarm.robot.r0_m)
    except ValueError:
        return np.full((len(MEASURES), len(world.starts)), np.nan)
    return np.array([measures[name] for name in MEASURES])


def maps_table(config: ExperimentConfig, *, executor: str = "local", workers: int | None = 1,
               scheduler: str | None = None) -> pd.DataFrame:
    """The difficulty measures of every robot of every map of an experiment.

    Parameters
    ----------
    config : ExperimentConfig
        Its worlds come from :func:`fftnav.runner.tasks.task_world`; r0 is
        ``config.swarm.robot.r0_m`` (:func:`map_measures`).
    executor, workers, scheduler
        Where the maps are computed, one task per map (:func:`fftnav.runner.executors.execute`;
        by default in this process).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`MAPS_COLUMNS`, one row per (env, map_seed, robot), sorted; NaN measures
        for a map without reference paths.

    Raises
    ------
    RuntimeError
        If computing a map raised anything but a ValueError (a bug, a lost worker).
    """
    tasks = (Task(env, map_seed, "", 0, False) for env, map_seed in _map_keys(config))
    found: dict[tuple[str, int], np.ndarray] = {}
    for task, result in execute(map_measures, config, tasks, executor=executor,
                                workers=workers, scheduler=scheduler):
        if isinstance(result, TaskError):
            raise RuntimeError(f"difficulty of map {task.env}-{task.map_seed} failed: "
                               f"{result.error_type}: {result.message}")
        found[task.env, task.map_seed] = result
    frames = [pd.DataFrame({"env": env, "map_seed": map_seed,
                            "robot": np.arange(values.shape[1]),
                            **dict(zip(MEASURES, values, strict=True))})
              for (env, map_seed), values in sorted(found.items())]
    return pd.concat(frames, ignore_index=True)[list(MAPS_COLUMNS)]


def write_maps_csv(out: str | Path, config: ExperimentConfig, **options: object) -> Path:
    """Write :func:`maps_table` (``options`` are its executor's) to ``OUT/maps.csv``
    atomically; returns its path."""
    path = Path(out) / "maps.csv"
    table = maps_table(config, **options)  # type: ignore[arg-type]
    write_atomic(path, table.to_csv(index=False, float_format=FLOAT_FORMAT))
    return path


def maps_current(out: str | Path, config: ExperimentConfig) -> bool:
    """Whether ``OUT/maps.csv`` exists with the columns of :data:`MAPS_COLUMNS` and exactly the
    experiment's (env, map_seed) pairs, each with the same number of robots.

    The folder's ``config.json`` pins the rest of the config (a run refuses another config
    without ``--fresh``), so this is what can go stale.
    """
    path = Path(out) / "maps.csv"
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError, UnicodeDecodeError):
        return False
    if tuple(table.columns) != MAPS_COLUMNS:
        return False
    counts = table.groupby(["env", "map_seed"]).size()
    found = {(str(env), int(seed)) for env, seed in counts.index}
    return found == set(_map_keys(config)) and bool((counts == config.robots).all())


def map_spl(episodes: pd.DataFrame, maps: pd.DataFrame) -> pd.DataFrame:
    """Per map and policy: SPL (the mean of the robots' ``spl``) and the map's mean measures.

    Parameters
    ----------
    episodes : pandas.DataFrame
        ``episodes.csv`` (columns env, map_seed, policy, spl at least).
    maps : pandas.DataFrame
        ``maps.csv`` (:data:`MAPS_COLUMNS`).

    Returns
    -------
    pandas.DataFrame
        Columns env, map_seed, policy, spl, then the :data:`~fftnav.optimal.difficulty.MEASURES`
        (each the mean over the map's robots, NaN left out); only maps in both tables.

    Examples
    --------
    >>> ep = pd.DataFrame({"env": "e", "map_seed": [1, 1, 2, 2], "policy": "p",
    ...                    "spl": [1.0, 0.5, 0.25, 0.75]})
    >>> mp = pd.DataFrame({"env": "e", "map_seed": [1, 1, 2, 2], "robot": [0, 1, 0, 1],
    ...                    **{m: [1.0, 3.0, 5.0, 7.0] for m in MEASURES}})
    >>> map_spl(ep, mp)[["map_seed", "spl", "tortuosity"]].to_numpy().tolist()
    [[1.0, 0.75, 2.0], [2.0, 0.5, 6.0]]
    """
    spl = episodes.groupby(["env", "map_seed", "policy"], as_index=False, sort=True)["spl"].mean()
    measures = maps.groupby(["env", "map_seed"], as_index=False)[list(MEASURES)].mean()
    return spl.merge(measures, on=["env", "map_seed"], how="inner")


def spearman_table(per_map: pd.DataFrame, *, envs: Sequence[str] | None = None,
                   policies: Sequence[str] | None = None) -> pd.DataFrame:
    """Spearman's rank correlation of per-map SPL with each measure, per policy.

    Parameters
    ----------
    per_map : pandas.DataFrame
        :func:`map_spl`'s table.
    envs, policies : sequence of str, optional
        Their order (default: as they first appear).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`SPEARMAN_COLUMNS`: for ``scope`` = ``"all"`` (every map of every env
        pooled) and then each env, each policy and measure, :func:`spearman_test` of SPL and
        the measure over the maps where both are defined (``maps`` of them): ``rho``, its
        two-sided ``p_value`` and how that was computed (``p_method``: ``"exact"`` up to
        :data:`SPEARMAN_EXACT_MAX` maps, :data:`T_APPROX` beyond). rho and p NaN, ``p_method``
        empty, with fewer than 3 maps or a constant column (no ranking).
    """
    envs = list(envs) if envs is not None else list(dict.fromkeys(per_map["env"]))
    policies = (list(policies) if policies is not None
                else list(dict.fromkeys(per_map["policy"])))
    scopes = [("all", per_map)] + [(env, per_map[per_map["env"] == env]) for env in envs]
    rows = []
    for scope, table in scopes:
        for policy in policies:
            sub = table[table["policy"] == policy]
            for measure in MEASURES:
                pair = sub[["spl", measure]].dropna()
                rho, p, method = spearman_test(pair["spl"].to_numpy(),
                                               pair[measure].to_numpy())
                rows.append((scope, policy, measure, len(pair), rho, p, method))
    return pd.DataFrame(rows, columns=list(SPEARMAN_COLUMNS))


def spearman_test(x: Sequence[float] | np.ndarray,
                  y: Sequence[float] | np.ndarray) -> tuple[float, float, str]:
    """Spearman's rank correlation of ``x`` and ``y`` and its two-sided p-value (H0: no
    association).

    rho is ``scipy.stats.spearmanr``'s (the Pearson correlation of the average ranks). With at
    most :data:`SPEARMAN_EXACT_MAX` pairs the p-value is **exact**: under H0 every one of the
    ``n!`` orderings of ``y`` against ``x`` is equally likely, and p is twice the smaller of
    the fractions of orderings whose rank correlation is at least, and at most, the observed
    one (at most 1; ties keep their average ranks). Beyond, ``spearmanr``'s t approximation.

    Parameters
    ----------
    x, y : (n,) array_like
        Paired values, finite.

    Returns
    -------
    (rho, p_value, p_method) : (float, float, str)
        ``p_method`` is ``"exact"`` or :data:`T_APPROX`; ``(nan, nan, "")`` for fewer than 3
        pairs or a constant input (no ranking).

    Raises
    ------
    ValueError
        ``x`` and ``y`` not 1-D of one length, or not finite.

    Examples
    --------
    Four maps in the same order: 1 of the 24 orderings has rho = 1, none more: p = 2/24.

    >>> rho, p, method = spearman_test([1, 2, 3, 4], [10, 20, 30, 40])
    >>> rho, round(p * 24, 9), method
    (1.0, 2.0, 'exact')
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.ndim != 1 or x.shape != y.shape:
        raise FftnavError(f"x and y must be 1-D of one length, got shapes {x.shape} and "
                          f"{y.shape}")
    for name, values in (("x", x), ("y", y)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise FftnavError(f"{name} must be finite, got {name}[{bad[0]}]={values[bad[0]]}")
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan"), float("nan"), ""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = stats.spearmanr(x, y)
    rho = float(result.statistic)
    if len(x) > SPEARMAN_EXACT_MAX:
        return rho, float(result.pvalue), T_APPROX
    rx, ry = _centred_ranks(x), _centred_ranks(y)
    observed = int(rx @ ry)
    null = _spearman_null(tuple(sorted(rx.tolist())), tuple(sorted(ry.tolist())))
    at_most = int(np.searchsorted(null, observed, side="right"))
    at_least = len(null) - int(np.searchsorted(null, observed, side="left"))
    return rho, min(1.0, 2 * min(at_most, at_least) / len(null)), "exact"


def _centred_ranks(values: np.ndarray) -> np.ndarray:
    """Twice the average ranks minus ``n + 1``: integers (ties' ranks end in .5) summing to 0,
    whose products sum to a multiple of the rank covariance, exactly."""
    return np.rint(2 * stats.rankdata(values) - (len(values) + 1)).astype(np.int64)


@functools.lru_cache(maxsize=64)
def _spearman_null(rx: tuple[int, ...], ry: tuple[int, ...]) -> np.ndarray:
    """``sum(rx * ry[perm])`` over every permutation ``perm``, sorted: the null distribution
    of the rank statistic, which depends only on the two multisets of ranks (so is cached)."""
    perms = np.array(list(itertools.permutations(range(len(ry)))), dtype=np.intp)
    null = np.sort(np.asarray(ry, dtype=np.int64)[perms] @ np.asarray(rx, dtype=np.int64))
    null.flags.writeable = False  # shared by the cache
    return null
