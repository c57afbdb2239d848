"""Shortest paths on an occupancy grid: move sets, the grid graph and batched Dijkstra.

A grid cell is ``(row, col)`` into a boolean array ``occupied`` (True = blocked, e.g. the
occupancy grid inflated by the robot radius r0). Cells are nodes; a *move* ``(di, dj)`` joins
two cell centres by a straight segment of length ``hypot(di, dj)`` cells, allowed only when
every cell the closed segment touches is free (its *footprint*). For the 8-connected moves this
is the usual "no corner cutting" rule: a diagonal step needs both orthogonal neighbours free.

``connectivity`` 8, 16 and 32 are the primitive moves with ``max(|di|, |dj|) <= 1, 2, 3``.
Their free-space lengths exceed the Euclidean distance by at most 8.2 %, 2.7 % and 1.3 %
(:func:`max_excess`).

:func:`shortest_paths` is the fast exact solver (``scipy.sparse.csgraph.dijkstra``, compiled,
one run per distinct start); :func:`fftnav.optimal.astar.astar` is the readable reference
that the tests compare it with.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import gcd
from typing import NamedTuple

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from fftnav.errors import FftnavError
from fftnav.validate import check_choice

__all__ = [
    "CONNECTIVITIES",
    "GridPath",
    "UnreachableGoalError",
    "Move",
    "grid_moves",
    "move_table",
    "move_footprint",
    "max_excess",
    "check_grid",
    "check_cell",
    "check_pairs",
    "grid_graph",
    "shortest_paths",
]

#: Supported connectivities -> largest move component.
CONNECTIVITIES: dict[int, int] = {8: 1, 16: 2, 32: 3}


class UnreachableGoalError(FftnavError):
    """No collision-free grid path joins the start cell to the goal cell."""

    def __init__(self, start: tuple[int, int], goal: tuple[int, int]) -> None:
        super().__init__(f"goal cell {goal} is unreachable from start cell {start}")
        self.start = start
        self.goal = goal

    def __reduce__(self) -> tuple:
        # made again from its cells when pickled (e.g. raised in a worker process)
        return type(self), (self.start, self.goal)


@dataclass(frozen=True)
class GridPath:
    """A grid path: the visited cells and its length.

    Attributes
    ----------
    cells : ndarray of int, shape (n, 2)
        ``(row, col)`` of each visited cell, start first, goal last.
    length_cells : float
        Sum of the Euclidean lengths of the moves, in cells (multiply by the resolution for
        metres, see :func:`fftnav.optimal.astar.path_length_m`).
    """

    cells: np.ndarray
    length_cells: float


class Move(NamedTuple):
    """One move: its step ``(di, dj)``, footprint offsets (F, 2) and length in cells."""

    step: tuple[int, int]
    footprint: np.ndarray
    cost: float


def grid_moves(connectivity: int) -> np.ndarray:
    """Primitive moves ``(di, dj)`` with ``max(|di|, |dj|) <= k`` (k = 1, 2, 3 for 8, 16, 32).

    Parameters
    ----------
    connectivity : int
        8, 16 or 32.

    Returns
    -------
    ndarray of int, shape (connectivity, 2)
    """
    check_choice("connectivity", connectivity, CONNECTIVITIES)
    k = CONNECTIVITIES[connectivity]
    return np.array(
        [
            (di, dj)
            for di in range(-k, k + 1)
            for dj in range(-k, k + 1)
            if gcd(di, dj) == 1
        ]
    )


def move_footprint(di: int, dj: int) -> np.ndarray:
    """Cells touched by the closed segment from cell centre (0, 0) to (di, dj).

    A unit cell centred at ``(a, b)`` meets the segment iff their ranges overlap on both axes
    and, on the segment's normal ``(-dj, di)``, ``2 |di b - dj a| <= |di| + |dj|``
    (separating-axis test; exact in integers, so touching a corner counts).

    Returns
    -------
    ndarray of int, shape (F, 2)
        Offsets ``(a, b)`` including ``(0, 0)`` and ``(di, dj)``.
    """
    return np.array(
        [
            (a, b)
            for a in range(min(0, di), max(0, di) + 1)
            for b in range(min(0, dj), max(0, dj) + 1)
            if 2 * abs(di * b - dj * a) <= abs(di) + abs(dj)
        ]
    )


def move_table(connectivity: int) -> list[Move]:
    """The moves of a connectivity with their footprints and lengths."""
    return [
        Move((int(di), int(dj)), move_footprint(di, dj), float(np.hypot(di, dj)))
        for di, dj in grid_moves(connectivity)
    ]


def max_excess(connectivity: int) -> float:
    """Largest relative excess of the free-space move-path length over the Euclidean distance.

    Between two angularly adjacent moves u, v the cheapest move-path to ``t = a u + b v`` costs
    ``c . t`` with ``c . u = |u|``, ``c . v = |v|``; its ratio to ``|t|`` peaks at ``|c|``.

    Returns
    -------
    float
        ``max |c| - 1``: 0.0824 (8), 0.0275 (16), 0.0131 (32).
    """
    moves = grid_moves(connectivity).astype(float)
    moves = moves[np.argsort(np.arctan2(moves[:, 0], moves[:, 1]))]
    worst = 0.0
    for u, v in zip(moves, np.roll(moves, -1, axis=0), strict=True):
        c = np.linalg.solve(np.stack([u, v]), [np.hypot(*u), np.hypot(*v)])
        worst = max(worst, float(np.hypot(*c)))
    return worst - 1.0


def check_grid(occupied: np.ndarray) -> np.ndarray:
    """Validate an occupancy grid: a 2-D boolean array, True = occupied. Returns it."""
    occupied = np.asarray(occupied)
    if occupied.ndim != 2 or occupied.dtype != bool or 0 in occupied.shape:
        raise FftnavError(
            "occupied must be a non-empty 2-D boolean array, "
            f"got occupied with shape={occupied.shape} dtype={occupied.dtype}"
        )
    return occupied


def check_cell(occupied: np.ndarray, cell: object, name: str) -> tuple[int, int]:
    """Validate a ``(row, col)`` cell: integer, inside the grid and free. Returns it as a tuple."""
    arr = np.asarray(cell)
    if arr.shape != (2,) or not np.issubdtype(arr.dtype, np.integer):
        raise FftnavError(f"{name} must be an integer (row, col) pair, got {name}={cell!r}")
    rc = (int(arr[0]), int(arr[1]))
    rows, cols = occupied.shape
    if not (0 <= rc[0] < rows and 0 <= rc[1] < cols):
        raise FftnavError(f"{name} must lie inside the {rows}x{cols} grid, got {name}={rc}")
    if occupied[rc]:
        raise FftnavError(f"{name} must be a free cell, got occupied {name}={rc}")
    return rc


def check_pairs(occupied: np.ndarray, starts: object,
                goals: object) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Validate start/goal cells ``(N, 2)`` of one grid: the pairs as ``((r, c), (r, c))``."""
    starts_arr, goals_arr = np.asarray(starts), np.asarray(goals)
    if starts_arr.ndim != 2 or starts_arr.shape != goals_arr.shape:
        raise FftnavError(
            "starts and goals must be (N, 2) arrays of the same shape, "
            f"got starts.shape={starts_arr.shape}, goals.shape={goals_arr.shape}"
        )
    return [
        (check_cell(occupied, s, "start_cell"), check_cell(occupied, g, "goal_cell"))
        for s, g in zip(starts_arr, goals_arr, strict=True)
    ]


