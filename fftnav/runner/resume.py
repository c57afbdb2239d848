"""What a results folder may be trusted with on resume: checked episode files, one run at a time.

A rerun skips an episode only if its file passes :func:`task_file_problem` (complete rows, the
expected columns, the task's keys, one row per robot; its trajectories readable when the task
keeps them); a file that fails is reported and the episode rerun. :class:`FolderLock` keeps two
runs out of one folder (an ``flock`` the kernel drops when its process dies, so a killed run
never blocks its resume), and :func:`remove_stale_temporaries` deletes what killed writers left.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from fftnav.files import load_npz
from fftnav.runner.tasks import Task

__all__ = ["FolderLock", "InvocationClock", "remove_stale_temporaries", "task_file_problem"]

LOCK_NAME = ".lock"


def task_file_problem(csv_path: Path, npz_path: Path | None, task: Task, *, robots: int,
                      columns: tuple[str, ...]) -> str | None:
    """Why a finished task's file cannot be trusted, or None if it can.

    The CSV must hold exactly ``robots`` complete lines (newline-terminated) of
    ``len(columns)`` fields, each starting with the task's ``env, map_seed, policy,
    episode_seed`` and the robot index ``0 .. robots - 1`` in order; ``npz_path`` (the
    trajectories, when the task keeps them) must be a readable archive of ``robots`` arrays.
    """
    try:
        text = csv_path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        return "not UTF-8 text"
    except OSError as exc:
        return f"unreadable ({exc.strerror})"
    if not text.endswith("\n"):
        return "empty" if not text else "its last line is incomplete"
    lines = text[:-1].split("\n")
    if len(lines) != robots:
        return f"{len(lines)} rows, expected {robots} (one per robot)"
    keys = [task.env, str(task.map_seed), task.policy, str(task.episode_seed)]
    robot_col = columns.index("robot")
    for i, line in enumerate(lines):
        fields = line.split(",")
        if len(fields) != len(columns):
            return f"row {i + 1} has {len(fields)} fields, expected {len(columns)}"
        if fields[:4] != keys or fields[robot_col] != str(i):
            return f"row {i + 1} belongs to another episode or robot"
    if npz_path is not None:
        try:
            arrays = load_npz(npz_path)
        except (ValueError, OSError) as exc:
            return f"its trajectories {npz_path.name} are damaged ({exc})"
        if len(arrays) != robots:
            return f"its trajectories {npz_path.name} hold {len(arrays)} arrays, expected {robots}"
    return None


def remove_stale_temporaries(out: Path) -> int:
    """Delete the ``.NAME.PID.tmp`` files a killed writer left in ``out`` and its result
    folders (safe under the folder lock: no other writer is alive); return how many."""
    count = 0
    for folder in (out, out / "episodes", out / "trajectories", out / "figures"):
        if folder.is_dir():
            for path in folder.glob(".*.tmp"):
                path.unlink(missing_ok=True)
                count += 1
    return count


class FolderLock:
    """An exclusive lock on a results folder for the life of one run (``DIR/.lock``).

    ``flock`` on Linux and macOS; the kernel releases it when the process exits or is killed,
    so a lock file left by a killed run blocks nothing. Elsewhere no lock is taken.
    """

    def __init__(self, out: Path) -> None:
        self.path = out / LOCK_NAME
        self._fd: int | None = None

    def __enter__(self) -> FolderLock:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows
            return self
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.read(fd, 64).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise ValueError(f"{self.path.parent} is in use by another fftnav run (pid "
                             f"{holder}); wait for it or use another --out") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd = fd
        return self

    def __exit__(self, *exc: object) -> None:
        if self._fd is not None:
            self.path.unlink(missing_ok=True)  # a finished folder keeps no lock file
            os.close(self._fd)  # releases the flock
            self._fd = None


class InvocationClock:
    """Wall time of every invocation in a folder, killed ones included.

    Each invocation keeps a marker ``DIR/.invocation-PID.json`` holding its start time; its
    modification time is touched after every finished episode (one ``utime``). A later
    invocation adds each marker left behind (a killed run) as ``mtime - start``: the time up to
    its last finished episode (a lower bound), then deletes it.
    """

    def __init__(self, out: Path) -> None:
        self.out = out
        self.start = time.time()
        self.path = out / f".invocation-{os.getpid()}.json"

    def begin(self) -> float:
        """Write this invocation's marker; return the seconds of earlier killed invocations
        (their markers removed)."""
        earlier = 0.0
        for marker in self.out.glob(".invocation-*.json"):
            try:
                started = float(json.loads(marker.read_text())["start"])
                earlier += max(0.0, marker.stat().st_mtime - started)
            except (OSError, ValueError, KeyError, TypeError):
                pass  # a damaged marker counts nothing
            marker.unlink(missing_ok=True)
        self.path.write_text(json.dumps({"start": self.start}))
        return earlier

    def tick(self) -> None:
        """Mark progress (after a finished episode)."""
        try:
            os.utime(self.path)
        except OSError:
            pass

    def end(self) -> None:
        """This invocation finished and counted its own time: drop the marker."""
        self.path.unlink(missing_ok=True)
