"""The report's section on map difficulty: per-map SPL against BARN's measures.

Reads ``maps.csv`` (:mod:`fftnav.runner.maps`) beside ``episodes.csv``; draws
``figures/spl_vs_difficulty.png`` (one panel per measure: each point a map and policy, its SPL
against the map's mean measure, one colour per policy, one marker per env) and tabulates
Spearman's rho of per-map SPL with each measure, per policy, over all maps pooled and per env
(:func:`fftnav.runner.maps.spearman_table`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from fftnav.optimal.difficulty import MEASURES
from fftnav.report import save_figure
from fftnav.report.markdown import markdown_table
from fftnav.runner.maps import map_spl, spearman_table

__all__ = ["SIGNIFICANCE", "difficulty_lines", "draw_spl_vs_difficulty", "spearman_markdown"]

#: Level below which a Spearman p-value counts as "the measure predicts SPL".
SIGNIFICANCE = 0.05
_MARKERS = ("o", "s", "^", "v", "D", "P", "X", "*")
#: Short names of the measures in the verdict column (a measure not listed keeps its name).
_SHORT = {"distance_to_closest_obstacle_m": "distance", "average_visibility_m": "visibility",
          "characteristic_dimension_m": "characteristic dimension"}


def draw_spl_vs_difficulty(per_map: pd.DataFrame, path: Path, *,
                           envs: Sequence[str], policies: Sequence[str]) -> Path:
    """One panel per measure: per-map SPL (%) against the map's mean measure.

    Parameters
    ----------
    per_map : pandas.DataFrame
        :func:`fftnav.runner.maps.map_spl`'s table.
    path : Path
        The PNG to write.
    envs, policies : sequence of str
        Their order: colour ``C<i>`` for the i-th policy, the i-th marker for the i-th env.
    """
    fig = Figure(figsize=(13, 7.5), layout="constrained")
    axes = fig.subplots(2, 3).ravel()
    for ax, measure in zip(axes, MEASURES, strict=False):
        for j, policy in enumerate(policies):
            for k, env in enumerate(envs):
                rows = per_map[(per_map["policy"] == policy) & (per_map["env"] == env)]
                ax.scatter(rows[measure], 100 * rows["spl"], s=22, alpha=0.75, color=f"C{j}",
                           marker=_MARKERS[k % len(_MARKERS)], label=f"{policy}, {env}")
        ax.set_xlabel(f"{measure} (map mean)")
        ax.set_ylabel("SPL of the map (%)")
        ax.grid(alpha=0.3)
    axes[-1].axis("off")
    axes[-1].legend(*axes[0].get_legend_handles_labels(), loc="center", fontsize=8,
                    title="policy, env", ncols=1 + len(policies) * len(envs) // 12)
    fig.suptitle("Per-map SPL against the map's difficulty (maps.csv, BARN's measures)")
    save_figure(fig, path, dpi=100)
    return path


def spearman_markdown(table: pd.DataFrame) -> pd.DataFrame:
    """:func:`~fftnav.runner.maps.spearman_table` as one row per (scope, policy): a cell
    ``rho (p)`` per measure, in bold when ``p < SIGNIFICANCE``, and a verdict column naming
    the measures that predict SPL.

    >>> t = pd.DataFrame({"scope": "all", "policy": "p", "measure": list(MEASURES), "maps": 9,
    ...                   "rho": [0.9, 0.1, -0.8, 0.0, np.nan],
    ...                   "p_value": [0.001, 0.5, 0.01, 1.0, np.nan]})
    >>> row = spearman_markdown(t).iloc[0]
    >>> row["dispersion"], row["tortuosity"], row["predicts SPL (p < 0.05)"]
    ('**-0.80 (0.01)**', '-', 'distance (+), dispersion (-)')
    """
    rows = []
    for (scope, policy), group in table.groupby(["scope", "policy"], sort=False):
        row = {"scope": scope, "policy": policy, "maps": int(group["maps"].max())}
        verdict = []
        for r in group.itertuples(index=False):
            if np.isnan(r.rho):
                row[r.measure] = "-"
                continue
            cell = f"{r.rho:+.2f} ({r.p_value:.2g})"
            significant = r.p_value < SIGNIFICANCE
            row[r.measure] = f"**{cell}**" if significant else cell
            if significant:
                verdict.append(f"{_SHORT.get(r.measure, r.measure)} "
                               f"({'+' if r.rho > 0 else '-'})")
        row[f"predicts SPL (p < {SIGNIFICANCE:g})"] = ", ".join(verdict) or "none"
        rows.append(row)
    return pd.DataFrame(rows)


def difficulty_lines(episodes: pd.DataFrame, maps: pd.DataFrame | None, figures: Path, *,
                     envs: Sequence[str], policies: Sequence[str]) -> list[str]:
    """The report's section on map difficulty (its figure written into ``figures``); a line
    saying what is missing when ``maps`` is None or shares no map with ``episodes``."""
    head = ["## How hard each map is, and whether that predicts SPL", ""]
    if maps is None:
        return [*head, "(no `maps.csv` in this folder: rerun `fftnav run` on it to write it)",
                ""]
    per_map = map_spl(episodes, maps)
    if per_map.empty:
        return [*head, "(`maps.csv` shares no map with `episodes.csv`)", ""]
    envs = [e for e in envs if e in set(per_map["env"])]
    policies = [p for p in policies if p in set(per_map["policy"])]
    picture = draw_spl_vs_difficulty(per_map, figures / "spl_vs_difficulty.png", envs=envs,
                                     policies=policies)
    table = spearman_markdown(spearman_table(per_map, envs=envs, policies=policies))
    return [
        *head,
        "Per map, each policy's SPL (the mean over the map's robots) and the map's difficulty "
        "(`maps.csv`: BARN's five measures along each robot's reference path, averaged over "
        "the map's robots; docs/analysis.md). Spearman's rho of per-map SPL with each measure "
        "and its two-sided p-value, over every map of every env (`all`) and over the maps of "
        f"each env; **bold** and named in the last column when p < {SIGNIFICANCE:g}. More "
        "room (distance, visibility, characteristic dimension) should go with a higher SPL "
        "(rho > 0), more clutter or detour (dispersion, tortuosity) with a lower one "
        "(rho < 0). The pooled rows mix envs whose SPL and measures both differ; the per-env "
        "rows compare maps of one kind. Each row tests 5 measures: at p < 0.05 about one "
        "bold cell in 20 is expected by chance alone. `-`: SPL or the measure is the same "
        "on every map.",
        "",
        *markdown_table(table),
        "",
        f"![{picture.stem}](figures/{picture.name})",
        "",
    ]
