"""Report of an experiment folder: ``report.md`` (beside the paper's Table I when the experiment
is the paper's protocol, :func:`is_paper_protocol`), and its figures.

Reads what :func:`fftnav.runner.run_experiment` wrote (``episodes.csv``, ``summary.csv``,
``paired_tests.csv``, ``run_info.json``, ``config.toml``, ``maps.csv``, ``trajectories/``,
``records/``) and writes ``report.md``, ``failures.csv`` (every robot that did not arrive,
:func:`fftnav.report.failures.failed_robots`) and ``figures/*.png`` into the same folder:

- ``trajectories_<env>.png``: all robots of the first map, one panel per policy (paper Fig. 7);
- ``spl_apl.png``: SPL and APL per env and policy with 95% bootstrap intervals over maps, the
  paper's Table I values as crosses (the paper's protocol only);
- ``path_lengths.png``: distributions of the path lengths of the robots that arrived;
- ``spl_vs_difficulty.png`` (with ``maps.csv``): per-map SPL against each difficulty measure,
  beside a table of Spearman's rho (:mod:`fftnav.report.difficulty`);
- ``failure_positions.png``: where the robots that failed ended, by cause, beside the failure
  counts per env and policy and the list of failed robots with links to their replays
  (:mod:`fftnav.report.failures`).

Every ``-`` of a table is a missing number whose reason, computed from the data, is given under
the table (:class:`fftnav.report.markdown.Dashes`).
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
from fftnav.files import read_json, read_text, write_atomic
from fftnav.report import save_figure
from fftnav.report.difficulty import difficulty_lines
from fftnav.report.failures import failure_lines
from fftnav.report.markdown import Dashes, markdown_table
from fftnav.report.trajectories import draw_trajectories as draw_paths
from fftnav.report.trajectories import plot_failures
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.maps import maps_current, write_maps_csv
from fftnav.runner.resume import (
    FolderLock,
    canonical_config,
    config_changes,
    located,
    stored_as_absolute,
)
from fftnav.runner.run import CSV_COLUMNS, read_episodes
from fftnav.runner.summary import EXACT, NORMAL_APPROX, WILCOXON_EXACT_MAX, in_order
from fftnav.runner.tasks import task_count, task_world
from fftnav.suites import find_suite

__all__ = ["PAPER_NAMES", "PAPER_TABLE1", "is_paper_protocol", "p_method_lines",
           "paired_table", "report_folder", "results_table", "write_report"]

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
#: The paper's protocol (Sec. IV), as :func:`is_paper_protocol` checks it: its envs, maps and
#: robots (the swarm settings are :class:`fftnav.config.SwarmConfig`'s defaults).
def is_paper_protocol(config: ExperimentConfig) -> bool:
    """Whether ``config`` runs the paper's protocol, so that its results may stand beside the
    paper's Table I: the newest version of the ``paper`` suite (``paper-v2``,
    :mod:`fftnav.suites`) on some of its envs: its maps, map seed and robots, its robot,
    sensor, comms, episode, planner and localization settings and its worlds (no other
    ``[world]`` overrides, no ``[world_files]``). The policies and ``[record]`` are free
    (recording changes no result).

    >>> from fftnav.runner import parse_config
    >>> paper = {"name": "t", "envs": ["rocky"], "maps": 20, "map_seed": 1000, "robots": 15,
    ...          "policies": ["fusion"]}
    >>> is_paper_protocol(parse_config({"experiment": paper}))
    True
    >>> is_paper_protocol(parse_config({"experiment": paper, "comms": {"packet_loss": 0.3}}))
    False
    """
    suite = find_suite("paper").experiment(["bug-left"])
    return (bool(config.envs) and set(config.envs) <= set(suite.envs)
            and config.maps == suite.maps and config.map_seed == suite.map_seed
            and config.robots == suite.robots and config.swarm == suite.swarm
            and all(config.world_overrides(env) == suite.world_overrides(env)
                    for env in config.envs)
            and not config.world_files)


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
    paper = is_paper_protocol(config)
    pictures = [draw_trajectories(config, out, env, episodes, figures) for env in config.envs]
    pictures = [p for p in pictures if p is not None]
    if len(summary):
        pictures += [draw_metric_bars(summary, figures / "spl_apl.png", paper=paper),
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
                                               episodes=episodes, paper=paper,
                                               pictures=pictures, sections=sections)))
    return path


def report_folder(config: ExperimentConfig, out_dir: str | Path, *,
                  workers: int | None = 1) -> Path:
    """Bring a finished results folder's ``maps.csv`` and report up to date, running no episode.

    ``maps.csv`` is written if missing or not of the config's maps
    (:func:`fftnav.runner.maps.maps_current`), then ``report.md``, ``failures.csv`` and the
    figures (:func:`write_report`); nothing else in the folder changes (the run's CSVs,
    ``run_info.json``).

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
    _check_folder(config, out)
    with FolderLock(out):
        if not maps_current(out, config):
            write_maps_csv(out, config, workers=workers)
        return write_report(config, out)


