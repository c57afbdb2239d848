"""What drift does: every method's SPL and AR against the odometry's drift preset.

:func:`write_drift_report` reads the cells of drift sweeps (``experiments/drift/*.toml``: the
base cell with ``[localization] mode = "odometry"``, each cell one ``localization.drift``
preset) and, optionally, results of the same maps with exact localization (the point
``exact``), and writes into one folder:

- ``drift_maps.csv``: per env, policy, drift and map, the sums everything else is made of
  (:func:`drift_maps`; small enough to keep in git where the cells' episodes are not);
- ``drift_summary.csv``: per env, policy and drift, the maps, AR and SPL with their 95%
  bootstrap intervals over maps, ``ar_believed`` and ``spl_believed`` (the robots that stopped
  where their estimate put their goal counted as arrived: how well they navigated, whatever
  their drift) and the share of robots ``lost``;
- ``drift_gains.csv``: the paired comparisons (per-map SPL differences over the same maps:
  mean, 95% bootstrap interval, two-sided Wilcoxon p, Holm-adjusted over all rows as one
  family; and the non-inferiority test against a loss of :data:`MARGIN` (0.1 SPL points),
  one-sided, Holm-adjusted over all rows; how each p was computed, ``p_method`` and
  ``p_noninferior_method``, :func:`fftnav.runner.summary.wilcoxon_method`: exact for up to 20
  non-zero differences) of ``collab`` against ``own-only`` and of ``fusion`` against each Bug
  baseline and ``own-only``, per env and drift;
- ``drift.png``: SPL and AR against drift, one line per policy, one column per env;
- ``drift.md``: the tables and the verdicts (``fftnav.report.sweep.verdict``), every missing
  number a ``-`` marked with its reason (:class:`fftnav.report.markdown.Dashes`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from fftnav.errors import FftnavError
from fftnav.files import write_atomic
from fftnav.metrics.measures import believed, believed_spl_terms
from fftnav.report import new_figure, save_figure
from fftnav.report.experiment import p_method_lines
from fftnav.report.markdown import Dashes
from fftnav.report.sweep import verdict
from fftnav.runner.config import ExperimentConfig
from fftnav.runner.summary import (
    bootstrap_ratio_ci,
    holm,
    in_order,
    noninferiority_p,
    paired_gain,
    wilcoxon_method,
)

__all__ = ["ALPHA", "COMPARISONS", "DRIFT_ORDER", "MAP_COLUMNS", "MARGIN", "drift_episodes",
           "drift_gains", "drift_maps", "drift_summary", "gain_lines", "write_drift_report"]

#: The x axis: exact localization, then the presets by drift.
DRIFT_ORDER = ("exact", "none", "low", "typical", "high")
#: The margin of the non-inferiority test (SPL as a fraction: 0.1 points).
MARGIN = 0.001
#: Significance level of the verdicts.
ALPHA = 0.05
#: The paired comparisons of ``drift_gains.csv``: (policy, reference).
COMPARISONS = (("collab", "own-only"), ("fusion", "bug-left"), ("fusion", "bug-right"),
               ("fusion", "own-only"))


def _cell_episodes(config: ExperimentConfig, root: Path) -> list[tuple[str, ExperimentConfig,
                                                                       Path]]:
    """Each cell of ``config`` run into ``root``: its name, config and ``episodes.csv``."""
    if not config.cells:
        return [("base", config, Path(root) / "episodes.csv")]
    return [(name, cell, Path(root) / name / "episodes.csv") for name, cell in config.cells]


def _drift_of(config: ExperimentConfig) -> str:
    loc = config.swarm.localization
    return loc.drift if loc.odometry else "exact"


def drift_episodes(configs: Sequence[ExperimentConfig], roots: Sequence[Path],
                   exact: Sequence[Path] = ()) -> pd.DataFrame:
    """The episodes of every cell of ``configs`` (run into ``roots``), with a ``drift`` column
    (the cell's preset, ``exact`` for exact localization), and of the ``exact`` results
    folders, kept to the (env, map) pairs and policies the drift cells ran."""
    parts = []
    for config, root in zip(configs, roots, strict=True):
        for name, cell, path in _cell_episodes(config, root):
            if not path.is_file():
                raise FftnavError(f"results must hold the episodes.csv of experiment "
                                  f"{config.name!r}, cell {name!r}: got no {path} (run the "
                                  f"experiment with fftnav run first)")
            parts.append(pd.read_csv(path).assign(drift=_drift_of(cell)))
    if not parts:
        raise FftnavError("configs must name at least one drift experiment, got none")
    ran = pd.concat(parts, ignore_index=True)
    keys = set(zip(ran["env"], ran["map_seed"], strict=True))
    for folder in exact:
        path = Path(folder) / "episodes.csv"
        if not path.is_file():
            raise FftnavError(f"--exact must be a results folder with episodes.csv, got {folder}")
        rows = pd.read_csv(path)
        mine = [(e, m) in keys for e, m in zip(rows["env"], rows["map_seed"], strict=True)]
        rows = rows[np.array(mine, dtype=bool) & rows["policy"].isin(set(ran["policy"]))]
        parts.append(rows.assign(drift="exact"))
    table = pd.concat(parts, ignore_index=True)
    keys = ["env", "map_seed", "policy", "robot", "drift"]
    twice = table[table.duplicated(subset=keys, keep=False)]
    if len(twice) and len(twice.drop_duplicates(subset=[*keys, "arrived", "spl",
                                                         "path_length_m"])) != len(
            twice.drop_duplicates(subset=keys)):
        raise FftnavError("--exact folders must agree where they hold the same episodes, got "
                          "different rows for the same env, map, policy and robot")
    return table.drop_duplicates(subset=keys)


#: Columns of ``drift_maps.csv``: per env, policy, drift and map, the robots and the sums
#: the summary and the paired tests are made of.
MAP_COLUMNS = ("env", "policy", "drift", "map_seed", "robots", "arrived", "spl", "believed",
               "spl_believed", "lost")


def drift_maps(episodes: pd.DataFrame) -> pd.DataFrame:
    """Per env, policy, drift and map (:data:`MAP_COLUMNS`): the robots, how many arrived, the
    sum of their SPL, how many reached their believed goal (arrived or ``lost``), the sum of
    their SPL counting those, and how many were lost."""
    lost = (episodes["failure"].fillna("") == "lost").to_numpy()
    frame = episodes.assign(believed=believed(episodes),
                            spl_believed=believed_spl_terms(episodes), lost=lost,
                            arrived=episodes["arrived"].astype(bool))
    maps = frame.groupby(["env", "policy", "drift", "map_seed"], sort=False).agg(
        robots=("robot", "count"), arrived=("arrived", "sum"), spl=("spl", "sum"),
        believed=("believed", "sum"), spl_believed=("spl_believed", "sum"),
        lost=("lost", "sum")).reset_index()
    return maps[list(MAP_COLUMNS)]


def drift_summary(maps: pd.DataFrame, *, policies: Sequence[str] | None = None
                  ) -> pd.DataFrame:
    """One row per env, policy and drift of the per-map table ``maps`` (:func:`drift_maps`):
    the maps, robots, AR and SPL with their 95% bootstrap intervals over maps, ``ar_believed``,
    ``spl_believed`` and the share ``lost``."""
    rows = []
    drifts = [d for d in DRIFT_ORDER if d in set(maps["drift"])]
    for env in in_order(maps["env"], None):
        for policy in in_order(maps["policy"], policies):
            for drift in drifts:
                g = maps[(maps["env"] == env) & (maps["policy"] == policy)
                         & (maps["drift"] == drift)]
                if g.empty:
                    continue
                n = g["robots"].to_numpy(dtype=float)
                total = n.sum()
                rows.append({
                    "env": env, "policy": policy, "drift": drift, "maps": len(g),
                    "robots": int(total), "ar": g["arrived"].sum() / total,
                    **dict(zip(("ar_ci_low", "ar_ci_high"), bootstrap_ratio_ci(
                        g["arrived"].to_numpy(dtype=float), n), strict=True)),
                    "spl": g["spl"].sum() / total,
                    **dict(zip(("spl_ci_low", "spl_ci_high"), bootstrap_ratio_ci(
                        g["spl"].to_numpy(dtype=float), n), strict=True)),
                    "ar_believed": g["believed"].sum() / total,
                    "spl_believed": g["spl_believed"].sum() / total,
                    "lost": g["lost"].sum() / total})
    return pd.DataFrame(rows)


def drift_gains(maps: pd.DataFrame) -> pd.DataFrame:
    """The paired comparisons of :data:`COMPARISONS` per env and drift (module docstring), on
    the per-map mean SPL of ``maps`` (:func:`drift_maps`).

    Returns
    -------
    pandas.DataFrame
        Per comparison, env and drift: the paired maps, the gain (mean per-map difference) and
        its 95% bootstrap interval, ``p_value`` (two-sided) and ``p_method``,
        ``p_noninferior`` (one-sided, against a loss of :data:`MARGIN`) and
        ``p_noninferior_method`` (``"exact"`` or ``"normal approx."``,
        :func:`fftnav.runner.summary.wilcoxon_method`; empty without a test), both p
        Holm-adjusted over all rows, ``noninferior`` and the ``verdict``. A comparison of a
        policy and a reference that never ran the same map at a drift keeps its row, with 0
        maps and NaN numbers.
    """
    per_map = maps.assign(mean=maps["spl"] / maps["robots"]).pivot_table(
        index=["env", "drift", "map_seed"], columns="policy", values="mean", aggfunc="mean")
    rows = []
    for (env, drift), group in per_map.groupby(level=["env", "drift"], sort=False):
        for policy, ref in COMPARISONS:
            if policy not in group or ref not in group:
                continue
            pair = group[[policy, ref]].dropna()
            diff = (pair[policy] - pair[ref]).to_numpy()
            gain, low, high, p = paired_gain(diff)
            rows.append({"env": env, "drift": drift, "policy": policy, "reference": ref,
                         "maps": len(pair), "gain": gain, "gain_ci_low": low,
                         "gain_ci_high": high, "p_value": p, "p_method": wilcoxon_method(diff),
                         "p_noninferior": noninferiority_p(diff, margin=MARGIN),
                         "p_noninferior_method": wilcoxon_method(diff + MARGIN,
                                                                 alternative="greater")})
    table = pd.DataFrame(rows)
    if len(table):
        table["p_holm"] = holm(table["p_value"].to_numpy(dtype=float))
        table["p_noninferior_holm"] = holm(table["p_noninferior"].to_numpy(dtype=float))
        table["noninferior"] = table["p_noninferior_holm"] < ALPHA
        table["verdict"] = [verdict(g, lo, hi, p) for g, lo, hi, p in zip(
            table["gain"], table["gain_ci_low"], table["gain_ci_high"], table["p_holm"],
            strict=True)]
        order = {d: k for k, d in enumerate(DRIFT_ORDER)}
        table = table.sort_values(["policy", "reference", "env", "drift"],
                                  key=lambda c: c.map(order) if c.name == "drift" else c,
                                  kind="stable", ignore_index=True)
    return table


def _figure(summary: pd.DataFrame, policies: Sequence[str], path: Path) -> Path:
    envs = in_order(summary["env"], None)
    drifts = [d for d in DRIFT_ORDER if d in set(summary["drift"])]
    fig = new_figure(figsize=(max(3.3 * len(envs), 7.0), 6.4), layout="constrained")
    axes = fig.subplots(2, len(envs), squeeze=False, sharex=True, sharey="row")
    styles = ["-o", "-s", "-^", "-v", "-D", "--o", "--s", "--^", "--v", "--D"]
    for col, env in enumerate(envs):
        for k, policy in enumerate(policies):
            rows = summary[(summary["env"] == env) & (summary["policy"] == policy)]
            rows = rows.set_index("drift").reindex(drifts)
            for row, measure in enumerate(("spl", "ar")):
                axes[row, col].plot(range(len(drifts)), 100 * rows[measure],
                                    styles[k % len(styles)], color=f"C{k}", ms=4, lw=1.2,
                                    label=policy)
        axes[0, col].set_title(env)
        axes[1, col].set_xticks(range(len(drifts)), drifts)
        axes[1, col].set_xlabel("localization (drift preset)")
    axes[0, 0].set_ylabel("SPL (%)")
    axes[1, 0].set_ylabel("AR (%)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 8),
               fontsize=7)
    save_figure(fig, path, dpi=100)
    return path


def _pct(v: float) -> str:
    return f"{100 * v:.1f}"


def _not_run(drift: str) -> str:
    """Why the summary has no row of a policy in an env at ``drift``."""
    if drift == "exact":
        return "no run with exact localization of this policy on these maps (`--exact` folders)"
    return "no run of this policy on this env at this drift"


def _policy_table(summary: pd.DataFrame, measure: str, policies: Sequence[str],
                  dashes: Dashes) -> list[str]:
    """One table per env of ``measure`` (percent) per policy and drift; a policy not run in
    an env at a drift is a ``-`` marked with its reason (collected in ``dashes``)."""
    drifts = [d for d in DRIFT_ORDER if d in set(summary["drift"])]
    lines = []
    for env in in_order(summary["env"], None):
        lines += [f"**{env}**", "", "| policy | " + " | ".join(drifts) + " |",
                  "|---|" + "---|" * len(drifts)]
        for policy in policies:
            rows = summary[(summary["env"] == env) & (summary["policy"] == policy)]
            rows = rows.set_index("drift").reindex(drifts)
            cells = [dashes.dash(_not_run(d)) if pd.isna(v) else _pct(v)
                     for d, v in zip(drifts, rows[measure], strict=True)]
            lines.append(f"| {policy} | " + " | ".join(cells) + " |")
        lines.append("")
    return lines


def _policy_section(summary: pd.DataFrame, measure: str, policies: Sequence[str]
                    ) -> list[str]:
    """:func:`_policy_table` and the legend of its missing numbers."""
    dashes = Dashes()
    lines = _policy_table(summary, measure, policies, dashes)
    legend = dashes.legend()
    return [*lines, *([*legend, ""] if legend else [])]


def gain_lines(gains: pd.DataFrame, *, dashes: Dashes | None = None) -> list[str]:
    """``drift_gains.csv`` (:func:`drift_gains`) as the Markdown table of ``drift.md``: the
    gain in SPL points with its interval, both p of the two-sided test, how they were computed
    (``p_method``), the verdict and the non-inferiority result; a number missing is a ``-``
    marked with its reason (collected in ``dashes``): no map with both policies at that drift,
    or every per-map difference 0 (no two-sided test)."""
    dashes = dashes if dashes is not None else Dashes()
    lines = ["| policy | vs | env | drift | maps | gain (SPL points) | p | p_method | p (Holm) "
             "| verdict | no worse than -0.1 (Holm p) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in gains.itertuples(index=False):
        if r.maps == 0:
            mark = dashes.dash("no map has results of both the policy and its reference (`vs`) "
                               "in this env at this drift")
            lines.append(f"| {r.policy} | {r.reference} | {r.env} | {r.drift} | 0 | {mark} | "
                         f"{mark} | {mark} | {mark} | {mark} | {mark} |")
            continue
        gain = (f"{100 * r.gain:+.1f} [{100 * r.gain_ci_low:+.1f}, "
                f"{100 * r.gain_ci_high:+.1f}]")
        if pd.isna(r.p_value):
            p = ph = method = dashes.dash(
                "every per-map difference is 0 (the policy and its reference, `vs`, have the "
                "same SPL on each map): no two-sided test")
        else:
            p, ph, method = f"{r.p_value:.2g}", f"{r.p_holm:.2g}", r.p_method
        if r.p_noninferior_method not in ("", r.p_method):
            method += f"; non-inferiority: {r.p_noninferior_method}"
        if pd.isna(r.p_noninferior_holm):
            shown = dashes.dash("every per-map difference is exactly -0.1 points: no "
                                "non-inferiority test")
        else:
            shown = (f"{'yes' if r.noninferior else 'not shown'} "
                     f"({r.p_noninferior_holm:.2g})")
        lines.append(f"| {r.policy} | {r.reference} | {r.env} | {r.drift} | {r.maps} | "
                     f"{gain} | {p} | {method} | {ph} | {r.verdict} | {shown} |")
    return lines


def _any_cell_run(configs: Sequence[ExperimentConfig], roots: Sequence[Path]) -> bool:
    """Whether the episodes of any cell of ``configs`` are in ``roots``."""
    return any(path.is_file() for config, root in zip(configs, roots, strict=True)
               for _, _, path in _cell_episodes(config, root))


def write_drift_report(configs: Sequence[ExperimentConfig], roots: Sequence[Path], out: Path,
                       *, exact: Sequence[Path] = (), sources: Sequence[str] = ()) -> Path:
    """Write the drift report (module docstring) of ``configs`` run into ``roots`` into
    ``out`` (``sources``: the configs' files, as the report names them); returns the path of
    ``drift.md``. Where no cell's ``episodes.csv`` is there (git keeps the drift cells'
    summaries only) and ``out`` holds ``drift_maps.csv``, the report is rebuilt from it; where
    some are, every cell's must be."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise FftnavError(f"--out must be a folder, got {str(out)!r}, a file")
    if _any_cell_run(configs, roots) or not (out / "drift_maps.csv").is_file():
        maps = drift_maps(drift_episodes(configs, roots, exact))
    else:  # no cell's episodes here (git keeps their summaries): the committed per-map table
        maps = pd.read_csv(out / "drift_maps.csv")
    out.mkdir(parents=True, exist_ok=True)
    policies = list(dict.fromkeys(p for c in configs for p in c.policy_names))
    summary = drift_summary(maps, policies=policies)
    gains = drift_gains(maps)
    write_atomic(out / "drift_maps.csv", maps.to_csv(index=False, float_format="%.6f"))
    write_atomic(out / "drift_summary.csv", summary.to_csv(index=False, float_format="%.6f"))
    write_atomic(out / "drift_gains.csv", gains.to_csv(index=False, float_format="%.6g"))
    figure = _figure(summary, policies, out / "drift.png")
    dashes = Dashes()
    lines = [
        "# What drift does: every method without external positioning",
        "",
        "Each robot knows only its own odometry (`[localization] mode = \"odometry\"`), at each "
        "drift preset (`none`, `low`, `typical`, `high`: about 0, 0.5, 2 and 5 % of the distance "
        "driven, docs/localization.md); `exact` is the same maps with exact poses. Arrival and "
        "SPL are judged on the true poses; a robot that stops where its estimate says its goal "
        "is, and is not within the arrival radius, is `lost`. Percentages; 95 % bootstrap "
        "intervals over maps in `drift_summary.csv`.",
        "",
        f"Experiments: {', '.join(f'`{s}`' for s in (sources or [c.name for c in configs]))}"
        + (f"; exact: {', '.join(f'`{p}`' for p in exact)}." if exact else "."),
        "",
        f"![SPL and AR against drift]({figure.name})",
        "",
        "## SPL (%)",
        "",
        *_policy_section(summary, "spl", policies),
        "## AR (%)",
        "",
        *_policy_section(summary, "ar", policies),
        "## SPL counting the robots that stopped at their believed goal (%)",
        "",
        "How well each method navigated in its own frame, whatever its drift (`spl_believed`).",
        "",
        *_policy_section(summary, "spl_believed", policies),
        "## Paired comparisons",
        "",
        "Per-map SPL differences on the same maps: mean and 95 % bootstrap interval (SPL "
        "points), two-sided Wilcoxon signed-rank p, Holm-adjusted over all rows of this table "
        "as one family. *pays*: interval above 0 and Holm p < 0.05; *costs*: below 0 and Holm "
        "p < 0.05. *No worse than -0.1*: the one-sided Wilcoxon test of the differences plus "
        "0.1 points against 0 (non-inferiority with a margin of 0.1 SPL points), Holm-adjusted "
        "over all rows, p < 0.05. `p_method`: how both p of the row were computed.",
        "",
        *gain_lines(gains, dashes=dashes),
        "",
        *([*dashes.legend(), ""] if dashes.legend() else []),
        *p_method_lines(pd.DataFrame({"p_method": [*gains.get("p_method", []),
                                                   *gains.get("p_noninferior_method", [])]})),
    ]
    path = out / "drift.md"
    write_atomic(path, "\n".join(lines))
    return path
