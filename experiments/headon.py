"""Two robots meeting head-on in a corridor: robots that are not walls, and the right of way.

A 6 m corridor (two walls 0.2 m thick, open at both ends) in a 12 m x 8 m world; one robot
starts at each end, 0.5 m inside, and its goal lies 2 m beyond the other end. The corridor's
walls are longer than the sensing range R, so ``collab``'s gate opens: each robot reads the
other's wall segments and, from its messages, knows where it stands
(:meth:`fftnav.navigation.ownmap.OwnMaps.set_robots`) and how far it is from its goal (the right
of way, :func:`fftnav.navigation.collab.waits_for`). Widths 0.8 m and 1.0 m (too narrow for the
two to pass) and 1.2 m (wide enough). Every policy runs the same episodes (seed 0, the paper's
setting otherwise), and ``collab`` twice more: without the right of way (``collab, no right of
way``: ``Walls.waits`` switched off, the robot with the right of way does not wait for the
other to give way) and with ``set_robots`` switched off (``collab, robots as walls``: each map
holds the other robot as an obstacle, like a wall).

Run from the repository root: ``python experiments/headon.py`` -> ``results/collab/headon.csv``
(one row per width, policy and robot: arrived, time and path length) and
``results/collab/figures/headon_<width>_<run>.png`` (the trajectories; ``<run>`` the label
with its spaces and commas as underscores).
"""

from __future__ import annotations

import math
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd

from fftnav.config import SwarmConfig
from fftnav.episode import run_episode
from fftnav.navigation.messages import Walls
from fftnav.navigation.ownmap import OwnMaps
from fftnav.report.trajectories import plot_episode
from fftnav.world import Polygon, World

ROOT = Path(__file__).resolve().parents[1]
#: (label, policy, whether OwnMaps.set_robots works, whether the right of way works)
RUNS = (("own-only", "own-only", True, True), ("fusion", "fusion", True, True),
        ("collab", "collab", True, True),
        ("collab, no right of way", "collab", True, False),
        ("collab, robots as walls", "collab", False, True))


def corridor(width_m: float) -> World:
    """The head-on world with a corridor ``width_m`` wide (between the walls' faces)."""
    half = width_m / 2.0

    def box(x0: float, y0: float, x1: float, y1: float) -> Polygon:
        return Polygon(((x0, y0), (x1, y0), (x1, y1), (x0, y1)), 1.0)

    walls = (box(3.0, 4.0 + half, 9.0, 4.2 + half), box(3.0, 3.8 - half, 9.0, 4.0 - half))
    starts = np.array([[3.5, 4.0, 0.0], [8.5, 4.0, math.pi]])
    goals = np.array([[11.0, 4.0], [1.0, 4.0]])
    return World("headon", 0, (12.0, 8.0), walls, starts, goals)


def main() -> pd.DataFrame:
    rows = []
    figures = ROOT / "results" / "collab" / "figures"
    for width in (0.8, 1.0, 1.2):
        world = corridor(width)
        for label, policy, robots_known, right_of_way in RUNS:
            with (mock.patch.object(OwnMaps, "set_robots",
                                    OwnMaps.set_robots if robots_known else lambda *a: None),
                  mock.patch.object(Walls, "waits",
                                    Walls.waits if right_of_way else lambda *a: False)):
                result = run_episode(world, policy, seed=0)
            name = label.replace(", ", "_").replace(" ", "_")
            plot_episode(world, result.trajectories, result.rows,
                         figures / f"headon_{width:.1f}_{name}.png",
                         title=f"{label}, corridor {width:.1f} m",
                         r0_m=SwarmConfig().robot.r0_m)
            for row in result.rows:
                rows.append({"width_m": width, "run": label, "robot": row.robot,
                             "arrived": row.arrived, "time_s": round(row.time_s, 2),
                             "path_length_m": round(row.path_length_m, 3),
                             "optimal_length_m": round(row.optimal_length_m, 3),
                             "spl": round(row.spl, 4)})
    table = pd.DataFrame(rows)
    out = ROOT / "results" / "collab" / "headon.csv"
    table.to_csv(out, index=False)
    print(table.to_string(index=False))
    print(f"-> {out.relative_to(ROOT)}")
    return table


if __name__ == "__main__":
    main()
