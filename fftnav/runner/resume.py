"""What a results folder may be trusted with on resume: checked episode files, one run at a time.

A rerun skips an episode only if its file passes :func:`task_file_problem` (complete rows, the
expected columns, the task's keys, one row per robot; its trajectories readable when the task
keeps them); a file that fails is reported and the episode rerun. :class:`FolderLock` keeps two
runs out of one folder (an ``flock`` the kernel drops when its process dies, so a killed run
never blocks its resume), and :func:`remove_stale_temporaries` deletes what killed writers left.
:func:`check_same_experiment` keeps one experiment per folder: its ``config.json`` must match,
else the run is refused naming what changed, or with ``fresh`` the folder's results are removed.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import fftnav
from fftnav.config import LocalizationConfig, PlannerConfig
from fftnav.errors import FftnavError
from fftnav.files import is_temporary, load_npz, write_atomic
from fftnav.plugins import file_sha256, plugin_sources
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.tasks import Task

__all__ = ["FolderLock", "InvocationClock", "canonical_config", "check_same_experiment",
           "config_changes", "located", "portable_path", "remove_results",
           "remove_stale_temporaries", "stored_as_absolute", "task_file_problem"]

LOCK_NAME = ".lock"
#: Folders and files ``fftnav run`` writes into a results folder (what :func:`remove_results`
#: deletes).
RESULT_FOLDERS: tuple[str, ...] = ("episodes", "trajectories", "records", "reference",
                                   "figures", "timing")
RESULT_FILES: tuple[str, ...] = ("episodes.csv", "summary.csv", "paired_tests.csv",
                                 "errors.csv", "report.md", "run_info.json", "config.toml",
                                 "config.json", "maps.csv", "timing.csv")
#: Fields of :class:`ExperimentConfig` that come from the ``[experiment]`` table.
_EXPERIMENT_FIELDS = ("name", "envs", "maps", "map_seed", "robots", "policies",
                      "trajectory_maps")


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
    problem = _rows_problem(text, task, robots=robots, columns=columns)
    if problem is None and npz_path is not None:
        problem = _trajectories_problem(npz_path, robots)
    return problem


def _rows_problem(text: str, task: Task, *, robots: int, columns: tuple[str, ...]) -> str | None:
    """Why a task file's text is not ``robots`` complete rows of ``task``, or None."""
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
    return None


def _trajectories_problem(npz_path: Path, robots: int) -> str | None:
    """Why a task's trajectories file is not a readable archive of ``robots`` arrays, or None."""
    try:
        arrays = load_npz(npz_path)
    except (ValueError, OSError) as exc:
        return f"its trajectories {npz_path.name} are damaged ({exc})"
    if len(arrays) != robots:
        return f"its trajectories {npz_path.name} hold {len(arrays)} arrays, expected {robots}"
    return None


