"""The learned methods' report: learning curves over seeds, and the trained networks beside the
built-ins on Table I's maps (``fftnav figure learning``, ``make learn``; docs/learning.md).

Inputs are training folders of ``fftnav learn`` (``config.json``, ``curve.csv``, ``run.json``)
and a results folder of ``fftnav run`` holding the learned methods' and the built-ins' rows.
Curves are grouped by what was trained (``controller/<observation>`` or ``decider``); a
group's band is the 95 % t-interval of the mean over its seeds at each validation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from fftnav.errors import FftnavError
from fftnav.files import read_json, write_atomic
from fftnav.metrics import FAILURE_CAUSES
from fftnav.report import new_figure, save_figure
from fftnav.report.markdown import markdown_table
from fftnav.runner.run import read_episodes
from fftnav.runner.summary import paired_gain, t_interval, wilcoxon_method

__all__ = ["comparison_pairs", "curve_figure", "paired_rows", "read_curves", "steps_to_ar",
           "table1_episodes", "training_table", "write_learning_report"]


def _group(config: dict) -> str:
    if config["method"] == "controller":
        return f"controller/{config['observation']}"
    return "decider"


def read_curves(folders: Sequence[str | Path]) -> pd.DataFrame:
    """Every training folder's ``curve.csv`` with its ``group``, ``seed`` and ``run`` (the
    folder's name) as columns, in the folders' order."""
    parts = []
    for folder in folders:
        folder = Path(folder)
        config = read_json(folder / "config.json")
        curve = pd.read_csv(folder / "curve.csv")
        curve.insert(0, "run", folder.name)
        curve.insert(1, "group", _group(config))
        curve.insert(2, "seed", int(config["seed"]))
        parts.append(curve)
    return pd.concat(parts, ignore_index=True)


def steps_to_ar(curves: pd.DataFrame, threshold: float) -> pd.Series:
    """Per run, the learner samples of its first validation with ``val_ar >= threshold``
    (NaN if none)."""
    out = {}
    for run, curve in curves.groupby("run", sort=False):
        hit = curve[curve["val_ar"] >= threshold - 1e-12]
        out[run] = float(hit["samples"].iloc[0]) if len(hit) else math.nan
    return pd.Series(out, name="samples_to_ar")


def training_table(curves: pd.DataFrame, folders: Sequence[str | Path], *,
                   threshold: float) -> pd.DataFrame:
    """One row per run: group, seed, samples, wall time, samples to the AR threshold, final
    and best validation AR and SPL."""
    reach = steps_to_ar(curves, threshold)
    rows = []
    for folder in folders:
        folder = Path(folder)
        run = read_json(folder / "run.json")
        curve = curves[curves["run"] == folder.name]
        last = curve.iloc[-1]
        best = curve.loc[curve["val_spl"].idxmax()]
        rows.append({"run": folder.name, "group": curve["group"].iloc[0],
                     "seed": int(curve["seed"].iloc[0]), "samples": int(run["samples"]),
                     "wall_s": float(run["wall_s"]), "samples_to_ar": reach[folder.name],
                     "final_val_ar": float(last["val_ar"]), "final_val_spl": float(last["val_spl"]),
                     "best_val_spl": float(best["val_spl"]),
                     "best_samples": int(best["samples"])})
    return pd.DataFrame(rows)


def _draw_group(ax, table: pd.DataFrame, measure: str, label: str) -> None:
    """One group's mean over its seeds (thick), each seed (thin) and the mean's 95 %
    t-interval (band) of ``measure`` against learner samples."""
    grid = table.pivot_table(index="samples", columns="seed", values=measure)
    grid = grid.interpolate(limit_area="inside")
    x = grid.index.to_numpy()
    bands = np.array([t_interval(row.to_numpy(float)) for _, row in grid.iterrows()])
    line = ax.plot(x, bands[:, 0], label=f"{label} ({grid.shape[1]} seeds)")[0]
    ax.fill_between(x, np.clip(bands[:, 1], 0, 1), np.clip(bands[:, 2], 0, 1),
                    color=line.get_color(), alpha=0.15, linewidth=0)
    for seed in grid.columns:
        ax.plot(x, grid[seed].to_numpy(float), color=line.get_color(), alpha=0.35,
                linewidth=0.6)


def curve_figure(curves: pd.DataFrame, path: str | Path, *, threshold: float) -> Path:
    """Validation AR and SPL of the controllers against learner samples (robot-steps), and the
    deciders' validation SPL against decisions: each group's mean over its seeds, each seed
    thin, the 95 % t-interval band of the mean; the AR threshold dashed."""
    controllers = curves[curves["group"] != "decider"]
    deciders = curves[curves["group"] == "decider"]
    panels = 2 + (len(deciders) > 0)
    fig = new_figure(figsize=(5 * panels, 4), dpi=110)
    axes = fig.subplots(1, panels, squeeze=False)[0]
    for group, table in controllers.groupby("group", sort=False):
        for ax, measure in zip(axes[:2], ("val_ar", "val_spl"), strict=True):
            _draw_group(ax, table, measure, group)
    axes[0].axhline(threshold, color="grey", linestyle="--", linewidth=0.8)
    titles = ["controllers: validation AR", "controllers: validation SPL"]
    for ax in axes[:2]:
        ax.set_xlabel("learner samples (one robot-step each)")
    if len(deciders):
        _draw_group(axes[2], deciders, "val_spl", "decider")
        axes[2].set_xlabel("learner samples (one decision each)")
        titles.append("decider: validation SPL")
    for ax, title in zip(axes, titles, strict=True):
        ax.set_title(title, fontsize=10)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.suptitle("Learning curves on the validation maps: mean over seeds (thick), each seed "
                 "(thin), 95 % t-interval of the mean (band)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def comparison_pairs(policies: Sequence[str]) -> list[tuple[str, str]]:
    """The comparisons the report tests: each ``X`` against ``X-untrained`` when both ran, and
    each learned decider against ``random``, ``own-only`` and ``fusion``.

    >>> comparison_pairs(["random", "learned-ppo-a", "learned-ppo-a-untrained",
    ...                   "learned-decider-d", "fusion"])
    [('learned-ppo-a', 'learned-ppo-a-untrained'), ('learned-decider-d', 'random'), \
('learned-decider-d', 'fusion')]
    """
    present = set(policies)
    pairs = [(p, f"{p}-untrained") for p in policies if f"{p}-untrained" in present]
    for p in policies:
        if p.startswith("learned-decider-") and not p.endswith("-untrained"):
            pairs += [(p, b) for b in ("random", "own-only", "fusion") if b in present]
    return pairs


def paired_rows(episodes: pd.DataFrame, pairs: Sequence[tuple[str, str]]) -> pd.DataFrame:
    """Per pair, per env and pooled: maps, mean per-map SPL of both, the mean difference with
    its 95 % bootstrap interval and the two-sided Wilcoxon signed-rank p of per-map SPL."""
    per_map = episodes.pivot_table(index=["env", "map_seed"], columns="policy", values="spl",
                                   aggfunc="mean")
    envs = sorted(per_map.index.get_level_values("env").unique())
    rows = []
    for method, other in pairs:
        for env in [*envs, "all"]:
            table = per_map if env == "all" else per_map.xs(env, level="env")
            pair = table[[method, other]].dropna()
            diff = (pair[method] - pair[other]).to_numpy()
            gain, low, high, p = paired_gain(diff)
            rows.append({"method": method, "against": other, "env": env, "maps": len(pair),
                         "spl_method": float(pair[method].mean()),
                         "spl_against": float(pair[other].mean()), "gain": gain,
                         "gain_ci_low": low, "gain_ci_high": high, "p_value": p,
                         "p_method": wilcoxon_method(diff)})
    return pd.DataFrame(rows)


def _method_rows(episodes: pd.DataFrame, policies: Sequence[str]) -> list[list[str]]:
    causes = list(FAILURE_CAUSES)
    rows = []
    for policy in policies:
        for env, table in episodes[episodes["policy"] == policy].groupby("env", sort=True):
            arrived = table["arrived"].astype(bool)
            failed = table.loc[~arrived, "failure"].value_counts()
            text = ", ".join(f"{c} {int(failed[c])}" for c in causes if c in failed) or "none"
            apl = table.loc[arrived, "path_length_m"].mean() if arrived.any() else math.nan
            rows.append([policy, env, f"{100 * arrived.mean():.1f}",
                         f"{100 * table['spl'].mean():.1f}",
                         "-" if math.isnan(apl) else f"{apl:.2f}", text])
    return rows


def _fmt_steps(mean: float, low: float, high: float, reached: int, runs: int) -> str:
    if reached == 0:
        return f"not reached (0 of {runs} seeds)"
    text = f"{mean:,.0f}"
    if not math.isnan(low):
        text += f" [{max(low, 0):,.0f}, {high:,.0f}]"
    if reached < runs:
        text += f" ({reached} of {runs} seeds reached it)"
    return text


def table1_episodes(folders: Sequence[Path]) -> pd.DataFrame:
    """The rows of several results folders of the same maps as one table; a policy in two of
    them must have the same rows (ValueError naming it)."""
    tables = [read_episodes(f / "episodes.csv") for f in folders]
    seen: dict[str, Path] = {}
    for folder, table in zip(folders, tables, strict=True):
        for policy in table["policy"].unique():
            if policy in seen:
                raise FftnavError(f"policy {policy!r} is in both {seen[policy]} and {folder}; "
                                  f"give each method's rows once")
            seen[policy] = folder
    return pd.concat(tables, ignore_index=True)


def write_learning_report(folders: Sequence[str | Path], out: str | Path, *,
                          table1: str | Path | Sequence[str | Path] | None = None,
                          threshold: float = 0.8, order: Sequence[str] | None = None) -> Path:
    """Write ``curves.csv``, ``training.csv``, ``curves.png`` and ``learning.md`` into ``out``
    from the training ``folders`` and, with ``table1`` (results folders of the same maps, each
    method's rows in one of them), the methods' rows (``order``: the policies shown, default
    all) and ``paired_tests.csv``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    curves = read_curves(folders)
    write_atomic(out / "curves.csv", curves.to_csv(index=False, float_format="%.6g"))
    runs = training_table(curves, folders, threshold=threshold)
    write_atomic(out / "training.csv", runs.to_csv(index=False, float_format="%.6g"))
    curve_figure(curves, out / "curves.png", threshold=threshold)
    lines = ["# Learned methods", "",
             f"Trainings: {len(runs)} runs, {runs['wall_s'].sum() / 60:.1f} min of training "
             f"in all (their own wall-clock times, summed). Validation AR threshold: "
             f"{100 * threshold:.0f} %. Curves: `curves.png`, `curves.csv`; runs: "
             f"`training.csv`.", "",
             "| trained | seeds | samples to validation AR >= "
             f"{100 * threshold:.0f} % (mean [95 % t-interval]) | final validation AR % | "
             "final validation SPL % | best validation SPL % |", "|---|---|---|---|---|---|"]
    for group, table in runs.groupby("group", sort=False):
        reach = table["samples_to_ar"].to_numpy(float)
        mean, low, high = t_interval(reach)
        ar = t_interval(100 * table["final_val_ar"].to_numpy(float))
        spl = t_interval(100 * table["final_val_spl"].to_numpy(float))
        lines.append(f"| {group} | {len(table)} | "
                     f"{_fmt_steps(mean, low, high, int((~np.isnan(reach)).sum()), len(table))} | "
                     f"{_ci_text(ar)} | {_ci_text(spl)} | "
                     f"{100 * table['best_val_spl'].max():.1f} |")
    if table1:
        folders = [Path(table1)] if isinstance(table1, (str, Path)) else [Path(t) for t in table1]
        episodes = table1_episodes(folders)
        policies = list(order) if order else sorted(episodes["policy"].unique())
        named = ", ".join(f"`{f}`" for f in folders)
        lines += ["", f"## On Table I's maps (maps never trained or validated on; rows of "
                  f"{named})", "",
                  *_md(["method", "env", "AR %", "SPL %", "APL (m)", "failed robots by cause"],
                       _method_rows(episodes, policies))]
        tests = paired_rows(episodes, comparison_pairs(policies))
        write_atomic(out / "paired_tests.csv", tests.to_csv(index=False, float_format="%.6g"))
        rows = [[r.method, r.against, r.env, str(r.maps), f"{100 * r.spl_method:.1f}",
                 f"{100 * r.spl_against:.1f}",
                 f"{100 * r.gain:+.1f} [{100 * r.gain_ci_low:+.1f}, {100 * r.gain_ci_high:+.1f}]",
                 "-" if math.isnan(r.p_value) else f"{r.p_value:.2g}", r.p_method or "-"]
                for r in tests.itertuples()]
        lines += ["", "Paired Wilcoxon signed-rank tests of per-map SPL (two-sided):", "",
                  *_md(["method", "against", "env", "maps", "SPL %", "against SPL %",
                        "gain (pts) [95 % CI]", "p", "p method"], rows)]
    write_atomic(out / "learning.md", "\n".join(lines) + "\n")
    return out / "learning.md"


def _md(headers: list[str], rows: list[list[str]]) -> list[str]:
    return markdown_table(pd.DataFrame(rows, columns=headers))


def _ci_text(ci: tuple[float, float, float]) -> str:
    mean, low, high = ci
    if math.isnan(low):
        return f"{mean:.1f}"
    return f"{mean:.1f} [{max(low, 0):.1f}, {min(high, 100):.1f}]"
