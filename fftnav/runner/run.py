"""Run an experiment into a folder: resumable, crash-isolated, atomic, deterministic.

Layout of the output folder ``DIR``:

- ``episodes/<env>-<map_seed>-<policy>.csv``: one file per finished task (a rerun skips a task
  whose file passes :func:`fftnav.runner.resume.task_file_problem`, and reruns it otherwise),
  ``trajectories/<same>.npz`` for the figure maps;
- ``records/<same>.npz``: the episodes' recordings that ``[record] episodes`` keeps (by default
  those in which a robot did not arrive; :mod:`fftnav.episode.recording`); a resume reruns a
  finished task whose wanted recording is missing;
- ``episodes.csv``: all finished tasks, rebuilt atomically now and then during the run, on
  interruption and at the end, sorted by (env, map_seed, policy, robot), so it is
  byte-identical whatever the completion order, the worker count or the executor;
- ``.lock`` (one run at a time), ``.invocation-PID.json`` (the wall time of a killed run);
- ``reference/<env>-<map_seed>.npy``: the map's reference lengths (grid A*, geodesic), computed
  once per map, 256 maps at a time just before their episodes, and shared by its policies;
- ``maps.csv``: every map's difficulty measures per robot (:mod:`fftnav.runner.maps`), written
  when missing or not of the config's maps (a resume keeps it; real episodes only, not with
  an injected ``task_fn``);
- ``timing/<same>.json`` and ``timing.csv`` (:data:`TIMING_COLUMNS`): each finished task's
  compute, the FFT pipeline and controller wall-clock seconds and robot-ticks
  (:attr:`fftnav.episode.EpisodeResult.compute_ms`); the one output that is not deterministic
  (it depends on the machine and its load), so it is kept out of every other file;
- ``errors.csv`` (only if some tasks failed in this run), ``summary.csv``, ``paired_tests.csv``,
  ``config.toml`` (verbatim copy), ``config.json`` (canonical form: a rerun into the folder
  must have the same), ``run_info.json`` (versions, git revision, workers, wall time).
"""

from __future__ import annotations

import io
import itertools
import json
import os
import platform
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from fftnav.episode.record import EPISODE_COLUMNS, EpisodeRow, episode_csv
from fftnav.episode.recording import read_recording
from fftnav.errors import FftnavError
from fftnav.files import atomic_writer, write_atomic
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.executors import TaskError, TaskFunction, check_options, execute, guarded
from fftnav.runner.maps import maps_current, write_maps_csv
from fftnav.runner.resume import (
    FolderLock,
    InvocationClock,
    check_same_experiment,
    remove_stale_temporaries,
    task_file_problem,
)
from fftnav.runner.summary import paired_tests, summarize
from fftnav.runner.tasks import (
    Task,
    TaskResult,
    iter_tasks,
    map_reference,
    run_task,
    task_count,
)

__all__ = ["CSV_COLUMNS", "TIMING_COLUMNS", "RunOutcome", "read_timing", "run_experiment"]

#: Columns of ``episodes.csv``: the task's keys, then the episode's per-robot columns.
CSV_COLUMNS: tuple[str, ...] = ("env", "map_seed", "policy", "episode_seed",
                                *(c for c in EPISODE_COLUMNS if c != "policy"))
#: Fixed float format so that CSVs are byte-identical across runs.
FLOAT_FORMAT = "%.6f"
ERROR_COLUMNS = ("env", "map_seed", "policy", "error_type", "message", "traceback")
#: Columns of ``timing.csv``: a task's compute seconds, robot-ticks and ms per robot-tick.
TIMING_COLUMNS = ("env", "map_seed", "policy", "compute_s", "robot_ticks", "compute_ms")
#: Maps whose reference lengths are computed together, just before their episodes: the first
#: episodes start after 256 maps' lengths, however many maps the experiment has.
REFERENCE_BATCH_MAPS = 256