def remove_stale_temporaries(out: Path) -> int:
    """Delete the temporary files a killed writer left in ``out``, its result folders and its
    figures (``.NAME.PID.tmp``, and ``.NAME.PID.tmp.png`` of an image, at any depth below
    them; safe under the folder lock: no other writer is alive); return how many."""
    count = 0
    found = list(out.glob(".*.tmp*")) if out.is_dir() else []
    for name in (*RESULT_FOLDERS, "figures"):
        if (out / name).is_dir():
            found += (out / name).rglob(".*.tmp*")
    for path in found:
        if is_temporary(path) and path.is_file():
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
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise FftnavError(f"{self.path.parent} cannot be written ({exc.strerror}): a "
                              f"results folder must be writable") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.read(fd, 64).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise FftnavError(f"{self.path.parent} is in use by another fftnav run (pid "
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
        write_atomic(self.path, json.dumps({"start": self.start}))
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


def canonical_config(config: ExperimentConfig, columns: tuple[str, ...], *,
                     folder: str | Path | None = None) -> str:
    """The ``config.json`` of a results folder: the config (without ``out`` and its source
    text), the fftnav version, the CSV ``columns``, and the SHA-256 of every plugin source
    (:func:`fftnav.plugins.plugin_sources`: the plugin files named by path and the modules
    beside them they import) and world file. A config without plugin or world files has no key
    for them (nor ``world_files``), and one with the default ``[planner]`` or ``[localization]``
    no ``planner`` or ``localization`` key:
    the ``config.json`` of results folders that hold no such key stays valid. ``record`` is
    left out: recordings change no result.

    With ``folder`` (the results folder), the files (plugins, trained networks, world files) are
    named by their path relative to it (:func:`portable_path`), so that a clone of a repository
    holding the results and the files, wherever it is, has the same ``config.json``; their
    contents are pinned by the hashes."""
    fields = {k: v for k, v in asdict(config).items()
              if not (k == "world_files" and not v) and k != "record"}
    if config.swarm.planner == PlannerConfig():
        del fields["swarm"]["planner"]
    if config.swarm.localization == LocalizationConfig():
        del fields["swarm"]["localization"]

    def name(path: str | Path) -> str:
        return str(path) if folder is None else portable_path(path, folder)

    plugins = {name(source): file_sha256(source) for found in config.resolved.values()
               if found.file for source in plugin_sources(found.file)}
    worlds = {name(path): file_sha256(Path(path)) for path in config.world_files.values()}
    if folder is not None:
        fields["policies"] = [_portable_ref(ref, folder) for ref in config.policies]
        if "world_files" in fields:
            fields["world_files"] = {env: name(path) for env, path in config.world_files.items()}
    return json.dumps({**fields, "out": None, "source": None, "fftnav_version": fftnav.__version__,
                       "csv_columns": list(columns),
                       **({"plugin_sha256": plugins} if plugins else {}),
                       **({"world_sha256": worlds} if worlds else {})},
                      indent=1, sort_keys=True)


def portable_path(path: str | Path, folder: str | Path) -> str:
    """``path`` relative to ``folder`` (both made absolute), with ``/`` between its parts: the
    same wherever a tree holding both is.

    >>> portable_path("/repo/results/nets/a.npz", "/repo/results/table1")
    '../nets/a.npz'
    """
    rel = os.path.relpath(os.path.abspath(path), os.path.abspath(folder))
    return Path(rel).as_posix()


def _portable_ref(ref: str, folder: str | Path) -> str:
    """A policy reference with its file (``path/to/file.py:attr``, ``learned:PATH``,
    ``learned-decider:PATH``) relative to ``folder``; any other reference as it is."""
    for prefix in ("learned-decider:", "learned:"):
        if ref.startswith(prefix) and Path(ref[len(prefix):]).is_absolute():
            return prefix + portable_path(ref[len(prefix):], folder)
    head, sep, attr = ref.rpartition(":")
    if sep and head.endswith(".py") and Path(head).is_absolute():
        return f"{portable_path(head, folder)}:{attr}"
    return ref


def check_same_experiment(config: ExperimentConfig, out: Path, *, columns: tuple[str, ...],
                          fresh: bool = False) -> None:
    """Write ``out/config.json`` (:func:`canonical_config`) unless the folder holds another
    experiment's results.

    Resuming must not mix configs, fftnav versions, plugin versions or CSV columns: a folder
    whose ``config.json`` differs, is damaged, or is missing beside episode files is refused
    with a ValueError naming what differs (:func:`config_changes`). With ``fresh`` such a
    folder's results are removed instead (:func:`remove_results`), so the experiment runs from
    scratch; a folder of the same experiment keeps its results until the rerun replaces them.
    """
    record = out / "config.json"
    canonical = canonical_config(config, columns, folder=out)
    problem = _folder_problem(out, canonical, columns)
    if problem is not None and stored_as_absolute(config, out, columns):
        problem = None  # the same experiment, its files named by absolute paths
    if problem is not None:
        if not fresh:
            raise FftnavError(f"{out} {problem}; rerun with --fresh to replace its results, or "
                              "use another --out")
        remove_results(out)
    write_atomic(record, canonical)


def stored_as_absolute(config: ExperimentConfig, out: Path, columns: tuple[str, ...]) -> bool:
    """Whether ``out/config.json`` is this experiment's with its files named by absolute paths
    (:func:`canonical_config` without ``folder``)."""
    try:
        return (out / "config.json").read_text(encoding="utf-8") == canonical_config(config,
                                                                                      columns)
    except (OSError, UnicodeDecodeError):
        return False


def _folder_problem(out: Path, canonical: str, columns: tuple[str, ...]) -> str | None:
    """Why the results in ``out`` are not of the experiment ``canonical`` describes, or None."""
    record = out / "config.json"
    if not record.exists():
        if any((out / "episodes").glob("*.csv")):
            return (f"holds episode files but no config.json ({record}): they cannot be told "
                    "apart from another experiment's")
        return None
    try:
        text = record.read_text(encoding="utf-8")
        stored = json.loads(text)
    except (UnicodeDecodeError, ValueError):
        stored = None
    if not isinstance(stored, dict):
        return f"holds a damaged config.json ({record})"
    if text == canonical:
        return None
    stored_columns = stored.get("csv_columns")
    episodes = out / "episodes.csv"
    if stored_columns is None and episodes.exists():  # a config.json without csv_columns
        stored_columns = episodes.read_text().split("\n", 1)[0].split(",")
    if stored_columns is not None and tuple(stored_columns) != tuple(columns):
        missing = [c for c in columns if c not in stored_columns]
        extra = [c for c in stored_columns if c not in columns]
        return (f"holds episodes with other columns than this fftnav writes (missing {missing}, "
                f"extra {extra}{', or in another order' if not missing + extra else ''})")
    changes = config_changes(located(_with_planner(stored), out),
                             located(_with_planner(json.loads(canonical)), out))
    return (f"holds results of a different experiment config ({record}); changed: "
            f"{', '.join(changes) or 'the layout of config.json'}")


def located(stored: dict[str, Any], folder: Path) -> dict[str, Any]:
    """A ``config.json`` content with the files it names relative to the results ``folder``
    (:func:`portable_path`) named by their absolute paths, as a reader finds them.

    >>> located({"plugin_sha256": {"../p/a.py": "1"}}, Path("/r/out"))
    {'plugin_sha256': {'/r/p/a.py': '1'}}
    """
    out = dict(stored)
    for key in ("plugin_sha256", "world_sha256"):
        files = stored.get(key)
        if isinstance(files, dict):
            out[key] = {os.path.normpath(os.path.join(os.path.abspath(folder), str(name))): digest
                        for name, digest in files.items()}
    return out


def _with_planner(stored: dict[str, Any]) -> dict[str, Any]:
    """A ``config.json`` content with its default ``planner`` and ``localization`` tables
    filled in where it has none (:func:`canonical_config` leaves default ones out), so that a
    changed constant is named by its key."""
    swarm = stored.get("swarm")
    if not isinstance(swarm, dict):
        return stored
    defaults = {"planner": asdict(PlannerConfig()), "localization": asdict(LocalizationConfig())}
    return {**stored, "swarm": {**defaults, **swarm}}


def config_changes(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """What differs between two ``config.json`` contents, as a reader names it: config keys
    as in the TOML file (``experiment.maps``, ``robot.r0_m``, ``world.forest.density``), plugin
    and world files by path, the fftnav version.

    >>> config_changes({"maps": 2, "swarm": {"robot": {"r0_m": 0.1, "r_m": 0.3}}},
    ...                {"maps": 3, "swarm": {"robot": {"r0_m": 0.2, "r_m": 0.3}}})
    ['experiment.maps', 'robot.r0_m']
    >>> config_changes({"plugin_sha256": {"/p/a.py": "1"}}, {"plugin_sha256": {"/p/a.py": "2"}})
    ['plugin file /p/a.py']
    """
    changes: list[str] = []
    for key in sorted(old.keys() | new.keys()):
        before, after = old.get(key), new.get(key)
        if before == after:
            continue
        if key in ("plugin_sha256", "world_sha256"):
            before = before if isinstance(before, dict) else {}
            after = after if isinstance(after, dict) else {}
            kind = "plugin file" if key == "plugin_sha256" else "world file"
            for path in sorted(before.keys() | after.keys()):
                if before.get(path) != after.get(path):
                    state = (" (new)" if path not in before else
                             " (no longer used)" if path not in after else "")
                    changes.append(f"{kind} {path}{state}")
        elif key == "fftnav_version":
            changes.append(f"fftnav version {before} -> {after}")
        else:
            changes += [_toml_key(k) for k in _changed_keys(key, before, after)]
    return changes


def _changed_keys(prefix: str, before: Any, after: Any) -> list[str]:
    """The dotted keys under ``prefix`` whose values differ (nested tables followed)."""
    if isinstance(before, dict) and isinstance(after, dict):
        return [k for key in sorted(before.keys() | after.keys())
                if before.get(key) != after.get(key)
                for k in _changed_keys(f"{prefix}.{key}", before.get(key), after.get(key))]
    return [prefix]


def _toml_key(key: str) -> str:
    """A dotted :class:`ExperimentConfig` field path as the TOML file names it."""
    head, _, rest = key.partition(".")
    if head in _EXPERIMENT_FIELDS:
        return f"experiment.{head}"
    if head == "swarm":
        return rest
    if head == "world_by_env":
        return f"world.{rest}"
    if head == "cells":
        return "sweep"
    return key


def remove_results(out: Path) -> None:
    """Delete what ``fftnav run`` wrote into ``out`` (:data:`RESULT_FOLDERS`,
    :data:`RESULT_FILES`); nothing else in it is touched (e.g. the cells of a sweep in its
    subfolders, other files of the user)."""
    for name in RESULT_FOLDERS:
        if (out / name).is_dir() and not (out / name).is_symlink():
            shutil.rmtree(out / name)
    for name in RESULT_FILES:
        (out / name).unlink(missing_ok=True)
