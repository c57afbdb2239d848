"""The robots' own maps (fftnav.navigation.ownmap) against hand geometry and grid A*."""

import math

import numpy as np
import pytest

from fftnav.navigation.bug import PlannerParams
from fftnav.navigation.ownmap import OwnMaps
from fftnav.optimal.astar import UnreachableGoalError, astar

R = 3.0
ANGLES = -math.pi + np.arange(360) * 2 * math.pi / 360


def _maps(n=1, lo=(-4.0, -4.0), hi=(8.0, 8.0)):
    return OwnMaps(n, np.array(lo), np.array(hi), resolution_m=0.2, range_m=R, clearance_m=0.3)


def _scan_of_segments(x, y, yaw, segments):
    """Exact ranges (R = no return) from (x, y, yaw) against line segments ((x0, y0), (x1, y1))."""
    out = np.full(len(ANGLES), R)
    for k, a in enumerate(ANGLES + yaw):
        d = np.array([math.cos(a), math.sin(a)])
        for p0, p1 in segments:
            p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
            e = p1 - p0
            m = np.array([d, -e]).T
            if abs(np.linalg.det(m)) < 1e-12:
                continue
            t, u = np.linalg.solve(m, p0 - np.array([x, y]))
            if t > 0 and 0 <= u <= 1:
                out[k] = min(out[k], t)
    return out


def test_a_wall_is_occupied_free_space_is_free_and_unseen_space_unknown():
    maps = _maps()
    wall = [((2.1, -1.0), (2.1, 1.0))]
    ranges = _scan_of_segments(0.0, 0.0, 0.0, wall)[None, :]
    maps.update(0, np.array([0]), np.array([[0.0, 0.0, 0.0]]), ranges, ANGLES)
    occ = maps.occupied(0)
    for y in np.linspace(-0.9, 0.9, 10):  # every cell of the wall's face
        r, c = maps.cell(np.array([2.1, y]))
        assert occ[r, c], y
    assert occ.sum() <= 12  # nothing else (the face spans 2 m = 10 or 11 cells)
    for xy in ((1.0, 0.0), (-2.0, 0.5), (0.0, 2.0)):  # seen through: free
        r, c = maps.cell(np.array(xy))
        assert maps.last_free[0, r, c] == 0 and not occ[r, c]
    r, c = maps.cell(np.array([6.0, 6.0]))  # never seen
    assert maps.last_free[0, r, c] == -1 and maps.last_hit[0, r, c] == -1


def test_a_robot_that_moved_away_is_cleared_but_a_grazed_wall_is_not():
    maps = _maps()
    robot = [((1.5, -0.15), (1.5, 0.15))]  # another robot's front, then it leaves
    back = [((2.9, -2.0), (2.9, 2.0))]
    maps.update(0, np.array([0]), np.zeros((1, 3)), _scan_of_segments(0, 0, 0, robot + back)[None],
                ANGLES)
    r, c = maps.cell(np.array([1.5, 0.0]))
    assert maps.occupied(0)[r, c]
    maps.update(1, np.array([0]), np.zeros((1, 3)), _scan_of_segments(0, 0, 0, back)[None],
                ANGLES)
    assert not maps.occupied(0)[r, c]
    # a robot driving along a wall 0.59 m away: beams graze the wall's face far ahead of their
    # hits; no cell of the face it ever hit is cleared by them (without the guard around the
    # hits of the same scan, 4 of these 48 cells would be)
    maps = _maps()
    wall = [((-3.0, 0.59), (7.0, 0.59))]
    hit = np.zeros(maps.shape, dtype=bool)
    for k, x in enumerate(np.arange(0.0, 4.0, 0.1)):
        maps.update(k, np.array([0]), np.array([[x, 0.0, 0.0]]),
                    _scan_of_segments(x, 0.0, 0.0, wall)[None], ANGLES, beam_step=2)
        hit |= maps.last_hit[0] == k
    assert hit.sum() >= 40 and np.array_equal(maps.occupied(0) & hit, hit)


def _closed_by_brute_force(occ, res, clearance):
    closed = np.zeros_like(occ)
    rows, cols = np.nonzero(occ)
    for i in range(occ.shape[0]):
        for j in range(occ.shape[1]):
            closed[i, j] = np.any(np.hypot(rows - i, cols - j) * res <= clearance + 1e-9)
    return closed


