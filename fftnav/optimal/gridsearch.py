"""Compiled grid A* for many start/goal pairs: the SPL reference lengths, fast (optional numba).

The same graph as :func:`fftnav.optimal.gridgraph.grid_graph` (cells are nodes; a move joins
two cell centres and is allowed only if its whole footprint is free), searched per pair by A*
(Hart, Nilsson & Raphael 1968) with the Euclidean heuristic: admissible and consistent, since
every move costs its Euclidean length, so the first time the goal leaves the open list its
cost is the shortest length. Where :func:`~fftnav.optimal.gridgraph.shortest_paths` runs a
full Dijkstra over the map from every start (scipy, compiled), A* expands only the cells whose
cost plus straight-line remainder stays below the answer: on the 20 m x 20 m benchmark maps at
0.05 m, a tenth of the time or less (``fftnav bench optimal`` has the figure).

The length of a path is the sum of its move costs in path order, as Dijkstra's; when several
paths are equally short, A* may return another one, whose sum can differ in the last bits
(``1 + sqrt(2) + 1`` against ``sqrt(2) + 1 + 1``): the tests hold the lengths to Dijkstra's to
1e-12 relative, far below the 1e-6 m of the CSV files.

Without numba (:data:`AVAILABLE` False), :func:`fftnav.optimal.geodesic.geodesic_lengths`
uses the Dijkstra solver.
"""

from __future__ import annotations

import numpy as np

from fftnav.errors import MissingExtraError
from fftnav.observe.kernels import AVAILABLE, njit
from fftnav.optimal.gridgraph import (
    GridPath,
    UnreachableGoalError,
    _allowed,
    check_grid,
    check_pairs,
    move_table,
)

__all__ = ["AVAILABLE", "HEAP_SIZE", "astar_lengths", "astar_paths"]


def astar_lengths(occupied: np.ndarray, starts: np.ndarray, goals: np.ndarray, *,
                  connectivity: int = 8) -> np.ndarray:
    """Shortest collision-free lengths, in cells, of many start/goal pairs on one grid.

    Parameters
    ----------
    occupied : ndarray of bool, shape (H, W)
        True = occupied.
    starts, goals : array_like of int, shape (N, 2)
        ``(row, col)`` free cells.
    connectivity : int, optional
        8 (default, the paper's A* reference), 16 or 32.

    Returns
    -------
    ndarray of float, shape (N,)
        Lengths in cells, equal to :func:`fftnav.optimal.gridgraph.shortest_paths`'
        ``length_cells`` to 1e-12 relative.

    Raises
    ------
    UnreachableGoalError
        If some goal cannot be reached from its start.
    MissingExtraError
        If numba is not installed (``pip install 'fftnav[fast]'``).
    FftnavError
        If a cell is invalid (naming it).

    Examples
    --------
    >>> free = np.zeros((5, 5), dtype=bool)
    >>> free[1:4, 2] = True  # a wall in the middle column
    >>> lengths = astar_lengths(free, [[2, 0]], [[2, 4]])  # around the wall
    >>> round(float(lengths[0]), 6)  # no corner cutting: 4 straight and 2 diagonal moves
    6.828427
    """
    return _run(occupied, starts, goals, connectivity, False)[0]


def astar_paths(occupied: np.ndarray, starts: np.ndarray, goals: np.ndarray, *,
                connectivity: int = 8) -> list[GridPath]:
    """Shortest collision-free paths of many start/goal pairs on one grid: the compiled
    twin of :func:`fftnav.optimal.gridgraph.shortest_paths` (same arguments and errors), the
    lengths of :func:`astar_lengths`. Where several paths are equally short, it may return
    another one than Dijkstra's, but always the same one: without numba the same search runs
    as plain Python (about ten times slower), so the paths do not depend on the install.

    >>> free = np.zeros((5, 5), dtype=bool)
    >>> free[1:4, 2] = True
    >>> path = astar_paths(free, [[2, 0]], [[2, 4]])[0]
    >>> path.cells[0].tolist(), path.cells[-1].tolist(), round(path.length_cells, 6)
    ([2, 0], [2, 4], 6.828427)
    """
    lengths, cells, offsets = _run(occupied, starts, goals, connectivity, True)
    return [GridPath(cells[a:b], float(n))
            for a, b, n in zip(offsets[:-1], offsets[1:], lengths, strict=True)]


