"""One episode of a results folder, rerun on demand and checked against the folder's rows.

A results folder keeps what a reader needs (``config.toml``, ``episodes.csv``, the summaries,
the report); the recording and the trajectories of an episode are regenerable, so they are made
when asked for: :func:`rerun_task` reruns the task from the folder's config and seeds through
the runner's own :func:`~fftnav.runner.tasks.run_task`, recorded, and refuses the result unless
its rows, written as ``episodes.csv`` writes them, are the folder's rows of that task, byte for
byte. ``fftnav replay RESULTS_DIR --task TASK`` draws the recording, ``fftnav figure failures``
the paths; a sweep's cell folder (``OUT/<cell>``, whose ``config.toml`` is the whole sweep) is
the cell's config.

>>> close_names("rocky-1014-bug-lft", ["rocky-1014-bug-left", "rocky-1014-fusion", "forest-1"])
['rocky-1014-bug-left', 'rocky-1014-fusion']
"""

from __future__ import annotations

import csv
import dataclasses
import difflib
import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from fftnav.episode.record import episode_csv
from fftnav.episode.recording import Recording, read_recording
from fftnav.errors import FftnavError
from fftnav.files import read_json, read_toml
from fftnav.runner.config import ExperimentConfig, load_config, parse_config
from fftnav.runner.run import CSV_COLUMNS
from fftnav.runner.tasks import Task, TaskResult, iter_tasks, run_task

__all__ = ["Rerun", "close_names", "committed_lines", "first_difference", "folder_config",
           "rerun_task", "results_folders", "task_ids", "task_lines"]

#: What makes a folder a results folder (``fftnav run`` writes both).
FOLDER_FILES = ("config.toml", "episodes.csv")


@dataclass(frozen=True)
class Rerun:
    """A rerun episode of a results folder whose rows equal the folder's.

    Attributes
    ----------
    config : ExperimentConfig
        The folder's config (a sweep cell's own).
    task : Task
        The task, its episode seed as the folder's rows carry it.
    result : TaskResult
        Its rows, trajectories (every robot's, ``(T_i, 3)``) and recording's bytes.
    """

    config: ExperimentConfig
    task: Task
    result: TaskResult

    def recording(self) -> Recording:
        """The episode's recording (:func:`fftnav.episode.recording.read_recording`)."""
        return read_recording(io.BytesIO(self.result.recording or b""))


def close_names(name: str, names: Sequence[str], *, n: int = 5) -> list[str]:
    """Up to ``n`` of ``names`` close to ``name`` (:func:`difflib.get_close_matches`), best
    first."""
    return difflib.get_close_matches(name, list(names), n=n, cutoff=0.6)


def results_folders(root: Path) -> list[str]:
    """The results folders directly in ``root`` (those holding :data:`FOLDER_FILES`), sorted."""
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir()
                  if p.is_dir() and all((p / f).is_file() for f in FOLDER_FILES))


def _check_folder(results_dir: Path) -> None:
    """ValueError unless ``results_dir`` is a results folder, naming the close ones beside it
    or, for a folder of folders, those inside it."""
    if all((results_dir / f).is_file() for f in FOLDER_FILES):
        return
    inside = results_folders(results_dir)
    beside = close_names(results_dir.name, results_folders(results_dir.parent))
    hint = (f"; did you mean {', '.join(str(results_dir.parent / b) for b in beside)}?"
            if beside else f"; it holds the results folders {', '.join(inside)}" if inside
            else "; it has a config.toml but no episodes.csv (a sweep's cell keeps its "
            "summaries only: fftnav run CONFIG writes its episodes.csv again)"
            if (results_dir / "config.toml").is_file() else "")
    raise FftnavError(f"results_dir must be a results folder of fftnav run (with "
                      f"{' and '.join(FOLDER_FILES)}), got results_dir={str(results_dir)!r}{hint}")


def folder_config(results_dir: str | Path) -> ExperimentConfig:
    """The config a results folder was run with: its ``config.toml`` (relative plugin and
    world file paths taken from the folder), the cell named as the folder for a sweep's cell.

    Raises
    ------
    ValueError
        Not a results folder (naming the close ones), or a config that no longer loads.
    """
    results_dir = Path(results_dir)
    _check_folder(results_dir)
    config = _load_folder_config(results_dir)
    if not config.cells:
        return config
    cells = dict(config.cells)
    if results_dir.name not in cells:
        raise FftnavError(f"results_dir must be a cell of the sweep {config.name!r} "
                          f"({', '.join(cells)}), got results_dir={str(results_dir)!r}")
    return cells[results_dir.name]


