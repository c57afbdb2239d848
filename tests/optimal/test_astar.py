"""Grid A* and the batched Dijkstra solver against independent references."""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from fftnav.optimal.astar import UnreachableGoalError, astar, path_length_m
from fftnav.optimal.gridgraph import grid_moves, move_footprint, shortest_paths

SQRT2 = math.sqrt(2.0)


def dijkstra_8(occupied: np.ndarray, start: tuple, goal: tuple) -> float:
    """Textbook Dijkstra, 8-connected; a diagonal step needs both orthogonal neighbours free."""
    rows, cols = occupied.shape

    def free(r: int, c: int) -> bool:
        return 0 <= r < rows and 0 <= c < cols and not occupied[r, c]

    best = {start: 0.0}
    heap = [(0.0, start)]
    while heap:
        d, (r, c) = heapq.heappop(heap)
        if (r, c) == goal:
            return d
        if d > best[(r, c)]:
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                if (dr, dc) == (0, 0) or not free(r + dr, c + dc):
                    continue
                if dr and dc and not (free(r + dr, c) and free(r, c + dc)):
                    continue
                nd = d + (SQRT2 if dr and dc else 1.0)
                if nd < best.get((r + dr, c + dc), math.inf):
                    best[(r + dr, c + dc)] = nd
                    heapq.heappush(heap, (nd, (r + dr, c + dc)))
    return math.inf


def random_case(rng: np.random.Generator) -> tuple[np.ndarray, tuple, tuple]:
    shape = tuple(rng.integers(6, 18, size=2))
    occupied = rng.random(shape) < rng.uniform(0.05, 0.4)
    free = np.argwhere(~occupied)
    start, goal = free[rng.choice(len(free), size=2)]
    return occupied, tuple(int(v) for v in start), tuple(int(v) for v in goal)


def check_valid_path(occupied: np.ndarray, path, start: tuple, goal: tuple, moves) -> None:
    cells = path.cells
    assert tuple(cells[0]) == start and tuple(cells[-1]) == goal
    assert not occupied[cells[:, 0], cells[:, 1]].any()
    steps = np.diff(cells, axis=0)
    assert {tuple(s) for s in steps} <= {tuple(m) for m in moves}
    assert path.length_cells == pytest.approx(np.hypot(*steps.T).sum(), abs=1e-9)


def test_astar_and_batched_dijkstra_match_reference_dijkstra_on_random_grids():
    rng = np.random.default_rng(20240501)
    moves = grid_moves(8)
    reachable = 0
    for _ in range(150):
        occupied, start, goal = random_case(rng)
        expected = dijkstra_8(occupied, start, goal)
        if math.isinf(expected):
            with pytest.raises(UnreachableGoalError, match="unreachable from start cell"):
                astar(occupied, start, goal)
            with pytest.raises(UnreachableGoalError, match="unreachable from start cell"):
                shortest_paths(occupied, [start], [goal])
            continue
        reachable += 1
        path = astar(occupied, start, goal)
        (fast,) = shortest_paths(occupied, [start], [goal])
        assert path.length_cells == pytest.approx(expected, abs=1e-9)
        assert fast.length_cells == pytest.approx(expected, abs=1e-9)
        for p in (path, fast):
            check_valid_path(occupied, p, start, goal, moves)
            diagonal = np.abs(np.diff(p.cells, axis=0)).sum(axis=1) == 2
            steps = np.diff(p.cells, axis=0)
            for (r, c), (dr, dc) in zip(p.cells[:-1][diagonal], steps[diagonal], strict=True):
                assert not occupied[r + dr, c] and not occupied[r, c + dc]  # no corner cutting
    assert reachable > 60  # both branches exercised


def test_free_space_length_is_octile():
    rng = np.random.default_rng(7)
    occupied = np.zeros((40, 50), dtype=bool)
    starts = rng.integers(0, (40, 50), size=(20, 2))
    goals = rng.integers(0, (40, 50), size=(20, 2))
    fast = shortest_paths(occupied, starts, goals)
    for s, g, f in zip(starts, goals, fast, strict=True):
        di, dj = np.abs(g - s)
        octile = max(di, dj) + (SQRT2 - 1) * min(di, dj)
        assert astar(occupied, tuple(s), tuple(g)).length_cells == pytest.approx(octile, abs=1e-9)
        assert f.length_cells == pytest.approx(octile, abs=1e-9)


