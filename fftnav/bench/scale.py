"""How the simulator's cost grows with the swarm (``fftnav bench scale``).

For each robot count N the map is grown so that obstacles and robots per m^2 stay the presets'
(:func:`fftnav.bench.sim.bench_world`: 15 robots on 20 m x 20 m, so 36.5 m for 50 robots,
51.6 m for 100, 73 m for 200), and the swarm is driven at random for the same simulated time
(:func:`fftnav.bench.sim.bench_sim`). The table has one row per (env, N): real-time factor and
wall milliseconds per simulated robot-second, whose growth from the smallest to the largest N
is the figure of merit (constant = linear cost in N).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fftnav.bench.sim import bench_sim
from fftnav.files import write_atomic
from fftnav.validate import check_integer

__all__ = ["COLUMNS", "ROBOTS", "bench_scale", "growth", "write_scale_csv"]

#: Default robot counts.
ROBOTS = (15, 50, 100, 200)
#: Columns of ``results/scale.csv``.
COLUMNS = ("env", "robots", "size_m", "simulated_s", "wall_s", "real_time_factor",
           "ms_per_robot_s", "lidar_ms_per_tick", "rays_cast_per_tick", "rays_static_per_tick",
           "physics_ms_per_s", "load_avg_1min")


def bench_scale(*, envs: Sequence[str] = ("forest", "rocky"), robots: Sequence[int] = ROBOTS,
                seconds: float = 20.0, seed: int = 0, runs: int = 1) -> list[dict[str, Any]]:
    """One :func:`fftnav.bench.sim.bench_sim` row per (env, robot count), ``COLUMNS`` only."""
    for n in robots:
        check_integer("robots", n, low=1)
    rows = []
    for env in envs:
        for n in robots:
            result = bench_sim(env=env, seconds=seconds, seed=seed, robots=n, runs=runs,
                               compare_lidar=False)
            rows.append({c: result[c] for c in COLUMNS})
    return rows


def growth(rows: Sequence[dict[str, Any]], env: str) -> float:
    """Cost per robot-second at the largest N over that at the smallest N, for one env."""
    mine = sorted((r for r in rows if r["env"] == env), key=lambda r: int(r["robots"]))
    return float(mine[-1]["ms_per_robot_s"]) / float(mine[0]["ms_per_robot_s"])


def write_scale_csv(rows: Sequence[dict[str, Any]], path: str | Path) -> None:
    """Write the rows (``COLUMNS``) to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(COLUMNS))
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(path, text.getvalue())


def format_scale(rows: Sequence[dict[str, Any]]) -> str:
    """The table, then the growth of the cost per robot-second per env."""
    lines = [f"{'env':<8}{'robots':>7}{'map m':>8}{'RTF x':>9}{'ms/robot-s':>12}"
             f"{'lidar ms/tick':>15}{'load':>7}"]
    lines += [f"{r['env']:<8}{r['robots']:>7}{r['size_m']:>8g}{r['real_time_factor']:>9.2f}"
              f"{r['ms_per_robot_s']:>12.3f}{r['lidar_ms_per_tick']:>15.2f}"
              f"{r['load_avg_1min']:>7.2f}" for r in rows]
    for env in dict.fromkeys(r["env"] for r in rows):
        ns = sorted(int(r["robots"]) for r in rows if r["env"] == env)
        lines.append(f"{env}: cost per robot-second grows x{growth(rows, env):.2f} from "
                     f"{ns[0]} to {ns[-1]} robots")
    return "\n".join(lines)