def _run(occupied: np.ndarray, starts: np.ndarray, goals: np.ndarray, connectivity: int,
         paths: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Check the input, search every pair; lengths, and with ``paths`` the cells of all paths
    one after the other and each path's offsets (paths: also without numba)."""
    if not AVAILABLE and not paths:
        raise MissingExtraError("numba", extra="fast",
                                needed_for="compiled A* lengths (astar_lengths)")
    occupied = check_grid(occupied)
    pairs = np.array([(*s, *g) for s, g in check_pairs(occupied, starts, goals)],
                     dtype=np.int64).reshape(-1, 4)
    moves = move_table(connectivity)
    allowed = np.stack([_allowed(occupied, move) for move in moves])
    steps = np.array([move.step for move in moves], dtype=np.int64)
    costs = np.array([move.cost for move in moves])
    lengths, cells, offsets = _search(allowed, steps, costs, pairs, HEAP_SIZE, paths)
    unreachable = np.flatnonzero(~np.isfinite(lengths))
    if unreachable.size:
        row = pairs[unreachable[0]]
        raise UnreachableGoalError((int(row[0]), int(row[1])), (int(row[2]), int(row[3])))
    return lengths, cells, offsets


#: Initial capacity of the open list (it doubles when full; tests start it at 1).
HEAP_SIZE = 1 << 16


@njit(cache=True, nogil=True)
def _push(keys: np.ndarray, nodes: np.ndarray, size: int, key: float, node: int) -> None:
    """Binary min-heap insert (the caller makes room and counts)."""
    i = size
    while i > 0:
        parent = (i - 1) // 2
        if keys[parent] <= key:
            break
        keys[i], nodes[i] = keys[parent], nodes[parent]
        i = parent
    keys[i], nodes[i] = key, node


@njit(cache=True, nogil=True)
def _pop(keys: np.ndarray, nodes: np.ndarray, size: int) -> int:
    """Remove the heap's minimum (size >= 1 before the call) and return its node."""
    top = nodes[0]
    size -= 1
    key, node = keys[size], nodes[size]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and keys[child + 1] < keys[child]:
            child += 1
        if keys[child] >= key:
            break
        keys[i], nodes[i] = keys[child], nodes[child]
        i = child
    keys[i], nodes[i] = key, node
    return top


@njit(cache=True, nogil=True)
def _search(allowed: np.ndarray, steps: np.ndarray, costs: np.ndarray, pairs: np.ndarray,
            heap_size: int, paths: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A* of every pair ``(start row, start col, goal row, goal col)``: lengths (inf if
    unreachable) and, with ``paths``, the cells of the found paths (start first) one after the
    other, path ``p`` at ``offsets[p]:offsets[p + 1]``."""
    rows, cols = allowed.shape[1], allowed.shape[2]
    cost = np.empty(rows * cols)
    parent = np.empty(rows * cols, np.int64)
    cells, offsets = np.empty((1024, 2), np.int64), np.zeros(pairs.shape[0] + 1, np.int64)
    seen = np.zeros(rows * cols, np.int64)  # pair number + 1 where ``cost`` is this pair's
    done = np.zeros(rows * cols, np.int64)  # pair number + 1 where the cell is closed
    keys, nodes = np.empty(heap_size), np.empty(heap_size, np.int64)
    lengths = np.full(pairs.shape[0], np.inf)
    for p in range(pairs.shape[0]):
        tag = p + 1
        sr, sc, gr, gc = pairs[p, 0], pairs[p, 1], pairs[p, 2], pairs[p, 3]
        start, goal = sr * cols + sc, gr * cols + gc
        cost[start], seen[start] = 0.0, tag
        _push(keys, nodes, 0, np.hypot(sr - gr, sc - gc), start)
        size = 1
        while size > 0:
            u = _pop(keys, nodes, size)
            size -= 1
            if done[u] == tag:
                continue
            done[u] = tag
            if u == goal:
                lengths[p] = cost[u]
                if paths:
                    cells = _append_path(cells, offsets, p, parent, start, goal, cols)
                break
            ur, uc = u // cols, u % cols
            for k in range(steps.shape[0]):
                if not allowed[k, ur, uc]:
                    continue
                vr, vc = ur + steps[k, 0], uc + steps[k, 1]
                v = vr * cols + vc
                if done[v] == tag:
                    continue
                new = cost[u] + costs[k]
                if seen[v] == tag and new >= cost[v]:
                    continue
                cost[v], seen[v], parent[v] = new, tag, u
                if size == keys.shape[0]:  # grow the heap
                    keys, nodes = np.concatenate((keys, keys)), np.concatenate((nodes, nodes))
                _push(keys, nodes, size, new + np.hypot(vr - gr, vc - gc), v)
                size += 1
        if not paths or not np.isfinite(lengths[p]):
            offsets[p + 1] = offsets[p]
    return lengths, cells, offsets


@njit(cache=True, nogil=True)
def _append_path(cells: np.ndarray, offsets: np.ndarray, p: int, parent: np.ndarray,
                 start: int, goal: int, cols: int) -> np.ndarray:
    """Walk ``parent`` back from ``goal`` to ``start``; write the path (start first) after
    ``offsets[p]`` in ``cells`` (grown as needed) and set ``offsets[p + 1]``."""
    n, u = 1, goal
    while u != start:
        u, n = parent[u], n + 1
    begin = offsets[p]
    while cells.shape[0] < begin + n:
        cells = np.concatenate((cells, cells))
    u = goal
    for k in range(n - 1, -1, -1):
        cells[begin + k, 0], cells[begin + k, 1] = u // cols, u % cols
        if k:
            u = parent[u]
    offsets[p + 1] = begin + n
    return cells