def test_distance_field_equals_grid_astar_and_the_waypoints_lead_to_the_goal():
    rng = np.random.default_rng(3)
    maps = _maps(lo=(0.0, 0.0), hi=(5.8, 5.8))
    occ = rng.random(maps.shape) < 0.06
    start, goal = np.array([0.5, 0.5]), np.array([5.3, 5.3])
    for xy in (start, goal):
        r, c = maps.cell(xy)
        occ[max(r - 2, 0):r + 3, max(c - 2, 0):c + 3] = False
    maps.last_hit[0][occ] = 1  # occupied: hit, never seen free since
    assert maps.plan(0, start, goal)
    closed = _closed_by_brute_force(occ, 0.2, 0.3)
    here, there = tuple(maps.cell(start)), tuple(maps.cell(goal))
    path = astar(closed, here, there)
    assert maps._field[0][here] == pytest.approx(path.length_cells, abs=1e-9)
    # follow the waypoints: they reach the goal along free cells, never longer than A*'s path
    xy, travelled = start.copy(), 0.0
    for _ in range(200):
        nxt = maps.waypoint(0, xy, 1.0)
        assert nxt is not None and not closed[tuple(maps.cell(nxt))]
        travelled += float(np.hypot(*(nxt - xy)))
        xy = nxt
        if tuple(maps.cell(xy)) == there:
            break
    assert tuple(maps.cell(xy)) == there
    assert travelled <= path.length_cells * 0.2 + 0.3


def test_outside_the_grid_there_is_no_way():
    maps = _maps()
    assert not maps.plan(0, np.array([50.0, 0.0]), np.array([1.0, 1.0]))
    assert maps.waypoint(0, np.array([50.0, 0.0]), 1.0) is None


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="resolution_m must be"):
        OwnMaps(1, np.zeros(2), np.ones(2), resolution_m=0.0, range_m=3.0, clearance_m=0.3)
    with pytest.raises(ValueError, match="clearance_m must be"):
        OwnMaps(1, np.zeros(2), np.ones(2), resolution_m=0.2, range_m=3.0, clearance_m=-1.0)


@pytest.mark.parametrize("beam_step", [1, 2])
def test_compiled_update_marks_the_same_cells_as_numpy(monkeypatch, beam_step):
    """The compiled marking loop against the numpy version (the oracle), cell for cell: random
    poses near and beyond the map's edges, readings of walls and random ranges with zeros
    (no reading), NaN and R (no return), several ticks so that later scans overwrite earlier."""
    from fftnav.navigation import ownmap

    if not ownmap.kernels_available():
        pytest.skip("numba is not installed")
    rng = np.random.default_rng(7)
    walls = [((2.1, -1.0), (2.1, 1.0)), ((-3.0, 5.0), (6.0, 6.5))]
    fast, slow = _maps(4), _maps(4)
    for tick in range(6):
        poses = np.c_[rng.uniform(-5.0, 9.0, (4, 2)), rng.uniform(-math.pi, math.pi, 4)]
        ranges = np.stack([_scan_of_segments(*pose, walls) for pose in poses[:2]]
                          + [rng.uniform(0.0, 4.0, 360) for _ in range(2)])
        ranges[2, rng.random(360) < 0.2] = 0.0
        ranges[3, rng.random(360) < 0.1] = np.nan
        fast.update(tick, np.arange(4), poses, ranges, ANGLES, beam_step=beam_step)
        monkeypatch.setattr(ownmap, "kernels_available", lambda: False)
        slow.update(tick, np.arange(4), poses, ranges, ANGLES, beam_step=beam_step)
        monkeypatch.undo()
    assert np.array_equal(fast.last_free, slow.last_free)
    assert np.array_equal(fast.last_hit, slow.last_hit)
    assert (fast.last_hit >= 0).sum() > 50 and (fast.last_free >= 0).sum() > 500


