"""Fig. 4 of the paper (spherical depth image and safe domain) and the 3D flight figure."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.patches import Circle, Rectangle

from fftnav.episode.flight3d import FlightResult
from fftnav.observe.spherical import DiscFilterBank, SphericalGrid
from fftnav.report import new_figure, save_figure
from fftnav.sim.drone import DroneSim, make_forest3d

__all__ = ["draw_depth3d_figure", "draw_flight_figure"]


def _extent_deg(grid: SphericalGrid) -> tuple[float, float, float, float]:
    """``imshow`` extent (left, right, bottom, top) in degrees: the outer pixel *edges*, half a
    step beyond the first and last pixel centres, so every pixel is drawn centred on its angle."""
    az, el = np.degrees(grid.azimuths_rad()), np.degrees(grid.elevations_rad())
    da, de = math.degrees(grid.az_step_rad) / 2, math.degrees(grid.el_step_rad) / 2
    return (az[0] - da, az[-1] + da, el[-1] - de, el[0] + de)


def draw_depth3d_figure(out_dir: Path, *, seed: int = 0) -> list[Path]:
    """Draw Fig. 4: (a) depth image in metres, (b) safe flight domain, from the PyBullet forest.

    The paper's drone (l_th = 2.82 m, alpha = 26.7 deg) hovers at the start of the seeded 3D forest
    (:func:`fftnav.sim.drone.make_forest3d`) looking along +x (towards the goal); a 90 x 360
    spherical image over 90 x 360 degrees, R = 10 m, is filtered by the 2D disc filter.

    Parameters
    ----------
    out_dir : pathlib.Path
        Output folder (created if missing).
    seed : int, optional
        Seed of the forest (default 0).

    Returns
    -------
    list of pathlib.Path
        ``fig4_depth.png`` and ``fig4_safe.png`` in ``out_dir``.
    """
    grid = SphericalGrid(90, 360)
    bank = DiscFilterBank(grid)
    forest = make_forest3d(np.random.default_rng(seed))
    with DroneSim(forest, grid=grid) as sim:
        depth = sim.scan(forest.start, 0.0)
    mask = bank.safe_mask(depth)
    best = bank.nearest_direction(mask, 0.0, 0.0)
    extent = _extent_deg(grid)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, title in (("depth", "(a) depth observation of the forest"),
                        ("safe", f"(b) safe direction domain ({mask.mean():.0%} of the image)")):
        fig = new_figure(figsize=(10, 3.2), layout="constrained")
        ax = fig.subplots()
        if name == "depth":
            im = ax.imshow(depth, extent=extent, cmap="viridis", vmin=0, vmax=bank.range_m,
                           aspect="equal")
            fig.colorbar(im, ax=ax, label="depth (m)", fraction=0.025)
        else:
            ax.imshow(depth, extent=extent, cmap="gray", vmin=0, vmax=bank.range_m, alpha=0.5)
            ax.imshow(np.where(mask, 1.0, np.nan), extent=extent, cmap="autumn", vmin=0, vmax=1,
                      alpha=0.8)
            ax.plot(0, 0, "k+", ms=12, label="goal direction")
            if best is not None:
                ax.plot(math.degrees(best[1]), math.degrees(best[0]), "bo", mfc="none", ms=10,
                        label="nearest safe direction")
            ax.legend(loc="lower right", fontsize=8)
        ax.set(xlabel="azimuth (deg, CCW from heading)", ylabel="elevation (deg)",
               title=title, xticks=np.arange(-180, 181, 45), yticks=[-45, 0, 45])
        path = out_dir / f"fig4_{name}.png"
        save_figure(fig, path, dpi=120)
        paths.append(path)
    return paths


def draw_flight_figure(result: FlightResult, path: Path) -> Path:
    """Draw one flight: top view (x, y) and side view (x, z) with the forest.

    Parameters
    ----------
    result : FlightResult
        A flight from :func:`fftnav.episode.flight3d.fly` (trajectory and forest in metres).
    path : pathlib.Path
        Output PNG.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    f, traj = result.forest, result.trajectory
    # side view: only trees whose canopy comes within 1 m (horizontally) of the flown path
    gap = np.min(np.hypot(f.canopies[:, None, 0] - traj[None, :, 0],
                          f.canopies[:, None, 1] - traj[None, :, 1]), axis=1) - f.canopies[:, 3]
    near = gap < 1.0
    fig = new_figure(figsize=(10, 7.5), layout="constrained")
    top, side = fig.subplots(2, 1, height_ratios=[20, 8])
    for (x, y, z, rc), (_, _, rt, h), shown in zip(f.canopies, f.trunks, near, strict=True):
        top.add_patch(Circle((x, y), rc, color="forestgreen", alpha=0.25, lw=0))
        top.add_patch(Circle((x, y), rt, color="saddlebrown"))
        if shown:
            side.add_patch(Circle((x, z), rc, color="forestgreen", alpha=0.2, lw=0))
            side.add_patch(Rectangle((x - rt, 0), 2 * rt, h, color="saddlebrown", alpha=0.5, lw=0))
    outcome = "arrived" if result.arrived else ("collided" if result.collided else "timed out")
    for ax, k, label in ((top, 1, "y (m)"), (side, 2, "z (m)")):
        ax.plot(traj[:, 0], traj[:, k], "r-", lw=1.8, label=f"flight ({outcome})")
        ax.plot([f.start[0], f.goal[0]], [f.start[k], f.goal[k]], "k:", lw=1, label="straight line")
        ax.plot(*f.start[[0, k]], "bs", label="start")
        ax.plot(*f.goal[[0, k]], "g*", ms=14, label="goal")
        ax.set(xlabel="x (m)", ylabel=label, aspect="equal")
    top.set(xlim=(-5, f.goal[0] + 5), ylim=(-10, 10),
            title=f"3D forest seed {result.seed}: path {result.path_length_m:.1f} m, "
                  f"{result.ratio:.2f} x straight line, {result.time_s:.1f} s (top view)")
    side.set(xlim=(-5, f.goal[0] + 5), ylim=(0, 8),
             title="side view (trees within 1 m of the path)")
    top.legend(loc="upper right", fontsize=8)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=110)
    return path