@dataclass
class RunOutcome:
    """What one invocation did: task counts, failures (task, error) and wall time in seconds."""

    total: int
    skipped: int
    completed: int
    failed: list[tuple[Task, TaskError]] = field(default_factory=list)
    wall_time_s: float = 0.0


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
        (its ``config.json``) is refused naming what changed, unless ``fresh``
        (:func:`fftnav.runner.resume.check_same_experiment`).
    workers, executor, scheduler
        See :func:`fftnav.runner.executors.execute`.
    task_fn : callable
        ``task_fn(config, task) -> TaskResult``; default :func:`run_task` (tests inject others).
    progress : bool
        Show a tqdm progress bar (episodes done / total, ETA) on stderr.
    fresh : bool
        Rerun every task from scratch (default: resume, skipping the tasks that have a result
        file). Results of another config in ``out_dir`` are deleted first; those of the same
        config are replaced as the new results arrive.

    Returns
    -------
    RunOutcome
        ``failed`` lists the tasks that raised; they are in ``errors.csv``, not in
        ``episodes.csv``, and a rerun retries them.
    """
    start = time.perf_counter()
    check_options(executor=executor, workers=workers, scheduler=scheduler)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise FftnavError(f"--out must be a folder, got {str(out)!r}, a file")
    out.mkdir(parents=True, exist_ok=True)
    with FolderLock(out):
        remove_stale_temporaries(out)
        check_same_experiment(config, out, columns=CSV_COLUMNS, fresh=fresh)
        clock = InvocationClock(out)
        earlier_killed = clock.begin()
        options = {"executor": executor, "workers": workers, "scheduler": scheduler}
        outcome = _run_tasks(config, out, options=options, task_fn=task_fn, progress=progress,
                             fresh=fresh, clock=clock)
        _write_errors(out, outcome.failed)
        _write_timing(out, config)
        episodes = read_episodes(out / "episodes.csv")
        order = {"envs": config.envs, "policies": config.policy_names}
        write_atomic(out / "summary.csv", summarize(
            episodes, **order, conditions=config.swarm.conditions).to_csv(
            index=False, float_format=FLOAT_FORMAT))
        write_atomic(out / "paired_tests.csv", paired_tests(episodes, **order).to_csv(
            index=False, float_format="%.6g"))  # p-values can be far below 1e-6
        if task_fn is run_task and (fresh or not maps_current(out, config)):
            write_maps_csv(out, config, executor=executor, workers=workers, scheduler=scheduler)
        outcome.wall_time_s = time.perf_counter() - start
        info = run_info(outcome, workers=workers, executor=executor, scheduler=scheduler)
        earlier = 0.0 if fresh else _earlier_wall_time(out) + earlier_killed
        info["wall_time_total_s"] = round(earlier + outcome.wall_time_s, 3)
        write_atomic(out / "run_info.json", json.dumps(info, indent=2))
        clock.end()
    return outcome


def _earlier_wall_time(out: Path) -> float:
    """The wall time of the folder's finished invocations (its ``run_info.json``); 0 without
    it, or when it is damaged (that time is lost, nothing else)."""
    try:
        return float(json.loads((out / "run_info.json").read_text()).get("wall_time_total_s",
                                                                          0.0))
    except (OSError, ValueError, AttributeError, TypeError):
        return 0.0


def _run_tasks(config: ExperimentConfig, out: Path, *, options: dict[str, object],
               task_fn: TaskFunction, progress: bool, fresh: bool,
               clock: InvocationClock) -> RunOutcome:
    """Run the unfinished tasks, :data:`REFERENCE_BATCH_MAPS` maps at a time (enumerated
    lazily, O(1) bookkeeping per finished episode) on the executor ``options``
    (:func:`~fftnav.runner.executors.execute`): with real episodes, each batch's reference
    lengths are computed just before its episodes. ``episodes.csv`` is rebuilt now and then
    (at most ~5 % of the time) and at the end, even on interruption."""
    for sub in ("episodes", "trajectories", "records", "timing"):
        _result_folder(out / sub)
    write_atomic(out / "config.toml", config.source)
    real = task_fn is run_task  # real episodes: each map's reference lengths computed once
    if real:
        _reference_folder(out, fresh=fresh)
    track = _Progress(config, out, clock, progress=progress)
    try:
        for batch in _map_batches(config):
            todo = _unfinished(config, out, batch, fresh=fresh, real=real, track=track)
            if real and todo:
                track.bar.set_description(f"{config.name} (reference lengths)")
                _compute_references(config, out, todo, **options)
                track.bar.set_description(config.name)
                todo = [_with_reference(out, task) for task in todo]
            if todo:  # a finished batch starts no workers
                _run_batch(task_fn, config, out, todo, options=options, track=track)
    finally:
        track.close()
    return track.outcome


class _Progress:
    """A run's bookkeeping: the outcome's counts, the progress bar, the invocation's clock and
    the rebuilds of ``episodes.csv``."""

    def __init__(self, config: ExperimentConfig, out: Path, clock: InvocationClock, *,
                 progress: bool) -> None:
        self.outcome = RunOutcome(total=task_count(config), skipped=0, completed=0)
        self.bar = tqdm(total=self.outcome.total, unit="episode", desc=config.name,
                        file=sys.stderr, disable=not progress, dynamic_ncols=True)
        self.clock, self.rebuilt = clock, _EpisodesRebuild(out, config)

    def skipped(self) -> None:
        self.outcome.skipped += 1
        self.bar.update()

    def finished(self, task: Task, result: TaskResult | TaskError) -> None:
        if isinstance(result, TaskError):
            self.outcome.failed.append((task, result))
            self.bar.set_postfix(failed=len(self.outcome.failed))
        else:
            self.outcome.completed += 1
            self.clock.tick()
            self.rebuilt.maybe()
        self.bar.update()

    def close(self) -> None:
        self.bar.close()
        self.clock.tick()
        self.rebuilt.now()


def _unfinished(config: ExperimentConfig, out: Path, batch: list[Task], *, fresh: bool,
                real: bool, track: _Progress) -> list[Task]:
    """The tasks of ``batch`` to run: all with ``fresh`` (their recordings removed), else those
    without trusted files (:func:`_trusted`; the others counted as skipped)."""
    todo = []
    for task in batch:
        if not fresh and _trusted(out, config, task, records=real):
            track.skipped()
        else:
            if fresh:  # an earlier recording would outlive an episode that now arrives
                record_path(out, task).unlink(missing_ok=True)
            todo.append(task)
    return todo


def _run_batch(task_fn: TaskFunction, config: ExperimentConfig, out: Path, todo: list[Task], *,
               options: dict[str, object], track: _Progress) -> None:
    """Run ``todo`` on the executor, saving each result as it comes (:func:`_save_task`)."""
    results = execute(task_fn, config, todo, **options)
    try:
        for task, result in results:
            if isinstance(result, TaskResult):
                result = guarded(_save_task, out, task, result)
            track.finished(task, result)
    finally:
        results.close()  # stops the workers now if interrupted


def _map_batches(config: ExperimentConfig) -> Iterator[list[Task]]:
    """The tasks of :func:`~fftnav.runner.tasks.iter_tasks` in lists of the tasks of
    :data:`REFERENCE_BATCH_MAPS` maps (the last list may hold fewer), in task order."""
    batch: list[Task] = []
    maps = 0
    for _, tasks in itertools.groupby(iter_tasks(config), key=lambda t: (t.env, t.map_seed)):
        if maps == REFERENCE_BATCH_MAPS:
            yield batch
            batch, maps = [], 0
        batch.extend(tasks)
        maps += 1
    if batch:
        yield batch


class _EpisodesRebuild:
    """Rebuilds ``episodes.csv`` (O(tasks)) only when the time since the last rebuild is 20
    times what the last one took (and at least 2 s): at most ~5 % of the run's time."""

    def __init__(self, out: Path, config: ExperimentConfig) -> None:
        self.out, self.config = out, config
        self.last, self.cost = time.perf_counter(), 0.0

    def maybe(self) -> None:
        if time.perf_counter() - self.last >= max(2.0, 20 * self.cost):
            self.now()

    def now(self) -> None:
        begin = time.perf_counter()
        _write_episodes(self.out, self.config)
        self.last = time.perf_counter()
        self.cost = self.last - begin


