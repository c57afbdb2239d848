"""Report of an experiment folder: ``report.md`` beside the paper's Table I, and its figures.

Reads what :func:`fftnav.runner.run_experiment` wrote (``episodes.csv``, ``summary.csv``,
``paired_tests.csv``, ``run_info.json``, ``config.toml``, ``maps.csv``, ``trajectories/``,
``records/``) and writes ``report.md`` and ``figures/*.png`` into the same folder:

- ``trajectories_<env>.png``: all robots of the first map, one panel per policy (paper Fig. 7);
- ``spl_apl.png``: SPL and APL per env and policy with 95% bootstrap intervals over maps, the
  paper's Table I values as crosses;
- ``path_lengths.png``: distributions of the path lengths of the robots that arrived;
- ``spl_vs_difficulty.png`` (with ``maps.csv``): per-map SPL against each difficulty measure,
  beside a table of Spearman's rho (:mod:`fftnav.report.difficulty`);
- ``failure_positions.png``: where the robots that failed ended, by cause, beside the failure
  counts per env and policy with links to the recordings (:mod:`fftnav.report.failures`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from fftnav.episode.record import EPISODE_COLUMNS, EpisodeRow
from fftnav.errors import FftnavError
from fftnav.files import write_atomic
from fftnav.report import save_figure
from fftnav.report.difficulty import difficulty_lines
from fftnav.report.failures import failure_lines
from fftnav.report.markdown import markdown_table
from fftnav.report.trajectories import draw_trajectories as draw_paths
from fftnav.report.trajectories import plot_failures
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.maps import maps_current, write_maps_csv
from fftnav.runner.resume import FolderLock, canonical_config, config_changes
from fftnav.runner.run import CSV_COLUMNS
from fftnav.runner.summary import in_order
from fftnav.runner.tasks import task_world

__all__ = ["PAPER_TABLE1", "PAPER_NAMES", "report_folder", "write_report"]

#: The paper's Table I (Gazebo): (env, policy) -> (AR %, APL m, SPL %).
PAPER_TABLE1: dict[tuple[str, str], tuple[float, float, float]] = {
    ("forest", "bug-left"): (99.7, 21.328, 87.3),
    ("forest", "bug-right"): (98.7, 21.320, 87.3),
    ("forest", "fusion"): (100.0, 19.452, 95.7),
    ("rocky", "bug-left"): (99.3, 20.780, 90.1),
    ("rocky", "bug-right"): (100.0, 20.688, 90.5),
    ("rocky", "fusion"): (100.0, 19.197, 97.6),
}
#: The paper's names of our policies.
PAPER_NAMES = {"bug-left": "Bug (left)", "bug-right": "Bug (right)", "fusion": "Proposed"}


def write_report(config: ExperimentConfig, out_dir: str | Path) -> Path:
    """Write ``report.md`` and ``figures/*.png`` for an experiment folder.

    Parameters
    ----------
    config : ExperimentConfig
        The experiment that was run into ``out_dir`` (its worlds are regenerated for the maps).
    out_dir : str or Path
        Folder written by :func:`fftnav.runner.run_experiment`.

    Returns
    -------
    Path
        The ``report.md`` written.
    """
    out = Path(out_dir)
    figures = out / "figures"
    figures.mkdir(exist_ok=True)
    episodes = pd.read_csv(out / "episodes.csv")
    summary = pd.read_csv(out / "summary.csv")
    paired = pd.read_csv(out / "paired_tests.csv")
    info = json.loads((out / "run_info.json").read_text())
    pictures = [draw_trajectories(config, out, env, episodes, figures) for env in config.envs]
    pictures = [p for p in pictures if p is not None]
    if len(summary):
        pictures += [draw_metric_bars(summary, figures / "spl_apl.png"),
                     draw_path_lengths(episodes, figures / "path_lengths.png",
                                       envs=config.envs, policies=config.policy_names)]
    sections = []
    if len(episodes):
        maps = pd.read_csv(out / "maps.csv") if (out / "maps.csv").is_file() else None
        sections = [*difficulty_lines(episodes, maps, figures, envs=config.envs,
                                      policies=config.policy_names),
                    *failure_lines(config, out, episodes, figures)]
    path = out / "report.md"
    write_atomic(path, "\n".join(_report_lines(config, info=info, summary=summary, paired=paired,
                                               pictures=pictures, sections=sections)))
    return path


def report_folder(config: ExperimentConfig, out_dir: str | Path, *,
                  workers: int | None = 1) -> Path:
    """Bring a finished results folder's ``maps.csv`` and report up to date, running no episode.

    ``maps.csv`` is written if missing or not of the config's maps
    (:func:`fftnav.runner.maps.maps_current`), then ``report.md`` and its figures
    (:func:`write_report`); nothing else in the folder changes (its CSVs, ``run_info.json``).

    Parameters
    ----------
    config : ExperimentConfig
        The experiment the folder holds: its ``config.json`` must be this config's.
    out_dir : str or Path
        A folder written by :func:`fftnav.runner.run_experiment` (``episodes.csv`` and the
        other CSVs, ``run_info.json``).
    workers : int, optional
        Processes computing ``maps.csv`` (1: in this process; None: all cores).

    Raises
    ------
    ValueError
        If the folder has no ``episodes.csv`` or holds another experiment, naming what differs.
    """
    out = Path(out_dir)
    if not (out / "episodes.csv").is_file():
        raise FftnavError(f"--out must be a results folder with an episodes.csv, got "
                          f"--out={str(out)!r}")
    canonical = canonical_config(config, CSV_COLUMNS)
    stored = (out / "config.json").read_text() if (out / "config.json").is_file() else "{}"
    if stored != canonical:
        changes = config_changes(json.loads(stored), json.loads(canonical))
        raise FftnavError(f"--out must hold results of {config.name!r} as configured, got "
                          f"--out={str(out)!r} whose config.json differs: "
                          f"{', '.join(changes) or 'the layout of config.json'}")
    with FolderLock(out):
        if not maps_current(out, config):
            write_maps_csv(out, config, workers=workers)
        return write_report(config, out)


def _report_lines(config: ExperimentConfig, *, info: dict[str, Any], summary: pd.DataFrame,
                  paired: pd.DataFrame, pictures: list[Path], sections: list[str]) -> list[str]:
    """The lines of ``report.md``: the run, the results beside the paper's Table I, the paired
    tests, the ``sections`` (map difficulty, failures), the figures and the config."""
    return [
        f"# Experiment `{config.name}`",
        "",
        f"{len(config.envs)} env(s) x {config.maps} maps (seeds {config.map_seed}..."
        f"{config.map_seed + config.maps - 1}) x {len(config.policies)} policies, "
        f"{config.robots} robots per episode. fftnav {info['fftnav_version']}, git "
        f"`{info['git_revision']}`, {info['executor']} executor, "
        f"{info['workers'] or info['scheduler']} workers, "
        f"wall time {info['wall_time_total_s']:.1f} s "
        f"(last invocation {info['wall_time_s']:.1f} s: "
        f"{info['tasks_completed']} episodes run, {info['tasks_skipped']} already done, "
        f"{info['tasks_failed']} failed).",
        "",
        *([f"**{info['tasks_failed']} episode(s) failed and are missing from the tables: see "
           "`errors.csv`; rerun the same command to retry them.**", ""]
          if info["tasks_failed"] else []),
        "## Results beside the paper's Table I",
        "",
        "This run: AR and SPL in percent with 95% bootstrap intervals over maps; APL in metres "
        "over the robots that arrived. SPL uses the paper's reference (8-connected grid A* at "
        "0.05 m); SPL geodesic uses the near-Euclidean 32-connected length, which does not let "
        "paths shorter than an 8-connected detour score 1. Paper: Table I (Gazebo, 20 maps, "
        "15 robots).",
        "",
        *markdown_table(results_table(summary)),
        "",
        "## Paired tests (per-map SPL, Wilcoxon signed-rank, two-sided)",
        "",
        *(markdown_table(paired.round(4).assign(
            p_value=paired["p_value"].map(lambda v: f"{v:.2g}")))
          if len(paired) else ["(no `fusion` rows to compare)"]),
        "",
        *sections,
        "## Figures",
        "",
        *(f"![{p.stem}](figures/{p.name})" for p in pictures),
        "",
        "## Config",
        "",
        "```toml",
        config.source.strip(),
        "```",
        "",
    ]


def results_table(summary: pd.DataFrame) -> pd.DataFrame:
    """Our AR / APL / SPL (percent, metres) beside the paper's Table I, one row per env/policy."""
    rows = []
    for r in summary.itertuples(index=False):
        paper = PAPER_TABLE1.get((r.env, r.policy), (np.nan,) * 3)
        rows.append({
            "env": r.env,
            "policy": r.policy,
            "paper name": PAPER_NAMES.get(r.policy, "-"),
            "AR %": _ci(100 * r.ar, 100 * r.ar_ci_low, 100 * r.ar_ci_high, 1),
            "APL m": _ci(r.apl_m, r.apl_ci_low, r.apl_ci_high, 3),
            "SPL %": _ci(100 * r.spl, 100 * r.spl_ci_low, 100 * r.spl_ci_high, 1),
            "SPL geodesic %": _fmt(100 * r.spl_geodesic, 1),
            "paper AR %": _fmt(paper[0], 1),
            "paper APL m": _fmt(paper[1], 3),
            "paper SPL %": _fmt(paper[2], 1),
        })
    return pd.DataFrame(rows)


def draw_trajectories(config: ExperimentConfig, out: Path, env: str, episodes: pd.DataFrame,
                      figures: Path) -> Path | None:
    """All robots' paths on the env's first map, one panel per policy (like the paper's Fig. 7).

    Arrived robots solid, failed ones dashed with a cross (:mod:`fftnav.report.trajectories`).
    """
    map_seed = config.map_seed
    found = [(p, out / "trajectories" / f"{env}-{map_seed}-{p}.npz") for p in config.policy_names]
    found = [(p, f) for p, f in found if f.exists()]
    if not found:
        return None
    world = task_world(config, env, map_seed)
    fig = Figure(figsize=(4.2 * len(found), 4.6), layout="constrained")
    axes = fig.subplots(1, len(found), squeeze=False)[0]
    for ax, (policy, file) in zip(axes, found, strict=True):
        rows = episodes[(episodes.env == env) & (episodes.map_seed == map_seed)
                        & (episodes.policy == policy)].sort_values("robot")
        with np.load(file) as data:
            paths = [data[f"arr_{i}"] for i in range(len(data.files))]
        draw_paths(ax, world, paths, rows.arrived.astype(bool).tolist())
        ax.set_title(f"{policy} ({PAPER_NAMES.get(policy, 'extra')}): "
                     f"{int(rows.arrived.sum())}/{len(rows)} arrived")
    fig.suptitle(f"{env}, map seed {map_seed}: trajectories of {config.robots} robots")
    path = figures / f"trajectories_{env}.png"
    save_figure(fig, path, dpi=110)
    return path


def draw_metric_bars(summary: pd.DataFrame, path: Path) -> Path:
    """SPL (%) and APL (m) bars per env and policy with 95% intervals; paper values as crosses."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    envs = list(dict.fromkeys(summary["env"]))
    policies = list(dict.fromkeys(summary["policy"]))
    width = 0.8 / len(policies)
    panels = (("spl", 100, "SPL (%)", 2), ("apl", 1, "APL (m)", 1))
    for ax, (metric, scale, label, paper_col) in zip(fig.subplots(1, 2), panels, strict=True):
        value = "apl_m" if metric == "apl" else metric
        for j, policy in enumerate(policies):
            rows = summary[summary["policy"] == policy].set_index("env").reindex(envs)
            x = np.arange(len(envs)) + (j - (len(policies) - 1) / 2) * width
            y = scale * rows[value].to_numpy()
            err = scale * np.abs(rows[[f"{metric}_ci_low", f"{metric}_ci_high"]].to_numpy().T
                                 - rows[value].to_numpy())
            ax.bar(x, y, width, yerr=err, capsize=3, label=policy, color=f"C{j}")
            paper = [PAPER_TABLE1.get((e, policy), (np.nan,) * 3)[paper_col] for e in envs]
            ax.plot(x, paper, "kx", ms=8, label="paper" if j == 0 else None)
        ax.set_xticks(np.arange(len(envs)), envs)
        ax.set_ylabel(label)
    fig.legend(*fig.axes[0].get_legend_handles_labels(), loc="outside upper center",
               ncols=len(policies) + 1, fontsize=8)
    save_figure(fig, path, dpi=110)
    return path


def draw_path_lengths(episodes: pd.DataFrame, path: Path, *, envs: Sequence[str] | None = None,
                      policies: Sequence[str] | None = None) -> Path:
    """Box plots of the path lengths (m) of the robots that arrived, per env and policy, in the
    order of ``envs`` and ``policies`` (:func:`fftnav.runner.summary.in_order`)."""
    envs = in_order(episodes["env"], envs)
    fig = Figure(figsize=(5 * len(envs), 4), layout="constrained")
    arrived = episodes[episodes["arrived"].astype(bool)]
    for ax, env in zip(fig.subplots(1, len(envs), squeeze=False)[0], envs, strict=True):
        data = arrived[arrived["env"] == env]
        names = in_order(episodes.loc[episodes["env"] == env, "policy"], policies)
        ax.boxplot([data.loc[data["policy"] == p, "path_length_m"] for p in names],
                   tick_labels=names)
        ax.axhline(data["optimal_length_m"].mean(), ls="--", color="grey",
                   label="mean optimal length")
        ax.set_title(f"{env}: path length of the robots that arrived")
        ax.set_ylabel("path length (m)")
        ax.legend(fontsize=8)
    save_figure(fig, path, dpi=110)
    return path


def _fmt(value: float, digits: int) -> str:
    return "-" if np.isnan(value) else f"{value:.{digits}f}"


def _ci(value: float, low: float, high: float, digits: int) -> str:
    """``value [low, high]``; the interval is left out when undefined (NaN)."""
    interval = "" if np.isnan(low) else f" [{low:.{digits}f}, {high:.{digits}f}]"
    return _fmt(value, digits) + interval


def draw_failures(config: ExperimentConfig, results: str | Path, *, env: str, map_seed: int,
                  policy: str, path: str | Path) -> Path:
    """The robots of one episode of a results folder that did not arrive
    (:func:`fftnav.report.trajectories.plot_failures`).

    The paths come from the folder's ``trajectories/<task>.npz`` (the first
    ``trajectory_maps`` maps of a run; the folder may be that of a run still going or
    interrupted, whose task CSV is read then) or, where the folder has none (any other map, or
    a clone of the repository, which keeps no trajectories), from the episode rerun on demand
    and checked against the folder's rows (:func:`fftnav.runner.rerun.rerun_task`).

    Raises
    ------
    ValueError
        No such episode in the folder (naming the close ones), or a rerun whose rows differ.
    """
    results = Path(results)
    stem = f"{env}-{map_seed}-{policy}"
    npz = results / "trajectories" / f"{stem}.npz"
    if npz.exists():
        rows = _task_rows(results, env, map_seed, policy)
        with np.load(npz) as z:
            paths = [z[f"arr_{i}"] for i in range(len(z.files))]
    else:
        from fftnav.runner.rerun import rerun_task

        rerun = rerun_task(results, stem)
        rows, paths = rerun.result.rows, rerun.result.trajectories or []
    return plot_failures(task_world(config, env, map_seed), paths, rows, path,
                         control_hz=config.swarm.episode.control_hz)


def _task_rows(results: Path, env: str, map_seed: int, policy: str) -> list[EpisodeRow]:
    """The rows of one task of a results folder: from ``episodes.csv``, else (a run going on)
    from the task's own CSV."""
    if (results / "episodes.csv").exists():
        table = pd.read_csv(results / "episodes.csv")
    else:
        columns = json.loads((results / "config.json").read_text())["csv_columns"]
        table = pd.read_csv(results / "episodes" / f"{env}-{map_seed}-{policy}.csv",
                            header=None, names=columns)
    table = table[(table.env == env) & (table.map_seed == map_seed)
                  & (table.policy == policy)].sort_values("robot")
    if "failure" in table:  # an empty cell (a robot that arrived) reads as NaN
        table["failure"] = table["failure"].fillna("")
    return [EpisodeRow(**{c: r[c] for c in EPISODE_COLUMNS if c in r})
            for r in table.to_dict("records")]
