"""Run tasks in-process, on a local process pool or on a Dask cluster; iterate completions.

All executors have the same interface, :func:`execute`: submit every task, yield
``(task, outcome)`` as tasks finish, in completion order. A task that raises does not stop the
others: its outcome is a :class:`TaskError` (built inside the worker, so it pickles everywhere).
"""

from __future__ import annotations

import os
import traceback
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any

from fftnav.runner.config import ExperimentConfig
from fftnav.runner.tasks import Task, TaskResult
from fftnav.validate import check_choice, check_integer

__all__ = ["EXECUTORS", "TaskError", "TaskFunction", "check_options", "execute"]

#: Names accepted by ``fftnav run --executor``.
EXECUTORS: tuple[str, ...] = ("local", "dask")

TaskFunction = Callable[[ExperimentConfig, Task], TaskResult]


@dataclass(frozen=True)
class TaskError:
    """A task that raised: exception type, message and the last lines of the traceback."""

    error_type: str
    message: str
    traceback: str


def guarded(fn: Callable[..., TaskResult], *args: Any) -> TaskResult | TaskError:
    """Call ``fn(*args)``; an exception becomes a :class:`TaskError`."""
    try:
        return fn(*args)
    except Exception as exc:  # crash isolation: record and go on
        tb = traceback.format_exception(type(exc), exc, exc.__traceback__)
        return TaskError(type(exc).__name__, str(exc), "".join(tb[-3:]).strip())


def _outcome(future: Any) -> TaskResult | TaskError:
    """The future's result; a lost worker (e.g. a crashed process) becomes a TaskError too."""
    try:
        return future.result()
    except Exception as exc:
        return TaskError(type(exc).__name__, str(exc), "worker failed")


def check_options(*, executor: str, workers: int | None, scheduler: str | None) -> int:
    """Validate the options of :func:`execute`; return the worker count (default: all cores)."""
    check_choice("executor", executor, EXECUTORS)
    if workers is not None:
        check_integer("workers", workers, low=1)
    if scheduler is not None and executor != "dask":
        raise ValueError(f"scheduler needs executor='dask', got executor={executor!r}")
    return workers or os.cpu_count() or 1


def execute(
    fn: TaskFunction,
    config: ExperimentConfig,
    tasks: Sequence[Task],
    *,
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
) -> Iterator[tuple[Task, TaskResult | TaskError]]:
    """Run ``fn(config, task)`` for every task; yield ``(task, outcome)`` as they complete.

    Parameters
    ----------
    fn : callable
        The task function (module-level, so that it pickles), e.g. :func:`run_task`.
    config : ExperimentConfig
    tasks : sequence of Task
    executor : {"local", "dask"}
        ``local``: a ``ProcessPoolExecutor`` (``workers=1`` runs in this process).
        ``dask``: a ``distributed.Client`` on ``scheduler`` (e.g. ``tcp://host:8786``), or on a
        ``LocalCluster`` of ``workers`` single-threaded processes when ``scheduler`` is None.
    workers : int, optional
        Worker processes (default ``os.cpu_count()``); ignored with a scheduler address.
    scheduler : str, optional
        Dask scheduler address; only with ``executor="dask"``.

    Yields
    ------
    (Task, TaskResult or TaskError)
    """
    workers = check_options(executor=executor, workers=workers, scheduler=scheduler)
    if executor == "dask":
        yield from _dask(fn, config, tasks, workers, scheduler)
    elif workers == 1 or len(tasks) <= 1:
        for task in tasks:
            yield task, guarded(fn, config, task)
    else:
        with ProcessPoolExecutor(max_workers=min(workers, len(tasks))) as pool:
            futures = {pool.submit(guarded, fn, config, t): t for t in tasks}
            try:
                for future in as_completed(futures):
                    yield futures[future], _outcome(future)
            finally:  # on interruption, do not start what is still queued
                for future in futures:
                    future.cancel()


def _dask(fn: TaskFunction, config: ExperimentConfig, tasks: Sequence[Task], workers: int,
          scheduler: str | None) -> Iterator[tuple[Task, TaskResult | TaskError]]:
    from distributed import Client, LocalCluster, as_completed

    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
    else:
        cluster = scheduler
    try:
        with Client(cluster) as client:
            futures = {client.submit(guarded, fn, config, t, pure=False): t for t in tasks}
            try:
                for future in as_completed(futures):
                    yield futures[future], _outcome(future)
            finally:
                client.cancel(list(futures))
    finally:
        if scheduler is None:
            cluster.close()