def test_way_length_and_blocking_the_way_ahead_make_the_next_plan_go_round():
    """A wall across the map with two gaps, the near one straight ahead: the planned way runs
    through the near gap and its length is grid A*'s; block_way closes the next metre of it
    (beyond the clearance, never the robot's own cell) and the next plan goes through the far
    gap, as long as A*'s path on the grid with those cells closed."""
    maps = _maps(lo=(0.0, 0.0), hi=(8.0, 6.0))
    occ = np.zeros(maps.shape, dtype=bool)
    row = maps.cell(np.array([0.0, 3.0]))[0]
    occ[row, :] = True
    near, far = maps.cell(np.array([2.0, 3.0]))[1], maps.cell(np.array([7.0, 3.0]))[1]
    occ[row, near - 2:near + 3] = False
    occ[row, far - 2:far + 3] = False
    maps.last_hit[0][occ] = 1
    start, goal = np.array([2.0, 1.0]), np.array([2.0, 5.0])
    here, there = tuple(maps.cell(start)), tuple(maps.cell(goal))
    assert maps.plan(0, start, goal)
    before = astar(_closed_by_brute_force(occ, 0.2, 0.3), here, there)
    assert maps.way_length(0, start) == pytest.approx(before.length_cells * 0.2, abs=1e-9)
    assert maps.way_length(0, start) < 5.0
    closed = maps.block_way(0, start, 1.0)
    assert closed == 5 and not maps.blocked[0][here]
    assert maps.occupied(0)[maps.blocked[0]].all()
    assert maps.plan(0, start, goal)
    after = astar(_closed_by_brute_force(occ | maps.blocked[0], 0.2, 0.3), here, there)
    assert maps.way_length(0, start) == pytest.approx(after.length_cells * 0.2, abs=1e-9)
    assert maps.way_length(0, start) > 10.0  # round by the far gap
    point = maps.waypoint(0, start, 1.0)
    assert point is not None and point[0] > start[0] + 0.5  # heads right, toward it
    assert maps.block_way(0, np.array([50.0, 0.0]), 1.0) == 0


def test_a_pocket_closed_at_the_clearance_is_planned_again_squeezed():
    """A diagonal corridor between two walls of cells (|row - col| = 3): at the clearance
    (0.3 m) only its middle diagonal stays open, and a diagonal step may not cut the corners of
    closed cells, so the robot inside has no way. Asked to squeeze, the plan is then made again
    with the walls widened by squeeze_m (0.2 m): the way runs along the corridor and its length
    is grid A*'s on the grid closed at 0.2 m. Not asked, without squeeze_m, or where a way
    exists at the clearance, nothing is planned twice."""
    kwargs = dict(resolution_m=0.2, range_m=R, clearance_m=0.3)
    lo, hi = np.array([0.0, 0.0]), np.array([6.0, 6.0])
    maps = OwnMaps(1, lo, hi, squeeze_m=0.2, **kwargs)
    plain = OwnMaps(1, lo, hi, **kwargs)
    rows, cols = np.indices(maps.shape)
    occ = np.abs(rows - cols) == 3
    for m in (maps, plain):
        m.last_hit[0][occ] = 1
    start, goal = lo + 3.5 * 0.2, lo + 27.5 * 0.2  # cells (3, 3) and (27, 27)
    here, there = tuple(maps.cell(start)), tuple(maps.cell(goal))

    def closed(clearance):  # as plan closes cells: all but those around the robot and goal
        out = _closed_by_brute_force(occ, 0.2, clearance)
        for r, c in (here, there):
            out[r - 1:r + 2, c - 1:c + 2] = False
        return out

    with pytest.raises(UnreachableGoalError):
        astar(closed(0.3), here, there)
    assert plain.plan(0, start, goal, squeeze=True) and plain.way_length(0, start) == math.inf
    assert plain.squeezes[0] == 0
    assert maps.plan(0, start, goal) and maps.squeezes[0] == 0  # not asked to squeeze
    assert maps.plan(0, start, goal, squeeze=True) and maps.squeezes[0] == 1
    path = astar(closed(0.2), here, there)
    assert path is not None
    assert maps.way_length(0, start) == pytest.approx(path.length_cells * 0.2, abs=1e-9)
    point = maps.waypoint(0, start, 1.0)
    assert point is not None and np.all(point > start + 0.5)  # along the corridor
    outside = np.array([5.0, 1.0])  # beside the corridor, goal beside it too: a way at 0.3 m
    assert maps.plan(0, outside, np.array([5.5, 0.5]), squeeze=True) and maps.squeezes[0] == 1
    same = OwnMaps(1, lo, hi, squeeze_m=0.29, **kwargs)  # closes the cells 0.3 m closes
    same.last_hit[0][occ] = 1
    assert same.plan(0, start, goal, squeeze=True) and same.squeezes[0] == 0
    with pytest.raises(ValueError, match="squeeze_m must be"):
        OwnMaps(1, lo, hi, squeeze_m=0.5, **kwargs)
    with pytest.raises(ValueError, match="map_squeeze_m must be <= map_clearance_m"):
        PlannerParams(map_squeeze_m=0.5)


