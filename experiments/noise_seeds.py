"""``collab`` with lidar range noise over several episode seeds: walls and traps, fresh maps.

``experiments/collab/fresh_noise.toml`` runs each of the fresh maps 61-80 once, with its map's
episode seed (:func:`fftnav.runner.tasks.episode_seed`). This script runs the same maps, the
same setting (15 robots, the paper's parameters, ``sensor.noise_std_m = 0.01``) and the same
three policies with ``SEEDS`` further episode seeds per map, ``SeedSequence((map_seed,
crc32(env), k))`` for k = 1, 2, 3: other noise draws, so other trajectories. Every policy of a
map runs the same seeds and its grid A* reference, so the comparisons are paired by map: a
map's SPL is the mean over its seeds' robots.

Run from the repository root: ``python experiments/noise_seeds.py`` (2 worker processes,
about 10 minutes on 2 cores) -> ``results/collab/noise_seeds.csv`` (one row per env, map,
seed, policy and robot: arrived, SPL, failure cause) and ``results/collab/noise_seeds.md``
(AR and SPL per env and policy, the per-map SPL differences with their paired Wilcoxon p).
``--set KEY=VALUE`` (repeatable) changes a config key for every policy, as ``fftnav episode
--set`` does (``--set planner.heading_tol_deg=10``), and ``--out PATH`` names the CSV (the
report beside it, ``.md``).
"""

from __future__ import annotations

import argparse
import zlib
from multiprocessing import Pool
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
ENVS = ("walls", "traps")
MAPS = range(61, 81)
POLICIES = ("own-only", "fusion", "collab")
SEEDS = 3
NOISE_STD_M = 0.01


def seed_of(env: str, map_seed: int, k: int) -> int:
    """The k-th further episode seed of a map (a 32-bit integer)."""
    return int(np.random.SeedSequence((map_seed, zlib.crc32(env.encode()), k))
               .generate_state(1)[0])


def run_map(job: tuple[str, int, dict[str, str]]) -> list[dict]:
    """Every policy and seed of one map (its reference computed once), with the config
    overrides of the job."""
    from fftnav.config import SwarmConfig
    from fftnav.episode import run_episode
    from fftnav.optimal.reference import optimal_lengths
    from fftnav.world.generate import generate_world

    env, map_seed, overrides = job
    config = SwarmConfig().replace({"sensor.noise_std_m": NOISE_STD_M, **overrides})
    world = generate_world(env, map_seed, robots=15)
    reference = tuple(np.asarray(r) for r in optimal_lengths(world, r0_m=config.robot.r0_m))
    rows = []
    for k in range(1, SEEDS + 1):
        seed = seed_of(env, map_seed, k)
        for policy in POLICIES:
            result = run_episode(world, policy, seed=seed, config=config, reference=reference)
            rows += [{"env": env, "map_seed": map_seed, "episode_seed": seed, "policy": policy,
                      "robot": r.robot, "arrived": r.arrived, "spl": round(r.spl, 6),
                      "failure": r.failure} for r in result.rows]
    return rows


def report(table: pd.DataFrame, overrides: dict[str, str] | None = None) -> str:
    """AR and SPL per env and policy, and the paired per-map SPL differences of ``collab``;
    ``overrides``: the ``--set`` keys the table was run with."""
    from fftnav.runner.summary import paired_tests

    tests = {ref: paired_tests(table, reference=ref).set_index(["env", "policy"]).p_value
             for ref in ("own-only", "fusion")}
    lines = [f"# `collab` with {NOISE_STD_M * 100:.0f} cm range noise, {SEEDS} more episode "
             f"seeds per map (maps {MAPS.start}-{MAPS.stop - 1})"
             + "".join(f", {k} = {v}" for k, v in (overrides or {}).items()), "",
             "Written by `python experiments/noise_seeds.py"
             + "".join(f" --set {k}={v}" for k, v in (overrides or {}).items())
             + "`. AR and SPL in % over "
             f"{len(MAPS)} maps x {SEEDS} seeds x 15 robots; differences are the mean of the "
             "per-map SPL differences (a map's SPL: the mean over its seeds' robots), in points, "
             "with the paired two-sided Wilcoxon signed-rank p over maps.", "",
             "| env | policy | AR % | SPL % | vs | SPL difference | maps better / worse | p |",
             "|---|---|---|---|---|---|---|---|"]
    for env in ENVS:
        part = table[table.env == env]
        per_map = part.groupby(["map_seed", "policy"]).spl.mean().unstack()
        for policy in POLICIES:
            mine = part[part.policy == policy]
            ar, spl = 100 * mine.arrived.mean(), 100 * mine.spl.mean()
            refs = {"own-only": (), "fusion": ("own-only",), "collab": ("own-only", "fusion")}
            if policy == "own-only":
                lines.append(f"| {env} | {policy} | {ar:.1f} | {spl:.1f} | | | | |")
            for ref in refs[policy]:
                diff = per_map[policy] - per_map[ref]
                p = tests[ref][env, policy]
                lines.append(f"| {env} | {policy} | {ar:.1f} | {spl:.1f} | {ref} | "
                             f"{100 * diff.mean():+.1f} | {(diff > 0).sum()} / {(diff < 0).sum()} "
                             f"| {p:.2g} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> pd.DataFrame:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a config key for every policy (planner.heading_tol_deg=10)")
    parser.add_argument("--out", type=Path, default=ROOT / "results/collab/noise_seeds.csv",
                        help="the CSV; its report beside it (.md)")
    args = parser.parse_args(argv)
    from fftnav.config import SwarmConfig
    bad = [item for item in args.set if "=" not in item]
    if bad:
        parser.error(f"--set must be KEY=VALUE, got --set {bad[0]}")
    overrides = dict(item.split("=", 1) for item in args.set)
    try:
        SwarmConfig().replace(overrides)
    except ValueError as exc:
        parser.error(str(exc))
    jobs = [(env, m, overrides) for env in ENVS for m in MAPS]
    with Pool(2) as pool:
        table = pd.DataFrame([row for rows in pool.imap(run_map, jobs) for row in rows])
    out = args.out.resolve()
    table.to_csv(out, index=False)
    text = report(table, overrides)
    (out.with_suffix(".md")).write_text(text)
    print(text)
    print(f"-> {out}, {out.with_suffix('.md')}")
    return table


if __name__ == "__main__":
    main()
