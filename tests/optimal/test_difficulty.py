"""BARN's difficulty measures (fftnav.optimal.difficulty) against hand-worked worlds and against a
transcription of BARN's own loops (difficulty_quant.py of dperille/jackal-map-creation)."""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest

from fftnav.optimal.difficulty import (
    DISPERSION_DIRECTIONS,
    MEASURES,
    characteristic_dimension_cells,
    clearance_cells,
    dispersion_counts,
    map_difficulty,
    path_difficulty,
    reference_paths,
    visibility_cells,
)
from fftnav.optimal.gridgraph import UnreachableGoalError
from fftnav.optimal.reference import optimal_lengths, robot_cells
from fftnav.world import World, generate_world
from fftnav.world.obstacles import rectangle

SQRT2 = math.sqrt(2)


# --- BARN's loops, transcribed from difficulty_quant.py (Python 2 Queue -> heapq) -------------

def barn_closest_wall(grid, r, c):
    rows, cols = grid.shape
    pq, seen = [(0.0, r, c)], {(r, c)}
    while pq:
        dist, pr, pc = heapq.heappop(pq)
        if grid[pr, pc]:
            return dist
        for row in range(pr - 1, pr + 2):
            for col in range(pc - 1, pc + 2):
                if 0 <= row < rows and 0 <= col < cols and (row, col) not in seen:
                    heapq.heappush(pq, (math.hypot(row - r, col - c), row, col))
                    seen.add((row, col))
    return (rows - 1) / 2


def barn_avg_vis(grid, r, c):
    rows, cols = grid.shape
    total, axes = 0.0, 0
    for r_move in (-1, 0, 1):
        for c_move in (-1, 0, 1):
            if r_move == 0 and c_move == 0:
                continue
            vis, rc, cc = 0.0, r, c
            while 0 <= rc < rows and 0 <= cc < cols and not grid[rc, cc]:
                vis += math.sqrt(r_move**2 + c_move**2)
                rc, cc = rc + r_move, cc + c_move
            total += vis
            axes += 1
    return total / axes


def barn_char_dim(grid, r, c):
    rows, cols = grid.shape
    best = rows + cols
    for axis in ((0, 1), (1, 1), (1, 0), (1, -1)):
        dist = 0.0
        for move in (axis, (-axis[0], -axis[1])):
            rc, cc = r, c
            while not grid[rc, cc]:
                rc, cc = rc + move[0], cc + move[1]
                if not (0 <= rc < rows and 0 <= cc < cols):
                    break
                if not grid[rc, cc]:
                    dist += math.sqrt(move[0] ** 2 + move[1] ** 2)
        best = min(best, dist)
    return best


#: BARN's 16 dispersion moves (difficulty_quant.py line 114), in its order.
BARN_DISPERSION_MOVES = [(0, 1), (1, 2), (1, 1), (2, 1), (1, 0), (2, -1), (1, -1), (1, -2),
                         (0, -1), (-2, -1), (-1, -1), (-1, -2), (-1, 0), (-2, 1), (-1, 1), (-1, 2)]