def _trusted(out: Path, config: ExperimentConfig, task: Task, *, records: bool) -> bool:
    """Whether a finished task's files pass the check and, with ``records`` (real episodes),
    the recording it should keep is there; a file that fails is reported once (one line on
    stderr) and the task rerun."""
    path = _task_csv(out, task)
    if not path.exists():
        return False
    npz = out / "trajectories" / f"{task.task_id}.npz" if task.keep_trajectories else None
    problem = task_file_problem(path, npz, task, robots=config.robots, columns=CSV_COLUMNS)
    if problem is None:
        return not (records and _recording_missing(out, config, task, path))
    sys.stderr.write(f"fftnav run: rerunning {task.task_id}: {path} cannot be trusted "
                     f"({problem})\n")
    return False


def read_episodes(path: Path) -> pd.DataFrame:
    """``episodes.csv`` as a table; a damaged file is a ValueError naming it."""
    try:
        return pd.read_csv(path)
    except (ValueError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise FftnavError(f"{path}: damaged CSV: {str(exc).strip().splitlines()[0]}") from None


def run_info(outcome: RunOutcome, *, workers: int | None, executor: str,
             scheduler: str | None) -> dict[str, object]:
    """Versions, git revision, executor and timing of this invocation (kept out of the CSVs).
    The fftnav version is the running package's ``fftnav.__version__`` (not the install's
    metadata, which an editable install keeps from when it was installed)."""
    import fftnav

    def pkg(name: str) -> str:
        try:
            return version(name)
        except PackageNotFoundError:
            return "not installed"

    return {
        "fftnav_version": fftnav.__version__,
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


def _reference_path(out: Path, env: str, map_seed: int) -> Path:
    return out / "reference" / f"{env}-{map_seed}.npy"


def _reference_folder(out: Path, *, fresh: bool) -> None:
    """Make ``reference/`` (emptied first if ``fresh``: every length is computed again)."""
    folder = out / "reference"
    if fresh and folder.is_dir():
        shutil.rmtree(folder)
    _result_folder(folder)


def _result_folder(folder: Path) -> None:
    """Make one of a results folder's folders; something else by its name is refused in one
    line naming it (not ``[Errno 17] File exists``)."""
    if folder.exists() and not folder.is_dir():
        raise FftnavError(f"{folder} must be a folder of the results, got a file by that name: "
                          f"move it away, or use another --out")
    folder.mkdir(parents=True, exist_ok=True)


def _compute_references(config: ExperimentConfig, out: Path, tasks: list[Task],
                        **options: object) -> None:
    """Compute the reference lengths of the maps of ``tasks`` that ``reference/`` lacks.

    The grid A* and geodesic lengths of a map are the same for all its policies and cost about
    as much as an episode: they are computed once per map, in parallel on the executor
    (:func:`fftnav.runner.tasks.map_reference`), just before the map's episodes, and kept in
    ``reference/<env>-<map_seed>.npy`` (a resumed run reuses them). A map whose lengths fail
    (an unreachable goal) is left to its episodes, which fail with the same error.
    """
    maps = dict.fromkeys((t.env, t.map_seed) for t in tasks)
    missing = [Task(env, map_seed, "", 0, False) for env, map_seed in maps
               if not _reference_path(out, env, map_seed).exists()]
    if not missing:
        return
    results = execute(map_reference, config, missing, **options)  # type: ignore[arg-type]
    try:
        for task, result in results:
            if isinstance(result, np.ndarray):
                buffer = io.BytesIO()
                np.save(buffer, result)
                write_atomic(_reference_path(out, task.env, task.map_seed), buffer.getvalue())
    finally:
        results.close()


def _with_reference(out: Path, task: Task) -> Task:
    """``task`` with its map's reference lengths attached, if a trusted file holds them (a
    damaged file is ignored: the episode computes the lengths itself)."""
    path = _reference_path(out, task.env, task.map_seed)
    try:
        lengths = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError):
        return task
    if lengths.ndim != 2 or lengths.shape[0] != 2 or lengths.dtype != np.float64:
        return task
    return replace(task, reference=tuple(tuple(row.tolist()) for row in lengths))


def _task_csv(out: Path, task: Task) -> Path:
    return out / "episodes" / f"{task.task_id}.csv"


def record_path(out: Path, task: Task) -> Path:
    """Where a task's recording is kept: ``OUT/records/<task id>.npz``."""
    return out / "records" / f"{task.task_id}.npz"


def _recording_missing(out: Path, config: ExperimentConfig, task: Task, csv: Path) -> bool:
    """Whether ``[record] episodes`` wants a recording of this finished task that the folder
    does not hold, or holds damaged (empty, cut short, not readable: reported in one line on
    stderr); the task is then rerun: its rows come out the same."""
    if config.record == "none":
        return False
    path = record_path(out, task)
    if path.exists():
        try:
            read_recording(path)
        except ValueError as exc:
            sys.stderr.write(f"fftnav run: rerunning {task.task_id}: its recording {path} "
                             f"cannot be trusted ({str(exc).splitlines()[0]})\n")
            return True
        return False
    if config.record == "all":
        return True
    arrived = CSV_COLUMNS.index("arrived")
    return any(line.split(",")[arrived] != "true" for line in csv.read_text().splitlines())


def _save_task(out: Path, task: Task, result: TaskResult) -> TaskResult:
    """Write the trajectories and the recording (if kept), then the task's CSV, which marks
    the task done."""
    if result.recording is not None:
        write_atomic(record_path(out, task), result.recording)
    if result.compute is not None:
        seconds, ticks = result.compute
        write_atomic(out / "timing" / f"{task.task_id}.json",
                     json.dumps({"compute_s": float(seconds), "robot_ticks": int(ticks)}))
    if result.trajectories is not None:
        buffer = io.BytesIO()
        np.savez_compressed(buffer, *result.trajectories)
        write_atomic(out / "trajectories" / f"{task.task_id}.npz", buffer.getvalue())
    if not result.rows:
        raise FftnavError(f"task {task.task_id} returned no rows")
    wrong = [type(row).__name__ for row in result.rows if not isinstance(row, EpisodeRow)]
    if wrong:
        raise FftnavError(f"task {task.task_id} returned rows of type {wrong[0]}, not EpisodeRow")
    keys = {"env": task.env, "map_seed": task.map_seed, "policy": task.policy,
            "episode_seed": task.episode_seed}
    rows = sorted(({**row.as_dict(), **keys} for row in result.rows), key=lambda r: r["robot"])
    write_atomic(_task_csv(out, task), episode_csv(rows, columns=CSV_COLUMNS, header=False))
    return result


def _write_episodes(out: Path, config: ExperimentConfig) -> None:
    """Rebuild ``episodes.csv`` from the finished tasks' files that pass the check, in task
    order (streamed into a temporary file, renamed over the old one)."""
    with atomic_writer(out / "episodes.csv") as fh:
        fh.write((",".join(CSV_COLUMNS) + "\n").encode())
        folder = out / "episodes"
        for task in iter_tasks(config, where=lambda name: (folder / f"{name}.csv").exists()):
            path = _task_csv(out, task)
            if task_file_problem(path, None, task, robots=config.robots,
                                 columns=CSV_COLUMNS) is None:
                fh.write(path.read_bytes())


def _write_timing(out: Path, config: ExperimentConfig) -> None:
    """Write ``timing.csv`` (:data:`TIMING_COLUMNS`) from the finished tasks' ``timing/``
    files, in task order; a missing or damaged file leaves its task out."""
    rows = []
    folder = out / "timing"
    for task in iter_tasks(config, where=lambda name: (folder / f"{name}.json").exists()):
        try:
            found = json.loads((folder / f"{task.task_id}.json").read_text())
            seconds, ticks = float(found["compute_s"]), int(found["robot_ticks"])
        except (OSError, ValueError, KeyError, TypeError):
            continue
        rows.append((task.env, task.map_seed, task.policy, seconds, ticks,
                     1000 * seconds / ticks if ticks else np.nan))
    write_atomic(out / "timing.csv", pd.DataFrame(rows, columns=list(TIMING_COLUMNS)).to_csv(
        index=False, float_format="%.6g"))


def read_timing(folder: str | Path) -> pd.DataFrame:
    """A results folder's ``timing.csv`` (:data:`TIMING_COLUMNS`); empty when the folder has
    none (results written before timing was kept, or by an injected task function)."""
    path = Path(folder) / "timing.csv"
    if not path.exists():
        return pd.DataFrame(columns=list(TIMING_COLUMNS))
    return read_episodes(path)


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
