"""The report of a sweep (or of one experiment): does collaboration pay, cell by cell?

For every cell of a ``[sweep]`` config (:attr:`fftnav.runner.config.ExperimentConfig.cells`; one
cell ``base`` for a plain config), env and policy: AR and SPL with 95% bootstrap intervals over
maps, bytes per robot, and the gain against ``own-only`` (per-map SPL of the policy minus that
of own-only: mean, 95% bootstrap interval, paired Wilcoxon signed-rank p, how that p was
computed (``p_method``, :func:`fftnav.runner.summary.wilcoxon_method`: exact for up to 20
non-zero differences) and that p Holm-adjusted over every comparison of the report, one
family); plus ``collab`` against ``fusion``. The verdicts use the adjusted p. Every missing
number of the report's table is a ``-`` marked with its reason
(:class:`fftnav.report.markdown.Dashes`). One figure per sweep axis: the gain of ``collab`` and
``fusion`` against the axis's values, one panel per env.

A cell's rows come from its ``episodes.csv`` where the folder has it (what a run writes); where
it has not (a committed sweep keeps its summaries only, ``.gitignore``), from the rows of that
cell in the folder's ``sweep_summary.csv`` (the p-values with 6 significant digits, and their
``p_method`` where the file records it), and the report says which cells those are. The Holm
adjustment is recomputed over all rows either way. Cells with neither are listed as not run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from fftnav.files import write_atomic
from fftnav.report import save_figure
from fftnav.report.experiment import p_method_lines
from fftnav.report.markdown import Dashes
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.summary import SWEEP_COLUMNS, gain_table, sweep_table, wilcoxon_method

__all__ = ["ALPHA", "SUMMARY_COLUMNS", "cell_tables", "figure_envs", "p_methods",
           "sweep_view", "verdict", "verdict_lines", "write_sweep_report"]

#: Significance level of the verdicts.
ALPHA = 0.05
#: Columns of ``sweep_summary.csv``: those of :func:`fftnav.runner.summary.gain_table`, then
#: how each p-value was computed (:func:`p_methods`; empty without a p).
SUMMARY_COLUMNS: tuple[str, ...] = (*SWEEP_COLUMNS, "p_method")

def _axis_of(cell: str) -> str:
    return cell.split("=")[0] if "=" in cell else ""


def figure_envs(table: pd.DataFrame, axis: str) -> list[str]:
    """The envs of an axis's figure: those with a cell of the axis (an axis of one env's
    world, ``world.walls.wall_length_m``, ran that env only), else every env of the table."""
    on_axis = table[[_axis_of(c) == axis and c != "base" for c in table["cell"]]]
    return sorted((on_axis if axis and len(on_axis) else table)["env"].unique())


def _gain_figure(table: pd.DataFrame, axis: str, path: Path) -> Path:
    """Gain of collab and fusion over own-only (SPL points) against the axis's cells."""
    cells = ["base", *[c for c in dict.fromkeys(table["cell"]) if _axis_of(c) == axis]]
    sub = table[table["cell"].isin(cells) & (table["reference"] == "own-only")
                & table["policy"].isin(["collab", "fusion"])]
    envs = figure_envs(sub, axis)
    fig = Figure(figsize=(3.2 * max(len(envs), 1), 3.0), dpi=120)
    axes = fig.subplots(1, max(len(envs), 1), squeeze=False, sharey=True)
    for ax, env in zip(axes[0], envs, strict=False):
        for k, (policy, color) in enumerate((("collab", "tab:red"), ("fusion", "tab:blue"))):
            rows = sub[(sub["env"] == env) & (sub["policy"] == policy)].set_index("cell")
            rows = rows.reindex([c for c in cells if c in rows.index])
            x = np.array([cells.index(c) for c in rows.index]) + (k - 0.5) * 0.12
            y = 100 * rows["gain"].to_numpy()
            err = 100 * np.abs(np.vstack([rows["gain"] - rows["gain_ci_low"],
                                          rows["gain_ci_high"] - rows["gain"]]))
            ax.errorbar(x, y, yerr=err, fmt="o-", color=color, capsize=3, label=policy)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xticks(range(len(cells)), [c.split("=")[-1] for c in cells], fontsize=7)
        ax.set_title(env, fontsize=9)
        ax.set_xlabel(axis or "cell", fontsize=8)
    axes[0][0].set_ylabel("SPL gain over own-only (points)", fontsize=8)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path)
    return path