def test_where_other_robots_stand_is_not_occupied_but_a_shared_wall_is():
    """A corridor four cells (0.8 m) wide: a robot's hits (a 2 x 2 blob) in its middle close
    it, so the way runs round the corridor. Told where that robot stands (set_robots), the map frees the
    cells within robot_radius_m of it and the way runs through, as long as grid A*'s on the
    grid with those cells free; a cell a neighbour's wall segment marked stays occupied."""
    maps = _maps(lo=(0.0, 0.0), hi=(8.0, 4.0))
    occ = np.zeros(maps.shape, dtype=bool)
    occ[8, 5:36] = occ[13, 5:36] = True  # the corridor's walls, rows 9-12 between them
    occ[10:12, 20:22] = True  # the other robot
    maps.last_hit[0][occ] = 1
    start = maps.lo + (np.array([6, 10]) + 0.5) * 0.2
    goal = maps.lo + (np.array([34, 10]) + 0.5) * 0.2
    here, there = tuple(maps.cell(start)), tuple(maps.cell(goal))
    assert maps.plan(0, start, goal)
    round_about = maps.way_length(0, start)
    assert round_about == pytest.approx(
        astar(_closed_by_brute_force(occ, 0.2, 0.3), here, there).length_cells * 0.2, abs=1e-9)
    robot_xy = maps.lo + np.array([21.0, 11.0]) * 0.2  # the blob's centre
    maps.set_robots(0, robot_xy[None, :])
    rows, cols = np.indices(maps.shape)
    near = np.hypot(maps.lo[0] + (cols + 0.5) * 0.2 - robot_xy[0],
                    maps.lo[1] + (rows + 0.5) * 0.2 - robot_xy[1]) <= maps.robot_radius_m
    assert not (maps.occupied(0) & near).any()
    assert np.array_equal(maps.occupied(0), occ & ~near)
    assert maps.plan(0, start, goal)
    through = astar(_closed_by_brute_force(occ & ~near, 0.2, 0.3), here, there).length_cells * 0.2
    assert maps.way_length(0, start) == pytest.approx(through, abs=1e-9)
    assert through < round_about - 1.0
    maps.add_segments(0, 2, np.array([[robot_xy - [0.3, 0.0], robot_xy + [0.3, 0.0]]]))
    marked = maps.last_shared[0] >= 0
    assert marked.any() and maps.occupied(0)[marked].all()
    maps.set_robots(0, np.zeros((0, 2)))
    assert maps.occupied(0)[occ].all()