#: What a finished results folder holds, each read by the report.
_FOLDER_FILES = ("episodes.csv", "summary.csv", "paired_tests.csv", "run_info.json",
                 "config.json")


def _check_folder(config: ExperimentConfig, out: Path) -> None:
    """Refuse, in one line naming the file, a folder that is not a finished results folder of
    ``config``: a file missing or damaged, another experiment's ``config.json``, or an
    ``episodes.csv`` without every robot of every task (a run still going, or killed)."""
    given = f"--out={str(out)!r}"
    for name in _FOLDER_FILES:
        if not (out / name).is_file():
            raise FftnavError(f"--out must be a finished results folder of fftnav run, got "
                              f"{given} without {name}")
    stored = read_json(out / "config.json")
    read_json(out / "run_info.json")
    canonical = canonical_config(config, CSV_COLUMNS, folder=out)
    if stored != json.loads(canonical) and not stored_as_absolute(config, out, CSV_COLUMNS):
        changes = config_changes(located(stored if isinstance(stored, dict) else {}, out),
                                 located(json.loads(canonical), out))
        raise FftnavError(f"--out must hold results of {config.name!r} as configured, got "
                          f"{given} whose config.json differs: "
                          f"{', '.join(changes) or 'the layout of config.json'}")
    text = read_text(out / "episodes.csv")
    rows = text.count("\n") - 1
    expected = task_count(config) * config.robots
    if not text.endswith("\n") or rows != expected:
        cut = "" if text.endswith("\n") else ", its last row cut short"
        raise FftnavError(f"{out / 'episodes.csv'} holds {max(rows, 0)} robot rows{cut}, "
                          f"expected {expected} ({task_count(config)} episodes x "
                          f"{config.robots} robots): the run has not finished; run "
                          f"`fftnav run` again to finish it")
    for name in ("episodes.csv", "summary.csv", "paired_tests.csv"):
        read_episodes(out / name)  # a CSV that does not parse: one line naming it


def _report_lines(config: ExperimentConfig, *, info: dict[str, Any], summary: pd.DataFrame,
                  paired: pd.DataFrame, episodes: pd.DataFrame, paper: bool,
                  pictures: list[Path], sections: list[str]) -> list[str]:
    """The lines of ``report.md``: the run, the results (beside the paper's Table I when
    ``paper``), the paired tests, the ``sections`` (map difficulty, failures), the figures and
    the config."""
    results_dashes, paired_dashes = Dashes(), Dashes()
    results = results_table(summary, episodes, paper=paper, dashes=results_dashes)
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
        "## Results beside the paper's Table I" if paper else "## Results",
        "",
        "This run: AR and SPL in percent with 95% bootstrap intervals over maps; APL in metres "
        "over the robots that arrived. SPL uses the paper's reference (8-connected grid A* at "
        "0.05 m); SPL geodesic uses the near-Euclidean 32-connected length, which does not let "
        "paths shorter than an 8-connected detour score 1."
        + (" Paper: Table I (Gazebo, 20 maps, 15 robots)." if paper else
           " The paper's Table I is not shown: this experiment is not the paper's protocol "
           "(forest and rocky, 20 maps from seed 1000, 15 robots, default settings, "
           "generated worlds)."),
        "",
        *markdown_table(results),
        "",
        *_legend(results_dashes),
        "## Paired tests (per-map SPL, Wilcoxon signed-rank, two-sided)",
        "",
        *([*markdown_table(paired_table(paired, dashes=paired_dashes)), "",
           *_legend(paired_dashes), *p_method_lines(paired)]
          if len(paired) else ["(no `fusion` rows to compare)", ""]),
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


