"""The report's section "Why robots failed": failure causes per env and policy, each failed robot,
where they happened.

Reads the ``failure`` column of ``episodes.csv`` (one cause of
:data:`fftnav.metrics.FAILURE_CAUSES` per robot that did not arrive, docs/metrics.md). The
counts table names every episode with a failure by its task (``env-map_seed-policy``).
:func:`failed_robots` lists every robot that did not arrive, with its cause, the time and
position of its failure from the episode's recording (``records/<task_id>.npz``, kept for the
episodes ``[record] episodes`` asks for; otherwise the reason there is none) and the link of
its replay page, ``replays/<task_id>.html#robot=R&t=T``, which opens at the failure (the
failure tick of :func:`fftnav.report.replay.failure_ticks`) with the robot picked;
:func:`failed_robots_lines` renders it for a report (the first :data:`LIST_LIMIT`, the rest
counted) and :func:`failure_lines` writes all of it to ``failures.csv`` beside ``report.md``.
The section says how to make a replay page on demand:
``fftnav replay RESULTS_DIR --task TASK --out RESULTS_DIR/replays/TASK.html`` reruns the
episode from the folder's config and seeds and checks its rows against ``episodes.csv``
(:mod:`fftnav.runner.rerun`). Where each failed robot ended (:func:`failure_positions`) comes
from the files a run leaves beside its results and git does not keep: ``records/`` and
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
from fftnav.errors import FftnavError
from fftnav.files import read_toml, write_atomic
from fftnav.metrics import FAILURE_CAUSES
from fftnav.report import save_figure
from fftnav.report.markdown import Dashes, markdown_table
from fftnav.report.replay import failure_ticks
from fftnav.runner import run
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.summary import in_order
from fftnav.runner.tasks import Task, task_id, task_world

__all__ = ["FAILED_COLUMNS", "LIST_LIMIT", "POSITION_COLUMNS", "REPLAY_COLUMN",
           "draw_failure_positions", "failed_robots", "failed_robots_lines", "failure_lines",
           "failure_positions", "failure_table", "last_positions", "record_path", "replay_link",
           "shown_causes", "shown_path"]

#: The column of :func:`failure_table` naming the episodes to replay.
REPLAY_COLUMN = "replay --task"
#: Columns of :func:`failure_positions`.
POSITION_COLUMNS: tuple[str, ...] = ("env", "map_seed", "policy", "robot", "cause", "x", "y")
#: Columns of :func:`failed_robots` and of ``failures.csv``.
FAILED_COLUMNS: tuple[str, ...] = ("env", "map_seed", "policy", "robot", "cause", "time_s",
                                   "x_m", "y_m", "replay", "source")
#: How many failed robots a report lists (:func:`failed_robots_lines`); ``failures.csv`` has
#: them all.
LIST_LIMIT = 50
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


def failure_positions(out: str | Path, episodes: pd.DataFrame | None = None, *,
                      failed: pd.DataFrame | None = None) -> pd.DataFrame:
    """Where each robot that did not arrive ended, for the episodes whose paths the folder keeps.

    Parameters
    ----------
    out : str or Path
        The results folder (:func:`last_positions` reads the episodes' files in it).
    episodes : pandas.DataFrame, optional
        ``episodes.csv`` (read from ``out`` by default).
    failed : pandas.DataFrame, optional
        :func:`failed_robots` of the folder: the episodes whose every failed robot it locates
        are taken from it (each robot at its failure tick, at most one control period before
        where it stopped) instead of reading their recordings again.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`POSITION_COLUMNS` (``x``, ``y`` in metres, world frame), one row per
        failed robot whose episode has a source of positions, in the order of ``episodes.csv``.
    """
    out = Path(out)
    if episodes is None:
        episodes = pd.read_csv(out / "episodes.csv")
    located = ({} if failed is None else
               {(r.env, int(r.map_seed), r.policy, int(r.robot)): (r.x_m, r.y_m)
                for r in failed.itertuples(index=False) if not np.isnan(r.x_m)})
    rows = []
    for (env, map_seed, policy), fails in _failed(episodes).groupby(
            ["env", "map_seed", "policy"], sort=False):
        robots = [int(r) for r in fails["robot"]]
        keys = [(env, int(map_seed), policy, robot) for robot in robots]
        found = (np.array([located[k] for k in keys]) if all(k in located for k in keys)
                 else last_positions(out, env, int(map_seed), policy, robots))
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


def replay_link(task: str, robot: int, time_s: float | None = None) -> str:
    """The replay page of robot ``robot`` of episode ``task``, opening at ``time_s`` (s, one
    decimal) when known, relative to the results folder.

    >>> replay_link("rocky-1014-bug-left", 9, 41.25)
    'replays/rocky-1014-bug-left.html#robot=9&t=41.2'
    >>> replay_link("rocky-1014-bug-left", 9)
    'replays/rocky-1014-bug-left.html#robot=9'
    """
    at = "" if time_s is None or np.isnan(time_s) else f"&t={time_s:.1f}"
    return f"replays/{task}.html#robot={robot}{at}"


def failed_robots(results: str | Path | None = None, *, episodes: pd.DataFrame | None = None,
                  records: str | Path | None = None, record: str | None = None,
                  envs: Sequence[str] | None = None,
                  policies: Sequence[str] | None = None) -> pd.DataFrame:
    """Every robot that did not arrive: its episode, cause, and the time and place it failed.

    The time and place come from the episode's recording, ``records/<task_id>.npz``
    (:func:`fftnav.episode.recording.read_recording`): the robot's failure tick, the one the
    replay player shows it fail at (:func:`fftnav.report.replay.failure_ticks`: collided or
    lost, the tick during whose control period it touched or stopped; out of time, the tick
    its time limit was reached), its time and true ``(x, y)`` there. Without a readable
    recording they are NaN and ``source`` says why.

    Parameters
    ----------
    results : str or Path, optional
        A results folder: ``episodes``, ``records`` and ``record`` default to its
        ``episodes.csv``, ``records/`` and its ``config.toml``'s ``[record] episodes``.
    episodes : pandas.DataFrame, optional
        ``episodes.csv`` rows (env, map_seed, policy, robot, arrived, failure); required
        without ``results``.
    records : str or Path, optional
        The folder of the recordings (none: no recording is read).
    record : {"none", "failures", "all"}, optional
        The experiment's ``[record] episodes``, when known: it names why a recording is
        missing.
    envs, policies : sequence of str, optional
        The order of the rows (the config's; :func:`fftnav.runner.summary.in_order`); default
        alphabetical.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`FAILED_COLUMNS`, sorted by env, map_seed, policy, robot: ``cause`` the
        ``failure`` column ('' if unclassified), ``time_s`` (s), ``x_m``, ``y_m`` (m, world
        frame), ``replay`` the robot's replay page (:func:`replay_link`), ``source`` the
        recording read (``records/<task_id>.npz``) or why there is none (``no recording:
        ...``).

    Raises
    ------
    ValueError
        Neither ``results`` nor ``episodes``; ``record`` not a ``[record] episodes`` choice.
    """
    if results is None and episodes is None:
        raise FftnavError("failed_robots needs results or episodes, got results=None and "
                          "episodes=None")
    if record is not None and record not in ("none", "failures", "all"):
        raise FftnavError(f"record must be one of ['none', 'failures', 'all'], got "
                          f"record={record!r}")
    if results is not None:
        folder = Path(results)
        episodes = pd.read_csv(folder / "episodes.csv") if episodes is None else episodes
        records = folder / "records" if records is None else records
        record = _record_setting(folder) if record is None else record
    assert episodes is not None
    failed = _failed(episodes) if "failure" in episodes else episodes[
        ~episodes["arrived"].astype(bool)].assign(failure="")
    rank = {"env": {e: i for i, e in enumerate(in_order(failed["env"], envs))},
            "policy": {p: i for i, p in enumerate(in_order(failed["policy"], policies))}}
    failed = failed.assign(_env=failed["env"].map(rank["env"]),
                           _policy=failed["policy"].map(rank["policy"])).sort_values(
        ["_env", "map_seed", "_policy", "robot"], kind="stable")
    rows = []
    for (env, map_seed, policy), group in failed.groupby(["env", "map_seed", "policy"],
                                                         sort=False):
        task = task_id(env, int(map_seed), policy)
        robots = [int(r) for r in group["robot"]]
        found = _located(records, task, robots, record)
        for robot, cause in zip(robots, group["failure"], strict=True):
            time_s, x, y, source = found[robot]
            rows.append((env, int(map_seed), policy, robot, cause, time_s, x, y,
                         replay_link(task, robot, time_s), source))
    return pd.DataFrame(rows, columns=list(FAILED_COLUMNS))


def _record_setting(folder: Path) -> str | None:
    """``[record] episodes`` of a results folder's ``config.toml`` (its default when the table
    is absent), or None when the folder has no readable ``config.toml``."""
    try:
        data, _ = read_toml(folder / "config.toml")
    except (OSError, ValueError):
        return None
    table = data.get("record", {})
    episodes = table.get("episodes", "failures") if isinstance(table, dict) else None
    return episodes if episodes in ("none", "failures", "all") else None


def _located(records: str | Path | None, task: str, robots: Sequence[int],
                   record: str | None) -> dict[int, tuple[float, float, float, str]]:
    """robot -> (time_s, x_m, y_m, source) of its failure in the task's recording; NaN and the
    reason there is none when it cannot be read."""
    def missing(reason: str) -> dict[int, tuple[float, float, float, str]]:
        return {r: (np.nan, np.nan, np.nan, f"no recording: {reason}") for r in robots}

    name = f"records/{task}.npz"
    if record == "none":
        return missing('[record] episodes = "none"')
    if records is None:
        return missing("no folder of recordings given")
    path = Path(records) / f"{task}.npz"
    if not path.parent.is_dir():
        return missing("the folder has no records/ (git keeps no recordings)")
    if not path.is_file():
        return missing(f"{name} is not in the folder")
    try:
        recording = read_recording(path)
    except RecordingError:
        return missing(f"{name} is not a readable recording")
    ticks = failure_ticks(recording)
    out = {}
    for robot in robots:
        if robot not in ticks:
            out[robot] = (np.nan, np.nan, np.nan,
                          f"no recording: {name} does not show robot {robot} fail")
            continue
        tick = ticks[robot]
        x, y = recording.pose[tick, robot, :2]
        out[robot] = (float(recording.time_s[tick]), float(x), float(y), name)
    return out


def failed_robots_lines(failed: pd.DataFrame, *, limit: int = LIST_LIMIT,
                        csv_name: str | None = "failures.csv") -> list[str]:
    """:func:`failed_robots` as Markdown: a table of the first ``limit`` robots (env, map,
    policy, robot, cause, when and where it failed, a link to its replay page) and, below it,
    how many more there are.

    Parameters
    ----------
    failed : pandas.DataFrame
        :func:`failed_robots`'s table.
    limit : int
        Rows listed (>= 1).
    csv_name : str, optional
        The CSV that holds every row, named under a capped table.

    Returns
    -------
    list of str
        The lines (none when no robot failed); a robot without a recording has the reason in
        its "failed at" cell, an unclassified cause a ``-`` explained under the table.
    """
    if limit < 1:
        raise FftnavError(f"limit must be an integer >= 1, got limit={limit!r}")
    if failed.empty:
        return []
    dashes = Dashes()
    rows = []
    for r in failed.head(limit).itertuples(index=False):
        at = (f"{r.time_s:.1f} s at ({r.x_m:.2f}, {r.y_m:.2f}) m" if not np.isnan(r.time_s)
              else r.source)
        cause = r.cause or dashes.dash("no cause in `episodes.csv` (its `failure` column is "
                                       "empty or absent)")
        rows.append((r.env, r.map_seed, r.policy, r.robot, cause, at,
                     f"[replay]({r.replay})"))
    table = pd.DataFrame(rows, columns=["env", "map", "policy", "robot", "cause", "failed at",
                                        "replay"])
    more = len(failed) - limit
    tail = ([f"... and {more} more robot(s)" + (f": all {len(failed)} in `{csv_name}`."
                                                  if csv_name else ".")] if more > 0 else [])
    legend = dashes.legend()
    return [*markdown_table(table), "", *([*tail, ""] if tail else []),
            *([*legend, ""] if legend else [])]


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


def _replay_lines(out: Path, tasks: Sequence[str]) -> list[str]:
    """How to make the replay page of an episode of the list, on demand."""
    if not tasks:
        return []
    shown, task = shown_path(out), tasks[0]
    return [f"The replay pages are made on demand (an offline player; `.gif`, `.mp4`, `.png` "
            f"too): `fftnav replay {shown} --task {task} --out {shown}/replays/{task}.html` "
            "reruns that episode from this folder's config and seeds, checks that its rows are "
            "those of `episodes.csv` (docs/analysis.md, \"Replaying an episode\") and writes the "
            "page the links open.", ""]


def failure_lines(config: ExperimentConfig, out: Path, episodes: pd.DataFrame,
                  figures: Path) -> list[str]:
    """The report's section "Why robots failed" (its figure written into ``figures``), and
    ``failures.csv`` (every failed robot, :func:`failed_robots`) written into ``out``."""
    head = ["## Why robots failed", ""]
    envs, policies = config.envs, config.policy_names
    failed = failed_robots(out, episodes=episodes, record=config.record, envs=envs,
                           policies=policies)
    write_atomic(out / "failures.csv", failed.to_csv(index=False, float_format="%.6f"))
    if "failure" not in episodes:
        return [*head, "(`episodes.csv` has no `failure` column: rerun the experiment to "
                "classify its failures)", ""]
    table = failure_table(episodes, envs=envs, policies=policies)
    dashes = Dashes()
    table[REPLAY_COLUMN] = [dashes.dash("no robot failed") if cell == "-" else cell
                            for cell in table[REPLAY_COLUMN]]
    located = int(failed["time_s"].notna().sum())
    lines = [
        *head,
        "Robots that did not arrive, by cause (the `failure` column of `episodes.csv`; each "
        "cause's definition and thresholds: docs/metrics.md, \"Why robots failed\"). "
        f"`{REPLAY_COLUMN}`: the episodes with a failure.",
        "",
        *markdown_table(table),
        "",
        *([*dashes.legend(), ""] if dashes.legend() else []),
    ]
    if len(failed):
        lines += [
            f"Each robot that did not arrive ({len(failed)}; all in `failures.csv`), when and "
            "where it failed, from its episode's recording (`records/`; "
            f"{located} of {len(failed)} have one): collided or lost, the start of the control "
            "period in which it touched or stopped; out of time, its time limit; its true "
            "position then. Each link opens the episode's replay page at the failure with the "
            "robot picked.",
            "",
            *failed_robots_lines(failed),
            *_replay_lines(out, list(dict.fromkeys(
                task_id(r.env, r.map_seed, r.policy) for r in failed.itertuples()))),
        ]
    positions = failure_positions(out, episodes, failed=failed)
    total = int(table["failed"].sum())
    if positions.empty:
        return [*lines, f"No position for the {total} failures: the folder has no recording "
                "of them (`records/`, `[record] episodes`) and none of the robots of the maps "
                f"that keep their paths (`trajectories/`, the first {config.trajectory_maps} "
                "per env) failed.", ""] if total else lines
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
