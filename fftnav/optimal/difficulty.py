"""How hard a map is along each robot's reference path: the five measures of BARN, in metres.

Perille, Truong, Xiao and Stone, "Benchmarking Metric Ground Navigation", IEEE SSRR 2020
(arXiv:2008.13315), rate the difficulty of a map by five measures taken along a path through its
configuration space. Their definitions are the code of ``difficulty_quant.py`` in
github.com/dperille/jackal-map-creation (class ``DifficultyMetrics``, commit 295ca5c; line
numbers below refer to that file). Per robot, over the cells of its path:

- ``distance_to_closest_obstacle_m``: mean Euclidean distance from the path cell to the nearest
  occupied cell, centre to centre (``_dist_closest_wall``, lines 186-210, a best-first search
  whose first occupied cell is the nearest one: here the exact Euclidean distance transform,
  ``scipy.ndimage.distance_transform_edt``); the map edge is not an obstacle (BARN's search
  stays in the map). NaN when the grid has no occupied cell (BARN falls back to half the map
  height, a case its walled maps never reach).
- ``average_visibility_m``: mean over the 8 grid directions of the ray from the cell to the
  first occupied cell or the map edge, counted as BARN does: every free cell from the cell itself
  on adds its step (1 or sqrt 2 cells) (``_avg_vis_cell``, lines 151-179).
- ``dispersion``: the number of changes between "hits an occupied cell within the radius" and
  "does not" going round 16 rays (``_cell_dispersion``, lines 107-149; the radius is 3 cells at
  line 274). Rays that leave the map do not hit.
- ``characteristic_dimension_m``: the narrowest of the free chords through the cell along 4 axes
  (horizontal, vertical, both diagonals), each chord the free cells on both sides excluding the
  cell itself times the step (``characteristic_dimension`` and ``_distance``, lines 47-88).
- ``tortuosity``: the path's length over the straight distance between its first and last cell
  (``tortuosity``, lines 95-105). NaN when they are the same cell.

BARN averages the first four over the path's cells (``avg_all_metrics``, lines 223-259); so does
:func:`map_difficulty`. Adaptations, each for a stated reason:

- **Units**: cells times the grid's cell size, in metres (BARN reports cells of 0.15 m), so that
  a value does not depend on the grid's resolution beyond one cell.
- **Grid and path**: the SPL reference of :mod:`fftnav.optimal.reference`: the world's solids
  inflated by the robot's radius r0 (BARN inflates by 2 cells, 0.3 m, for a Jackal), at 0.05 m
  cells, and the shortest 8-connected path between the start and goal cells
  (:func:`reference_paths`, whose lengths are ``optimal_lengths``' ``astar_m``). BARN's path is
  an A* with at most 45-degree turns and a penalty near walls (``gen_world_ca.py``); the
  measures here describe the very path that SPL compares a robot with. Where several
  8-connected paths are equally short, scipy's Dijkstra picks one, deterministically.
- **Dispersion radius**: a length, :data:`DISPERSION_RADIUS_M` = 0.45 m = BARN's 3 cells of
  0.15 m, so the measure keeps BARN's metric scale on a finer grid. Every ray is that long and
  is blocked by any occupied cell its closed segment touches (the rule of the grid graph's
  moves); BARN steps 3 cells on the 8 grid directions but 2 knight moves (4.5 cells, looking at
  the landing cells only) on the other 8.
- **Dispersion ray order**: the 16 BARN directions are taken in angular order; BARN's list
  (line 114) visits the third quadrant backwards (180, 243, 225, 207, 270 degrees), which
  counts changes between rays that are not neighbours.
- Visibility and the characteristic dimension keep BARN's 8 grid directions and its counting,
  exactly (the tests compare with a transcription of BARN's loops).

Pure numpy and scipy, vectorised over all path cells of all robots: on a 20 m x 20 m benchmark
map with 15 robots, well under a second besides the path search (docs/analysis.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import ndimage

from fftnav.errors import FftnavError
from fftnav.optimal import gridsearch
from fftnav.optimal.gridgraph import GridPath, check_grid, grid_moves
from fftnav.optimal.reference import reference_resolution, robot_cells
from fftnav.validate import check_number
from fftnav.world import World
from fftnav.world.grid import OccupancyGrid, occupancy_grid

__all__ = [
    "AXES",
    "DISPERSION_DIRECTIONS",
    "DISPERSION_RADIUS_M",
    "MEASURES",
    "characteristic_dimension_cells",
    "clearance_cells",
    "dispersion_counts",
    "free_runs",
    "map_difficulty",
    "path_difficulty",
    "reference_paths",
    "visibility_cells",
]

#: The measures, in BARN's order (``avg_all_metrics``).
MEASURES: tuple[str, ...] = ("distance_to_closest_obstacle_m", "average_visibility_m",
                             "dispersion", "characteristic_dimension_m", "tortuosity")
#: Radius of the dispersion rays (m): BARN's 3 cells of 0.15 m.
DISPERSION_RADIUS_M = 0.45
#: BARN's 4 axes ``(drow, dcol)`` (line 14); with their opposites, the 8 visibility directions.
AXES: tuple[tuple[int, int], ...] = ((0, 1), (1, 1), (1, 0), (1, -1))
_DIRECTIONS = np.array(AXES + tuple((-a, -b) for a, b in AXES))
#: BARN's 16 dispersion directions ``(drow, dcol)`` (line 114), in angular order.
DISPERSION_DIRECTIONS: np.ndarray = np.array(
    sorted(grid_moves(16).tolist(), key=lambda rc: math.atan2(rc[0], rc[1]) % (2 * math.pi)))
#: Points per chunk of the dispersion rays (bounds the sample array's memory).
_CHUNK = 4096


def _check_cells(occupied: np.ndarray, cells: object) -> np.ndarray:
    """``cells`` as an (P, 2) int array of free cells inside the grid, else ValueError."""
    arr = np.asarray(cells)
    if arr.ndim != 2 or arr.shape[1] != 2 or not np.issubdtype(arr.dtype, np.integer):
        raise FftnavError(f"cells must be an integer (P, 2) array of (row, col), "
                          f"got cells with shape={arr.shape} dtype={arr.dtype}")
    rows, cols = occupied.shape
    inside = (arr[:, 0] >= 0) & (arr[:, 0] < rows) & (arr[:, 1] >= 0) & (arr[:, 1] < cols)
    bad = np.flatnonzero(~inside)
    if not bad.size:
        bad = np.flatnonzero(occupied[arr[:, 0], arr[:, 1]])
    if bad.size:
        raise FftnavError(f"cells must be free cells of the {rows}x{cols} grid, "
                          f"got cells[{bad[0]}]={arr[bad[0]].tolist()}")
    return arr


def clearance_cells(occupied: np.ndarray, cells: object) -> np.ndarray:
    """Euclidean distance (cells) from each cell's centre to the nearest occupied cell's centre.

    BARN's ``_dist_closest_wall``; the map edge is not an obstacle.

    Parameters
    ----------
    occupied : ndarray of bool, shape (H, W)
        True = occupied (the configuration space).
    cells : array_like of int, shape (P, 2)
        Free ``(row, col)`` cells.

    Returns
    -------
    ndarray of float, shape (P,)
        NaN for every cell if the grid has no occupied cell.

    >>> occ = np.zeros((3, 5), dtype=bool)
    >>> occ[0, 4] = True
    >>> clearance_cells(occ, [[2, 0], [2, 4]]).round(3).tolist()
    [4.472, 2.0]
    """
    occupied = check_grid(occupied)
    cells = _check_cells(occupied, cells)
    if not occupied.any():
        return np.full(len(cells), np.nan)
    return ndimage.distance_transform_edt(~occupied)[cells[:, 0], cells[:, 1]]


def free_runs(occupied: np.ndarray, cells: object, steps: object) -> np.ndarray:
    """Free cells met from each cell (itself included) stepping along each direction, up to the
    first occupied cell or the map edge.

    Parameters
    ----------
    occupied : ndarray of bool, shape (H, W)
    cells : array_like of int, shape (P, 2)
        Free ``(row, col)`` cells.
    steps : array_like of int, shape (D, 2)
        ``(drow, dcol)`` steps.

    Returns
    -------
    ndarray of int, shape (P, D)
        At least 1 (the cell itself).

    >>> occ = np.zeros((1, 6), dtype=bool)
    >>> occ[0, 4] = True
    >>> free_runs(occ, [[0, 1]], [[0, 1], [0, -1]]).tolist()
    [[3, 2]]
    """
    occupied = check_grid(occupied)
    cells = _check_cells(occupied, cells)
    steps = np.asarray(steps, dtype=np.int64).reshape(-1, 2)
    n, d = len(cells), len(steps)
    rows, cols = occupied.shape
    runs = np.zeros(n * d, dtype=np.int64)
    ray = np.arange(n * d)  # the rays still running: point p, direction k at p * d + k
    r, c = np.repeat(cells[:, 0], d), np.repeat(cells[:, 1], d)
    dr, dc = np.tile(steps[:, 0], n), np.tile(steps[:, 1], n)
    while ray.size:
        free = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        free[free] = ~occupied[r[free], c[free]]
        ray, r, c, dr, dc = ray[free], r[free], c[free], dr[free], dc[free]
        runs[ray] += 1
        r, c = r + dr, c + dc
    return runs.reshape(n, d)


def visibility_cells(occupied: np.ndarray, cells: object) -> np.ndarray:
    """BARN's average visibility (cells): the mean over the 8 grid directions of the free run
    from the cell (itself included), each free cell counting its step, 1 or sqrt 2.

    >>> occ = np.zeros((3, 3), dtype=bool)
    >>> float(visibility_cells(occ, [[1, 1]])[0]) == (4 * 2 + 4 * 2 * math.sqrt(2)) / 8
    True
    """
    return _visibility(free_runs(occupied, cells, _DIRECTIONS))


def characteristic_dimension_cells(occupied: np.ndarray, cells: object) -> np.ndarray:
    """BARN's characteristic dimension (cells): over the 4 axes, the narrowest free chord through
    the cell, i.e. the free cells on both sides (the cell itself excluded) times the step.

    >>> occ = np.zeros((4, 9), dtype=bool)
    >>> occ[[0, 3]] = True  # two free rows between walls
    >>> characteristic_dimension_cells(occ, [[1, 4]]).tolist()
    [1.0]
    """
    return _narrowest_chord(free_runs(occupied, cells, _DIRECTIONS))


def _visibility(runs: np.ndarray) -> np.ndarray:
    """Average visibility (cells) from the free runs (P, 8) along :data:`_DIRECTIONS`."""
    return (runs * np.hypot(*_DIRECTIONS.T)).mean(axis=1)


def _narrowest_chord(runs: np.ndarray) -> np.ndarray:
    """Characteristic dimension (cells) from the free runs (P, 8) along :data:`_DIRECTIONS`."""
    n = len(AXES)
    chords = (runs[:, :n] - 1 + runs[:, n:] - 1) * np.hypot(*_DIRECTIONS[:n].T)
    return chords.min(axis=1)


def _ray_cells(radius_cells: float) -> tuple[np.ndarray, np.ndarray]:
    """The cells that the 16 dispersion rays from a cell's centre touch, as offsets.

    A cell ``(a, b)`` (the unit square centred there) meets the closed segment from ``(0, 0)``
    to ``e`` iff their ranges overlap on both axes and ``2 |e_r b - e_c a| <= |e_r| + |e_c|``
    (separating axes, as :func:`fftnav.optimal.gridgraph.move_footprint`); the cell itself is
    left out, as in BARN.

    Returns
    -------
    offsets : ndarray of int, shape (M, 2)
        ``(drow, dcol)``, grouped by ray in the order of :data:`DISPERSION_DIRECTIONS`.
    first : ndarray of int, shape (16,)
        Index in ``offsets`` of each ray's first cell.
    """
    unit = DISPERSION_DIRECTIONS / np.hypot(*DISPERSION_DIRECTIONS.T)[:, None]
    k = math.ceil(radius_cells) + 1
    a, b = (x.ravel() for x in np.mgrid[-k: k + 1, -k: k + 1])
    groups = []
    for er, ec in unit * radius_cells:
        overlap = ((a - 0.5 <= max(0, er)) & (a + 0.5 >= min(0, er))
                   & (b - 0.5 <= max(0, ec)) & (b + 0.5 >= min(0, ec)))
        touch = 2 * np.abs(er * b - ec * a) <= abs(er) + abs(ec) + 1e-9
        keep = overlap & touch & ((a != 0) | (b != 0))
        groups.append(np.c_[a[keep], b[keep]])
    first = np.r_[0, np.cumsum([len(g) for g in groups])[:-1]]
    return np.concatenate(groups), first


def dispersion_counts(occupied: np.ndarray, cells: object, radius_cells: float) -> np.ndarray:
    """BARN's dispersion: changes between blocked and clear rays going round the 16
    :data:`DISPERSION_DIRECTIONS`.

    A ray of length ``radius_cells`` from the cell's centre is blocked if a cell it touches (the
    closed segment, as the grid graph's moves) is occupied; cells off the map are clear.

    Returns
    -------
    ndarray of int, shape (P,)
        An even number from 0 to 16.

    >>> occ = np.zeros((9, 9), dtype=bool)
    >>> occ[7:, :] = True  # a wall 3 cells above the centre cell
    >>> dispersion_counts(occ, [[4, 4]], 3.5).tolist()
    [2]
    """
    occupied = check_grid(occupied)
    cells = _check_cells(occupied, cells)
    check_number("radius_cells", radius_cells, low=0, low_open=True)
    offsets, first = _ray_cells(radius_cells)
    rows, cols = occupied.shape
    counts = np.empty(len(cells), dtype=np.int64)
    for lo in range(0, len(cells), _CHUNK):
        r = cells[lo: lo + _CHUNK, 0, None] + offsets[:, 0]  # (P, M)
        c = cells[lo: lo + _CHUNK, 1, None] + offsets[:, 1]
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        hit = np.zeros(r.shape, dtype=bool)
        hit[inside] = occupied[r[inside], c[inside]]
        blocked = np.logical_or.reduceat(hit, first, axis=1)  # (P, 16)
        counts[lo: lo + _CHUNK] = (blocked != np.roll(blocked, -1, axis=1)).sum(axis=1)
    return counts


def path_difficulty(grid: OccupancyGrid, paths: Sequence[GridPath], *,
                    dispersion_radius_m: float = DISPERSION_RADIUS_M) -> dict[str, np.ndarray]:
    """The :data:`MEASURES` of each path on a grid, in metres where the name says ``_m``.

    Parameters
    ----------
    grid : OccupancyGrid
        The configuration space (inflated by the robot's radius).
    paths : sequence of GridPath
        Free cells from start to goal, consecutive cells 8-neighbours as BARN's paths.
    dispersion_radius_m : float, optional
        Length of the dispersion rays (m), :data:`DISPERSION_RADIUS_M` by default.

    Returns
    -------
    dict of str to ndarray of float, shape (N,)
        One array per measure of :data:`MEASURES`, one value per path: the first four are means
        over the path's cells, the fifth is the path's tortuosity.
    """
    check_number("dispersion_radius_m", dispersion_radius_m, low=0, low_open=True)
    if not paths:
        return {name: np.empty(0) for name in MEASURES}
    cells = np.concatenate([p.cells for p in paths]).astype(np.int64)
    sizes = np.array([len(p.cells) for p in paths])
    first = np.r_[0, np.cumsum(sizes)[:-1]]
    res = grid.resolution_m
    runs = free_runs(grid.grid, cells, _DIRECTIONS)

    def mean(per_cell: np.ndarray) -> np.ndarray:
        return np.add.reduceat(per_cell.astype(float), first) / sizes

    chords = np.array([np.hypot(*(p.cells[-1] - p.cells[0])) for p in paths], dtype=float)
    lengths = np.array([p.length_cells for p in paths], dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        tortuosity = np.where(chords > 0, lengths / chords, np.nan)
    return {
        "distance_to_closest_obstacle_m": mean(clearance_cells(grid.grid, cells)) * res,
        "average_visibility_m": mean(_visibility(runs)) * res,
        "dispersion": mean(dispersion_counts(grid.grid, cells, dispersion_radius_m / res)),
        "characteristic_dimension_m": mean(_narrowest_chord(runs)) * res,
        "tortuosity": tortuosity,
    }


def reference_paths(world: World, *, r0_m: float,
                    resolution_m: float = 0.05) -> tuple[OccupancyGrid, list[GridPath]]:
    """The configuration space and every robot's SPL reference path.

    The grid of :func:`fftnav.optimal.reference.optimal_lengths` (solids inflated by ``r0_m``,
    cells of :func:`~fftnav.optimal.reference.reference_resolution`) and, per robot, a shortest
    8-connected path between its start and goal cells (A*,
    :func:`fftnav.optimal.gridsearch.astar_paths`: compiled with numba, the same search and
    the same paths in plain Python without it): its ``length_cells`` times the cell size is
    ``optimal_lengths``' ``astar_m`` (to 1e-12 relative).

    Raises
    ------
    ValueError
        If a start or goal lies in an inflated obstacle cell, or
        :class:`~fftnav.optimal.gridgraph.UnreachableGoalError` if a goal cannot be reached.
    """
    check_number("r0_m", r0_m, low=0)
    grid = occupancy_grid(world, resolution_m=reference_resolution(world, resolution_m),
                          inflate_m=r0_m)
    starts, goals = robot_cells(grid, world)
    return grid, gridsearch.astar_paths(grid.grid, starts, goals, connectivity=8)


def map_difficulty(world: World, *, r0_m: float, resolution_m: float = 0.05,
                   dispersion_radius_m: float = DISPERSION_RADIUS_M) -> dict[str, np.ndarray]:
    """BARN's difficulty measures of every robot of a world, along its reference path.

    Parameters
    ----------
    world : World
        Obstacles, boundary, ``starts`` (N, 3) and ``goals`` (N, 2), metres.
    r0_m : float
        The robot's radius r0 (m): the inflation of the configuration space.
    resolution_m : float, optional
        Cell size (m) of the reference grid (:func:`reference_paths`).
    dispersion_radius_m : float, optional
        Length of the dispersion rays (m).

    Returns
    -------
    dict of str to ndarray of float, shape (N,)
        :data:`MEASURES` to one value per robot (see the module docstring).

    Raises
    ------
    ValueError
        As :func:`reference_paths`, or for a bad parameter.

    Examples
    --------
    >>> from fftnav.world import World
    >>> field = World("field", 0, (4.0, 3.0), (), np.array([[0.55, 1.55, 0.0]]),
    ...               np.array([[3.45, 1.55]]), "walls")
    >>> m = map_difficulty(field, r0_m=0.12, resolution_m=0.1)
    >>> round(float(m["tortuosity"][0]), 6)  # a straight path
    1.0
    >>> round(float(m["distance_to_closest_obstacle_m"][0]), 6)  # mean of min(c, 39 - c, 14) cells
    1.1
    """
    check_number("dispersion_radius_m", dispersion_radius_m, low=0, low_open=True)
    grid, paths = reference_paths(world, r0_m=r0_m, resolution_m=resolution_m)
    return path_difficulty(grid, paths, dispersion_radius_m=dispersion_radius_m)
