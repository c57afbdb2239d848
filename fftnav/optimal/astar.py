"""Grid A* (Hart, Nilsson & Raphael 1968): the paper's optimal-path reference (Sec. IV).

The paper takes l_i in SPL (Anderson et al. 2018) from "the A* algorithm with a resolution of
0.05 m". :func:`astar` is that search, written to be read (a ``heapq`` open list, the octile
heuristic for 8-connected moves, PythonRobotics style). It serves as the reference the tests
hold the fast batched solver :func:`fftnav.optimal.gridgraph.shortest_paths` to; episodes use
the latter (:func:`fftnav.optimal.reference.optimal_lengths`).
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from fftnav.optimal.gridgraph import (
    GridPath,
    UnreachableGoalError,
    check_cell,
    check_grid,
    move_table,
)
from fftnav.validate import check_number

__all__ = ["GridPath", "UnreachableGoalError", "astar", "octile", "path_length_m"]


def octile(a: tuple[int, int], b: tuple[int, int]) -> float:
    """Length (cells) of the shortest 8-connected path between cells ``a`` and ``b`` with
    nothing in the way: ``max(di, dj) + (sqrt(2) - 1) min(di, dj)``.

    >>> octile((0, 0), (3, 1)) == 2 + 2 ** 0.5
    True
    """
    di, dj = abs(int(a[0]) - int(b[0])), abs(int(a[1]) - int(b[1]))
    return max(di, dj) + (math.sqrt(2.0) - 1.0) * min(di, dj)


def _euclidean(a: tuple[int, int], b: tuple[int, int]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


def astar(
    occupied: np.ndarray,
    start_cell: tuple[int, int],
    goal_cell: tuple[int, int],
    *,
    connectivity: int = 8,
) -> GridPath:
    """Shortest collision-free grid path from ``start_cell`` to ``goal_cell`` by A*.

    Parameters
    ----------
    occupied : ndarray of bool, shape (H, W)
        True = occupied (the map already inflated by the robot radius r0).
    start_cell, goal_cell : (int, int)
        ``(row, col)`` of free cells.
    connectivity : int, optional
        8 (default; octile heuristic, exact in free space), 16 or 32 (Euclidean heuristic).
        Moves and the corner-cutting rule are those of :mod:`fftnav.optimal.gridgraph`.

    Returns
    -------
    GridPath
        Cells from start to goal and the length in cells.

    Raises
    ------
    UnreachableGoalError
        If no path exists (a ``ValueError`` naming both cells).
    """
    occupied = check_grid(occupied)
    moves = move_table(connectivity)  # validates connectivity
    start = check_cell(occupied, start_cell, "start_cell")
    goal = check_cell(occupied, goal_cell, "goal_cell")
    heuristic = octile if connectivity == 8 else _euclidean
    rows, cols = occupied.shape

    def passable(cell: tuple[int, int], footprint: np.ndarray) -> bool:
        for a, b in footprint:
            r, c = cell[0] + a, cell[1] + b
            if not (0 <= r < rows and 0 <= c < cols) or occupied[r, c]:
                return False
        return True

    cost_so_far = {start: 0.0}
    came_from: dict[tuple[int, int], tuple[int, int]] = {}
    open_list = [(heuristic(start, goal), 0.0, start)]
    while open_list:
        _, cost, cell = heapq.heappop(open_list)
        if cell == goal:
            path = [goal]
            while path[-1] != start:
                path.append(came_from[path[-1]])
            return GridPath(np.array(path[::-1]), cost)
        if cost > cost_so_far[cell]:
            continue  # stale entry: a cheaper one was already expanded
        for move in moves:
            nxt = (cell[0] + move.step[0], cell[1] + move.step[1])
            new_cost = cost + move.cost
            if new_cost < cost_so_far.get(nxt, math.inf) and passable(cell, move.footprint):
                cost_so_far[nxt] = new_cost
                came_from[nxt] = cell
                heapq.heappush(open_list, (new_cost + heuristic(nxt, goal), new_cost, nxt))
    raise UnreachableGoalError(start, goal)


def path_length_m(path: GridPath, resolution_m: float) -> float:
    """Length of a grid path in metres: ``length_cells * resolution_m``.

    Parameters
    ----------
    path : GridPath
    resolution_m : float
        Cell size in metres (> 0; the paper uses 0.05 m).
    """
    check_number("resolution_m", resolution_m, low=0, low_open=True)
    return path.length_cells * resolution_m
