"""How hard each map of an experiment is (``maps.csv``), and whether that predicts SPL.

``maps.csv`` holds, per env, map and robot, BARN's five difficulty measures along the robot's
reference path (:func:`fftnav.optimal.difficulty.map_difficulty`, docs/analysis.md), with the
robot's radius from the experiment's config (as ``fftnav world difficulty``). Rows sorted
(env, map_seed, robot), floats ``%.6f``, an undefined measure an empty field: the same config
gives a byte-identical file.

:func:`map_spl` puts each map's SPL (per policy, the mean over its robots) beside the map's
mean measures; :func:`spearman_table` says which measures rank the maps as SPL does.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from fftnav.files import write_atomic
from fftnav.optimal.difficulty import MEASURES, map_difficulty
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.executors import TaskError, execute
from fftnav.runner.tasks import Task, task_world

__all__ = ["MAPS_COLUMNS", "SPEARMAN_COLUMNS", "map_measures", "map_spl", "maps_current",
           "maps_table", "spearman_table", "write_maps_csv"]

#: Columns of ``maps.csv``: the map's keys, the robot, then the measures in BARN's order.
MAPS_COLUMNS: tuple[str, ...] = ("env", "map_seed", "robot", *MEASURES)
#: Columns of :func:`spearman_table`.
SPEARMAN_COLUMNS: tuple[str, ...] = ("scope", "policy", "measure", "maps", "rho", "p_value")
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
        pooled) and then each env, each policy and measure, ``scipy.stats.spearmanr`` of SPL
        and the measure over the maps where both are defined (``maps`` of them): ``rho`` and its
        two-sided ``p_value``. Both NaN with fewer than 3 maps or a constant column (no ranking).
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
                rho, p = _spearman(pair["spl"].to_numpy(), pair[measure].to_numpy())
                rows.append((scope, policy, measure, len(pair), rho, p))
    return pd.DataFrame(rows, columns=list(SPEARMAN_COLUMNS))


def _spearman(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``spearmanr(x, y)``'s (rho, p), NaN for fewer than 3 pairs or a constant input."""
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan"), float("nan")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = stats.spearmanr(x, y)
    return float(result.statistic), float(result.pvalue)