def _allowed(occupied: np.ndarray, move: Move) -> np.ndarray:
    """(H, W) mask: the move from each cell stays on the grid and its footprint is free."""
    rows, cols = occupied.shape
    pad = max(CONNECTIVITIES.values())
    free = np.pad(~occupied, pad, constant_values=False)
    ok = np.ones_like(occupied)
    for a, b in move.footprint:
        ok &= free[pad + a : pad + a + rows, pad + b : pad + b + cols]
    return ok


def grid_graph(occupied: np.ndarray, *, connectivity: int = 8) -> csr_matrix:
    """Directed weighted graph of the allowed moves, nodes ``row * W + col``, weights in cells.

    Parameters
    ----------
    occupied : ndarray of bool, shape (H, W)
        True = occupied.
    connectivity : int, optional
        8 (default), 16 or 32.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (H*W, H*W)
    """
    occupied = check_grid(occupied)
    moves = move_table(connectivity)
    rows, cols = occupied.shape
    src, dst, cost = [], [], []
    for move in moves:
        i, j = np.nonzero(_allowed(occupied, move))
        s = i * cols + j
        src.append(s)
        dst.append(s + move.step[0] * cols + move.step[1])
        cost.append(np.full(s.size, move.cost))
    n = rows * cols
    return csr_matrix(
        (np.concatenate(cost), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)
    )


def shortest_paths(
    occupied: np.ndarray,
    starts: np.ndarray,
    goals: np.ndarray,
    *,
    connectivity: int = 8,
) -> list[GridPath]:
    """Exact shortest grid paths for many start/goal pairs on one grid (batched Dijkstra).

    Builds :func:`grid_graph` once and runs ``scipy.sparse.csgraph.dijkstra`` from every
    distinct start. Same lengths as :func:`fftnav.optimal.astar.astar` (tested).

    Parameters
    ----------
    occupied : ndarray of bool, shape (H, W)
        True = occupied.
    starts, goals : array_like of int, shape (N, 2)
        ``(row, col)`` cells, each free.
    connectivity : int, optional
        8 (default, the paper's A* reference), 16 or 32.

    Returns
    -------
    list of GridPath
        One per pair, in order.

    Raises
    ------
    UnreachableGoalError
        If some goal cannot be reached from its start.
    """
    occupied = check_grid(occupied)
    pairs = check_pairs(occupied, starts, goals)
    cols = occupied.shape[1]
    sources = sorted({s for s, _ in pairs})
    dist, pred = dijkstra(
        grid_graph(occupied, connectivity=connectivity),
        indices=[r * cols + c for r, c in sources],
        return_predecessors=True,
    )
    paths = []
    for start, goal in pairs:
        row = sources.index(start)
        node = goal[0] * cols + goal[1]
        if not np.isfinite(dist[row, node]):
            raise UnreachableGoalError(start, goal)
        nodes = [node]
        while nodes[-1] != start[0] * cols + start[1]:
            nodes.append(pred[row, nodes[-1]])
        cells = np.stack(np.divmod(np.array(nodes[::-1]), cols), axis=1)
        paths.append(GridPath(cells, float(dist[row, node])))
    return paths