def verdict(gain: float, low: float, high: float, p: float, *, alpha: float = ALPHA) -> str:
    """``"pays"`` when the gain's 95% interval lies above 0 and the paired p is below
    ``alpha``, ``"costs"`` when it lies below 0 with p below ``alpha``, else ``"no clear
    difference"`` (also without a gain). The reports pass the Holm-adjusted p (``p_holm``).

    >>> verdict(0.04, 0.01, 0.07, 0.003), verdict(-0.02, -0.03, -0.01, 0.01)
    ('pays', 'costs')
    >>> verdict(0.03, -0.01, 0.07, 0.15)
    'no clear difference'
    """
    if any(pd.isna(v) for v in (gain, low, high, p)) or not p < alpha:
        return "no clear difference"
    if low > 0:
        return "pays"
    if high < 0:
        return "costs"
    return "no clear difference"


def _pair(r: Any) -> str:
    return (f"{r.cell} / {r.env} ({100 * r.gain:+.1f}, p = {r.p_value:.2g}, "
            f"Holm p = {r.p_holm:.2g})")


def verdict_lines(table: pd.DataFrame) -> list[str]:
    """Plain sentences from a sweep table (:data:`fftnav.runner.summary.SWEEP_COLUMNS`): for
    ``collab`` and ``fusion`` against ``own-only``, and ``collab`` against ``fusion``, the
    (cell, env) pairs where the policy pays, where it costs (:func:`verdict` with the
    Holm-adjusted p), how many show no clear difference, and which of those would pay or cost
    by their raw p alone."""
    lines: list[str] = []
    for policy, ref in (("collab", "own-only"), ("fusion", "own-only"), ("collab", "fusion")):
        rows = table[(table["policy"] == policy) & (table["reference"] == ref)]
        if not len(rows):
            continue
        found: dict[str, list[str]] = {"pays": [], "costs": [], "no clear difference": []}
        raw_only: dict[str, list[str]] = {"pays": [], "costs": [], "no clear difference": []}
        for r in rows.itertuples(index=False):
            word = verdict(r.gain, r.gain_ci_low, r.gain_ci_high, r.p_holm)
            found[word].append(_pair(r))
            raw = verdict(r.gain, r.gain_ci_low, r.gain_ci_high, r.p_value)
            if raw != word:  # the adjusted p is never below the raw p
                raw_only[raw].append(_pair(r))
        lines.append(f"- `{policy}` against `{ref}`, {len(rows)} (cell, env) pairs:")
        for word in ("pays", "costs"):
            lines.append(f"  - {word} in {len(found[word])}"
                         + (": " + "; ".join(found[word]) if found[word] else "") + ".")
        lines.append(f"  - no clear difference in {len(found['no clear difference'])}.")
        for word in ("pays", "costs"):
            if raw_only[word]:
                lines.append(f"    - would {word[:-1]} by the raw p alone in "
                             f"{len(raw_only[word])}: " + "; ".join(raw_only[word]) + ".")
    return lines


def _fmt(v: float, scale: float = 100.0, digits: int = 1) -> str:
    return f"{scale * v:.{digits}f}"


def _no_gain_reason(r: Any) -> str:
    """Why a row of the sweep table has no comparison (an empty ``reference``)."""
    if r.policy == "own-only":
        return "`own-only` is the reference of the gains: it is not compared with itself"
    return "the cell has no `own-only` rows to compare this policy with"


def _no_p_reason(r: Any) -> str:
    """Why a compared row of the sweep table has no p-value."""
    if pd.isna(r.gain):
        return "no map has results of both the policy and its reference (`vs`) in this env"
    return ("every per-map difference is 0 (the policy and its reference, `vs`, have the same "
            "SPL on each map): no test")


def _interval(dashes: Dashes, r: Any, value: float, low: float, high: float) -> str:
    """``value [low, high]`` in percent; an undefined interval ``[-]`` with its reason."""
    if pd.isna(low) or pd.isna(high):
        reason = ("1 map: no interval over maps (it needs two or more)" if r.maps < 2 else
                  "the bootstrap interval over maps is undefined")
        return f"{_fmt(value)} [{dashes.dash(reason)}]"
    return f"{_fmt(value)} [{_fmt(low)}, {_fmt(high)}]"


