"""The compiled A* gives Dijkstra's shortest lengths (the independent oracle: scipy's
``csgraph.dijkstra`` over the same move graph, and the readable ``heapq`` A*)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fftnav.errors import MissingExtraError
from fftnav.optimal import gridsearch
from fftnav.optimal.astar import astar
from fftnav.optimal.geodesic import geodesic_lengths
from fftnav.optimal.gridgraph import UnreachableGoalError, shortest_paths

pytestmark = pytest.mark.skipif(not gridsearch.AVAILABLE, reason="numba is not installed")


def dijkstra_lengths(occupied, starts, goals, connectivity):
    return np.array([p.length_cells for p in shortest_paths(occupied, starts, goals,
                                                            connectivity=connectivity)])


@st.composite
def grids_with_pairs(draw):
    rows, cols = draw(st.integers(4, 24)), draw(st.integers(4, 24))
    density = draw(st.sampled_from([0.0, 0.1, 0.25, 0.35]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    occupied = rng.random((rows, cols)) < density
    free = np.argwhere(~occupied)
    if len(free) < 2:
        occupied[:] = False
        free = np.argwhere(~occupied)
    n = draw(st.integers(1, 6))
    starts = free[rng.integers(len(free), size=n)]
    starts[n // 2:] = starts[0]  # repeated starts, as several robots of a strip
    goals = free[rng.integers(len(free), size=n)]
    return occupied, starts, goals


@settings(max_examples=150, deadline=None)
@given(grids_with_pairs(), st.sampled_from([8, 16, 32]))
def test_lengths_equal_dijkstra(case, connectivity):
    occupied, starts, goals = case
    try:
        expected = dijkstra_lengths(occupied, starts, goals, connectivity)
    except UnreachableGoalError as error:
        with pytest.raises(UnreachableGoalError, match="is unreachable from start cell"):
            gridsearch.astar_lengths(occupied, starts, goals, connectivity=connectivity)
        assert error.start is not None
        return
    got = gridsearch.astar_lengths(occupied, starts, goals, connectivity=connectivity)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)


def test_lengths_on_a_benchmark_map_equal_dijkstra_and_the_readable_astar():
    """A rocky map at the paper's 0.05 m: every robot's 8- and 32-connected lengths."""
    from fftnav.optimal.reference import robot_cells
    from fftnav.world.generate import generate_world
    from fftnav.world.grid import occupancy_grid

    world = generate_world("rocky", 3, robots=15)
    grid = occupancy_grid(world, resolution_m=0.05, inflate_m=0.15)
    starts, goals = robot_cells(grid, world)
    for connectivity in (32, 8):
        got = gridsearch.astar_lengths(grid.grid, starts, goals, connectivity=connectivity)
        expected = dijkstra_lengths(grid.grid, starts, goals, connectivity)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)
    readable = astar(grid.grid, tuple(starts[0]), tuple(goals[0]))  # 8-connected
    assert got[0] == pytest.approx(readable.length_cells, rel=1e-12)


def test_an_unreachable_goal_is_named():
    occupied = np.zeros((6, 6), dtype=bool)
    occupied[:, 3] = True
    with pytest.raises(UnreachableGoalError, match=r"goal cell \(2, 5\) is unreachable from "
                                                   r"start cell \(2, 0\)"):
        gridsearch.astar_lengths(occupied, [[0, 0], [2, 0]], [[5, 0], [2, 5]])


def test_bad_cells_and_shapes_are_refused():
    occupied = np.zeros((4, 4), dtype=bool)
    occupied[1, 1] = True
    with pytest.raises(ValueError, match=r"start_cell must be a free cell, got occupied "
                                         r"start_cell=\(1, 1\)"):
        gridsearch.astar_lengths(occupied, [[1, 1]], [[3, 3]])
    with pytest.raises(ValueError, match=r"goal_cell must lie inside the 4x4 grid"):
        gridsearch.astar_lengths(occupied, [[0, 0]], [[4, 0]])
    with pytest.raises(ValueError, match="starts and goals must be"):
        gridsearch.astar_lengths(occupied, [[0, 0]], [[3, 3], [2, 2]])


def test_geodesic_lengths_methods(monkeypatch):
    occupied = np.zeros((30, 30), dtype=bool)
    occupied[5:25, 14] = True
    starts, goals = [[15, 2], [2, 2]], [[15, 27], [27, 27]]
    astar_m = geodesic_lengths(occupied, starts, goals, method="astar")
    dijkstra_m = geodesic_lengths(occupied, starts, goals, method="dijkstra")
    np.testing.assert_allclose(astar_m, dijkstra_m, rtol=1e-12, atol=0)
    assert np.array_equal(geodesic_lengths(occupied, starts, goals), astar_m)  # auto: A*
    with pytest.raises(ValueError, match=r"method must be one of .*got method='bfs'"):
        geodesic_lengths(occupied, starts, goals, method="bfs")
    monkeypatch.setattr(gridsearch, "AVAILABLE", False)  # no numba: auto is Dijkstra
    assert np.array_equal(geodesic_lengths(occupied, starts, goals), dijkstra_m)
    with pytest.raises(MissingExtraError, match=r"^compiled A\* lengths \(astar_lengths\) need "
                                                r"the numba package: pip install 'fftnav\[fast\]'$"):
        geodesic_lengths(occupied, starts, goals, method="astar")


@settings(max_examples=60, deadline=None)
@given(grids_with_pairs(), st.sampled_from([8, 32]))
def test_the_open_list_grows_from_one_entry(case, connectivity):
    """The heap starts at HEAP_SIZE entries and doubles when full: started at 1, every search
    grows it, and the lengths still equal Dijkstra's."""
    occupied, starts, goals = case
    try:
        expected = dijkstra_lengths(occupied, starts, goals, connectivity)
    except UnreachableGoalError:
        return
    size, gridsearch.HEAP_SIZE = gridsearch.HEAP_SIZE, 1
    try:
        got = gridsearch.astar_lengths(occupied, starts, goals, connectivity=connectivity)
    finally:
        gridsearch.HEAP_SIZE = size
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)


