"""The leaderboard's tables: every method ranked on every suite, and submissions.

:func:`ranking` ranks the methods of a suite's rows by SPL (pooled over the suite's maps, with
95 % bootstrap intervals over maps, the summary's registered measures); :func:`build_leaderboard`
makes the table of every built-in on every suite from the shipped references, plus the
submissions kept in a leaderboard folder; :func:`add_submission` checks an ``fftnav evaluate``
folder (suite versions and pins, fftnav version, method and rows hashes) and keeps its rows.

A leaderboard folder (``results/leaderboard/``):

- ``leaderboard.csv`` (:data:`LEADERBOARD_COLUMNS`), ``leaderboard.md``, ``index.html``;
- ``<suite>/report.md`` and ``<suite>/failures.md`` (written by :mod:`fftnav.report.leaderboard`);
- ``submissions/<method>/``: an added method's ``evaluation.json`` and ``<suite>.csv`` rows.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from fftnav.errors import FftnavError
from fftnav.metrics import MEASURES
from fftnav.plugins import file_sha256, plugin_sources
from fftnav.runner.run import read_episodes, read_timing
from fftnav.runner.summary import holm, paired_gain, summarize
from fftnav.suites import (
    SUITES,
    Suite,
    find_suite,
    ordered_suites,
    pins_path,
    read_references,
    rows_csv,
)

__all__ = ["LEADERBOARD_COLUMNS", "add_submission", "build_leaderboard", "leaderboard_columns",
           "leaderboard_episodes", "method_sha256", "rank_suites", "ranking", "rows_sha256",
           "submissions"]

#: The leading columns of ``leaderboard.csv``; then one ``failures_<cause>`` per registered
#: failure cause (:func:`leaderboard_columns`), then ``p_holm``.
LEADERBOARD_COLUMNS = ("suite", "method", "rank", "maps", "robots", "spl", "spl_ci_low",
                       "spl_ci_high", "ar", "ar_ci_low", "ar_ci_high", "apl_m",
                       "bytes_per_robot", "compute_ms")


def leaderboard_columns(conditions: Iterable[str] = ()) -> tuple[str, ...]:
    """Every column of ``leaderboard.csv``: :data:`LEADERBOARD_COLUMNS`, the failure counts of
    the registered causes that apply to ``conditions``, then ``p_holm``."""
    conditions = tuple(conditions)
    causes = tuple(m.name for m in MEASURES.values()
                   if m.name.startswith("failures_") and m.applies(conditions))
    return (*LEADERBOARD_COLUMNS, *causes, "p_holm")


def _pooled(episodes: pd.DataFrame, suite: str) -> pd.DataFrame:
    """The rows with one env (the suite) and one map key per (env, map_seed), so that the
    bootstrap resamples the suite's maps, not map seeds shared by two envs."""
    keys = pd.MultiIndex.from_frame(episodes[["env", "map_seed"]])
    codes = pd.factorize(keys, sort=True)[0]
    return episodes.assign(env=suite, map_seed=codes)


def _compute_ms(timing: pd.DataFrame) -> dict[str, float]:
    """Per method: compute per robot-tick (ms) over its tasks."""
    if timing is None or not len(timing):
        return {}
    sums = timing.groupby("policy")[["compute_s", "robot_ticks"]].sum()
    return {m: (1000 * r.compute_s / r.robot_ticks if r.robot_ticks else np.nan)
            for m, r in sums.iterrows()}