def sweep_view(table: pd.DataFrame, *, dashes: Dashes | None = None) -> pd.DataFrame:
    """The sweep table (:data:`SUMMARY_COLUMNS`) as ``report.md`` shows it: percent with
    intervals, both p with how the raw one was computed, verdicts; every missing number a
    ``-`` marked with its reason, collected in ``dashes``.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`fftnav.runner.summary.sweep_table`'s rows with a ``p_method`` column
        (:func:`p_methods`; empty where none was recorded).
    dashes : Dashes, optional
        Collects the reasons: no comparison (``own-only`` itself, or a cell without it), no
        map with both policies, every per-map difference 0, an interval over one map, a p
        whose method the summary does not record.

    Returns
    -------
    pandas.DataFrame
        One text row per row of ``table``.
    """
    dashes = dashes if dashes is not None else Dashes()
    rows = []
    for r in table.itertuples(index=False):
        row = {"cell": r.cell, "env": r.env, "policy": r.policy, "maps": r.maps,
               "AR %": _interval(dashes, r, r.ar, r.ar_ci_low, r.ar_ci_high),
               "SPL %": _interval(dashes, r, r.spl, r.spl_ci_low, r.spl_ci_high),
               "bytes/robot": f"{r.bytes_per_robot:.0f}"}
        if not r.reference:
            mark = dashes.dash(_no_gain_reason(r))
            rows.append({**row, "vs": mark, "gain (SPL points)": mark, "p (Wilcoxon)": mark,
                         "p_method": mark, "p (Holm)": mark, "verdict": mark})
            continue
        no_p = dashes.dash(_no_p_reason(r)) if pd.isna(r.p_value) else ""
        gain = (no_p if pd.isna(r.gain) else
                _interval(dashes, r, r.gain, r.gain_ci_low, r.gain_ci_high))
        recorded = r.p_method if isinstance(r.p_method, str) else ""
        method = recorded or no_p or dashes.dash(
            "`sweep_summary.csv` does not record how this p was computed (no `p_method`): "
            "rerun the cell with `fftnav run` to recompute it")
        rows.append({**row, "vs": r.reference, "gain (SPL points)": gain,
                     "p (Wilcoxon)": no_p or f"{r.p_value:.2g}", "p_method": method,
                     "p (Holm)": no_p or f"{r.p_holm:.2g}",
                     "verdict": verdict(r.gain, r.gain_ci_low, r.gain_ci_high, r.p_holm)})
    return pd.DataFrame(rows, columns=["cell", "env", "policy", "maps", "AR %", "SPL %",
                                       "bytes/robot", "vs", "gain (SPL points)",
                                       "p (Wilcoxon)", "p_method", "p (Holm)", "verdict"])


def _family_lines(table: pd.DataFrame) -> list[str]:
    """What the report's Holm family holds."""
    compared = table[table["reference"].fillna("") != ""]
    tested = int(compared["p_value"].notna().sum())
    unpaired = int((compared["p_value"].isna() & compared["gain"].isna()).sum())
    untested = len(compared) - tested - unpaired
    return [
        f"The p-values are Holm-Bonferroni adjusted over one family: all {tested} paired "
        "comparisons of this report with a p (every policy against `own-only` and `collab` "
        "against `fusion`, in every cell and env"
        + (f"; {untested} more have no p, every per-map difference being 0" if untested else "")
        + (f"; {unpaired} more have no map with both policies" if unpaired else "")
        + f"), so the chance of any false *pays* or *costs* in the report is at most {ALPHA}, "
        "whatever the dependence between the tests (`fftnav.runner.summary.holm`)."
    ]


def _summary_csv(table: pd.DataFrame) -> str:
    """``sweep_summary.csv`` (:data:`SUMMARY_COLUMNS`): floats ``%.6f``, the p-values ``%.6g``
    (they go far below 1e-6, and a report rebuilt from this file adjusts them again)."""
    out = table[list(SUMMARY_COLUMNS)].copy()
    for column in ("p_value", "p_holm"):
        out[column] = ["" if pd.isna(v) else f"{v:.6g}" for v in out[column]]
    return out.to_csv(index=False, float_format="%.6f")


