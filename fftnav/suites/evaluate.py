"""Rank one method on versioned suites beside every built-in: ``fftnav evaluate``.

:func:`evaluate` runs only the method on a suite's maps (through the runner: resumable, on any
executor), checks the suite's shipped reference rows before trusting them
(:func:`check_references`: a sample of reference episodes rerun here must give the same rows
byte for byte), joins them, and ranks every method (:func:`ranking`), with the paired Wilcoxon
signed-rank test of the method against every built-in on the same maps, Holm-adjusted
(:func:`paired_against`).

Output folder ``OUT``:

- ``runs/<suite>/``: the runner's folder of the method on each suite of its own maps (its
  ``episodes.csv``, ``timing.csv``, the recordings of failed episodes in ``records/``);
- ``references/<suite>/``: the built-ins rerun here, only when the shipped rows did not
  reproduce on this machine;
- ``leaderboard.csv`` (:data:`fftnav.suites.leaderboard.LEADERBOARD_COLUMNS`), ``tests.csv``
  (:data:`TEST_COLUMNS`), ``report.md`` and ``evaluation.json`` (what ``fftnav leaderboard
  add`` checks: suite versions and pins, fftnav version, the method's source hash and the hash
  of its rows).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from fftnav.runner.config import ExperimentConfig
from fftnav.runner.rerun import first_difference, task_lines
from fftnav.runner.run import read_episodes, read_timing, run_experiment
from fftnav.runner.summary import holm, paired_gain, wilcoxon_method
from fftnav.runner.tasks import Task, episode_seed, run_task
from fftnav.suites import (
    ReferenceError,
    Suite,
    builtin_methods,
    read_references,
    reference_lines,
    resolve_suites,
)
from fftnav.suites.leaderboard import method_sha256, ranking, rows_sha256

__all__ = ["TEST_COLUMNS", "Evaluation", "Options", "ReferenceCheck", "SuiteResult",
           "check_references", "evaluate", "paired_against", "run_references"]

#: Columns of ``tests.csv``: the method against one built-in on one suite's maps.
TEST_COLUMNS = ("suite", "method", "against", "maps", "spl_method", "spl_against", "mean_diff",
                "diff_ci_low", "diff_ci_high", "p_value", "p_holm", "p_method")


@dataclass(frozen=True)
class ReferenceCheck:
    """What rerunning a sample of a suite's reference episodes here found.

    Attributes
    ----------
    suite : str
    method : str
        The built-in whose episodes were rerun.
    tasks : tuple of str
        The tasks rerun (``env-map_seed-method``).
    same : bool
        Whether every rerun gave the shipped rows byte for byte.
    detail : str
        The first difference, in words (empty when ``same``).
    compute_ms_here, compute_ms_shipped : float
        That built-in's compute per robot-tick on these tasks, measured here and as shipped:
        their ratio scales the shipped compute of the other built-ins to this machine.
    """

    suite: str
    method: str
    tasks: tuple[str, ...]
    same: bool
    detail: str = ""
    compute_ms_here: float = float("nan")
    compute_ms_shipped: float = float("nan")

    @property
    def line(self) -> str:
        """One line: what was rerun and whether it reproduced."""
        if self.same:
            return (f"references of {self.suite} reproduce here: {', '.join(self.tasks)} "
                    "rerun, rows identical byte for byte")
        return (f"references of {self.suite} do not reproduce here ({self.detail}): another "
                "platform or library version")


@dataclass
class SuiteResult:
    """One suite of an evaluation: every method's rows, the ranking and the tests."""

    suite: Suite
    episodes: pd.DataFrame
    timing: pd.DataFrame
    table: pd.DataFrame
    tests: pd.DataFrame
    checks: list[ReferenceCheck] = field(default_factory=list)
    run_dirs: list[Path] = field(default_factory=list)


@dataclass
class Evaluation:
    """What :func:`evaluate` made: the method's name (as its rows carry it) and the suites."""

    method: str
    reference: str
    out: Path
    suites: list[SuiteResult]

    @property
    def table(self) -> pd.DataFrame:
        """Every suite's ranking, one table (``leaderboard.csv``)."""
        return pd.concat([s.table for s in self.suites], ignore_index=True)

    @property
    def tests(self) -> pd.DataFrame:
        """Every suite's tests, one table (``tests.csv``)."""
        return pd.concat([s.tests for s in self.suites], ignore_index=True)


def _sample_method(method: str) -> str:
    """The built-in whose reference episodes are rerun: ``bug-left`` (the paper's baseline,
    and the fastest), or ``bug-right`` when ``bug-left`` is the method evaluated."""
    return "bug-right" if method == "bug-left" else "bug-left"


