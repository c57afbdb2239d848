"""The report's section on map difficulty: per-map SPL against BARN's measures.

Reads ``maps.csv`` (:mod:`fftnav.runner.maps`) beside ``episodes.csv``; draws
``figures/spl_vs_difficulty.png`` (one panel per measure: each point a map and policy, its SPL
against the map's mean measure, one colour per policy, one marker per env) and tabulates
Spearman's rho of per-map SPL with each measure, per policy, over all maps pooled and per env
(:func:`fftnav.runner.maps.spearman_table`), each missing rho a ``-`` marked with its reason
(:class:`fftnav.report.markdown.Dashes`), and says how each p-value was computed (exact or the
t approximation, :func:`fftnav.runner.maps.spearman_test`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from fftnav.optimal.difficulty import MEASURES
from fftnav.report import save_figure
from fftnav.report.markdown import Dashes, markdown_table
from fftnav.runner.maps import SPEARMAN_EXACT_MAX, T_APPROX, map_spl, spearman_table

__all__ = ["SIGNIFICANCE", "difficulty_lines", "draw_spl_vs_difficulty", "no_rho_reason",
           "spearman_markdown", "spearman_method_lines"]

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


def _scope_rows(per_map: pd.DataFrame, scope: str, policy: str) -> pd.DataFrame:
    """The rows of :func:`~fftnav.runner.maps.map_spl`'s table that a (scope, policy) row of
    :func:`~fftnav.runner.maps.spearman_table` ranks: every env for ``"all"``, else one."""
    rows = per_map[per_map["policy"] == policy]
    return rows if scope == "all" else rows[rows["env"] == scope]


def no_rho_reason(maps: int, measure: str, *, rows: pd.DataFrame | None = None) -> str:
    """Why Spearman's rho of per-map SPL with ``measure`` is undefined.

    Parameters
    ----------
    maps : int
        The maps where both SPL and the measure are defined (the ``maps`` of
        :func:`~fftnav.runner.maps.spearman_table`).
    measure : str
        The measure's column.
    rows : pandas.DataFrame, optional
        The per-map rows ranked (:func:`~fftnav.runner.maps.map_spl`'s, of one scope and
        policy): with them the reason says which of SPL and the measure is constant.

    Returns
    -------
    str
        Fewer than 3 maps, or SPL, the measure or both the same on every map (no ranking).

    Examples
    --------
    >>> no_rho_reason(2, "tortuosity")
    'fewer than 3 maps with both SPL and the measure (2): no rank correlation'
    >>> rows = pd.DataFrame({"spl": [1.0, 1.0, 1.0], "tortuosity": [1.1, 1.3, 1.2]})
    >>> no_rho_reason(3, "tortuosity", rows=rows)
    "the policy's SPL is the same on every map of the row: no ranking"
    """
    if maps < 3:
        return f"fewer than 3 maps with both SPL and the measure ({maps}): no rank correlation"
    if rows is None:
        return "SPL or the measure is the same on every map of the row: no ranking"
    pair = rows[["spl", measure]].dropna()
    same_spl, same_measure = (bool(np.ptp(pair[c].to_numpy()) == 0) for c in ("spl", measure))
    if same_spl and same_measure:
        return ("the policy's SPL and the measure are both the same on every map of the row: "
                "no ranking")
    if same_spl:
        return "the policy's SPL is the same on every map of the row: no ranking"
    return "the measure is the same on every map of the row: no ranking"


def spearman_markdown(table: pd.DataFrame, *, per_map: pd.DataFrame | None = None,
                      dashes: Dashes | None = None) -> pd.DataFrame:
    """:func:`~fftnav.runner.maps.spearman_table` as one row per (scope, policy): a cell
    ``rho (p)`` per measure, in bold when ``p < SIGNIFICANCE``, and a verdict column naming
    the measures that predict SPL.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`~fftnav.runner.maps.spearman_table`'s table.
    per_map : pandas.DataFrame, optional
        The :func:`~fftnav.runner.maps.map_spl` table it was computed from: an undefined rho's
        reason then says whether SPL or the measure is the constant one (:func:`no_rho_reason`).
    dashes : Dashes, optional
        Collects the reason of every undefined rho, shown as a marked ``-``.

    Examples
    --------
    >>> t = pd.DataFrame({"scope": "all", "policy": "p", "measure": list(MEASURES), "maps": 9,
    ...                   "rho": [0.9, 0.1, -0.8, 0.0, np.nan],
    ...                   "p_value": [0.001, 0.5, 0.01, 1.0, np.nan]})
    >>> dashes = Dashes()
    >>> row = spearman_markdown(t, dashes=dashes).iloc[0]
    >>> row["dispersion"], row["tortuosity"], row["predicts SPL (p < 0.05)"]
    ('**-0.80 (0.01)**', '-¹', 'distance (+), dispersion (-)')
    >>> dashes.legend()
    ['`-¹` SPL or the measure is the same on every map of the row: no ranking.']
    """
    dashes = dashes if dashes is not None else Dashes()
    rows = []
    for (scope, policy), group in table.groupby(["scope", "policy"], sort=False):
        row = {"scope": scope, "policy": policy, "maps": int(group["maps"].max())}
        ranked = None if per_map is None else _scope_rows(per_map, scope, policy)
        verdict = []
        for r in group.itertuples(index=False):
            if np.isnan(r.rho):
                row[r.measure] = dashes.dash(no_rho_reason(int(r.maps), r.measure, rows=ranked))
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


def spearman_method_lines(table: pd.DataFrame) -> list[str]:
    """How the p-values of a :func:`~fftnav.runner.maps.spearman_table` were computed (its
    ``p_method``), per method the (scope, policy) rows that hold one: a line and a blank
    line, or nothing without a p-value.

    >>> t = pd.DataFrame({"scope": ["all", "forest", "rocky"], "policy": "p",
    ...                   "p_method": ["t approx.", "exact", ""]})
    >>> import textwrap
    >>> print(textwrap.fill(spearman_method_lines(t)[0], 88))
    Spearman p-values above: exact (all n! orderings of the maps) in the 1 row(s) of at most
    9 maps (scope forest); from the t approximation in the 1 row(s) of more than 9 maps
    (scope all).
    """
    parts = []
    for method, how in (("exact", "exact (all n! orderings of the maps) in the {rows} of at "
                                  f"most {SPEARMAN_EXACT_MAX} maps"),
                        (T_APPROX, "from the t approximation in the {rows} of more than "
                                   f"{SPEARMAN_EXACT_MAX} maps")):
        rows = table[table["p_method"] == method]
        if len(rows):
            scopes = list(dict.fromkeys(rows["scope"]))
            count = rows.groupby(["scope", "policy"]).ngroups
            parts.append(how.format(rows=f"{count} row(s)") + f" (scope {', '.join(scopes)})")
    return [f"Spearman p-values above: {'; '.join(parts)}.", ""] if parts else []


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
    spearman = spearman_table(per_map, envs=envs, policies=policies)
    dashes = Dashes()
    table = spearman_markdown(spearman, per_map=per_map, dashes=dashes)
    legend = dashes.legend()
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
        "bold cell in 20 is expected by chance alone.",
        "",
        *markdown_table(table),
        "",
        *([*legend, ""] if legend else []),
        *spearman_method_lines(spearman),
        f"![{picture.stem}](figures/{picture.name})",
        "",
    ]