def _load_folder_config(results_dir: Path) -> ExperimentConfig:
    """The folder's ``config.toml``; where its relative policy files (``file.py:attr``,
    ``learned:PATH``) were relative to the config's own folder, not to this copy's, the
    policies the run resolved (``config.json``) are taken instead when those files exist."""
    try:
        return load_config(results_dir / "config.toml")
    except FftnavError as first:
        data, text = read_toml(results_dir / "config.toml")
        stored = read_json(results_dir / "config.json") if (results_dir / "config.json").is_file() \
            else {}
        policies = stored.get("policies") if isinstance(stored, dict) else None
        experiment = data.get("experiment")
        if not isinstance(policies, list) or not isinstance(experiment, dict):
            raise first from None
        try:
            return parse_config({**data, "experiment": {**experiment, "policies": policies}},
                                source=text, base=results_dir)
        except ValueError:
            raise first from None


def task_ids(results_dir: str | Path) -> list[str]:
    """The tasks of a results folder's ``episodes.csv`` (``env-map_seed-policy``), in order."""
    ids = {}
    for key in _episode_keys(Path(results_dir) / "episodes.csv"):
        ids[f"{key[0]}-{key[1]}-{key[2]}"] = None
    return list(ids)


def _episode_keys(path: Path) -> list[tuple[str, ...]]:
    """The (env, map_seed, policy) of every row of an ``episodes.csv``."""
    with path.open(newline="", encoding="utf-8") as fh:
        rows = csv.reader(fh)
        next(rows, None)
        return [tuple(row[:3]) for row in rows if row]


def committed_lines(results_dir: str | Path, task: Task) -> list[str]:
    """The lines of the folder's ``episodes.csv`` that belong to ``task``, as written."""
    keys = [task.env, str(task.map_seed), task.policy]
    text = (Path(results_dir) / "episodes.csv").read_text(encoding="utf-8")
    return [line for line in text.splitlines()[1:]
            if line and next(csv.reader([line]))[:3] == keys]


def _find_task(config: ExperimentConfig, results_dir: Path, name: str) -> Task:
    """The task called ``name`` in the folder (ValueError naming the close names)."""
    names = task_ids(results_dir)
    if name not in names:
        close = close_names(name, names)
        hint = (f"did you mean {', '.join(close)}?" if close else
                f"its {len(names)} tasks are named ENV-MAP_SEED-POLICY, e.g. "
                f"{', '.join(names[:3])}")
        raise FftnavError(f"task must be an episode of {results_dir / 'episodes.csv'}, got "
                          f"task={name!r}; {hint}")
    found = list(iter_tasks(config, where=lambda task_id: task_id == name))
    if not found:
        raise FftnavError(f"task must be an episode of the folder's config.toml, got task="
                          f"{name!r}: episodes.csv has it, the config does not")
    return dataclasses.replace(found[0], keep_trajectories=True)


def task_lines(task: Task, result: TaskResult) -> list[str]:
    """The rerun's rows as ``episodes.csv`` writes them (:func:`fftnav.runner.run._save_task`)."""
    keys = {"env": task.env, "map_seed": task.map_seed, "policy": task.policy,
            "episode_seed": task.episode_seed}
    rows = sorted(({**row.as_dict(), **keys} for row in result.rows), key=lambda r: r["robot"])
    return episode_csv(rows, columns=CSV_COLUMNS, header=False).splitlines()


def first_difference(committed: list[str], rerun: list[str]) -> str:
    """The first difference between two tasks' lines, in words."""
    if len(committed) != len(rerun):
        return f"{len(rerun)} rows, the folder has {len(committed)}"
    for old, new in zip(committed, rerun, strict=True):
        before, after = next(csv.reader([old])), next(csv.reader([new]))
        changed = [f"{c} {a or '(empty)'} here, {b or '(empty)'} in the folder"
                   for c, a, b in zip(CSV_COLUMNS, after, before, strict=False) if a != b]
        if changed or len(before) != len(after):
            robot = after[CSV_COLUMNS.index("robot")]
            return f"robot {robot}: " + (", ".join(changed[:3]) or "other columns")
    return "none"


def rerun_task(results_dir: str | Path, task: str) -> Rerun:
    """Rerun the episode ``task`` (``env-map_seed-policy``) of a results folder, recorded, with
    every robot's trajectory, from the folder's config and the task's seeds.

    Raises
    ------
    ValueError
        ``results_dir`` is not a results folder or ``task`` not one of its episodes (naming the
        close names), or the rerun's rows are not the folder's rows of that task byte for byte
        (naming the first robot and columns that differ: the config, the fftnav that runs it or
        its dependencies changed since the folder was written).
    """
    results_dir = Path(results_dir)
    config = folder_config(results_dir)
    found = _find_task(config, results_dir, task)
    result = run_task(dataclasses.replace(config, record="all"), found)
    committed, rerun = committed_lines(results_dir, found), task_lines(found, result)
    if rerun != committed:
        raise FftnavError(f"the rerun of {task} must give the rows of "
                          f"{results_dir / 'episodes.csv'}, got other rows "
                          f"({first_difference(committed, rerun)}): this fftnav does not reproduce "
                          "the folder")
    return Rerun(config, found, result)