def ranking(episodes: pd.DataFrame, timing: pd.DataFrame | None, *, suite: str) -> pd.DataFrame:
    """Every method of a suite's rows, ranked by SPL.

    Parameters
    ----------
    episodes : DataFrame
        Per-robot rows (the runner's columns) of every method on the suite's maps.
    timing : DataFrame, optional
        ``timing.csv`` rows of those tasks (:data:`fftnav.runner.run.TIMING_COLUMNS`).
    suite : str
        The suite's name (the ``suite`` column).

    Returns
    -------
    DataFrame
        :func:`leaderboard_columns`, one row per method, best SPL first. SPL, AR and APL are
        pooled over the suite's robots (a map counts by its robots), with 95 % percentile
        bootstrap intervals over maps (:func:`fftnav.runner.summary.summarize`); ``rank`` 1 is
        the best (ties share a rank); ``p_holm`` is the two-sided paired Wilcoxon signed-rank
        p of per-map SPL against the rank-1 method, Holm-adjusted over the others (NaN for
        rank 1).
    """
    pooled = _pooled(episodes, suite)
    summary = summarize(pooled).rename(columns={"policy": "method", "episodes": "maps"})
    summary["suite"] = suite
    compute = _compute_ms(timing)
    summary["compute_ms"] = [compute.get(m, np.nan) for m in summary["method"]]
    summary = summary.sort_values(["spl", "method"], ascending=[False, True],
                                  kind="stable").reset_index(drop=True)
    summary["rank"] = summary["spl"].round(9).rank(method="min", ascending=False).astype(int)
    best = summary["method"].iloc[0] if len(summary) else None
    per_map = pooled.pivot_table(index="map_seed", columns="policy", values="spl",
                                 aggfunc="mean")
    p = []
    for m in summary["method"]:
        if m == best:
            p.append(np.nan)
            continue
        pair = per_map[[best, m]].dropna()
        p.append(paired_gain((pair[best] - pair[m]).to_numpy())[3])
    summary["p_holm"] = holm(np.array(p, dtype=float)) if p else []
    return summary[list(leaderboard_columns())]


def rows_sha256(rows: pd.DataFrame) -> str:
    """SHA-256 of a method's rows as the runner writes them (CSV, fixed float format, sorted
    by env, map seed and robot): what ``fftnav leaderboard add`` recomputes to detect rows
    changed after the evaluation."""
    return hashlib.sha256(rows_csv(rows).encode()).hexdigest()


def method_sha256(resolved: Any) -> str:
    """The method's source hash: SHA-256 over its plugin files (the file and the modules beside
    it that it imported) or, for a module or entry point, its module's file; ``builtin`` plus
    the fftnav version for a built-in."""
    from fftnav import __version__
    from fftnav.plugins import source_file

    if not resolved.plugin:
        return f"builtin-{__version__}"
    if resolved.file is not None:
        files = list(plugin_sources(resolved.file))
    else:
        found = source_file(resolved.policy.decide if resolved.policy is not None
                            else resolved.controller)
        files = [found] if found is not None else []
    digest = hashlib.sha256()
    for path in files:
        digest.update(file_sha256(path).encode())
    return digest.hexdigest()


