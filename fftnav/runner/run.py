"""Run an experiment into a folder: resumable, crash-isolated, atomic, deterministic.

Layout of the output folder ``DIR``:

- ``episodes/<env>-<map_seed>-<policy>.csv``: one file per finished task (its existence marks
  the task done; a rerun skips it), ``trajectories/<same>.npz`` for the figure maps;
- ``episodes.csv``: all finished tasks, rebuilt atomically after every completion, sorted by
  (env, map_seed, policy, robot), so it is byte-identical whatever the completion order, the
  worker count or the executor;
- ``reference/<env>-<map_seed>.npy``: the map's reference lengths (grid A*, geodesic), computed
  once per map before its episodes and shared by its policies;
- ``errors.csv`` (only if some tasks failed in this run), ``summary.csv``, ``paired_tests.csv``,
  ``config.toml`` (verbatim copy), ``config.json`` (canonical form: a rerun into the folder
  must have the same), ``run_info.json`` (versions, git revision, workers, wall time).
"""

from __future__ import annotations

import io
import json
import os
import platform
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from fftnav import __version__
from fftnav.episode.record import EPISODE_COLUMNS, EpisodeRow, episode_csv
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.executors import TaskError, TaskFunction, check_options, execute, guarded
from fftnav.runner.summary import paired_tests, summarize
from fftnav.runner.tasks import Task, TaskResult, make_tasks, map_reference, run_task

__all__ = ["CSV_COLUMNS", "RunOutcome", "run_experiment", "write_atomic"]

#: Columns of ``episodes.csv``: the task's keys, then the episode's per-robot columns.
CSV_COLUMNS: tuple[str, ...] = ("env", "map_seed", "policy", "episode_seed",
                                *(c for c in EPISODE_COLUMNS if c != "policy"))
#: Fixed float format so that CSVs are byte-identical across runs.
FLOAT_FORMAT = "%.6f"
ERROR_COLUMNS = ("env", "map_seed", "policy", "error_type", "message", "traceback")


@dataclass
class RunOutcome:
    """What one invocation did: task counts, failures (task, error) and wall time in seconds."""

    total: int
    skipped: int
    completed: int
    failed: list[tuple[Task, TaskError]] = field(default_factory=list)
    wall_time_s: float = 0.0


