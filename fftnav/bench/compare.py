"""A benchmark result beside the paper (or the issue's target) and the previous recorded run.

``fftnav bench pipeline|sim`` print, after their table, one line per headline figure: this run,
the paper's figure (or the target where the paper gives none) and the previously recorded row
of the same kind in a CSV (``results/pipeline_latency.csv``, ``results/sim_speed.csv``: the
committed results), with the ratio new / previous.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

__all__ = ["HEADLINES", "format_comparison", "previous_row"]

#: Headline figures: key -> (label, reference kind, reference value, better).
HEADLINES: dict[str, tuple[str, str, float, str]] = {
    "single_us": ("1 scan, us", "paper", 13.0, "lower"),
    "batch15_us_per_scan": ("batch of 15, us/scan", "paper", 13.0, "lower"),
    "real_time_factor": ("real-time factor, x", "target", 30.0, "higher"),
    "ms_per_robot_s": ("ms per robot-second", "target", float("nan"), "lower"),
}


def previous_row(path: str | Path, match: dict[str, Any]) -> dict[str, str] | None:
    """The last row of the CSV ``path`` whose columns equal ``match`` (as strings), or None
    (no such file or row)."""
    path = Path(path)
    if not path.is_file():
        return None
    with path.open(newline="") as fh:
        rows = [r for r in csv.DictReader(fh)
                if all(r.get(k) == str(v) for k, v in match.items())]
    return rows[-1] if rows else None


def format_comparison(result: dict[str, Any], previous: dict[str, str] | None,
                      source: str = "previous") -> str:
    """Lines ``label: new | paper/target | previous (ratio)`` for the headline keys of
    ``result``."""
    lines = []
    for key, (label, kind, value, better) in HEADLINES.items():
        if key not in result:
            continue
        new = float(result[key])
        ref = f"{kind} {value:g}" if value == value else f"{kind} -"
        meets = "" if value != value else (
            " (meets it)" if (new <= value if better == "lower" else new >= value) else
            " (misses it)")
        old = "-"
        if previous is not None and previous.get(key) not in (None, ""):
            before = float(previous[key])
            old = f"{before:g} in {source} (new/old x{new / before:.2f})"
        lines.append(f"  {label:<24} {new:>9g}   {ref}{meets}   {old}")
    return "\n".join(["comparison: this run | paper or target | previous record", *lines])
