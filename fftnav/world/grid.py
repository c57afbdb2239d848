"""Occupancy grids of worlds, reachability, and ROS ``map_server`` export.

Axis order: ``grid[row, col]`` with ``row`` the y index counted **from the bottom** (row 0 holds
``origin_y <= y < origin_y + resolution``) and ``col`` the x index, so ``grid[i, j]`` is the cell
whose centre is ``origin + ((j + 0.5) res, (i + 0.5) res)``. ``True`` means occupied: the cell
centre lies inside an obstacle or within ``inflate_m`` of one. numpy + scipy only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from fftnav.files import write_atomic
from fftnav.limits import MAX_GRID_CELLS, check_limit, grid_cells
from fftnav.validate import check_number
from fftnav.world.model import World

__all__ = ["OccupancyGrid", "occupancy_grid", "unreachable_robots", "write_ros_map"]


@dataclass(frozen=True)
class OccupancyGrid:
    """Boolean occupancy grid ``(rows, cols)`` (row = y index from the bottom, col = x index),
    cell size ``resolution_m`` (m) and world position ``origin_m`` (x, y) of the lower-left
    corner of cell ``[0, 0]``."""

    grid: np.ndarray
    resolution_m: float
    origin_m: tuple[float, float]

    def world_to_cell(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, cols)`` integer indices of the cells containing the points ``(P, 2)`` (m).

        Indices are not clipped: points outside the grid give indices outside ``grid.shape``.
        """
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        ij = np.floor((pts - self.origin_m) / self.resolution_m).astype(int)
        return ij[:, 1], ij[:, 0]

    def cell_to_world(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """World coordinates ``(P, 2)`` (m) of the centres of cells ``(rows, cols)``."""
        rc = np.c_[np.ravel(cols), np.ravel(rows)].astype(float)
        return np.asarray(self.origin_m) + (rc + 0.5) * self.resolution_m


def occupancy_grid(world: World, *, resolution_m: float = 0.05,
                   inflate_m: float = 0.0) -> OccupancyGrid:
    """Rasterise a world's solids (obstacles and boundary walls, :attr:`World.solids`; exact
    distance of each cell centre, no approximation).

    Parameters
    ----------
    world : World
        The world; the grid covers ``[0, w] x [0, h]`` with origin (0, 0).
    resolution_m : float, optional
        Cell size in metres (the paper's A* uses 0.05 m).
    inflate_m : float, optional
        Cells whose centre is within this distance (m) of an obstacle are occupied too, e.g.
        the robot radius r0 for configuration-space planning.

    Returns
    -------
    OccupancyGrid
        ``ceil(h / res)`` rows by ``ceil(w / res)`` columns.
    """
    w, h = world.size_m
    check_number("resolution_m", resolution_m, low=0, low_open=True, high=min(w, h))
    check_number("inflate_m", inflate_m, low=0, high=max(w, h))
    check_limit("grid cells (world size / resolution_m)", grid_cells(w, h, resolution_m),
                MAX_GRID_CELLS, hint="raise resolution_m")
    shape = (math.ceil(h / resolution_m - 1e-9), math.ceil(w / resolution_m - 1e-9))
    grid = np.zeros(shape, dtype=bool)
    for obstacle in world.solids:
        lo, hi = obstacle.bounds()
        c0, r0 = np.maximum(np.floor((lo - inflate_m) / resolution_m).astype(int), 0)
        c1, r1 = np.minimum(np.ceil((hi + inflate_m) / resolution_m).astype(int) + 1,
                            [shape[1], shape[0]])
        if r1 <= r0 or c1 <= c0:
            continue
        rows, cols = np.mgrid[r0:r1, c0:c1]
        centres = (np.c_[cols.ravel(), rows.ravel()] + 0.5) * resolution_m
        near = obstacle.distance(centres) <= inflate_m  # 0 inside the obstacle
        grid[r0:r1, c0:c1] |= near.reshape(rows.shape)
    return OccupancyGrid(grid, float(resolution_m), (0.0, 0.0))


def unreachable_robots(world: World, *, radius_m: float, resolution_m: float = 0.05) -> list[int]:
    """Indices of robots whose goal is not reachable from their start by a disc of ``radius_m``.

    Reachable means start and goal cells lie in the same 4-connected component of the free
    cells of the grid inflated by ``radius_m`` (``scipy.ndimage.label``); a start or goal in
    an occupied cell is unreachable.
    """
    og = occupancy_grid(world, resolution_m=resolution_m, inflate_m=radius_m)
    labels, _ = ndimage.label(~og.grid)
    top = np.array(og.grid.shape) - 1  # points on the far world edges belong to the last cells
    rows, cols = og.world_to_cell(world.starts[:, :2])
    start_lab = labels[np.minimum(rows, top[0]), np.minimum(cols, top[1])]
    rows, cols = og.world_to_cell(world.goals)
    goal_lab = labels[np.minimum(rows, top[0]), np.minimum(cols, top[1])]
    return np.flatnonzero((start_lab == 0) | (start_lab != goal_lab)).tolist()


def write_ros_map(grid: OccupancyGrid, prefix: str | Path) -> tuple[Path, Path]:
    """Write a ROS ``map_server`` pair ``PREFIX.yaml`` + ``PREFIX.pgm``; return their paths.

    The PGM (binary P5) has the top row of the map first (ROS image convention), occupied
    cells 0 (black) and free cells 254; the YAML gives ``resolution``, ``origin`` (the lower-left
    pixel's pose ``[x, y, yaw]``), ``negate: 0``, ``occupied_thresh: 0.65``,
    ``free_thresh: 0.196``.
    """
    prefix = Path(prefix)
    pgm, yaml = prefix.with_name(prefix.name + ".pgm"), prefix.with_name(prefix.name + ".yaml")
    rows, cols = grid.grid.shape
    pixels = np.where(np.flipud(grid.grid), 0, 254).astype(np.uint8)
    write_atomic(pgm, f"P5\n{cols} {rows}\n255\n".encode() + pixels.tobytes())
    ox, oy = grid.origin_m
    write_atomic(
        yaml,
        f"image: {pgm.name}\nresolution: {grid.resolution_m}\norigin: [{ox}, {oy}, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return yaml, pgm
