"""Large worlds (``fftnav bench worlds``): how soon a big world is ready, and its episodes.

The cases are trunk fields drawn from one seeded generator: ``trunks-20k`` (20,000 trunks of
radius 5 to 10 cm in a 100 m x 100 m world) and ``largest`` (the largest world the documented
limits allow: :data:`fftnav.limits.MAX_OBSTACLES` = 50,000 trunks in a world of
:data:`fftnav.limits.MAX_MAP_SIDE_M` = 1000 m a side). Each case runs in a fresh process (its
peak memory is its own, numba's compiled kernels loaded from its cache there): build the
world, time the simulator until its first scan (``SwarmSim`` and ``reset``), then, for
``trunks-20k``, run one ``fusion`` episode of 5 simulated seconds (``run_episode``, from the
world to its rows: simulator, first scan, A* reference and metrics included).

:func:`side_by_side` compares this code with another source tree of fftnav (``--against``,
e.g. ``git archive`` of an older commit) on the same world, alternating old and new runs, and
checks that both give the same episode rows.
"""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.limits import MAX_MAP_SIDE_M, MAX_OBSTACLES
from fftnav.validate import check_integer
from fftnav.world import World
from fftnav.world.obstacles import Circle

__all__ = ["LARGE_WORLDS", "bench_large_world", "bench_worlds", "format_worlds",
           "side_by_side", "trunk_field"]

#: The cases: trunks, side of the square world (m), seconds of the measured episode (0: none).
LARGE_WORLDS: dict[str, dict[str, Any]] = {
    "trunks-20k": {"trunks": 20_000, "side_m": 100.0, "episode_s": 5.0},
    "largest": {"trunks": MAX_OBSTACLES, "side_m": MAX_MAP_SIDE_M, "episode_s": 0.0},
}
_ROBOTS = 15
_CLEAR_M = 2.0  # strips along the start and goal rows kept free of trunks


