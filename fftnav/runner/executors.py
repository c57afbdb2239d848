"""Run tasks in-process, on a local process pool or on a Dask cluster; iterate completions.

All executors have the same interface, :func:`execute`: submit every task, yield
``(task, outcome)`` as tasks finish, in completion order. A task that raises does not stop the
others: its outcome is a :class:`TaskError` (built inside the worker, so it pickles everywhere).
"""

from __future__ import annotations

import ctypes
import itertools
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

from fftnav.errors import FftnavError
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.tasks import Task, TaskResult
from fftnav.validate import check_choice, check_integer

__all__ = ["EXECUTORS", "TaskError", "TaskFunction", "check_options", "execute"]

#: Names accepted by ``fftnav run --executor``.
EXECUTORS: tuple[str, ...] = ("local", "dask")

TaskFunction = Callable[[ExperimentConfig, Task], TaskResult]

#: Tasks in flight per worker (bounded memory however many tasks an experiment has).
_WINDOW_PER_WORKER = 4
#: prctl option: signal sent to this process when its parent dies (linux/prctl.h).
_PR_SET_PDEATHSIG = 1
#: Seconds between the parent checks of a worker (where PR_SET_PDEATHSIG does not exist).
_PARENT_POLL_S = 1.0


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
        raise FftnavError(f"scheduler needs executor='dask', got executor={executor!r}")
    return workers or os.cpu_count() or 1


def execute(
    fn: TaskFunction,
    config: ExperimentConfig,
    tasks: Iterable[Task],
    *,
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
) -> Iterator[tuple[Task, TaskResult | TaskError]]:
    """Run ``fn(config, task)`` for every task; yield ``(task, outcome)`` as they complete.

    Tasks are taken from the iterable lazily, a few per worker at a time, so an experiment of
    millions of episodes costs memory for the episodes in flight only.

    Parameters
    ----------
    fn : callable
        The task function (module-level, so that it pickles), e.g. :func:`run_task`.
    config : ExperimentConfig
    tasks : iterable of Task
    executor : {"local", "dask"}
        ``local``: a process pool (``workers=1`` runs in this process). Its workers die with
        this process (``PR_SET_PDEATHSIG`` on Linux, a parent check elsewhere), ignore Ctrl-C
        (the parent handles it) and are killed at once when the iteration is interrupted.
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
    tasks = iter(tasks)
    first = list(itertools.islice(tasks, 2))
    tasks = itertools.chain(first, tasks)
    if executor == "dask":
        yield from _dask(fn, config, tasks, workers, scheduler)
    elif workers == 1 or len(first) <= 1:
        for task in tasks:
            yield task, guarded(fn, config, task)
    else:
        yield from _pool(fn, config, tasks, workers)


def _worker_init(parent_pid: int) -> None:
    """Initializer of pool workers: die with the parent, leave Ctrl-C to the parent."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):  # pragma: no cover - no libc prctl
            pass
    if os.getppid() != parent_pid:  # the parent died before prctl took effect
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True).start()


def _watch_parent(parent_pid: int) -> None:
    """Fallback where PR_SET_PDEATHSIG does not exist: exit once the parent is gone."""
    while True:
        time.sleep(_PARENT_POLL_S)
        if os.getppid() != parent_pid:
            os._exit(1)


def _kill_pool(pool: ProcessPoolExecutor) -> None:
    """Stop a pool now: kill its workers (running episodes are lost; a rerun redoes them)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        if process.is_alive():
            process.kill()
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.join(timeout=5)


def _pool(fn: TaskFunction, config: ExperimentConfig, tasks: Iterator[Task],
          workers: int) -> Iterator[tuple[Task, TaskResult | TaskError]]:
    window = _WINDOW_PER_WORKER * workers
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_worker_init,
                               initargs=(os.getpid(),))
    pending: dict[Any, Task] = {}
    clean = False
    try:
        exhausted = False
        while True:
            while not exhausted and len(pending) < window:
                task = next(tasks, None)
                if task is None:
                    exhausted = True
                    break
                try:
                    pending[pool.submit(guarded, fn, config, task)] = task
                except BrokenProcessPool:  # a worker died: what is in flight is lost
                    for future, lost in pending.items():
                        yield lost, _outcome(future)
                    pending.clear()
                    _kill_pool(pool)
                    pool = ProcessPoolExecutor(max_workers=workers, initializer=_worker_init,
                                               initargs=(os.getpid(),))
                    pending[pool.submit(guarded, fn, config, task)] = task
            if not pending:
                break
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                yield pending.pop(future), _outcome(future)
        clean = True
    finally:
        if clean:
            pool.shutdown(wait=True)
        else:  # interrupted (Ctrl-C, SIGTERM, the consumer stopped): do not wait for episodes
            _kill_pool(pool)


def _dask(fn: TaskFunction, config: ExperimentConfig, tasks: Iterator[Task], workers: int,
          scheduler: str | None) -> Iterator[tuple[Task, TaskResult | TaskError]]:
    from distributed import Client, LocalCluster, as_completed

    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
    else:
        cluster = scheduler
    try:
        with Client(cluster) as client:
            futures: dict[Any, Task] = {}

            def submit(count: int) -> list[Any]:
                batch = []
                for task in itertools.islice(tasks, count):
                    future = client.submit(guarded, fn, config, task, pure=False)
                    futures[future] = task
                    batch.append(future)
                return batch

            window = _WINDOW_PER_WORKER * max(workers, len(client.nthreads()) or 1)
            completed = as_completed(submit(window))
            try:
                for future in completed:
                    yield futures.pop(future), _outcome(future)
                    completed.update(submit(1))
            finally:
                client.cancel(list(futures))
    finally:
        if scheduler is None:
            cluster.close()