def random_grids(count, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        shape = rng.integers(5, 18, size=2)
        grid = rng.random(shape) < rng.uniform(0.05, 0.4)
        grid[rng.integers(shape[0]), rng.integers(shape[1])] = True  # at least one obstacle
        yield grid


def test_grid_measures_equal_barns_loops_on_random_grids():
    compared = 0
    for grid in random_grids(60):
        cells = np.argwhere(~grid)
        if not len(cells):
            continue
        expected = np.array([[barn_closest_wall(grid, r, c), barn_avg_vis(grid, r, c),
                              barn_char_dim(grid, r, c)] for r, c in cells])
        got = np.c_[clearance_cells(grid, cells), visibility_cells(grid, cells),
                    characteristic_dimension_cells(grid, cells)]
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
        compared += len(cells)
    assert compared > 3000


def test_dispersion_rays_are_barns_directions_in_angular_order():
    assert sorted(map(tuple, DISPERSION_DIRECTIONS.tolist())) == sorted(BARN_DISPERSION_MOVES)
    angles = np.arctan2(DISPERSION_DIRECTIONS[:, 0], DISPERSION_DIRECTIONS[:, 1]) % (2 * np.pi)
    assert angles[0] == 0 and np.all(np.diff(angles) > 0)
    # BARN's list runs 180, 243, 225, 207, 270 degrees: not in order
    barn = np.array(BARN_DISPERSION_MOVES)
    assert not np.all(np.diff(np.arctan2(barn[:, 0], barn[:, 1]) % (2 * np.pi)) > 0)


def test_dispersion_counts_the_openings_around_a_cell():
    # Cell (10, 10) of a 21 x 21 grid; a ray of length R at angle t (from +col towards +row)
    # reaches an occupied row 4 above (its edge 3.5 away) if R sin t >= 3.5, etc.
    occ = np.zeros((21, 21), dtype=bool)
    centre = [[10, 10]]
    assert dispersion_counts(occ, centre, 4.0).tolist() == [0]  # nothing around
    occ[14:, :] = True  # a wall 4 rows above
    assert dispersion_counts(occ, centre, 4.0).tolist() == [2]  # 63, 90, 117 degrees blocked
    assert dispersion_counts(occ, centre, 3.0).tolist() == [0]  # too short to reach it
    occ[:, :7] = True  # and a wall 4 columns to the left
    assert dispersion_counts(occ, centre, 4.0).tolist() == [4]  # and 153, 180, 207: two groups
    assert dispersion_counts(occ, centre, 5.0).tolist() == [2]  # 45 to 225 degrees: one group
    post = np.zeros((21, 21), dtype=bool)
    post[4, 16] = True  # 6 rows down, 6 columns right: its corner 5.5 sqrt 2 = 7.78 away
    assert dispersion_counts(post, centre, 8.0).tolist() == [2]  # the -45 degree ray only
    assert dispersion_counts(post, centre, 7.7).tolist() == [0]
    corner = np.zeros((21, 21), dtype=bool)
    corner[10, 11] = corner[11, 10] = True  # right and up: they touch at a corner on the 45 ray
    assert dispersion_counts(corner, centre, 2.0).tolist() == [2]  # no slipping between them


# --- hand-worked worlds (0.1 m cells so that the cells can be counted) -----------------------

def corridor():
    """6 m x 2 m, walls y <= 0.5 and y >= 1.5 all along x; one robot along y = 1.05."""
    walls = (rectangle(0.0, 0.0, 6.0, 0.5, 1.0), rectangle(0.0, 1.5, 6.0, 2.0, 1.0))
    return World("corridor", 0, (6.0, 2.0), walls, np.array([[0.55, 1.05, 0.0]]),
                 np.array([[5.45, 1.05]]))


@pytest.mark.parametrize(("r0_m", "below", "above", "dispersion"),
                         [(0.12, 5, 4, 2.0), (0.22, 4, 3, 4.0)])
def test_straight_corridor(r0_m, below, above, dispersion):
    # Cell centres at y = 0.05 + 0.1 k; those within r0 of a wall are occupied: free rows
    # 6..13 (r0 = 0.12) or 7..12 (r0 = 0.22). The robot's row 10 sees `below` free rows
    # downwards (itself included) and `above` upwards; its path is row 10, columns 5..54.
    m = map_difficulty(corridor(), r0_m=r0_m, resolution_m=0.1, dispersion_radius_m=0.4)
    # nearest occupied cell: straight up, `above` rows away
    assert m["distance_to_closest_obstacle_m"][0] == pytest.approx(0.1 * above)
    # 8 rays: up, down, left + right = 61 cells whatever the column, 4 diagonals
    rays = above + below + 61 + SQRT2 * (2 * above + 2 * below)
    assert m["average_visibility_m"][0] == pytest.approx(0.1 * rays / 8)
    # narrowest chord: vertical, the free rows beside the robot's
    assert m["characteristic_dimension_m"][0] == pytest.approx(0.1 * (above + below - 2))
    assert m["tortuosity"][0] == pytest.approx(1.0)
    # rays of 4 cells reach the occupied rows, above - 0.5 and below - 0.5 cells away, if
    # 4 |sin(angle)| reaches that: r0 = 0.12, the rays at 63, 90 and 117 degrees upwards and
    # none downwards (2 changes); r0 = 0.22, 45 to 135 degrees upwards and 243 to 297 degrees
    # downwards (4 changes)
    assert m["dispersion"][0] == dispersion


def test_corridor_dispersion_needs_a_long_enough_ray():
    m = map_difficulty(corridor(), r0_m=0.12, resolution_m=0.1, dispersion_radius_m=0.3)
    assert m["dispersion"][0] == 0.0  # the wall above is 3.5 cells away


def wall_world():
    """4 m x 4 m, a 2 m x 0.2 m wall across the way of a robot going up at x = 2.05."""
    return World("wall", 0, (4.0, 4.0), (rectangle(1.0, 1.9, 3.0, 2.1, 1.0),),
                 np.array([[2.05, 0.55, 0.0]]), np.array([[2.05, 3.45]]))


def test_one_wall_to_go_round():
    # Inflated by 0.12 m the wall covers rows 18..21, columns 9..30; the robot goes from cell
    # (5, 20) to (34, 20). Round the right end (column 31): 11 diagonals up to (18, 31), 2
    # straight, 3 up the wall's end, and the mirror image: 22 sqrt 2 + 7 cells; round the left
    # end (column 8) it is 24 sqrt 2 + 5, longer.
    world = wall_world()
    grid, (path,) = reference_paths(world, r0_m=0.12, resolution_m=0.1)
    assert np.flatnonzero(grid.grid.any(axis=1)).tolist() == [18, 19, 20, 21]
    assert np.flatnonzero(grid.grid.any(axis=0)).tolist() == list(range(9, 31))
    assert path.cells[0].tolist() == [5, 20] and path.cells[-1].tolist() == [34, 20]
    assert path.length_cells == pytest.approx(22 * SQRT2 + 7)
    assert path.cells[:, 1].max() == 31
    m = map_difficulty(world, r0_m=0.12, resolution_m=0.1)
    assert m["tortuosity"][0] == pytest.approx((22 * SQRT2 + 7) / 29)
    # the path's cells that pass the wall's end (column 31, rows 18..21) are 1 cell from it
    assert clearance_cells(grid.grid, [[19, 31]]).tolist() == [1.0]
    # the other measures are BARN's, cell by cell, averaged over the same path
    barn = np.mean([[barn_closest_wall(grid.grid, r, c), barn_avg_vis(grid.grid, r, c),
                     barn_char_dim(grid.grid, r, c)] for r, c in path.cells], axis=0)
    got = [m["distance_to_closest_obstacle_m"][0], m["average_visibility_m"][0],
           m["characteristic_dimension_m"][0]]
    np.testing.assert_allclose(got, 0.1 * barn, rtol=1e-12)


def field(boundary):
    """4 m x 3 m, no obstacle; one robot along y = 1.55 (row 15) from column 5 to 34."""
    return World("field", 0, (4.0, 3.0), (), np.array([[0.55, 1.55, 0.0]]),
                 np.array([[3.45, 1.55]]), boundary)


def box_measures(lo, hi, row, columns):
    """Visibility and characteristic dimension (cells) in a free box of rows lo[0]..hi[0] and
    columns lo[1]..hi[1], everything outside it blocked or off the map, worked ray by ray."""
    up, down = hi[0] - row, row - lo[0]  # free cells beyond the robot's
    vis, chord = [], []
    for c in columns:
        right, left = hi[1] - c, c - lo[1]
        ur, dl = min(up, right), min(down, left)
        ul, dr = min(up, left), min(down, right)
        vis.append((up + down + right + left + 4 + SQRT2 * (ur + dl + ul + dr + 4)) / 8)
        chord.append(min(up + down, right + left, SQRT2 * (ur + dl), SQRT2 * (ul + dr)))
    return np.mean(vis), np.mean(chord)


def test_open_field_is_bounded_by_the_map_edges():
    # Nothing is occupied: no distance to an obstacle, no dispersion; the rays of visibility and
    # of the characteristic dimension end at the edges of the 30 x 40 cell map.
    m = map_difficulty(field("open"), r0_m=0.15, resolution_m=0.1)
    vis, chord = box_measures((0, 0), (29, 39), 15, range(5, 35))
    assert math.isnan(m["distance_to_closest_obstacle_m"][0])
    assert m["average_visibility_m"][0] == pytest.approx(0.1 * vis)
    assert m["characteristic_dimension_m"][0] == pytest.approx(0.1 * chord)
    assert m["dispersion"][0] == 0.0 and m["tortuosity"][0] == pytest.approx(1.0)
    assert 0.1 * chord < 2.9  # near its ends the path's diagonal chords are shorter than 29


def test_walled_field_counts_the_walls():
    # The boundary walls inflated by 0.12 m occupy the outer ring of cells: the free box is
    # rows 1..28, columns 1..38, and the nearest wall of cell (15, c) is min(c, 39 - c, 14) away.
    m = map_difficulty(field("walls"), r0_m=0.12, resolution_m=0.1, dispersion_radius_m=0.6)
    vis, chord = box_measures((1, 1), (28, 38), 15, range(5, 35))
    distance = np.mean([min(c, 39 - c, 14) for c in range(5, 35)])
    assert m["distance_to_closest_obstacle_m"][0] == pytest.approx(0.1 * distance)
    assert m["average_visibility_m"][0] == pytest.approx(0.1 * vis)
    assert m["characteristic_dimension_m"][0] == pytest.approx(0.1 * chord)
    # rays of 6 cells reach the side walls (5.5 cells from columns 5 and 34, 6.5 from 6 and 33)
    # along the row only (the knight rays reach 5.37 cells sideways): 2 changes at 4 of 30 cells
    assert m["dispersion"][0] == pytest.approx(4 * 2 / 30)


def test_measures_of_several_paths_are_kept_apart():
    # robot 0 goes round the wall, robot 1 passes it on the left in a straight line (column 5)
    world = wall_world().with_robots([[2.05, 0.55, 0.0], [0.55, 0.55, 0.0]],
                                     [[2.05, 3.45], [0.55, 3.45]])
    grid, paths = reference_paths(world, r0_m=0.12, resolution_m=0.1)
    both = path_difficulty(grid, paths)
    for i, path in enumerate(paths):
        alone = path_difficulty(grid, [path])
        for name in MEASURES:
            assert both[name][i] == pytest.approx(alone[name][0])
    assert both["tortuosity"].tolist() == pytest.approx([(22 * SQRT2 + 7) / 29, 1.0])
    assert both["distance_to_closest_obstacle_m"][1] > both["distance_to_closest_obstacle_m"][0]


def test_reference_paths_are_the_spl_reference():
    world = generate_world("rocky", 2, size_m=(6.0, 6.0), robots=4, start_y_m=0.5, goal_y_m=5.5,
                           strip_half_width_m=0.4)
    grid, paths = reference_paths(world, r0_m=0.15)
    astar_m, _ = optimal_lengths(world, r0_m=0.15)
    np.testing.assert_allclose([p.length_cells * grid.resolution_m for p in paths], astar_m,
                               rtol=1e-12)
    starts, goals = robot_cells(grid, world)
    for path, s, g in zip(paths, starts, goals, strict=True):
        assert path.cells[0].tolist() == s.tolist() and path.cells[-1].tolist() == g.tolist()
        steps = np.abs(np.diff(path.cells, axis=0))
        assert steps.max() == 1 and steps.sum(axis=1).min() >= 1  # 8-neighbours
        assert not grid.grid[path.cells[:, 0], path.cells[:, 1]].any()


def test_a_generated_map_gives_finite_measures_in_their_ranges():
    world = generate_world("forest", 0, size_m=(8.0, 8.0), robots=5, start_y_m=0.5,
                           goal_y_m=7.5, strip_half_width_m=0.4)
    m = map_difficulty(world, r0_m=0.15)
    assert set(m) == set(MEASURES) and all(v.shape == (5,) for v in m.values())
    assert np.all(m["distance_to_closest_obstacle_m"] > 0)
    assert np.all(m["characteristic_dimension_m"] > 0)
    assert np.all((m["dispersion"] >= 0) & (m["dispersion"] <= 16))
    assert np.all(m["tortuosity"] >= 1.0)


def test_bad_input_is_refused_by_name():
    with pytest.raises(ValueError, match=r"r0_m must be a finite number >= 0, got r0_m=-1"):
        map_difficulty(corridor(), r0_m=-1)
    with pytest.raises(ValueError, match=r"dispersion_radius_m must be a finite number > 0, "
                       r"got dispersion_radius_m=0"):
        map_difficulty(corridor(), r0_m=0.12, dispersion_radius_m=0)
    grid, _ = reference_paths(corridor(), r0_m=0.12, resolution_m=0.1)
    with pytest.raises(ValueError, match=r"cells must be free cells of the 20x60 grid, "
                       r"got cells\[1\]=\[0, 0\]"):
        clearance_cells(grid.grid, [[10, 5], [0, 0]])
    with pytest.raises(ValueError, match=r"lies in an occupied cell"):
        map_difficulty(corridor(), r0_m=0.5)
    blocked = World("blocked", 0, (4.0, 4.0), (rectangle(0.0, 1.9, 4.0, 2.1, 1.0),),
                    np.array([[2.05, 0.55, 0.0]]), np.array([[2.05, 3.45]]))
    with pytest.raises(UnreachableGoalError, match="unreachable"):
        map_difficulty(blocked, r0_m=0.12, resolution_m=0.1)