def _legend(dashes: Dashes) -> list[str]:
    """The legend of a table's missing numbers and a blank line, or nothing."""
    legend = dashes.legend()
    return [*legend, ""] if legend else []


def results_table(summary: pd.DataFrame, episodes: pd.DataFrame | None = None, *,
                  paper: bool = True, dashes: Dashes | None = None) -> pd.DataFrame:
    """Our AR / APL / SPL (percent, metres), one row per env/policy, beside the paper's Table I
    when ``paper`` (:func:`is_paper_protocol`).

    Parameters
    ----------
    summary : pandas.DataFrame
        ``summary.csv``.
    episodes : pandas.DataFrame, optional
        ``episodes.csv``: the maps without an arrived robot, which leave APL's interval
        undefined, are counted from it.
    paper : bool
        Add the paper's columns (its name of the policy, AR, APL, SPL).
    dashes : Dashes, optional
        Collects the reason of every missing number (its legend goes under the table).

    Returns
    -------
    pandas.DataFrame
        Values as text; an undefined interval is ``[-]`` and a missing value ``-``, each
        marked with its reason's number.
    """
    dashes = dashes if dashes is not None else Dashes()
    rows = []
    for r in summary.itertuples(index=False):
        mine = (episodes[(episodes["env"] == r.env) & (episodes["policy"] == r.policy)]
                if episodes is not None else None)
        maps = int(r.episodes)
        no_robot = f"no robot of `{r.policy}` on {r.env} in `episodes.csv`"
        row = {
            "env": r.env,
            "policy": r.policy,
            "AR %": _ci(dashes, 100 * r.ar, 100 * r.ar_ci_low, 100 * r.ar_ci_high, 1,
                        reason=no_robot, interval_reason=_interval_reason("ar", maps, mine)),
            "APL m": _ci(dashes, r.apl_m, r.apl_ci_low, r.apl_ci_high, 3,
                         reason="no robot arrived (APL is the mean path length of the robots "
                         "that arrived)", interval_reason=_interval_reason("apl", maps, mine)),
            "SPL %": _ci(dashes, 100 * r.spl, 100 * r.spl_ci_low, 100 * r.spl_ci_high, 1,
                         reason=no_robot, interval_reason=_interval_reason("spl", maps, mine)),
            "SPL geodesic %": _fmt(dashes, 100 * r.spl_geodesic, 1, _geodesic_reason(mine)),
        }
        if paper:
            figures = PAPER_TABLE1.get((r.env, r.policy), (np.nan,) * 3)
            absent = "the paper's Table I has no row of this env and policy"
            row = {"env": row.pop("env"), "policy": row.pop("policy"),
                   "paper name": PAPER_NAMES.get(r.policy) or dashes.dash(
                       "the policy is not one of the paper's methods"), **row,
                   "paper AR %": _fmt(dashes, figures[0], 1, absent),
                   "paper APL m": _fmt(dashes, figures[1], 3, absent),
                   "paper SPL %": _fmt(dashes, figures[2], 1, absent)}
        rows.append(row)
    return pd.DataFrame(rows)


def _interval_reason(measure: str, maps: int, episodes: pd.DataFrame | None) -> str:
    """Why the bootstrap interval of ``measure`` over ``maps`` maps is undefined."""
    if maps < 2:
        return f"{maps} map: no interval over maps (it needs two or more)"
    if measure == "apl" and episodes is not None:
        arrived = episodes.groupby("map_seed")["arrived"].sum()
        empty = int((arrived == 0).sum())
        if empty:
            return (f"{empty} of the {maps} maps had no robot arrive: a bootstrap resample of "
                    "those maps alone has no APL, so the interval is undefined")
    return f"the bootstrap interval of {measure} is undefined (a resample with no {measure})"


def _geodesic_reason(episodes: pd.DataFrame | None) -> str:
    """Why SPL geodesic is missing."""
    if episodes is not None and "geodesic_length_m" not in episodes:
        return "`episodes.csv` has no `geodesic_length_m` column"
    return "no geodesic length in `episodes.csv` for these robots"


