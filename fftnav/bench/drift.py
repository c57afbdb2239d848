"""The drift presets measured (``fftnav bench drift``): how far each preset's odometry strays.

For every preset of :data:`fftnav.localization.DRIFT_PRESETS`: its alphas, and the mean
position error of the estimate at the end of a path in percent of the distance driven
(:func:`fftnav.localization.drift_percent`), over ``runs`` simulated robots, on the reference
path (20 m, what the presets are calibrated on) and on 10 m and 40 m versions of it (the drift
grows with the distance: the heading error of a random walk grows with its square root), and
on the true paths of the robots of a benchmark episode (``own-only`` with exact localization on
Table I's first forest map: the turns and speeds of real runs, each robot's path replayed
through the model ``episode_runs`` times).
"""

from __future__ import annotations

import numpy as np

from fftnav.localization import DRIFT_PRESETS, drift_percent, reference_path
from fftnav.validate import check_integer

__all__ = ["bench_drift", "episode_paths", "format_drift"]


def episode_paths(env: str = "forest", map_seed: int = 1000) -> list[np.ndarray]:
    """The true paths ``(T, 3)`` of the robots of one exact ``own-only`` episode of the paper's
    swarm (15 robots) on map ``map_seed`` of ``env`` (episode seed 0)."""
    from fftnav.episode import run_episode
    from fftnav.world import generate_world

    world = generate_world(env, map_seed, robots=15)
    return [t for t in run_episode(world, "own-only", seed=0).trajectories if len(t) > 10]


def bench_drift(*, runs: int = 20_000, seed: int = 0, episode_runs: int = 200,
                paths: list[np.ndarray] | None = None) -> list[dict]:
    """One row per preset (module docstring): ``preset``, ``alpha1`` ... ``alpha4``, and the
    drift in percent ``drift_10m_pct``, ``drift_20m_pct`` (the reference path),
    ``drift_40m_pct`` and ``drift_episode_pct`` (the mean over the episode's robots;
    ``paths``: default :func:`episode_paths`), with ``episode_path_m`` their mean length."""
    n = check_integer("runs", runs, low=1)
    m = check_integer("episode_runs", episode_runs, low=1)
    paths = episode_paths() if paths is None else paths
    lengths = [float(np.hypot(*np.diff(p[:, :2], axis=0).T).sum()) for p in paths]
    rows = []
    for name, noise in DRIFT_PRESETS.items():
        row = {"preset": name, **dict(zip(("alpha1", "alpha2", "alpha3", "alpha4"),
                                          noise.alphas, strict=True))}
        for length in (10.0, 20.0, 40.0):
            row[f"drift_{length:g}m_pct"] = drift_percent(
                noise, runs=n, seed=seed, path=reference_path(length_m=length))
        row["drift_episode_pct"] = float(np.mean([
            drift_percent(noise, runs=m, seed=seed + k, path=p) for k, p in enumerate(paths)]))
        row["episode_path_m"] = float(np.mean(lengths))
        rows.append(row)
    return rows


def format_drift(rows: list[dict]) -> str:
    """The rows as a text table."""
    head = (f"{'preset':<8} {'alpha1':>9} {'alpha2':>9} {'alpha3':>9} {'alpha4':>9} "
            f"{'10 m %':>7} {'20 m %':>7} {'40 m %':>7} {'episode %':>9}")
    lines = [head]
    for r in rows:
        lines.append(f"{r['preset']:<8} {r['alpha1']:9.5f} {r['alpha2']:9.6f} "
                     f"{r['alpha3']:9.5f} {r['alpha4']:9.6f} {r['drift_10m_pct']:7.2f} "
                     f"{r['drift_20m_pct']:7.2f} {r['drift_40m_pct']:7.2f} "
                     f"{r['drift_episode_pct']:9.2f}")
    if rows:
        lines.append(f"(episode: own-only on forest map 1000, mean path "
                     f"{rows[0]['episode_path_m']:.1f} m)")
    return "\n".join(lines)
