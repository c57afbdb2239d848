"""Per-robot optimal path lengths of a world: the l_i of SPL (Anderson et al. 2018).

The paper (Sec. IV) takes l_i from grid A* at 0.05 m. The map is inflated by the robot's
safety radius r0 (configuration space of a disc robot), start and goal positions are mapped to
their grid cells, and two lengths are returned per robot: the 8-connected length (the paper's
A* reference, exact) and the near-Euclidean 32-connected geodesic length, which does not carry
the up-to-8 % excess of 8-connected paths; both by
:func:`fftnav.optimal.geodesic.geodesic_lengths` (the compiled A* of
:mod:`fftnav.optimal.gridsearch` when numba is installed, else scipy's Dijkstra).
"""

from __future__ import annotations

import math

import numpy as np

from fftnav.errors import FftnavError
from fftnav.limits import MAX_REFERENCE_CELLS, grid_cells
from fftnav.optimal.geodesic import geodesic_lengths
from fftnav.validate import check_number
from fftnav.world import World
from fftnav.world.grid import OccupancyGrid, occupancy_grid

__all__ = ["optimal_lengths", "reference_resolution", "robot_cells"]


def robot_cells(grid: OccupancyGrid, world: World) -> tuple[np.ndarray, np.ndarray]:
    """Grid cells ``(row, col)`` of the robots' start and goal positions.

    Points on the far world edges (x = w or y = h) belong to the last row/column.

    Parameters
    ----------
    grid : OccupancyGrid
        The world's (inflated) occupancy grid.
    world : World
        ``starts`` (N, 3) and ``goals`` (N, 2), metres.

    Returns
    -------
    starts, goals : ndarray of int, shape (N, 2)

    Raises
    ------
    ValueError
        If a start or goal cell is occupied, naming the robot and its position.
    """
    last = np.array(grid.grid.shape) - 1

    def cells(points: np.ndarray, name: str) -> np.ndarray:
        rc = np.minimum(np.c_[grid.world_to_cell(points)], last)
        blocked = np.flatnonzero(grid.grid[rc[:, 0], rc[:, 1]])
        if blocked.size:
            i = blocked[0]
            raise FftnavError(
                f"{name} of robot {i} at {points[i].tolist()} m lies in an occupied cell of the "
                "inflated grid (too close to an obstacle)"
            )
        return rc

    return cells(world.starts[:, :2], "start"), cells(world.goals, "goal")


def reference_resolution(world: World, resolution_m: float = 0.05) -> float:
    """Cell size (m) of the reference grid: ``resolution_m`` while the grid has at most
    :data:`fftnav.limits.MAX_REFERENCE_CELLS` cells, else the smallest multiple of 1 cm that
    keeps it within (a 60 m x 60 m map keeps 0.05 m; 224 m x 224 m gets 0.19 m).

    >>> from fftnav.world import World
    >>> big = World("forest", 0, (224.0, 224.0), (), np.zeros((1, 3)), np.zeros((1, 2)))
    >>> reference_resolution(big), reference_resolution(big, 0.5)
    (0.19, 0.5)
    """
    w, h = world.size_m
    if grid_cells(w, h, resolution_m) <= MAX_REFERENCE_CELLS:
        return resolution_m
    cm = math.ceil(100 * math.sqrt(w * h / MAX_REFERENCE_CELLS))
    while grid_cells(w, h, cm / 100) > MAX_REFERENCE_CELLS:
        cm += 1
    return cm / 100


def optimal_lengths(
    world: World, *, r0_m: float, resolution_m: float = 0.05
) -> tuple[np.ndarray, np.ndarray]:
    """Shortest start-to-goal lengths of every robot of a world, in metres.

    Parameters
    ----------
    world : World
        Obstacles, ``starts`` (N, 3) as (x, y, yaw) and ``goals`` (N, 2), metres.
    r0_m : float
        Inflation radius (m): the robot's safety radius r0 (Sec. III-A; 0.15 m in simulation).
    resolution_m : float, optional
        Grid cell size (m); the paper's 0.05 m by default, coarser for maps larger than
        :data:`fftnav.limits.MAX_REFERENCE_CELLS` cells (:func:`reference_resolution`), so that
        the search graph stays within memory.

    Returns
    -------
    astar_m : ndarray of float, shape (N,)
        8-connected grid A* length (the paper's reference), m.
    geodesic_m : ndarray of float, shape (N,)
        32-connected geodesic length (<= 1.3 % over Euclidean in free space), m.

    Raises
    ------
    ValueError
        If a start or goal lies in an inflated obstacle cell (naming the robot), or
        :class:`~fftnav.optimal.gridgraph.UnreachableGoalError` if a goal cannot be reached.
    """
    check_number("r0_m", r0_m, low=0)
    og = occupancy_grid(world, resolution_m=reference_resolution(world, resolution_m),
                        inflate_m=r0_m)
    starts, goals = robot_cells(og, world)
    astar_m = geodesic_lengths(og.grid, starts, goals, connectivity=8) * og.resolution_m
    geodesic_m = geodesic_lengths(og.grid, starts, goals, connectivity=32) * og.resolution_m
    return astar_m, geodesic_m