def trunk_field(trunks: int, side_m: float, *, seed: int = 0, robots: int = _ROBOTS) -> World:
    """A square forest of ``trunks`` trunks (radius uniform in [0.05, 0.1] m, 2 m tall), one
    in each cell of a regular grid over the band ``2 m <= y <= side - 2 m``, jittered within
    its cell (at least 0.1 m apart), coordinates rounded to 0.1 mm; ``robots`` robots start
    evenly spaced on ``y = 1 m`` facing +y, their goals straight across on ``y = side - 1 m``.
    """
    rng = np.random.default_rng(seed)
    band = side_m - 2 * _CLEAR_M
    cols = int(np.ceil(np.sqrt(trunks * side_m / band)))
    rows = int(np.ceil(trunks / cols))
    width, height = side_m / cols, band / rows
    k = np.arange(trunks)
    radius = np.round(rng.uniform(0.05, 0.1, trunks), 4)
    slack = np.array([width, height]) / 2 - 0.1 - 0.05 - 1e-4  # 0.1 m apart at the most
    if np.any(slack < 0):
        raise FftnavError(f"trunks: {trunks} do not fit {side_m:g} m x {side_m:g} m")
    x = (k % cols + 0.5) * width + rng.uniform(-slack[0], slack[0], trunks)
    y = _CLEAR_M + (k // cols + 0.5) * height + rng.uniform(-slack[1], slack[1], trunks)
    obstacles = tuple(Circle((cx, cy), r, 2.0) for cx, cy, r in
                      zip(np.round(x, 4).tolist(), np.round(y, 4).tolist(), radius.tolist(),
                          strict=True))
    sx = (np.arange(robots) + 0.5) * side_m / robots
    return World("forest", seed, (float(side_m), float(side_m)), obstacles,
                 np.c_[sx, np.full(robots, 1.0), np.full(robots, np.pi / 2)],
                 np.c_[sx, np.full(robots, side_m - 1.0)])


def _rows_digest(rows: list[Any]) -> str:
    """SHA-256 of the episode rows' text (the same rows give the same digest)."""
    return hashlib.sha256(repr([tuple(vars(r).values()) for r in rows]).encode()).hexdigest()


def bench_large_world(name: str, *, seed: int = 0) -> dict[str, Any]:
    """Measure one case of :data:`LARGE_WORLDS` in this process.

    Returns
    -------
    dict
        ``obstacles``, ``tiles`` (of the static mesh) and ``tiles_built`` at the first scan,
        ``generate_s`` (drawing the world), ``ready_s`` (simulator built and first scan taken),
        ``episode_s`` and ``episode_wall_s`` (one ``fusion`` episode of that many simulated
        seconds, from the world to its rows; empty without one), ``max_rss_mb`` (peak resident
        memory of the process) and the load average.
    """
    from fftnav.config import SwarmConfig
    from fftnav.episode import run_episode
    from fftnav.sim.swarm import SimConfig, SwarmSim

    case = LARGE_WORLDS[name]
    tic = time.perf_counter()
    world = trunk_field(case["trunks"], case["side_m"], seed=seed)
    generate_s = time.perf_counter() - tic
    swarm = SwarmConfig().replace({"time_limit_s": max(case["episode_s"], 1.0)})
    tic = time.perf_counter()
    with SwarmSim(world, config=SimConfig.for_swarm(swarm)) as sim:
        sim.reset(seed=seed)
        ready_s = time.perf_counter() - tic
        built, tiles = sim.tiles_built
    row: dict[str, Any] = {
        "bench": "worlds", "case": name, "size_m": f"{case['side_m']:g}x{case['side_m']:g}",
        "seed": seed, "obstacles": len(world.obstacles), "robots": len(world.starts),
        "tiles": tiles, "tiles_built": built, "generate_s": round(generate_s, 2),
        "ready_s": round(ready_s, 2), "episode_s": "", "episode_wall_s": "", "rows_sha256": "",
    }
    if case["episode_s"]:
        tic = time.perf_counter()
        result = run_episode(world, "fusion", seed=seed, config=swarm)
        row["episode_wall_s"] = round(time.perf_counter() - tic, 2)
        row["episode_s"] = case["episode_s"]
        row["rows_sha256"] = _rows_digest(result.rows)[:16]
    row["max_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    row["load_avg_1min"] = round(os.getloadavg()[0], 2)
    return row


def bench_worlds(cases: list[str] | None = None, **kwargs: Any) -> list[dict[str, Any]]:
    """Run :func:`bench_large_world` for each case, each in a fresh process."""
    names = list(LARGE_WORLDS) if cases is None else cases
    for name in names:
        if name not in LARGE_WORLDS:
            raise FftnavError(f"case must be one of {list(LARGE_WORLDS)}, got case={name!r}")
    context = multiprocessing.get_context("spawn")
    results = []
    for name in names:
        with context.Pool(1) as pool:
            results.append(pool.apply(bench_large_world, (name,), kwargs))
    return results


def format_worlds(results: list[dict[str, Any]]) -> str:
    """One line per case."""
    lines = []
    for r in results:
        line = (f"{r['case']}: {r['obstacles']} trunks in {r['size_m']} m, {r['tiles']} tiles "
                f"({r['tiles_built']} built at the first scan); ready for the first scan in "
                f"{r['ready_s']:.2f} s")
        if r.get("episode_wall_s") != "":
            line += f", a {r['episode_s']:g} s episode in {r['episode_wall_s']:.2f} s"
        lines.append(line + f", peak {r['max_rss_mb']:.0f} MB")
    return "\n".join(lines)


#: Run in a fresh interpreter by :func:`side_by_side` with either source tree first on the
#: path: only APIs that both versions have (a world file, SwarmSim, run_episode).
_PROBE = """
import hashlib, json, resource, sys, time
from pathlib import Path
from fftnav.config import SwarmConfig
from fftnav.episode import run_episode
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.world import World
world = World.from_json(Path(sys.argv[1]).read_text())
swarm = SwarmConfig().replace({"time_limit_s": float(sys.argv[2])})
tic = time.perf_counter()
with SwarmSim(world, config=SimConfig.for_swarm(swarm)) as sim:
    sim.reset(seed=0)
    ready = time.perf_counter() - tic
tic = time.perf_counter()
rows = run_episode(world, "fusion", seed=0, config=swarm).rows
episode = time.perf_counter() - tic
digest = hashlib.sha256(repr([tuple(vars(r).values()) for r in rows]).encode()).hexdigest()
print(json.dumps({"ready_s": ready, "episode_wall_s": episode, "rows_sha256": digest[:16],
                  "max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def side_by_side(against: str | os.PathLike[str], *, case: str = "trunks-20k",
                 repeats: int = 2, seed: int = 0) -> list[dict[str, Any]]:
    """This code against the fftnav source tree ``against`` on one world, alternating.

    Each run is a fresh interpreter (``against`` or this package's tree first on the path)
    that builds the simulator for the case's world until its first scan, then runs one
    ``fusion`` episode of the case's length (5 s when it has none). Runs alternate old, new,
    ``repeats`` times, so that both see the same load.

    Returns
    -------
    list of dict
        One row per run (``code``: ``old`` or ``new``, ``repeat``, ``ready_s``,
        ``episode_wall_s``, ``max_rss_mb``, ``rows_sha256``), then one ``ratio`` row: the new
        median over the old median of each time and of the peak memory, and whether every
        run gave the same rows (``rows_identical``).
    """
    check_integer("repeats", repeats, low=1)
    tree = Path(against)
    if not (tree / "fftnav" / "__init__.py").is_file():
        raise FftnavError(f"against must be a source tree holding fftnav/, got {str(tree)!r}")
    if case not in LARGE_WORLDS:
        raise FftnavError(f"case must be one of {list(LARGE_WORLDS)}, got case={case!r}")
    spec = LARGE_WORLDS[case]
    world = trunk_field(spec["trunks"], spec["side_m"], seed=seed)
    ours = Path(__file__).resolve().parents[2]
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "world.json"
        path.write_text(world.to_json())
        for repeat in range(repeats):
            for code, root in (("old", tree), ("new", ours)):
                env = dict(os.environ, PYTHONPATH=str(root))
                proc = subprocess.run(
                    [sys.executable, "-c", _PROBE, str(path), str(spec["episode_s"] or 5.0)],
                    env=env, cwd=tmp, capture_output=True, text=True)
                if proc.returncode != 0:
                    last = (proc.stderr.strip().splitlines() or ["no message"])[-1]
                    raise FftnavError(f"the {code} tree {str(root)!r} could not run the "
                                      f"{case!r} probe: {last}")
                row = json.loads(proc.stdout.strip().splitlines()[-1])
                rows.append({"bench": "worlds-side-by-side", "case": case, "code": code,
                             "repeat": repeat, **{k: (round(v, 2) if isinstance(v, float)
                                                      else v) for k, v in row.items()},
                             "load_avg_1min": round(os.getloadavg()[0], 2)})
    ratio = dict(rows[-1], code="new/old", repeat=repeats,
                 rows_sha256=("identical" if len({r["rows_sha256"] for r in rows}) == 1
                              else "DIFFERENT"), load_avg_1min=round(os.getloadavg()[0], 2))
    for key in ("ready_s", "episode_wall_s", "max_rss_mb"):
        old = np.median([r[key] for r in rows if r["code"] == "old"])
        new = np.median([r[key] for r in rows if r["code"] == "new"])
        ratio[key] = round(float(new / old), 3)
    return [*rows, ratio]