def _sample_tasks(config: ExperimentConfig, method: str, sample: int) -> list[Task]:
    """``sample`` tasks of ``method``: the first map of each env in turn, then the last."""
    envs = sorted(config.envs)
    seeds = [config.map_seed, config.map_seed + config.maps - 1]
    picks = [(envs[i % len(envs)], seeds[(i // len(envs)) % 2]) for i in range(sample)]
    return [Task(env, s, method, episode_seed(env, s), False)
            for env, s in dict.fromkeys(picks)]


def check_references(suite: Suite, *, method: str, sample: int = 2,
                     folder: str | Path | None = None) -> ReferenceCheck:
    """Rerun ``sample`` reference episodes of one built-in (not ``method``) on ``suite`` (a
    suite of its own maps) and compare their rows with the shipped ones byte for byte.

    Raises
    ------
    fftnav.suites.ReferenceError
        The shipped rows are missing or were changed after they were made (checksum).
    """
    builtin = _sample_method(method)
    config = dataclasses.replace(suite.experiment([builtin]), record="none")
    timing = read_references(suite, folder=folder)[1]
    seconds = ticks = 0.0
    names = []
    for task in _sample_tasks(config, builtin, sample):
        shipped = reference_lines(suite, builtin, task.env, task.map_seed,
                                  folder=folder).splitlines()
        result = run_task(config, task)
        names.append(task.task_id)
        here = task_lines(task, result)
        if here != shipped:
            return ReferenceCheck(suite.name, builtin, tuple(names), False,
                                  f"{task.task_id}: {first_difference(shipped, here)}")
        if result.compute is not None:
            seconds += result.compute[0]
            ticks += result.compute[1]
    rerun = {(t.env, t.map_seed) for t in _sample_tasks(config, builtin, sample)}
    keys = zip(timing["env"], timing["map_seed"], strict=True)
    rows = timing[(timing["policy"] == builtin).to_numpy() & np.array([k in rerun for k in keys])]
    shipped_ms = (1000 * rows["compute_s"].sum() / rows["robot_ticks"].sum()
                  if len(rows) and rows["robot_ticks"].sum() else float("nan"))
    return ReferenceCheck(suite.name, builtin, tuple(names), True,
                          compute_ms_here=1000 * seconds / ticks if ticks else float("nan"),
                          compute_ms_shipped=shipped_ms)


def paired_against(episodes: pd.DataFrame, method: str, *, suite: str,
                   against: Sequence[str]) -> pd.DataFrame:
    """The paired Wilcoxon signed-rank test of ``method`` against each of ``against`` on the
    maps both ran (per-map mean SPL; maps keyed by env and map seed), Holm-adjusted over
    ``against`` as one family (:func:`fftnav.runner.summary.holm`).

    Returns
    -------
    DataFrame
        :data:`TEST_COLUMNS`; ``mean_diff`` is method - other (SPL fraction) with its 95 %
        bootstrap interval over maps, ``p_method`` says how p was computed
        (:func:`fftnav.runner.summary.paired_gain`).
    """
    per_map = episodes.pivot_table(index=["env", "map_seed"], columns="policy", values="spl",
                                   aggfunc="mean")
    rows = []
    for other in against:
        if other == method or other not in per_map.columns or method not in per_map.columns:
            continue
        pair = per_map[[method, other]].dropna()
        diff = (pair[method] - pair[other]).to_numpy()
        gain, low, high, p = paired_gain(diff)
        rows.append((suite, method, other, len(pair), pair[method].mean(), pair[other].mean(),
                     gain, low, high, p, np.nan, _p_method(diff)))
    table = pd.DataFrame(rows, columns=list(TEST_COLUMNS))
    if len(table):
        table["p_holm"] = holm(table["p_value"].to_numpy(dtype=float))
    return table


def _p_method(diff: np.ndarray) -> str:
    """How p is computed for these differences (:func:`fftnav.runner.summary.wilcoxon_method`),
    in words."""
    return wilcoxon_method(diff) or "no test: every difference 0"


def _method_rows(run_dir: Path, name: str) -> pd.DataFrame:
    episodes = read_episodes(run_dir / "episodes.csv")
    return episodes[episodes["policy"] == name]


@dataclass(frozen=True)
class Options:
    """How :func:`evaluate` runs.

    Attributes
    ----------
    workers, executor, scheduler
        Where the episodes run (:func:`fftnav.runner.executors.execute`).
    progress : bool
        Progress bars on stderr.
    rerun : bool
        When the shipped references do not reproduce here, rerun them (True) or refuse
        (False: a ValueError).
    sample : int
        Reference episodes rerun per suite to check them (>= 1).
    references : str or Path, optional
        A folder of reference rows (``<suite>/``) to use instead of the package's.
    """

    workers: int | None = None
    executor: str = "local"
    scheduler: str | None = None
    progress: bool = True
    rerun: bool = True
    sample: int = 2
    references: str | Path | None = None

    def run(self) -> dict[str, object]:
        """The options of :func:`fftnav.runner.run.run_experiment`."""
        return {"workers": self.workers, "executor": self.executor,
                "scheduler": self.scheduler, "progress": self.progress}


def evaluate(method: str, suites: Sequence[str], out: str | Path, *,
             options: Options | None = None,
             say: Callable[[str], None] | None = None) -> Evaluation:
    """Run ``method`` on ``suites`` into ``out`` and rank it beside every built-in.

    Parameters
    ----------
    method : str
        A built-in name, ``module:attr``, ``path/to/file.py:attr`` or an entry point.
    suites : sequence of str
        Suite names or families (:func:`fftnav.suites.find_suite`).
    out : str or Path
        Output folder (module docstring); a rerun resumes it.
    options : Options, optional
        Executor, progress, what to do with references that do not reproduce.
    say : callable, optional
        Receives the one-line notes (reference checks) as they happen.

    Returns
    -------
    Evaluation
    """
    from fftnav.navigation.resolve import resolve
    from fftnav.validate import check_integer

    options = options or Options()
    check_integer("sample", options.sample, low=1)
    say = say or (lambda text: None)
    chosen = resolve_suites(suites)
    name = resolve(method).name
    out = Path(out)
    results = []
    parts_done: dict[str, tuple[pd.DataFrame, pd.DataFrame, ReferenceCheck, Path]] = {}
    for suite in chosen:
        suite.check()
        for part in suite.parts:
            if part.name not in parts_done:
                part.check()
                parts_done[part.name] = _run_part(part, method, name, out,
                                                  options=options, say=say)
        episodes = pd.concat([parts_done[p.name][0] for p in suite.parts], ignore_index=True)
        timing = pd.concat([parts_done[p.name][1] for p in suite.parts], ignore_index=True)
        table = ranking(episodes, timing, suite=suite.name)
        others = [m for m in table["method"] if m != name]
        results.append(SuiteResult(
            suite, episodes, timing, table,
            paired_against(episodes, name, suite=suite.name, against=others),
            checks=[parts_done[p.name][2] for p in suite.parts],
            run_dirs=[parts_done[p.name][3] for p in suite.parts]))
    evaluation = Evaluation(name, method, out, results)
    _write_outputs(evaluation)
    return evaluation


def _run_part(part: Suite, method: str, name: str, out: Path, *, options: Options,
              say: Callable[[str], None]
              ) -> tuple[pd.DataFrame, pd.DataFrame, ReferenceCheck, Path]:
    """Run the method on one suite of its own maps, check and join the references."""
    folder = None if options.references is None else Path(options.references) / part.name
    check = check_references(part, method=name, sample=options.sample, folder=folder)
    say(check.line)
    if check.same:
        shipped, shipped_timing = read_references(part, folder=folder)
    elif not options.rerun:
        raise ReferenceError(f"{check.line}; --no-rerun refuses to run them here")
    else:
        say(f"rerunning every built-in on {part.name} into {out / 'references' / part.name}")
        shipped, shipped_timing = run_references(
            part, out / "references" / part.name, options=options,
            methods=[m for m in builtin_methods() if m != name])
    run_dir = out / "runs" / part.name
    run_experiment(part.experiment([method]), run_dir, **options.run())
    mine = _method_rows(run_dir, name)
    mine_timing = read_timing(run_dir)
    keep = shipped["policy"] != name
    episodes = pd.concat([shipped[keep], mine], ignore_index=True)
    timing = pd.concat([shipped_timing[shipped_timing["policy"] != name], mine_timing],
                       ignore_index=True)
    return episodes, timing, check, run_dir


def run_references(suite: Suite, run_dir: str | Path, *, options: Options | None = None,
                   methods: Sequence[str] | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Run ``methods`` (default: every built-in) on a suite of its own maps into ``run_dir``
    (a results folder, resumable; no recordings) and return their rows and timing: the
    reference rows (:func:`fftnav.suites.write_references` ships them)."""
    options = options or Options()
    config = dataclasses.replace(suite.experiment(list(methods or builtin_methods())),
                                 record="none")
    run_experiment(config, run_dir, **options.run())
    return read_episodes(Path(run_dir) / "episodes.csv"), read_timing(run_dir)


def _write_outputs(evaluation: Evaluation) -> None:
    """``leaderboard.csv``, ``tests.csv`` and ``evaluation.json`` of an evaluation."""
    from fftnav import __version__
    from fftnav.files import write_atomic
    from fftnav.navigation.resolve import resolve
    from fftnav.suites import pins_path

    out = evaluation.out
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(out / "leaderboard.csv", evaluation.table.to_csv(index=False,
                                                                  float_format="%.6g"))
    write_atomic(out / "tests.csv", evaluation.tests.to_csv(index=False, float_format="%.6g"))
    info = {
        "fftnav_version": __version__,
        "method": evaluation.method,
        "reference": evaluation.reference,
        "method_sha256": method_sha256(resolve(evaluation.reference)),
        "suites": {
            s.suite.name: {
                "pins_sha256": hashlib.sha256(pins_path(s.suite.name).read_bytes()).hexdigest(),
                "parts": [p.name for p in s.suite.parts],
                "rows_sha256": rows_sha256(s.episodes[s.episodes["policy"]
                                                      == evaluation.method]),
                "reference_checks": [dataclasses.asdict(c) for c in s.checks],
            } for s in evaluation.suites},
    }
    write_atomic(out / "evaluation.json", json.dumps(_plain(info), indent=1, sort_keys=True)
                 + "\n")


def _plain(value: object) -> object:
    """``value`` with NaN as None and numpy scalars as Python's (strict JSON)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value