def _slug(method: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", method)


def submissions(folder: str | Path) -> list[tuple[dict[str, Any], dict[str, pd.DataFrame]]]:
    """The submissions kept in a leaderboard folder: ``(evaluation.json, {suite: rows})``;
    a suite's timing rows are under the key ``<suite>.timing``."""
    root = Path(folder) / "submissions"
    found = []
    if not root.is_dir():
        return found
    for sub in sorted(p for p in root.iterdir() if p.is_dir()):
        info = json.loads((sub / "evaluation.json").read_text(encoding="utf-8"))
        rows = {p.name.removesuffix(".csv"): read_episodes(p) for p in sorted(sub.glob("*.csv"))}
        found.append((info, rows))
    return found


def leaderboard_episodes(folder: str | Path | None = None, *,
                         suites: Sequence[str] | None = None,
                         references: str | Path | None = None
                         ) -> dict[str, tuple[pd.DataFrame, pd.DataFrame]]:
    """Each suite's rows and timing: every built-in's shipped references, with the rows of the
    submissions kept in ``folder`` (a submission of a built-in's name replaces its rows)."""
    chosen = [find_suite(s) for s in suites] if suites else ordered_suites()
    kept = submissions(folder) if folder is not None else []
    found = {}
    for suite in chosen:
        episodes, timing = read_references(suite, folder=references)
        extra = [rows[suite.name] for _, rows in kept if suite.name in rows]
        if extra:
            names = set().union(*(set(e["policy"]) for e in extra))
            episodes = pd.concat([episodes[~episodes["policy"].isin(names)], *extra],
                                 ignore_index=True)
            timing = pd.concat([timing[~timing["policy"].isin(names)],
                                *(rows[f"{suite.name}.timing"] for _, rows in kept
                                  if f"{suite.name}.timing" in rows)], ignore_index=True)
        found[suite.name] = (episodes, timing)
    return found


def build_leaderboard(folder: str | Path | None = None, *, suites: Sequence[str] | None = None,
                      references: str | Path | None = None) -> pd.DataFrame:
    """Every built-in on every suite (the shipped references), plus the submissions kept in
    ``folder``, ranked per suite: the table of ``leaderboard.csv``
    (:func:`rank_suites` of :func:`leaderboard_episodes`)."""
    return rank_suites(leaderboard_episodes(folder, suites=suites, references=references))


def rank_suites(found: Mapping[str, tuple[pd.DataFrame, pd.DataFrame]]) -> pd.DataFrame:
    """Each suite's ``(rows, timing)`` ranked (:func:`ranking`), one table in their order."""
    return pd.concat([ranking(episodes, timing, suite=name)
                      for name, (episodes, timing) in found.items()], ignore_index=True)


def add_submission(evaluation_dir: str | Path, folder: str | Path) -> str:
    """Keep the method of an ``fftnav evaluate`` folder in the leaderboard ``folder``, after
    checking it: its fftnav version is this one, each suite's version and pins are this
    fftnav's, the method's rows hash to what the evaluation recorded, and the method's source
    hash is recorded. Returns the method's name.

    Raises
    ------
    ValueError
        A folder that is not an evaluation, or any check that fails (named).
    """
    from fftnav import __version__
    from fftnav.files import write_atomic

    src = Path(evaluation_dir)
    record = src / "evaluation.json"
    if not record.is_file():
        raise FftnavError(f"evaluation_dir must be a folder written by fftnav evaluate (with "
                          f"evaluation.json), got evaluation_dir={str(src)!r}")
    try:
        info = json.loads(record.read_text(encoding="utf-8"))
        method, parts = info["method"], info["suites"]
    except (ValueError, KeyError, TypeError):
        raise FftnavError(f"{record} is damaged") from None
    if info.get("fftnav_version") != __version__:
        raise FftnavError(f"{record} was written by fftnav {info.get('fftnav_version')}, this "
                          f"is fftnav {__version__}: evaluate the method again with this one")
    if not info.get("method_sha256"):
        raise FftnavError(f"{record} has no method_sha256")
    rows_by_suite = {}
    for name, part in sorted(parts.items()):
        suite = _known_suite(name, record)
        pins = hashlib.sha256(pins_path(suite.name).read_bytes()).hexdigest()
        if part.get("pins_sha256") != pins:
            raise FftnavError(f"{record}: suite {name} was evaluated with other pins than this "
                              "fftnav's: evaluate the method again")
        rows = _suite_rows(src, suite, method)
        if rows_sha256(rows) != part.get("rows_sha256"):
            raise FftnavError(f"{record}: the rows of {method} on {name} are not those the "
                              "evaluation recorded (changed after it ran)")
        rows_by_suite[name] = rows
    dest = Path(folder) / "submissions" / _slug(method)
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    for name, rows in rows_by_suite.items():
        write_atomic(dest / f"{name}.csv", rows_csv(rows))
        timing = pd.concat([read_timing(src / "runs" / p.name) for p in SUITES[name].parts],
                           ignore_index=True)
        write_atomic(dest / f"{name}.timing.csv",
                     timing[timing["policy"] == method].to_csv(index=False, float_format="%.6g"))
    write_atomic(dest / "evaluation.json", record.read_text(encoding="utf-8"))
    return method


def _known_suite(name: str, record: Path) -> Suite:
    if name not in SUITES:
        raise FftnavError(f"{record}: suite {name!r} is not one of this fftnav's suites "
                          f"({', '.join(SUITES)}): it was retired or renamed")
    return SUITES[name]


def _suite_rows(src: Path, suite: Suite, method: str) -> pd.DataFrame:
    """The method's rows of a suite in an evaluation folder (pooled over its parts)."""
    parts = []
    for part in suite.parts:
        path = src / "runs" / part.name / "episodes.csv"
        if not path.is_file():
            raise FftnavError(f"{src} has no runs/{part.name}/episodes.csv")
        table = read_episodes(path)
        parts.append(table[table["policy"] == method])
    return pd.concat(parts, ignore_index=True)