def test_the_walls_only_plan_sees_wall_segments_and_not_other_hits():
    """plan(walls_only=True) closes only the cells of wall segments (the robot's own,
    add_walls, or a neighbour's, add_segments), as grid A* on those cells does: a blob of scan
    hits (a rock, a robot) across the way is not there, and a wall the robot later looks
    through is cleared. The ordinary plan still goes round the blob."""
    maps = _maps(lo=(0.0, 0.0), hi=(8.0, 4.0))
    start = maps.lo + (np.array([6, 10]) + 0.5) * 0.2
    goal = maps.lo + (np.array([34, 10]) + 0.5) * 0.2
    here, there = tuple(maps.cell(start)), tuple(maps.cell(goal))
    blob = np.zeros(maps.shape, dtype=bool)
    blob[4:17, 20:22] = True  # hits from the bottom to near the top, across the straight way
    maps.last_hit[0][blob] = 1
    assert maps.plan(0, start, goal, walls_only=True)
    assert maps.way_length(0, start) == pytest.approx(
        astar(np.zeros(maps.shape, dtype=bool), here, there).length_cells * 0.2, abs=1e-9)
    assert maps.plan(0, start, goal)
    around = astar(_closed_by_brute_force(blob, 0.2, 0.3), here, there).length_cells * 0.2
    assert maps.way_length(0, start) == pytest.approx(around, abs=1e-9)
    assert around > 28 * 0.2 + 1.0
    # a wall of the robot's own scan at x = 3 m from y = 0 to 3 m, and a neighbour's at x = 5 m
    # from y = 1 to 4 m: the way snakes between them
    maps.add_walls(0, 2, np.array([[[3.0, 0.0], [3.0, 3.0]]]))
    maps.add_segments(0, 2, np.array([[[5.0, 1.0], [5.0, 4.0]]]))
    walls = (maps.last_wall[0] >= 0)
    assert maps.plan(0, start, goal, walls_only=True)
    snake = astar(_closed_by_brute_force(walls, 0.2, 0.3), here, there).length_cells * 0.2
    assert maps.way_length(0, start) == pytest.approx(snake, abs=1e-9)
    assert snake > 28 * 0.2 + 2.0
    maps.last_free[0][walls & (maps.last_shared[0] < 0)] = 3  # looked through the own wall
    assert maps.plan(0, start, goal, walls_only=True)
    shared = maps.last_shared[0] >= 0
    assert maps.way_length(0, start) == pytest.approx(
        astar(_closed_by_brute_force(shared, 0.2, 0.3), here, there).length_cells * 0.2,
        abs=1e-9)


def test_the_walls_only_plan_of_a_walled_arena_stays_inside_it():
    """With ``walled_m``, plan(walls_only=True) closes the cells outside the arena: a wall
    across the whole 6 m x 4 m arena leaves no way, where an open world's plan goes round its
    end outside the arena (grid A* on the wall's cells). The ordinary plan is not changed."""
    wall = np.array([[[3.0, 0.0], [3.0, 4.0]]])
    start, goal = np.array([1.0, 2.0]), np.array([5.0, 2.0])
    open_world = _maps(lo=(-2.0, -2.0), hi=(8.0, 6.0))
    walled = OwnMaps(1, np.array([-2.0, -2.0]), np.array([8.0, 6.0]), resolution_m=0.2,
                     range_m=3.0, clearance_m=0.3, walled_m=(6.0, 4.0))
    for maps in (open_world, walled):
        maps.add_walls(0, 1, wall)
    here, there = tuple(open_world.cell(start)), tuple(open_world.cell(goal))
    cells = open_world.last_wall[0] >= 0
    assert open_world.plan(0, start, goal, walls_only=True)
    around = astar(_closed_by_brute_force(cells, 0.2, 0.3), here, there).length_cells * 0.2
    assert math.isfinite(around)
    assert open_world.way_length(0, start) == pytest.approx(around, abs=1e-9)
    assert walled.plan(0, start, goal, walls_only=True)
    assert walled.way_length(0, start) == math.inf
    centres = walled.lo + (np.stack(np.nonzero(walled.outside)[::-1], axis=-1) + 0.5) * 0.2
    assert ((centres < 0) | (centres > [6.0, 4.0])).any(axis=1).all()
    assert walled.plan(0, start, goal)  # the ordinary plan does not read the walls layer
    assert walled.way_length(0, start) == pytest.approx(
        astar(np.zeros(walled.shape, dtype=bool), here, there).length_cells * 0.2, abs=1e-9)


def test_free_share_says_where_a_segment_crosses_what_the_robot_sees_free():
    """A robot 2.1 m before a wall: a neighbour's copy of that wall lies on what it sees hit
    (share 0, even a cell off its face), a copy moved 1 m toward the robot lies in what it sees
    free (share 1), a segment beyond its range in what it has never seen (share 0)."""
    maps = _maps()
    wall = [((2.1, -1.0), (2.1, 1.0))]
    maps.update(1, np.array([0]), np.zeros((1, 3)), _scan_of_segments(0.0, 0.0, 0.0, wall)[None],
                ANGLES)
    segments = np.array([[[2.1, -0.8], [2.1, 0.8]], [[1.95, -0.8], [1.95, 0.8]],
                         [[1.1, -0.8], [1.1, 0.8]], [[6.0, 5.0], [7.0, 5.0]],
                         [[20.0, 0.0], [21.0, 0.0]]])
    assert maps.free_share(0, segments).tolist() == [0.0, 0.0, 1.0, 0.0, 0.0]