def write_atomic(path: Path, data: str | bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, then rename it over ``path``."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data.encode() if isinstance(data, str) else data)
    os.replace(tmp, path)


def run_experiment(
    config: ExperimentConfig,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    executor: str = "local",
    scheduler: str | None = None,
    task_fn: TaskFunction = run_task,
    progress: bool = True,
    fresh: bool = False,
) -> RunOutcome:
    """Run every unfinished task of ``config`` into ``out_dir`` and write the CSVs.

    Parameters
    ----------
    config : ExperimentConfig
    out_dir : str or Path
        Output folder; created if needed. A folder that holds results of a different config
        (its ``config.json``) is refused.
    workers, executor, scheduler
        See :func:`fftnav.runner.executors.execute`.
    task_fn : callable
        ``task_fn(config, task) -> TaskResult``; default :func:`run_task` (tests inject others).
    progress : bool
        Show a tqdm progress bar (episodes done / total, ETA) on stderr.
    fresh : bool
        Rerun every task, replacing finished ones as the new results arrive (default: resume,
        skipping the tasks that have a result file).

    Returns
    -------
    RunOutcome
        ``failed`` lists the tasks that raised; they are in ``errors.csv``, not in
        ``episodes.csv``, and a rerun retries them.
    """
    start = time.perf_counter()
    check_options(executor=executor, workers=workers, scheduler=scheduler)
    out = Path(out_dir)
    _check_same_experiment(config, out)
    for sub in ("episodes", "trajectories"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    write_atomic(out / "config.toml", config.source)
    tasks = make_tasks(config)
    todo = [t for t in tasks if fresh or not _task_csv(out, t).exists()]
    if task_fn is run_task:  # real episodes: each map's reference lengths computed once
        todo = _with_references(config, out, todo, executor=executor, workers=workers,
                                scheduler=scheduler, progress=progress)
    outcome = RunOutcome(total=len(tasks), skipped=len(tasks) - len(todo), completed=0)
    bar = tqdm(total=len(tasks), initial=outcome.skipped, unit="episode", desc=config.name,
               file=sys.stderr, disable=not progress, dynamic_ncols=True)
    try:
        for task, result in execute(task_fn, config, todo, executor=executor, workers=workers,
                                    scheduler=scheduler):
            if isinstance(result, TaskResult):
                result = guarded(_save_task, out, task, result)
            if isinstance(result, TaskError):
                outcome.failed.append((task, result))
                bar.set_postfix(failed=len(outcome.failed))
            else:
                outcome.completed += 1
                _write_episodes(out, tasks)
            bar.update()
    finally:
        bar.close()
        _write_episodes(out, tasks)
    _write_errors(out, outcome.failed)
    episodes = pd.read_csv(out / "episodes.csv")
    write_atomic(out / "summary.csv", summarize(episodes).to_csv(index=False,
                                                                  float_format=FLOAT_FORMAT))
    write_atomic(out / "paired_tests.csv", paired_tests(episodes).to_csv(
        index=False, float_format="%.6g"))  # p-values can be far below 1e-6
    outcome.wall_time_s = time.perf_counter() - start
    info = run_info(outcome, workers=workers, executor=executor, scheduler=scheduler)
    previous = out / "run_info.json"
    earlier = 0.0 if fresh or not previous.exists() else json.loads(
        previous.read_text()).get("wall_time_total_s", 0.0)
    info["wall_time_total_s"] = round(earlier + outcome.wall_time_s, 3)
    write_atomic(previous, json.dumps(info, indent=2))
    return outcome


def run_info(outcome: RunOutcome, *, workers: int | None, executor: str,
             scheduler: str | None) -> dict[str, object]:
    """Versions, git revision, executor and timing of this invocation (kept out of the CSVs)."""
    def pkg(name: str) -> str:
        try:
            return version(name)
        except PackageNotFoundError:
            return "not installed"

    return {
        "fftnav_version": pkg("fftnav"),
        "git_revision": git_revision(),
        "python": platform.python_version(),
        "numpy": pkg("numpy"),
        "scipy": pkg("scipy"),
        "pybullet": pkg("pybullet"),
        "platform": platform.platform(),
        "cpu_count": os.cpu_count(),
        "executor": executor,
        "workers": None if scheduler else workers or os.cpu_count(),  # remote: the cluster's
        "scheduler": scheduler,
        "tasks_total": outcome.total,
        "tasks_skipped": outcome.skipped,
        "tasks_completed": outcome.completed,
        "tasks_failed": len(outcome.failed),
        "wall_time_s": round(outcome.wall_time_s, 3),
    }


def git_revision() -> str:
    """The git revision of the fftnav source, when it runs from a git checkout of it.

    ``git rev-parse HEAD`` (``-dirty`` if files under ``fftnav/`` are modified) of the
    repository whose top level holds this ``fftnav`` package; ``unknown`` for an installed wheel
    (even one installed into a virtualenv inside some repository), without git, or on any error.
    """
    package = Path(__file__).resolve().parents[1]
    root = package.parent

    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True,
                              check=True, timeout=10).stdout.strip()

    try:
        if Path(git("rev-parse", "--show-toplevel")).resolve() != root:
            return "unknown"
        head = git("rev-parse", "HEAD")
        dirty = git("status", "--porcelain", "--", package.name)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return head + ("-dirty" if dirty else "")


def _check_same_experiment(config: ExperimentConfig, out: Path) -> None:
    """Refuse a folder whose ``config.json`` (canonical config without ``out``, the fftnav
    version and the CSV columns that wrote it) differs: resuming must not mix configs, code
    versions or columns. A folder written with other columns is refused naming them."""
    record = out / "config.json"
    canonical = json.dumps({**asdict(config), "out": None, "source": None,
                            "fftnav_version": __version__, "csv_columns": list(CSV_COLUMNS)},
                           indent=1, sort_keys=True)
    if record.exists():
        text = record.read_text()
        try:
            columns = json.loads(text).get("csv_columns")
        except (ValueError, AttributeError):
            columns = None
        episodes = out / "episodes.csv"
        if columns is None and episodes.exists():  # a folder written before columns were kept
            columns = episodes.read_text().split("\n", 1)[0].split(",")
        if columns is not None and tuple(columns) != CSV_COLUMNS:
            missing = [c for c in CSV_COLUMNS if c not in columns]
            extra = [c for c in columns if c not in CSV_COLUMNS]
            raise ValueError(f"{out} holds episodes with other columns than this fftnav writes "
                             f"(missing {missing}, extra {extra}"
                             f"{', or in another order' if not missing + extra else ''}); "
                             "use another --out")
        if text != canonical:
            raise ValueError(f"{out} holds results of a different experiment config or fftnav "
                             f"version ({record}); use another --out")
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(record, canonical)


def _with_references(config: ExperimentConfig, out: Path, todo: list[Task], *,
                     progress: bool, **options: object) -> list[Task]:
    """``todo`` with every map's reference lengths attached.

    The grid A* and geodesic lengths of a map are the same for all its policies and cost about
    as much as an episode: they are computed once per map, in parallel on the executor
    (:func:`fftnav.runner.tasks.map_reference`), before the episodes, and kept in
    ``reference/<env>-<map_seed>.npy`` (a resumed run reuses them). A map whose lengths fail
    (an unreachable goal) is left to its episodes, which fail with the same error.
    """
    folder = out / "reference"
    folder.mkdir(exist_ok=True)

    def path(env: str, map_seed: int) -> Path:
        return folder / f"{env}-{map_seed}.npy"

    maps = sorted({(t.env, t.map_seed) for t in todo})
    missing = [Task(env, seed, "", 0, False) for env, seed in maps if not path(env, seed).exists()]
    bar = tqdm(total=len(missing), unit="map", desc="reference lengths", file=sys.stderr,
               disable=not progress or not missing, dynamic_ncols=True)
    try:
        for task, result in execute(map_reference, config, missing, **options):
            if isinstance(result, np.ndarray):
                buffer = io.BytesIO()
                np.save(buffer, result)
                write_atomic(path(task.env, task.map_seed), buffer.getvalue())
            bar.update()
    finally:
        bar.close()
    known = {m: np.load(path(*m)) for m in maps if path(*m).exists()}
    return [t if (t.env, t.map_seed) not in known else
            replace(t, reference=tuple(tuple(row.tolist()) for row in known[t.env, t.map_seed]))
            for t in todo]


def _task_csv(out: Path, task: Task) -> Path:
    return out / "episodes" / f"{task.task_id}.csv"


def _save_task(out: Path, task: Task, result: TaskResult) -> TaskResult:
    """Write the trajectories (if kept), then the task's CSV, which marks the task done."""
    if result.trajectories is not None:
        buffer = io.BytesIO()
        np.savez_compressed(buffer, *result.trajectories)
        write_atomic(out / "trajectories" / f"{task.task_id}.npz", buffer.getvalue())
    if not result.rows:
        raise ValueError(f"task {task.task_id} returned no rows")
    wrong = [type(row).__name__ for row in result.rows if not isinstance(row, EpisodeRow)]
    if wrong:
        raise ValueError(f"task {task.task_id} returned rows of type {wrong[0]}, not EpisodeRow")
    keys = {"env": task.env, "map_seed": task.map_seed, "policy": task.policy,
            "episode_seed": task.episode_seed}
    rows = sorted(({**row.as_dict(), **keys} for row in result.rows), key=lambda r: r["robot"])
    write_atomic(_task_csv(out, task), episode_csv(rows, columns=CSV_COLUMNS, header=False))
    return result


def _write_episodes(out: Path, tasks: list[Task]) -> None:
    """Rebuild ``episodes.csv`` from the finished tasks' files, in task order."""
    parts = [",".join(CSV_COLUMNS) + "\n"]
    parts += [p.read_text() for p in (_task_csv(out, t) for t in tasks) if p.exists()]
    write_atomic(out / "episodes.csv", "".join(parts))


def _write_errors(out: Path, failed: list[tuple[Task, TaskError]]) -> None:
    path = out / "errors.csv"
    if not failed:
        path.unlink(missing_ok=True)
        return
    table = pd.DataFrame(
        [(t.env, t.map_seed, t.policy, e.error_type, e.message, e.traceback)
         for t, e in sorted(failed, key=lambda item: item[0])],
        columns=list(ERROR_COLUMNS))
    write_atomic(path, table.to_csv(index=False))
