"""The report's section "Why robots failed": failure causes per env and policy, where they happened.

Reads the ``failure`` column of ``episodes.csv`` (one cause of
:data:`fftnav.metrics.FAILURE_CAUSES` per robot that did not arrive, docs/metrics.md). The table
names every episode with a failure by its task (``env-map_seed-policy``), and the section says
how to make its recording on demand: ``fftnav replay RESULTS_DIR --task TASK --out X.html``
reruns the episode from the folder's config and seeds and checks its rows against
``episodes.csv`` (:mod:`fftnav.runner.rerun`). Where each failed robot ended
(:func:`failure_positions`) comes from the files a run leaves beside its results and git does
not keep: ``records/<task_id>.npz`` (the recordings ``[record] episodes`` keeps) and
``trajectories/<task_id>.npz`` (the robots' paths of the first ``trajectory_maps`` maps);
``figures/failure_positions.png`` draws those positions per env in the map frame.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from fftnav.episode.recording import RecordingError, read_recording
from fftnav.metrics import FAILURE_CAUSES
from fftnav.report import save_figure
from fftnav.report.markdown import markdown_table
from fftnav.runner import run
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.tasks import Task, task_id, task_world

__all__ = ["POSITION_COLUMNS", "REPLAY_COLUMN", "draw_failure_positions", "failure_lines",
           "failure_positions", "failure_table", "last_positions", "record_path", "shown_causes",
           "shown_path"]

#: The column of :func:`failure_table` naming the episodes to replay.
REPLAY_COLUMN = "replay --task"
#: Columns of :func:`failure_positions`.
POSITION_COLUMNS: tuple[str, ...] = ("env", "map_seed", "policy", "robot", "cause", "x", "y")
_MARKERS = ("X", "o", "s", "^", "D", "v", "P", "*")


def record_path(out: str | Path, env: str, map_seed: int, policy: str) -> Path:
    """Where a results folder keeps an episode's recording: ``OUT/records/<task_id>.npz``
    (:func:`fftnav.runner.run.record_path` of the task)."""
    return run.record_path(Path(out), Task(env, map_seed, policy, 0, False))


def _failed(episodes: pd.DataFrame) -> pd.DataFrame:
    """The rows of the robots that did not arrive, ``failure`` as text ('' if unclassified)."""
    failed = episodes[~episodes["arrived"].astype(bool)].copy()
    failed["failure"] = failed["failure"].fillna("").astype(str)
    return failed


def shown_causes(failures: pd.Series) -> list[str]:
    """The causes a report shows, in their order: every cause that needs no condition
    (:attr:`fftnav.metrics.FailureCause.requires`), and those that do where ``failures`` (a
    ``failure`` column) holds them.

    >>> shown_causes(pd.Series(["stuck"]))[:3], "lost" in shown_causes(pd.Series(["lost"]))
    (['collision', 'jam', 'stuck'], True)
    """
    present = set(failures.dropna().astype(str))
    return [name for name, cause in FAILURE_CAUSES.items()
            if not cause.requires or name in present]


def failure_table(episodes: pd.DataFrame, *, envs: Sequence[str],
                  policies: Sequence[str]) -> pd.DataFrame:
    """Failure counts by cause per env and policy, with the episodes to replay.

    Parameters
    ----------
    episodes : pandas.DataFrame
        ``episodes.csv``, with its ``failure`` column.
    envs, policies : sequence of str
        The rows, in this order (pairs without episodes are left out).

    Returns
    -------
    pandas.DataFrame
        Columns env, policy, robots, failed, one column per cause of :func:`shown_causes`
        (in the order of :data:`fftnav.metrics.FAILURE_CAUSES`), then :data:`REPLAY_COLUMN`: the
        task of every episode with a failure, in map order (``rocky-1003-bug-left``, what
        ``fftnav replay RESULTS_DIR --task`` takes), as code, or ``-``.
    """
    failed = _failed(episodes)
    causes = shown_causes(failed["failure"])
    rows = []
    for env in envs:
        for policy in policies:
            mine = episodes[(episodes["env"] == env) & (episodes["policy"] == policy)]
            if mine.empty:
                continue
            fails = failed[(failed["env"] == env) & (failed["policy"] == policy)]
            row = {"env": env, "policy": policy, "robots": len(mine), "failed": len(fails)}
            row |= {cause: int((fails["failure"] == cause).sum()) for cause in causes}
            tasks = [f"`{task_id(env, int(seed), policy)}`"
                     for seed in sorted(set(fails["map_seed"]))]
            row[REPLAY_COLUMN] = ", ".join(tasks) or "-"
            rows.append(row)
    columns = ["env", "policy", "robots", "failed", *causes, REPLAY_COLUMN]
    return pd.DataFrame(rows, columns=columns)


def failure_positions(out: str | Path, episodes: pd.DataFrame | None = None) -> pd.DataFrame:
    """Where each robot that did not arrive ended, for the episodes whose paths the folder keeps.

    Parameters
    ----------
    out : str or Path
        The results folder (:func:`last_positions` reads the episodes' files in it).
    episodes : pandas.DataFrame, optional
        ``episodes.csv`` (read from ``out`` by default).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`POSITION_COLUMNS` (``x``, ``y`` in metres, world frame), one row per
        failed robot whose episode has a source of positions, in the order of ``episodes.csv``.
    """
    out = Path(out)
    if episodes is None:
        episodes = pd.read_csv(out / "episodes.csv")
    rows = []
    for (env, map_seed, policy), fails in _failed(episodes).groupby(
            ["env", "map_seed", "policy"], sort=False):
        robots = [int(r) for r in fails["robot"]]
        found = last_positions(out, env, int(map_seed), policy, robots)
        if found is None:
            continue
        for robot, cause, (x, y) in zip(robots, fails["failure"], found, strict=True):
            rows.append((env, int(map_seed), policy, robot, cause, float(x), float(y)))
    return pd.DataFrame(rows, columns=list(POSITION_COLUMNS))


def last_positions(out: Path, env: str, map_seed: int, policy: str,
                   robots: Sequence[int]) -> np.ndarray | None:
    """The last ``(x, y)`` (m) of the given robots of one episode, ``(len(robots), 2)``, or None
    when the folder has no path of that episode.

    The sources, in order: the episode's recording (``records/<task_id>.npz``, kept for the
    episodes ``[record] episodes`` asks for, by default those with a failure: its last tick's
    poses; a damaged one is passed over), then ``trajectories/<task_id>.npz`` (arrays
    ``arr_<robot>``, rows ``x, y, yaw``, kept for the first ``trajectory_maps`` maps of each
    env).
    """
    recorded = record_path(out, env, map_seed, policy)
    if recorded.is_file():
        try:
            return read_recording(recorded).pose[-1, list(robots), :2]
        except (RecordingError, IndexError):  # a damaged file: the next source
            pass
    path = out / "trajectories" / f"{task_id(env, map_seed, policy)}.npz"
    if not path.is_file():
        return None
    with np.load(path) as paths:
        return np.array([paths[f"arr_{robot}"][-1, :2] for robot in robots], dtype=float)


def draw_failure_positions(config: ExperimentConfig, positions: pd.DataFrame, path: Path, *,
                           envs: Sequence[str]) -> Path:
    """One panel per env, in the map frame (m): every located failure's last position, a
    marker and colour per cause, and a grey line to the robot's goal; the maps of an env are
    overlaid (their obstacles differ and are not drawn), the frame is that of the env's first
    map."""
    causes = shown_causes(positions["cause"])
    fig = Figure(figsize=(4.8 * len(envs), 5.0), layout="constrained")
    for ax, env in zip(fig.subplots(1, len(envs), squeeze=False)[0], envs, strict=True):
        width, height = task_world(config, env, config.map_seed).size_m
        ax.add_patch(Rectangle((0, 0), width, height, fill=False, edgecolor="k", lw=1))
        mine = positions[positions["env"] == env]
        for r in mine.itertuples(index=False):
            gx, gy = task_world(config, env, r.map_seed).goals[r.robot]
            ax.plot([r.x, gx], [r.y, gy], color="0.75", lw=0.7, zorder=1)
            ax.plot(gx, gy, ".", color="0.5", ms=4, zorder=1)
        for i, cause in enumerate(causes):
            at = mine[mine["cause"] == cause]
            ax.scatter(at["x"], at["y"], s=40, color=f"C{i}", marker=_MARKERS[i % len(_MARKERS)],
                       label=f"{cause} ({len(at)})", zorder=2)
        ax.set_aspect("equal")
        ax.set_xlim(-0.5, width + 0.5)
        ax.set_ylim(-0.5, height + 0.5)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"{env}: {len(mine)} failures located, "
                     f"{mine['map_seed'].nunique()} map(s)")
        ax.legend(fontsize=7, loc="lower right", title="cause (grey: line to goal)",
                  title_fontsize=7)
    save_figure(fig, path, dpi=100)
    return path


def shown_path(path: Path) -> str:
    """``path`` as a command names it: relative to the current directory when inside it.

    >>> shown_path(Path.cwd() / "results" / "table1")
    'results/table1'
    """
    absolute = Path(os.path.abspath(path))
    if absolute.is_relative_to(Path.cwd()):
        return absolute.relative_to(Path.cwd()).as_posix() or "."
    return str(path)


def _replay_lines(out: Path, table: pd.DataFrame) -> list[str]:
    """How to make the recording of an episode of the table, on demand."""
    tasks = [t.strip("`") for cell in table[REPLAY_COLUMN] if cell != "-"
             for t in cell.split(", ")]
    if not tasks:
        return []
    return [f"Make the recording of one (an offline player; `.gif`, `.mp4`, `.png` too): "
            f"`fftnav replay {shown_path(out)} --task {tasks[0]} --out {tasks[0]}.html` reruns "
            "that episode from this folder's config and seeds and checks that its rows are "
            "those of `episodes.csv` (docs/analysis.md, \"Replaying an episode\").", ""]


def failure_lines(config: ExperimentConfig, out: Path, episodes: pd.DataFrame,
                  figures: Path) -> list[str]:
    """The report's section "Why robots failed" (its figure written into ``figures``)."""
    head = ["## Why robots failed", ""]
    if "failure" not in episodes:
        return [*head, "(`episodes.csv` has no `failure` column: rerun the experiment to "
                "classify its failures)", ""]
    envs, policies = config.envs, config.policy_names
    table = failure_table(episodes, envs=envs, policies=policies)
    lines = [
        *head,
        "Robots that did not arrive, by cause (the `failure` column of `episodes.csv`; each "
        "cause's definition and thresholds: docs/metrics.md, \"Why robots failed\"). "
        f"`{REPLAY_COLUMN}`: the episodes with a failure.",
        "",
        *markdown_table(table),
        "",
        *_replay_lines(out, table),
    ]
    positions = failure_positions(out, episodes)
    total = int(table["failed"].sum())
    if positions.empty:
        return [*lines, f"No position for the {total} failures: the folder has no recording "
                "of them (`records/`, `[record] episodes`) and none of the robots of the maps "
                f"that keep their paths (`trajectories/`, the first {config.trajectory_maps} "
                "per env) failed.", ""]
    picture = draw_failure_positions(config, positions, figures / "failure_positions.png",
                                     envs=envs)
    return [
        *lines,
        f"Where they ended: {len(positions)} of the {total} failures (those with a recording "
        "in `records/` or a path in `trajectories/`), each robot's last position in the map "
        "frame with a grey line to its goal; the maps of an env overlaid.",
        "",
        f"![{picture.stem}](figures/{picture.name})",
        "",
    ]
