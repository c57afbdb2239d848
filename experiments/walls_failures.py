"""Which robots fail at walls and traps on the fresh maps, and why they are hard.

Reads the committed episodes of ``experiments/collab/fresh.toml`` (maps 61-80, 15 robots, the
paper's setting) and of ``experiments/noise_seeds.py`` (the same maps with 1 cm lidar noise, 3
more episode seeds), and sorts every robot of the walls and traps maps three ways:

- **where it starts**: the two robots at each end of the start line (robots 0, 1, 13 and 14 of
  15: start and goal within 2 m of the arena's side wall) or the 11 between them;
- **whether the planner fits through the short way**: the robot's grid A* length with obstacles
  inflated by the protective radius r (``robot.r_m``, 0.3 m: the safe directions keep a
  sector 2 r wide free) against its reference, inflated by r0 (``robot.r0_m``, 0.15 m).
  "Narrow": more than 10 % longer at r, or no way at r; the short way passes a gap that
  rocks narrow below 2 r.
- **whether the planner's own map closes the short way**: the way through an own map
  (:class:`~fftnav.navigation.ownmap.OwnMaps`, at the planner's cell size and clearance:
  0.2 m and 0.3 m) that holds every obstacle's surface, as if the robot had seen them all.
  "Map-closed": more than 10 % longer than the reference, or no way. A cell is closed within
  the clearance of a hit *cell*, so a straight gap stays open in it only from 0.7-0.8 m
  on (2 r is 0.6 m).

Run from the repository root: ``python experiments/walls_failures.py`` (about half a minute)
-> ``results/collab/walls_failures.md`` (failures per policy and class).
"""

from __future__ import annotations

from dataclasses import replace
from multiprocessing import Pool
from pathlib import Path

import numpy as np
import pandas as pd

from fftnav.config import SwarmConfig
from fftnav.navigation.bug import BugPlanner, PlannerParams
from fftnav.optimal.gridgraph import UnreachableGoalError
from fftnav.optimal.reference import optimal_lengths
from fftnav.world.generate import generate_world

ROOT = Path(__file__).resolve().parents[1]
ENVS = ("walls", "traps")
POLICIES = ("own-only", "fusion", "collab")
EDGE = (0, 1, 13, 14)
NARROW = 1.1
PARAMS = PlannerParams()


def lengths(job: tuple[str, int]) -> list[dict]:
    """Every robot's A* length at r0 and at r on one map (inf where there is no way at r)."""
    env, map_seed = job
    robot = SwarmConfig().robot
    world = generate_world(env, map_seed, robots=15)
    at_r0, _ = optimal_lengths(world, r0_m=robot.r0_m)
    try:
        at_r, _ = optimal_lengths(world, r0_m=robot.r_m)
    except (ValueError, UnreachableGoalError):  # a start, a goal or a way closed at r
        at_r = np.array([optimal_lengths_one(world, i, robot.r_m) for i in range(15)])
    return [{"env": env, "map_seed": map_seed, "robot": i, "astar_r0_m": at_r0[i],
             "astar_r_m": at_r[i]} for i in range(15)]


def optimal_lengths_one(world, robot: int, r_m: float) -> float:
    """One robot's A* length at ``r_m`` (inf if its start, goal or way is closed)."""
    one = replace(world, starts=world.starts[robot:robot + 1], goals=world.goals[robot:robot + 1])
    try:
        return float(optimal_lengths(one, r0_m=r_m)[0][0])
    except (ValueError, UnreachableGoalError):
        return float("inf")


def surface_points(world, spacing_m: float = 0.02) -> np.ndarray:
    """Points ``(P, 2)`` at most ``spacing_m`` apart along every solid's outline."""
    points = []
    for solid in world.solids:
        ring = solid.outline()
        for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
            n = int(np.ceil(np.hypot(*(b - a)) / spacing_m)) + 1
            points.append(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a))
    return np.concatenate(points)