@settings(max_examples=100, deadline=None)
@given(grids_with_pairs(), st.sampled_from([8, 16, 32]))
def test_paths_are_allowed_move_chains_as_short_as_dijkstra(case, connectivity):
    """Each path runs from its start to its goal by allowed moves (footprints free), and its
    moves add up to Dijkstra's length."""
    from fftnav.optimal.gridgraph import _allowed, move_table

    occupied, starts, goals = case
    try:
        expected = dijkstra_lengths(occupied, starts, goals, connectivity)
    except UnreachableGoalError:
        with pytest.raises(UnreachableGoalError, match="is unreachable from start cell"):
            gridsearch.astar_paths(occupied, starts, goals, connectivity=connectivity)
        return
    moves = {tuple(m.step): (m, _allowed(occupied, m)) for m in move_table(connectivity)}
    paths = gridsearch.astar_paths(occupied, starts, goals, connectivity=connectivity)
    for path, start, goal, length in zip(paths, starts, goals, expected, strict=True):
        assert path.cells[0].tolist() == list(start) and path.cells[-1].tolist() == list(goal)
        total = 0.0
        for a, b in zip(path.cells[:-1], path.cells[1:], strict=True):
            move, allowed = moves[tuple((b - a).tolist())]
            assert allowed[a[0], a[1]]
            total += move.cost
        assert total == pytest.approx(length, rel=1e-12)
        assert path.length_cells == pytest.approx(length, rel=1e-12)


def test_paths_do_not_depend_on_numba():
    """Without numba the same search runs as plain Python: the same cells on a benchmark map
    (``maps.csv`` is the same on every install)."""
    from fftnav.optimal.gridgraph import _allowed, check_pairs, move_table
    from fftnav.optimal.reference import robot_cells
    from fftnav.world.generate import generate_world
    from fftnav.world.grid import occupancy_grid

    world = generate_world("rocky", 1003, robots=15)
    grid = occupancy_grid(world, resolution_m=0.05, inflate_m=0.15)
    starts, goals = robot_cells(grid, world)
    pairs = np.array([(*s, *g) for s, g in check_pairs(grid.grid, starts, goals)])[:4]
    moves = move_table(8)
    args = (np.stack([_allowed(grid.grid, m) for m in moves]),
            np.array([m.step for m in moves], dtype=np.int64),
            np.array([m.cost for m in moves]), pairs, gridsearch.HEAP_SIZE, True)
    compiled, plain = gridsearch._search(*args), gridsearch._search.py_func(*args)
    np.testing.assert_array_equal(compiled[0], plain[0])
    np.testing.assert_array_equal(compiled[2], plain[2])
    np.testing.assert_array_equal(compiled[1][:compiled[2][-1]], plain[1][:plain[2][-1]])