def paired_table(paired: pd.DataFrame, *, dashes: Dashes | None = None) -> pd.DataFrame:
    """``paired_tests.csv`` as the report shows it: numbers rounded to 4 decimals, p to 2
    significant digits, and each missing number a ``-`` marked with its reason (collected in
    ``dashes``): no map with both policies, or every paired difference 0 (no test)."""
    dashes = dashes if dashes is not None else Dashes()
    shown = paired.round(4).astype(object)
    for i, r in enumerate(paired.itertuples(index=False)):
        if r.maps == 0:
            reason = (f"no map has results of both `{r.reference}` and `{r.policy}` on "
                      f"{r.env}")
        else:
            reason = (f"every paired difference is 0 (`{r.reference}` and `{r.policy}` have "
                      f"the same SPL on each of the {r.maps} maps): no test")
        for column in ("spl_reference", "spl_policy", "median_diff", "statistic", "p_value"):
            if pd.isna(getattr(r, column)):
                shown.iloc[i, shown.columns.get_loc(column)] = dashes.dash(reason)
        if not pd.isna(r.p_value):
            shown.iloc[i, shown.columns.get_loc("p_value")] = f"{r.p_value:.2g}"
        if "p_method" in paired and pd.isna(r.p_method):
            shown.iloc[i, shown.columns.get_loc("p_method")] = dashes.dash(reason)
    return shown


def p_method_lines(paired: pd.DataFrame) -> list[str]:
    """The footnote of a table of paired tests (``paired_tests.csv``): how its p-values were
    computed, from its ``p_method`` column (a line and a blank line; none without a p-value)."""
    if "p_method" not in paired:
        return ["How these p-values were computed is not recorded: this `paired_tests.csv` "
                "has no `p_method` column (rerun `fftnav run` on the folder to rewrite it).", ""]
    used = set(paired["p_method"].dropna())
    lines = []
    if EXACT in used:
        lines.append(f"`{EXACT}`: from the exact null distribution, the 2^n equally likely "
                     "signs of the n non-zero per-map differences, ties at their average rank "
                     f"(n <= {WILCOXON_EXACT_MAX}; beyond, scipy's exact distribution, which "
                     "holds without ties or zeros up to 50 maps)")
    if NORMAL_APPROX in used:
        lines.append(f"`{NORMAL_APPROX}`: the normal approximation (scipy's default: no "
                     "continuity correction, the variance corrected for ties) "
                     f"(more than {WILCOXON_EXACT_MAX} non-zero differences, with ties or zeros "
                     "or more than 50 maps)")
    return ["`p_method` " + "; ".join(lines) + ".", ""] if lines else []


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


def draw_metric_bars(summary: pd.DataFrame, path: Path, *, paper: bool = True) -> Path:
    """SPL (%) and APL (m) bars per env and policy with 95% intervals; with ``paper``
    (:func:`is_paper_protocol`), the paper's Table I values as crosses."""
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
            if paper:
                values = [PAPER_TABLE1.get((e, policy), (np.nan,) * 3)[paper_col] for e in envs]
                ax.plot(x, values, "kx", ms=8, label="paper" if j == 0 else None)
        ax.set_xticks(np.arange(len(envs)), envs)
        ax.set_ylabel(label)
    fig.legend(*fig.axes[0].get_legend_handles_labels(), loc="outside upper center",
               ncols=len(policies) + int(paper), fontsize=8)
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


def _fmt(dashes: Dashes, value: float, digits: int, reason: str) -> str:
    """``value`` with ``digits`` decimals, or a dash marked with ``reason`` when NaN."""
    return dashes.dash(reason) if np.isnan(value) else f"{value:.{digits}f}"


def _ci(dashes: Dashes, value: float, low: float, high: float, digits: int, *, reason: str,
        interval_reason: str) -> str:
    """``value [low, high]``; a dash marked with ``reason`` when the value is NaN, and
    ``value [-]`` marked with ``interval_reason`` when only the interval is."""
    if np.isnan(value):
        return dashes.dash(reason)
    if np.isnan(low):
        return f"{value:.{digits}f} [{dashes.dash(interval_reason)}]"
    return f"{value:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"


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