def map_ways(job: tuple[str, int]) -> list[dict]:
    """Every robot's way length through an own map holding every obstacle surface of one map
    (the planner's own maps of the swarm, :meth:`BugPlanner.new_maps`; inf where it has no
    way)."""
    env, map_seed = job
    world = generate_world(env, map_seed, robots=15)
    planner = BugPlanner.for_swarm(15, SwarmConfig(), lambda i: 1, area_m=world.size_m,
                                   walled=world.boundary == "walls")
    maps = planner.new_maps(world.starts, world.goals)
    cells = maps.cell(surface_points(world))
    cells = cells[maps.inside(cells)]
    maps.last_hit[:, cells[:, 0], cells[:, 1]] = 0  # seen as hits at tick 0, never passed
    rows = []
    for i in range(15):
        maps.plan(i, world.starts[i, :2], world.goals[i])
        rows.append({"env": env, "map_seed": map_seed, "robot": i,
                     "own_map_m": maps.way_length(i, world.starts[i, :2])})
    return rows


def classify(episodes: pd.DataFrame, ways: pd.DataFrame) -> pd.DataFrame:
    """``episodes`` (env, map_seed, robot, policy, arrived) with the classes ``edge``,
    ``narrow`` and ``map_closed`` of each robot."""
    table = episodes.merge(ways, on=["env", "map_seed", "robot"], how="left")
    table["edge"] = table.robot.isin(EDGE)
    table["narrow"] = ~(table.astar_r_m <= NARROW * table.astar_r0_m)
    table["map_closed"] = ~(table.own_map_m <= NARROW * table.astar_r0_m)
    return table


def _failures(fail: pd.Series, mask: pd.Series) -> str:
    """``failures / robots (AR %)`` of the robots in ``mask``."""
    n, k = int(mask.sum()), int((fail & mask).sum())
    return f"{k} / {n} ({100 * (n - k) / max(n, 1):.1f})"


def report(runs: dict[str, pd.DataFrame]) -> str:
    """Failures per env, policy and class, for each run."""
    lines = ["# Who fails at walls and traps on the fresh maps 61-80", "",
             "Written by `python experiments/walls_failures.py` from the committed episodes. "
             f"Edge: robots {', '.join(map(str, EDGE))} of 15 (start and goal within 2 m of "
             "the arena's side wall); middle: the other 11. Narrow: the grid A* way with "
             f"obstacles inflated by r (0.3 m) is more than {NARROW - 1:.0%} longer than the "
             "reference at r0 (0.15 m), or closed. Map-closed: the way through an own map at "
             f"the planner's cell size and clearance ({PARAMS.map_resolution_m} m, "
             f"{PARAMS.map_clearance_m} m) holding every obstacle "
             f"surface is more than {NARROW - 1:.0%} longer than the reference, or closed. "
             "Cells: failures / robots (AR %).", ""]
    for title, table in runs.items():
        lines += [f"## {title}", "",
                  "| env | policy | AR % | edge | middle | narrow | AR % without narrow "
                  "| map-closed | AR % without map-closed |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for env in ENVS:
            for policy in POLICIES:
                part = table[(table.env == env) & (table.policy == policy)]
                fail = ~part.arrived.astype(bool)
                lines.append(
                    f"| {env} | {policy} | {100 * (~fail).mean():.1f} | "
                    f"{_failures(fail, part.edge)} | {_failures(fail, ~part.edge)} | "
                    f"{_failures(fail, part.narrow)} | {100 * (~fail[~part.narrow]).mean():.1f} | "
                    f"{_failures(fail, part.map_closed)} | "
                    f"{100 * (~fail[~part.map_closed]).mean():.1f} |")
        lines.append("")
    return "\n".join(lines)


def main() -> str:
    jobs = [(env, m) for env in ENVS for m in range(61, 81)]
    with Pool(2) as pool:
        ways = pd.DataFrame([row for rows in pool.imap(lengths, jobs) for row in rows])
        own = pd.DataFrame([row for rows in pool.imap(map_ways, jobs) for row in rows])
    ways = ways.merge(own, on=["env", "map_seed", "robot"])
    fresh = pd.read_csv(ROOT / "results" / "collab" / "fresh" / "episodes.csv")
    noise = pd.read_csv(ROOT / "results" / "collab" / "noise_seeds.csv")
    keep = ["env", "map_seed", "robot", "policy", "arrived"]
    runs = {"Without noise (`experiments/collab/fresh.toml`)":
            classify(fresh[fresh.env.isin(ENVS)][keep], ways),
            "1 cm noise, 3 more episode seeds (`experiments/noise_seeds.py`)":
            classify(noise[keep], ways)}
    text = report(runs)
    out = ROOT / "results" / "collab" / "walls_failures.md"
    out.write_text(text)
    print(text)
    print(f"-> {out.relative_to(ROOT)}")
    return text


if __name__ == "__main__":
    main()