def _texts_filled(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with the columns :data:`SUMMARY_COLUMNS` (a missing one added), its
    ``reference`` and ``p_method`` text, ``""`` where empty."""
    table = table.reindex(columns=list(SUMMARY_COLUMNS))
    return table.assign(**{c: table[c].astype(object).fillna("").astype(str)
                           for c in ("reference", "p_method")})


def p_methods(episodes: pd.DataFrame, table: pd.DataFrame) -> list[str]:
    """How each p-value of a cell's :func:`fftnav.runner.summary.gain_table` was computed:
    :func:`fftnav.runner.summary.wilcoxon_method` of the row's per-map SPL differences (the
    policy minus its ``reference``, on the maps where both have results, as
    :func:`~fftnav.runner.summary.gain_table` pairs them); ``""`` for a row without a p.

    >>> episodes = pd.DataFrame({"env": "walls", "map_seed": [1, 2, 1, 2],
    ...                          "policy": ["own-only", "own-only", "collab", "collab"],
    ...                          "spl": [0.5, 0.6, 0.7, 0.6]})
    >>> table = pd.DataFrame({"env": "walls", "policy": ["own-only", "collab"],
    ...                       "reference": ["", "own-only"]})
    >>> p_methods(episodes, table)
    ['', 'exact']
    """
    per_map = episodes.pivot_table(index=["env", "map_seed"], columns="policy", values="spl",
                                   aggfunc="mean")
    methods = []
    for r in table.itertuples(index=False):
        if not r.reference:
            methods.append("")
            continue
        pair = per_map.loc[r.env][[r.policy, r.reference]].dropna()
        methods.append(wilcoxon_method((pair[r.policy] - pair[r.reference]).to_numpy()))
    return methods


def cell_tables(config: ExperimentConfig, root: Path) -> tuple[list[pd.DataFrame], list[str],
                                                                 list[str]]:
    """Each cell's gain table (module docstring) with its ``p_method`` column
    (:data:`SUMMARY_COLUMNS`): from its ``episodes.csv``, else from the folder's
    ``sweep_summary.csv`` (``p_method`` empty where the file has none); and the names of the
    cells read from that summary and of those with neither."""
    cells = [(name, root / name, cell) for name, cell in config.cells] or [("base", root, config)]
    summary = pd.DataFrame(columns=list(SUMMARY_COLUMNS))
    if (root / "sweep_summary.csv").is_file():
        summary = pd.read_csv(root / "sweep_summary.csv", keep_default_na=False,
                              na_values=[""], dtype={"reference": str, "p_method": str})
        summary = _texts_filled(summary)
    tables, from_summary, missing = [], [], []
    for name, folder, cell in cells:
        if (folder / "episodes.csv").exists():
            episodes = pd.read_csv(folder / "episodes.csv")
            table = gain_table(episodes, name, envs=cell.envs, policies=cell.policy_names)
            tables.append(table.assign(p_method=p_methods(episodes, table)))
        elif (summary["cell"] == name).any():
            tables.append(summary[summary["cell"] == name].reset_index(drop=True))
            from_summary.append(name)
        else:
            missing.append(name)
    return tables, from_summary, missing


def write_sweep_report(config: ExperimentConfig, root: str | Path) -> Path:
    """Write ``ROOT/report.md``, ``ROOT/sweep_summary.csv`` and ``ROOT/figures/gain_*.png``
    for a sweep run into ``ROOT/<cell>`` (for a plain experiment run into ``ROOT``: the report
    is ``ROOT/gains.md``, beside the run's own ``report.md``)."""
    root = Path(root)
    tables, from_summary, missing = cell_tables(config, root)
    table = _texts_filled(sweep_table(tables))
    write_atomic(root / "sweep_summary.csv", _summary_csv(table))
    axes = sorted({_axis_of(c) for c in table["cell"]} - {""})
    figures = [_gain_figure(table, axis, root / "figures" / f"gain_{axis or 'cells'}.png")
               for axis in (axes or [""])] if len(table) else []
    dashes = Dashes()
    view = sweep_view(table, dashes=dashes)
    legend = dashes.legend()
    lines = [
        f"# Sweep `{config.name}`: does collaboration pay?",
        "",
        "Per cell, env and policy: AR and SPL (percent, 95% bootstrap intervals over maps), "
        "bytes sent per robot, and the gain in SPL points over `own-only` (and, for `collab`, "
        "over `fusion`): mean of the per-map differences, its 95% bootstrap interval, the "
        "paired two-sided Wilcoxon signed-rank p over maps and how it was computed "
        "(`p_method`, explained under the table).",
        "",
        *([f"Cells not run (no episodes.csv): {', '.join(missing)}.", ""] if missing else []),
        *([f"Cells read from the folder's `sweep_summary.csv` (their episodes.csv is not here; "
           f"rerun them with `fftnav run` to recompute them): {', '.join(from_summary)}.", ""]
          if from_summary else []),
        "## Where collaboration pays",
        "",
        f"A policy *pays* where its SPL gain's 95% interval lies above 0 and the Holm-adjusted "
        f"p is below {ALPHA}; it *costs* where the interval lies below 0 with the adjusted p "
        f"below {ALPHA}; elsewhere there is no clear difference (gain in SPL points, raw and "
        "adjusted p in brackets).",
        "",
        *_family_lines(table),
        "",
        *verdict_lines(table),
        "",
        "## Every cell",
        "",
        "| " + " | ".join(view.columns) + " |",
        "|" + "---|" * len(view.columns),
        *("| " + " | ".join(str(v) for v in row) + " |" for row in view.itertuples(index=False)),
        "",
        *([*legend, ""] if legend else []),
        *p_method_lines(table),
        *(f"![{p.stem}](figures/{p.name})" for p in figures),
        "",
    ]
    path = root / ("report.md" if config.cells else "gains.md")  # beside a run's report.md
    write_atomic(path, "\n".join(lines))
    return path
