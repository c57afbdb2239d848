"""The leaderboard's and ``fftnav evaluate``'s reports: the terminal table, ``report.md``,
``leaderboard.md``, each suite's ``report.md`` and ``failures.md``, and the HTML page.

Tables come from :mod:`fftnav.suites.leaderboard` (:func:`~fftnav.suites.leaderboard.ranking`)
and :mod:`fftnav.suites.evaluate` (the paired tests); this module only writes them.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from fftnav.files import write_atomic
from fftnav.report.markdown import markdown_table
from fftnav.suites import SUITES, Suite, find_suite, ordered_suites

__all__ = ["evaluation_report", "leaderboard_markdown",
           "ranked_lines", "terminal_table", "write_evaluation", "write_leaderboard"]


def _pct(value: float) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{100 * value:.1f}"


def _ci(value: float, low: float, high: float) -> str:
    if not np.isfinite(value):
        return "-"
    if not (np.isfinite(low) and np.isfinite(high)):
        return _pct(value)
    return f"{_pct(value)} [{_pct(low)}, {_pct(high)}]"


def _num(value: float, digits: int) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{value:.{digits}f}"


def _sig(value: float) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{value:#.3g}"


def _p(value: float) -> str:
    if value is None or not np.isfinite(value):
        return "-"
    return "<0.001" if value < 0.001 else f"{value:.3f}"


def _failures(row: pd.Series, causes: Sequence[str]) -> str:
    parts = [f"{c.removeprefix('failures_')} {int(row[c])}" for c in causes
             if np.isfinite(row[c]) and row[c] > 0]
    return ", ".join(parts) or "none"


def ranked_lines(table: pd.DataFrame, *, highlight: str | None = None) -> pd.DataFrame:
    """A suite's ranking (:func:`fftnav.suites.leaderboard.ranking`) as display columns:
    rank, method (bold when ``highlight``), SPL [95 % CI] %, AR [95 % CI] %, APL m, failures
    by cause, bytes per robot, compute ms per robot-tick, Holm p against rank 1."""
    causes = [c for c in table.columns if c.startswith("failures_")]
    rows = []
    for _, r in table.iterrows():
        name = f"**{r['method']}**" if r["method"] == highlight else str(r["method"])
        rows.append((int(r["rank"]), name, _ci(r["spl"], r["spl_ci_low"], r["spl_ci_high"]),
                     _ci(r["ar"], r["ar_ci_low"], r["ar_ci_high"]), _num(r["apl_m"], 2),
                     _failures(r, causes), _num(r["bytes_per_robot"], 0),
                     _sig(r["compute_ms"]), _p(r["p_holm"])))
    return pd.DataFrame(rows, columns=["rank", "method", "SPL % [95% CI]", "AR % [95% CI]",
                                       "APL (m)", "failed robots by cause", "bytes/robot",
                                       "compute ms/robot-tick", "p vs #1 (Holm)"])


def terminal_table(table: pd.DataFrame, *, highlight: str | None = None) -> str:
    """A suite's ranking as aligned plain text for the terminal (``>`` marks ``highlight``)."""
    shown = ranked_lines(table)
    shown.insert(0, "", ["> " if m == highlight else "  " for m in table["method"]])
    cells = [list(shown.columns)] + [[str(v) for v in row] for row in shown.to_numpy()]
    widths = [max(len(row[i]) for row in cells) for i in range(len(cells[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
             for row in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


_EXPLAIN = [
    "SPL and AR are pooled over the suite's robots (percent) with 95 % percentile bootstrap "
    "intervals over maps; APL is the mean path of the robots that arrived (m, `-`: none "
    "arrived).",
    "Failed robots by cause: the classifier of docs/metrics.md (collision, jam, stuck, loop, "
    "slow, detour).",
    "compute ms/robot-tick: the method's own wall-clock compute (FFT pipeline when it uses it, "
    "and its controller) per robot per control tick, as measured where its rows were made: "
    "it depends on the machine, unlike every other column.",
    "p vs #1: two-sided paired Wilcoxon signed-rank test of per-map SPL against the rank-1 "
    "method, Holm-adjusted over the suite's other methods (`-` for rank 1).",
]


def _tests_table(tests: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for _, t in tests.iterrows():
        rows.append((t["against"], int(t["maps"]), _pct(t["spl_method"]), _pct(t["spl_against"]),
                     f"{100 * t['mean_diff']:+.1f} [{100 * t['diff_ci_low']:+.1f}, "
                     f"{100 * t['diff_ci_high']:+.1f}]" if np.isfinite(t["mean_diff"]) else "-",
                     _p(t["p_value"]), _p(t["p_holm"]), t.get("p_method", "")))
    return pd.DataFrame(rows, columns=["against", "maps", "SPL method %", "SPL other %",
                                       "gain (points) [95% CI]", "p", "p (Holm)", "p computed"])


def _reference_failures(episodes: pd.DataFrame, method: str, *, limit: int) -> list[str]:
    """Markdown lines listing ``method``'s failed robots of a suite's reference rows (env, map,
    robot, cause, the task to replay), at most ``limit``: the references keep no recording, so
    no time or place (:func:`fftnav.report.failures.failed_robots` has them for a run)."""
    failed = episodes[(episodes["policy"] == method) & ~episodes["arrived"].astype(bool)]
    if not len(failed):
        return [f"No robot of {method} failed."]
    failed = failed.sort_values(["env", "map_seed", "robot"])
    rows = [(r["env"], int(r["map_seed"]), int(r["robot"]), r["failure"] or "-",
             f"`{r['env']}-{int(r['map_seed'])}-{method}`")
            for _, r in failed.head(limit).iterrows()]
    lines = markdown_table(pd.DataFrame(rows, columns=["env", "map", "robot", "cause", "task"]))
    if len(failed) > limit:
        lines.append(f"\n... and {len(failed) - limit} more robots.")
    return lines


def evaluation_report(evaluation: Any) -> str:
    """``report.md`` of an ``fftnav evaluate`` folder (:class:`fftnav.suites.evaluate.
    Evaluation`)."""
    method = evaluation.method
    lines = [f"# {method} on the fftnav suites", "",
             f"`fftnav evaluate {evaluation.reference}` ranked beside every built-in method "
             "(the suites' shipped reference rows), on the same maps and episode seeds.", ""]
    for result in evaluation.suites:
        suite = result.suite
        lines += [f"## {suite.name}", "", f"{suite.description}. Measures {suite.measures}.",
                  ""]
        lines += [f"- {c.line}" for c in result.checks]
        here = [c for c in result.checks if np.isfinite(c.compute_ms_here)
                and np.isfinite(c.compute_ms_shipped) and c.compute_ms_shipped > 0]
        for c in here:
            lines.append(f"- compute on this machine: {c.method} took "
                         f"{c.compute_ms_here:.3g} ms per robot-tick here, "
                         f"{c.compute_ms_shipped:.3g} in the references "
                         f"(x{c.compute_ms_here / c.compute_ms_shipped:.2f}): scale the "
                         "built-ins' compute by that to compare with yours.")
        lines += ["", *markdown_table(ranked_lines(result.table, highlight=method)), ""]
        lines += [f"{method} against every built-in (per-map SPL, paired):", "",
                  *markdown_table(_tests_table(result.tests)), ""]
        lines += [f"### Failed robots of {method} on {suite.name}", ""]
        for run_dir in result.run_dirs:
            lines += _method_failures(Path(evaluation.out), Path(run_dir), method)
    lines += ["## How to read the tables", "", *[f"- {e}" for e in _EXPLAIN], ""]
    return "\n".join(lines)


def _method_failures(out: Path, run_dir: Path, method: str) -> list[str]:
    """The method's failed robots in one run folder (:func:`fftnav.report.failures.
    failed_robots`: when, where, a replay link that opens at the failure), written in full to
    the folder's ``failures.csv``, and how to make the replay pages."""
    from fftnav.files import write_atomic
    from fftnav.report.failures import failed_robots, failed_robots_lines

    failed = failed_robots(run_dir)
    failed = failed[failed["policy"] == method].reset_index(drop=True)
    if failed.empty:
        return [f"No robot of {method} failed on {run_dir.name}.", ""]
    where = run_dir.relative_to(out) if run_dir.is_relative_to(out) else run_dir
    failed["replay"] = [f"{where.as_posix()}/{link}" for link in failed["replay"]]
    write_atomic(run_dir / "failures.csv", failed.to_csv(index=False, float_format="%.6g"))
    return [*failed_robots_lines(failed, csv_name=f"{where.as_posix()}/failures.csv"),
            f"Each replay page is made on demand (the episode rerun from the folder, its rows "
            f"checked first): `fftnav replay {run_dir} --task TASK --out "
            f"{run_dir}/replays/TASK.html`; it opens at the failure with that robot picked.",
            ""]


def write_evaluation(evaluation: Any) -> Path:
    """Write ``report.md`` of an evaluation folder; its path."""
    path = Path(evaluation.out) / "report.md"
    write_atomic(path, evaluation_report(evaluation))
    return path


def leaderboard_markdown(table: pd.DataFrame, *, suites: Sequence[Suite]) -> str:
    """``leaderboard.md``: a ranked table per suite, each with its description."""
    lines = ["# fftnav leaderboard", "",
             "Every built-in method on every versioned suite (`fftnav suites`), ranked by SPL. "
             "Rank your own method beside them with `fftnav evaluate METHOD --suite NAME`; "
             "`fftnav leaderboard add DIR` adds it here.", ""]
    for suite in suites:
        rows = table[table["suite"] == suite.name]
        lines += [f"## {suite.name}", "", f"{suite.description}. Measures {suite.measures}. "
                  f"[report]({suite.name}/report.md) · [failed robots]({suite.name}/failures.md)",
                  "", *markdown_table(ranked_lines(rows)), ""]
    lines += ["## How to read the tables", "", *[f"- {e}" for e in _EXPLAIN], ""]
    return "\n".join(lines)


def _suite_report(suite: Suite, rows: pd.DataFrame, episodes: pd.DataFrame) -> str:
    """A suite's ``report.md``: its protocol, the ranking and each method's per-env SPL."""
    lines = [f"# {suite.name}", "", f"{suite.description}. Measures {suite.measures}.", ""]
    parts = suite.parts
    if suite.includes:
        lines += [f"Pools the maps of {', '.join(p.name for p in parts)}.", ""]
    lines += ["## Ranking", "", *markdown_table(ranked_lines(rows)), ""]
    per_env = (episodes.groupby(["policy", "env"])["spl"].mean().unstack("env") * 100)
    per_env = per_env.reindex(list(rows["method"]))
    shown = pd.DataFrame({"method": per_env.index,
                          **{f"SPL % {env}": [_num(v, 1) for v in per_env[env]]
                             for env in per_env.columns}})
    lines += ["## SPL by world", "", *markdown_table(shown), ""]
    if suite.family == "paper":
        lines += _beside_the_paper(episodes)
    lines += ["## How to read the tables", "", *[f"- {e}" for e in _EXPLAIN], ""]
    return "\n".join(lines)


def _beside_the_paper(episodes: pd.DataFrame) -> list[str]:
    """The paper's Table I beside our rows of its methods (the paper's suite only: its maps
    and settings are the protocol of Table I; absolute numbers differ, Gazebo vs PyBullet)."""
    from fftnav.report.experiment import PAPER_NAMES, PAPER_TABLE1

    rows = []
    for (env, method), (ar, apl, spl) in PAPER_TABLE1.items():
        ours = episodes[(episodes["env"] == env) & (episodes["policy"] == method)]
        if not len(ours):
            continue
        arrived = ours["arrived"].astype(bool)
        rows.append((env, f"{method} ({PAPER_NAMES[method]})", _pct(arrived.mean()),
                     _num(ours.loc[arrived, "path_length_m"].mean(), 3),
                     _pct(ours["spl"].mean()), f"{ar:.1f}", f"{apl:.3f}", f"{spl:.1f}"))
    table = pd.DataFrame(rows, columns=["env", "method", "AR %", "APL m", "SPL %",
                                        "paper AR %", "paper APL m", "paper SPL %"])
    return ["## Beside the paper's Table I", "",
            "The paper's methods on its protocol; the paper ran Gazebo and its own planner, so "
            "the ranking compares, not the absolute numbers.", "", *markdown_table(table), ""]


def _suite_failures(suite: Suite, rows: pd.DataFrame, episodes: pd.DataFrame) -> str:
    lines = [f"# Failed robots on {suite.name}", "",
             "Each method's failed robots. A replay of one, made on demand from the suite "
             "(the episode rerun, its rows checked against the shipped references first): "
             f"`fftnav replay --suite {suite.name} --task TASK --out TASK.html`; the page opens "
             "at the failure with `#robot=R&t=T`.", ""]
    for method in rows["method"]:
        lines += [f'<a id="{html.escape(method)}"></a>', "", f"## {method}", "",
                  *_reference_failures(episodes, method, limit=30), ""]
    return "\n".join(lines)


def write_leaderboard(folder: str | Path, table: pd.DataFrame, *,
                      episodes: dict[str, pd.DataFrame], highlight: str | None = None,
                      generated: str = "") -> list[Path]:
    """Write a leaderboard folder (:mod:`fftnav.suites.leaderboard`): ``leaderboard.csv``,
    ``leaderboard.md``, ``index.html`` and each suite's ``report.md`` and ``failures.md``
    (``episodes``: each suite's rows)."""
    from fftnav.report.leaderboard_page import write_leaderboard_page

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    present = set(table["suite"])
    suites = [s for s in ordered_suites() if s.name in present] + [
        find_suite(name) for name in dict.fromkeys(table["suite"]) if name not in SUITES]
    written = [out / "leaderboard.csv", out / "leaderboard.md"]
    write_atomic(written[0], table.to_csv(index=False, float_format="%.6g"))
    write_atomic(written[1], leaderboard_markdown(table, suites=suites))
    for suite in suites:
        rows = table[table["suite"] == suite.name]
        (out / suite.name).mkdir(exist_ok=True)
        for name, text in (("report.md", _suite_report(suite, rows, episodes[suite.name])),
                           ("failures.md", _suite_failures(suite, rows,
                                                           episodes[suite.name]))):
            write_atomic(out / suite.name / name, text)
            written.append(out / suite.name / name)
    written.append(write_leaderboard_page(
        out / "index.html", table, suites={s.name: s.description for s in suites},
        highlight=highlight, generated=generated))
    return written
