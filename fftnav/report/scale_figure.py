"""The scale figure: real-time factor and cost per robot-second against the swarm size."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fftnav.report import new_figure, save_figure

__all__ = ["draw_scale_figure"]


def draw_scale_figure(rows: Sequence[dict[str, Any]], path: str | Path) -> Path:
    """Two panels per env line, against the number of robots N: the real-time factor
    (simulated / wall seconds, log scale) and wall milliseconds per simulated robot-second
    (flat = cost linear in N). ``rows`` as written by ``fftnav bench scale``."""
    path = Path(path)
    fig = new_figure(figsize=(9.0, 3.6))
    rtf, cost = fig.subplots(1, 2)
    for env in dict.fromkeys(str(r["env"]) for r in rows):
        mine = sorted((r for r in rows if r["env"] == env), key=lambda r: int(r["robots"]))
        n = [int(r["robots"]) for r in mine]
        rtf.plot(n, [float(r["real_time_factor"]) for r in mine], "o-", label=env)
        cost.plot(n, [float(r["ms_per_robot_s"]) for r in mine], "o-", label=env)
    rtf.set(xlabel="robots N", ylabel="real-time factor (x)", yscale="log",
            title="simulated s per wall s")
    cost.set(xlabel="robots N", ylabel="ms per robot-second", title="wall ms per robot per s")
    cost.set_ylim(bottom=0)
    for ax in (rtf, cost):
        ax.grid(alpha=0.3)
        ax.legend()
    loads = [float(r["load_avg_1min"]) for r in rows if "load_avg_1min" in r]
    if loads:  # the machine's state is part of the measurement
        fig.suptitle(f"1-min load average {min(loads):.1f} to {max(loads):.1f} during the runs",
                     fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=120)
    return path