@pytest.mark.parametrize("connectivity", [16, 32])
def test_astar_matches_batched_solver_at_higher_connectivity(connectivity):
    rng = np.random.default_rng(connectivity)
    moves = grid_moves(connectivity)
    for _ in range(25):
        occupied, start, goal = random_case(rng)
        try:
            (fast,) = shortest_paths(occupied, [start], [goal], connectivity=connectivity)
        except UnreachableGoalError:
            with pytest.raises(UnreachableGoalError):
                astar(occupied, start, goal, connectivity=connectivity)
            continue
        path = astar(occupied, start, goal, connectivity=connectivity)
        assert path.length_cells == pytest.approx(fast.length_cells, abs=1e-9)
        check_valid_path(occupied, path, start, goal, moves)


@pytest.mark.parametrize("connectivity", [8, 16, 32])
def test_move_footprint_is_the_set_of_cells_the_segment_touches(connectivity):
    for di, dj in grid_moves(connectivity):
        got = {tuple(c) for c in move_footprint(di, dj)}
        expected = set()
        for a in range(-3, 4):
            for b in range(-3, 4):
                # L-inf distance from the cell centre to the segment; <= 0.5 means it touches.
                res = minimize_scalar(
                    lambda t, a=a, b=b, di=di, dj=dj: max(abs(t * di - a), abs(t * dj - b)),
                    bounds=(0.0, 1.0),
                    method="bounded",
                    options={"xatol": 1e-12},
                )
                if res.fun <= 0.5 + 1e-6:
                    expected.add((a, b))
        assert got == expected, (di, dj)


def test_grid_moves_counts_and_primitive():
    for connectivity in (8, 16, 32):
        moves = grid_moves(connectivity)
        assert len({tuple(m) for m in moves}) == connectivity
        assert all(math.gcd(*m) == 1 for m in moves)


def test_batched_solver_serves_many_robots_with_shared_starts():
    occupied = np.zeros((30, 30), dtype=bool)
    occupied[5:25, 15] = True
    starts = [(15, 2), (15, 2), (0, 0)]
    goals = [(15, 28), (29, 29), (29, 0)]
    got = [p.length_cells for p in shortest_paths(occupied, starts, goals)]
    expected = [dijkstra_8(occupied, s, g) for s, g in zip(starts, goals, strict=True)]
    assert got == pytest.approx(expected, abs=1e-9)


def test_path_length_m_scales_by_resolution():
    occupied = np.zeros((5, 5), dtype=bool)
    path = astar(occupied, (0, 0), (3, 4))
    assert path_length_m(path, 0.05) == pytest.approx((4 + 3 * (SQRT2 - 1)) * 0.05)
    with pytest.raises(ValueError, match=r"resolution_m must be a finite number > 0, got resolution_m=0"):
        path_length_m(path, 0)


def test_unreachable_goal_names_both_cells():
    occupied = np.zeros((6, 6), dtype=bool)
    occupied[:, 3] = True
    with pytest.raises(UnreachableGoalError, match=r"goal cell \(2, 5\) is unreachable from start cell \(1, 0\)"):
        astar(occupied, (1, 0), (2, 5))
    with pytest.raises(UnreachableGoalError, match=r"goal cell \(2, 5\) is unreachable"):
        shortest_paths(occupied, [(1, 0)], [(2, 5)])
    assert issubclass(UnreachableGoalError, ValueError)


def test_diagonal_gap_is_not_passable():
    occupied = np.zeros((4, 4), dtype=bool)
    occupied[np.arange(4), 3 - np.arange(4)] = True  # anti-diagonal wall, corners touch
    with pytest.raises(UnreachableGoalError):
        astar(occupied, (0, 0), (3, 3))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"start_cell": (5, 0)}, r"start_cell must lie inside the 4x4 grid, got start_cell=\(5, 0\)"),
        ({"goal_cell": (1, 1)}, r"goal_cell must be a free cell, got occupied goal_cell=\(1, 1\)"),
        ({"start_cell": (0.5, 0)}, r"start_cell must be an integer \(row, col\) pair"),
        ({"connectivity": 4}, r"connectivity must be one of \[8, 16, 32\], got connectivity=4"),
        (
            {"occupied": np.zeros((4, 4))},
            r"occupied must be a non-empty 2-D boolean array, got occupied with shape=\(4, 4\) "
            r"dtype=float64",
        ),
    ],
)
def test_invalid_inputs_raise(kwargs, message):
    occupied = np.zeros((4, 4), dtype=bool)
    occupied[1, 1] = True
    args = {"occupied": occupied, "start_cell": (0, 0), "goal_cell": (3, 3)} | kwargs
    with pytest.raises(ValueError, match=message):
        astar(args.pop("occupied"), args.pop("start_cell"), args.pop("goal_cell"), **args)


def test_batched_solver_validates_pairs():
    occupied = np.zeros((4, 4), dtype=bool)
    with pytest.raises(ValueError, match=r"starts and goals must be \(N, 2\) arrays of the same shape"):
        shortest_paths(occupied, [(0, 0), (1, 1)], [(3, 3)])
