"""Each robot's memory of what its own lidar has seen, and the way to its goal through it.

The Bug planner (:mod:`fftnav.navigation.bug`) only looks at the current scan, so a robot that
chose the wrong side of a long wall, or walked into a pocket, has forgotten the walls it saw a
few seconds ago. :class:`OwnMaps` keeps, per robot, a coarse occupancy grid built from that
robot's own scans and poses only (nothing shared, no ground truth beyond the robot's pose): a
cell is *occupied* when the last scan that saw it ended there (a hit) rather than passing
through it (the beam went on), so robots that moved away are cleared when seen through.

:meth:`OwnMaps.waypoint` gives an escaping robot a point about ``lookahead_m`` ahead on the
shortest 8-connected path to its goal through its own map, with cells never seen taken as free
(optimistic: the path tries the unknown, and the map learns the walls it meets). The distance
field to the goal is a Dijkstra run from the goal cell
(:func:`fftnav.optimal.gridgraph.grid_graph`, ``scipy.sparse.csgraph.dijkstra``), recomputed
when asked (the planner asks once a second while a robot escapes). A second layer holds only
wall segments (the robot's own, :meth:`OwnMaps.add_walls`, and its neighbours',
:meth:`OwnMaps.add_segments`): ``plan(..., walls_only=True)`` plans through those alone, the way
a guided robot follows and escapes (:class:`~fftnav.navigation.bug.BugPlanner`, ``guide``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import binary_dilation
from scipy.sparse.csgraph import dijkstra

from fftnav.navigation import kernels
from fftnav.optimal.gridgraph import grid_graph
from fftnav.validate import check_number

__all__ = ["OwnMaps"]

#: A beam clears only the cells it passes at least this far (m) before its reading: a beam
#: grazing a wall passes within a cell of the wall's face well before it hits it, and what
#: should be cleared (a robot that moved away) is smaller than this.
CLEAR_BEFORE_HIT_M = 0.4
#: Nor does it clear a cell next to a hit of the same scan (a wall's face, grazed by beams that
#: hit it farther on).
_RING = np.ones((3, 3), dtype=bool)
#: The 8 neighbour offsets of a cell (row, col).
_NEIGHBOURS = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)])


class OwnMaps:
    """Occupancy grids, one per robot, over the rectangle ``lo``-``hi`` (m).

    Parameters
    ----------
    n_robots : int
        Robots (one grid each).
    lo, hi : array_like, shape (2,)
        Corners ``(x, y)`` of the mapped rectangle (m); points outside it are not mapped and a
        robot outside it gets no waypoint.
    resolution_m : float
        Cell size (m).
    range_m : float
        Lidar range R: a reading of R or more is "no return" (the beam passed).
    clearance_m : float
        Cells within this distance of an occupied cell are closed to paths (the robot radius
        and a margin).
    squeeze_m : float, optional
        ``plan(..., squeeze=True)``: when no way leaves the robot's cell at ``clearance_m`` (its
        pocket is closed, as by another robot standing next to it and seen as an obstacle), the
        way is planned again with the occupied cells dilated only by ``squeeze_m`` (the
        narrower ways). Default: ``clearance_m``; no second plan where ``squeeze_m`` closes the
        same cells as ``clearance_m``.
    walled_m : (float, float), optional
        Width and height (m) of a walled arena with its corner at the origin:
        ``plan(..., walls_only=True)`` also closes the cells whose centres lie outside it
        (nothing beyond its boundary walls is ever seen, so no wall segment closes it).
        Default: none (an open world).

    Attributes
    ----------
    robot_radius_m : float
        :meth:`set_robots`: cells within this distance of where other robots are known to stand
        are not occupied (0.45 m: a robot's radius and half a second of its travel; a class
        attribute, so a subclass may change it).
    """

    robot_radius_m: float = 0.45

    def __init__(self, n_robots: int, lo: np.ndarray, hi: np.ndarray, *, resolution_m: float,
                 range_m: float, clearance_m: float, squeeze_m: float | None = None,
                 walled_m: tuple[float, float] | None = None) -> None:
        for name, value in (("resolution_m", resolution_m), ("range_m", range_m)):
            check_number(name, value, low=0, low_open=True)
        check_number("clearance_m", clearance_m, low=0)
        if squeeze_m is not None:
            check_number("squeeze_m", squeeze_m, low=0, high=clearance_m)
        self.lo = np.asarray(lo, dtype=float)
        self.res, self.range_m = float(resolution_m), float(range_m)
        cols, rows = (np.ceil((np.asarray(hi, float) - self.lo) / self.res).astype(int) + 1)
        self.shape = (int(rows), int(cols))
        #: Control tick of the last hit in / beam through each cell, -1 never.
        self.last_hit = np.full((n_robots, *self.shape), -1, dtype=np.int32)
        self.last_free = np.full((n_robots, *self.shape), -1, dtype=np.int32)
        #: Control tick at which a neighbour's segment last marked a cell (:meth:`add_segments`).
        self.last_shared = np.full((n_robots, *self.shape), -1, dtype=np.int32)
        #: Control tick at which a wall segment, the robot's own or a neighbour's, last marked a
        #: cell (:meth:`add_walls`, :meth:`add_segments`; ``plan(..., walls_only=True)``).
        self.last_wall = np.full((n_robots, *self.shape), -1, dtype=np.int32)
        self._disc = self._disc_of(clearance_m)
        squeezed = None if squeeze_m is None else self._disc_of(squeeze_m)
        same = squeezed is None or np.array_equal(squeezed, self._disc)
        self._squeeze = None if same else squeezed  # None: no narrower way to try
        #: Per robot, where it knows other robots stand (:meth:`set_robots`), (n, 2) m.
        self.robots: dict[int, np.ndarray] = {}
        #: Plans per robot that found no way at the clearance and planned again squeezed.
        self.squeezes = np.zeros(n_robots, dtype=np.int64)
        #: Cells a robot closed itself: the ways of escapes that led nowhere (:meth:`block_way`).
        self.blocked = np.zeros((n_robots, *self.shape), dtype=bool)
        self._field: dict[int, np.ndarray] = {}
        #: The cells outside the walled arena (closed in walls-only plans), None: open world.
        self.outside: np.ndarray | None = None
        if walled_m is not None:
            rows, cols = np.mgrid[0:self.shape[0], 0:self.shape[1]]
            x, y = self.lo[0] + (cols + 0.5) * self.res, self.lo[1] + (rows + 0.5) * self.res
            self.outside = (x < 0) | (y < 0) | (x > walled_m[0]) | (y > walled_m[1])
        self._closed = np.zeros(self.shape, dtype=bool)  # the closed cells of the last plan

    def _disc_of(self, radius_m: float) -> np.ndarray:
        """The cells within ``radius_m`` of a cell (a dilation structure)."""
        reach = int(math.floor(radius_m / self.res + 1e-9))
        di, dj = np.mgrid[-reach:reach + 1, -reach:reach + 1]
        return np.hypot(di, dj) * self.res <= radius_m + 1e-9

    def cell(self, xy: np.ndarray) -> np.ndarray:
        """``(row, col)`` of points ``(..., 2)`` (may lie outside the grid)."""
        ij = np.floor((np.asarray(xy, float) - self.lo) / self.res).astype(np.int64)
        return ij[..., ::-1]

    def inside(self, rc: np.ndarray) -> np.ndarray:
        """Whether cells ``(..., 2)`` lie in the grid."""
        return ((rc[..., 0] >= 0) & (rc[..., 0] < self.shape[0]) & (rc[..., 1] >= 0)
                & (rc[..., 1] < self.shape[1]))

    def update(self, tick: int, robots: np.ndarray, poses: np.ndarray, ranges_m: np.ndarray,
               angles_rad: np.ndarray, *, beam_step: int = 1) -> None:
        """Add the scans ``ranges_m[robots]`` (zero = no reading) taken at ``poses[robots]``,
        every ``beam_step``-th beam.

        Cells a beam passes through (up to CLEAR_BEFORE_HIT_M short of its reading, and not
        next to the cell of a reading of the same scan) are marked seen free at ``tick``; the
        cell of every reading below R is marked hit at ``tick``."""
        step = self.res / 2.0
        samples = np.arange(step, self.range_m, step)
        size = int(math.ceil(2 * self.range_m / self.res)) + 6
        for i in np.asarray(robots, dtype=np.int64).tolist():
            r = ranges_m[i, ::beam_step]
            seen = r > 0
            if not seen.any():
                continue
            x, y, yaw = poses[i]
            ang = angles_rad[::beam_step][seen] + yaw
            rr = np.minimum(r[seen], self.range_m)
            ux, uy = np.cos(ang), np.sin(ang)
            corner = self.cell(np.array([x, y]) - self.range_m - 2 * self.res)
            if kernels_available():  # the same cells, by a compiled loop
                kernels.mark_scan(ux, uy, rr, float(x), float(y), samples, self.lo, self.res,
                                  self.range_m, CLEAR_BEFORE_HIT_M, int(corner[0]),
                                  int(corner[1]), size, tick, self.last_free[i],
                                  self.last_hit[i])
                continue
            along = samples[None, :] <= (rr[:, None] - CLEAR_BEFORE_HIT_M)
            px = x + ux[:, None] * samples[None, :]
            py = y + uy[:, None] * samples[None, :]
            hit = rr < self.range_m * (1.0 - 1e-6)
            hits = self.cell(np.stack([x + ux[hit] * rr[hit], y + uy[hit] * rr[hit]], axis=-1))
            hits = hits[self.inside(hits)]
            # the cells of this scan's hits and around them, in a window around the robot
            near = np.zeros((size, size), dtype=bool)
            near[hits[:, 0] - corner[0], hits[:, 1] - corner[1]] = True
            near = binary_dilation(near, structure=_RING)
            free = self.cell(np.stack([px[along], py[along]], axis=-1))
            free = free[self.inside(free)]
            free = free[~near[free[:, 0] - corner[0], free[:, 1] - corner[1]]]
            self.last_free[i, free[:, 0], free[:, 1]] = tick
            self.last_hit[i, hits[:, 0], hits[:, 1]] = tick

    def add_segments(self, robot: int, tick: int, segments: np.ndarray) -> None:
        """Mark the cells along line segments ``(n, 2, 2)`` (m; walls a neighbour saw) hit at
        ``tick`` in robot ``robot``'s map (its own later looks through them clear them)."""
        self._mark_segments((self.last_hit, self.last_shared, self.last_wall), robot, tick,
                            segments)

    def free_share(self, robot: int, segments: np.ndarray) -> np.ndarray:
        """For each line segment ``(n, 2, 2)`` (m), the share of its cells inside the grid that
        robot ``robot``'s own scans see free with all their 8 neighbours (seen free, and not hit
        since): a segment through such cells lies where the robot sees nothing (0 for a segment
        outside the grid). The one-cell margin forgives a wall placed a cell off its face."""
        free = (self.last_free[robot] >= 0) & (self.last_free[robot] > self.last_hit[robot])
        shares = []
        for a, b in np.asarray(segments, dtype=float).reshape(-1, 2, 2):
            n = int(math.ceil(float(np.hypot(*(b - a))) / (self.res / 2.0))) + 1
            cells = self.cell(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a))
            cells = np.unique(cells[self.inside(cells)], axis=0)
            if not len(cells):
                shares.append(0.0)
                continue
            around = cells[:, None, :] + np.vstack([[0, 0], _NEIGHBOURS])[None, :, :]
            ok = self.inside(around)
            clear = np.where(ok, free[np.clip(around[..., 0], 0, self.shape[0] - 1),
                                      np.clip(around[..., 1], 0, self.shape[1] - 1)], False)
            shares.append(float(clear.all(axis=1).mean()))
        return np.array(shares, dtype=float)

    def add_walls(self, robot: int, tick: int, segments: np.ndarray) -> None:
        """Mark the cells along line segments ``(n, 2, 2)`` (m; walls robot ``robot`` fitted to
        its own scan) as walls at ``tick``: only ``plan(..., walls_only=True)`` reads them."""
        self._mark_segments((self.last_wall,), robot, tick, segments)

    def _mark_segments(self, layers: tuple[np.ndarray, ...], robot: int, tick: int,
                       segments: np.ndarray) -> None:
        for a, b in np.asarray(segments, dtype=float).reshape(-1, 2, 2):
            n = int(math.ceil(float(np.hypot(*(b - a))) / (self.res / 2.0))) + 1
            cells = self.cell(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a))
            cells = cells[self.inside(cells)]
            for layer in layers:
                layer[robot, cells[:, 0], cells[:, 1]] = np.maximum(
                    layer[robot, cells[:, 0], cells[:, 1]], tick)

    def set_robots(self, robot: int, xy: np.ndarray) -> None:
        """Tell robot ``robot``'s map where other robots stand, ``(n, 2)`` m (from their
        messages): from now on its cells within ``robot_radius_m`` of these points are not
        occupied, unless a neighbour's wall segment marked them (:meth:`add_segments`), so
        the way to the goal may pass where a robot stands and a wall never is."""
        self.robots[robot] = np.asarray(xy, dtype=float).reshape(-1, 2)

    def occupied(self, robot: int) -> np.ndarray:
        """Robot ``robot``'s occupancy grid (True: its last look at the cell was a hit, or it
        closed the cell with :meth:`block_way`; but not where :meth:`set_robots` says other
        robots stand)."""
        occupied = (self.last_hit[robot] > self.last_free[robot]) | self.blocked[robot]
        robots = self.robots.get(robot)
        if robots is None or not len(robots):
            return occupied
        reach = int(math.ceil(self.robot_radius_m / self.res)) + 1
        for rc, (x, y) in zip(self.cell(robots), robots, strict=True):
            r0, c0 = max(rc[0] - reach, 0), max(rc[1] - reach, 0)
            r1 = min(rc[0] + reach + 1, self.shape[0])
            c1 = min(rc[1] + reach + 1, self.shape[1])
            if r0 >= r1 or c0 >= c1:
                continue  # outside the map
            rows, cols = np.mgrid[r0:r1, c0:c1]
            near = (np.hypot(self.lo[0] + (cols + 0.5) * self.res - x,
                             self.lo[1] + (rows + 0.5) * self.res - y) <= self.robot_radius_m)
            near &= self.last_shared[robot, r0:r1, c0:c1] < 0
            occupied[r0:r1, c0:c1] &= ~near
        return occupied

    def plan(self, robot: int, xy: np.ndarray, goal: np.ndarray, *,
             squeeze: bool = False, walls_only: bool = False) -> bool:
        """Recompute robot ``robot``'s distance field to ``goal`` (cells within the clearance
        of an occupied cell are closed, except around the robot and the goal; with ``squeeze``,
        planned again at ``squeeze_m`` when that leaves the robot no way); False when the robot
        or the goal lies outside the grid (no field). With ``walls_only``, the occupied cells
        are only those of wall segments (:meth:`add_walls`, :meth:`add_segments`) not seen
        through since, the cells :meth:`block_way` closed and those outside a walled arena
        (``walled_m``): no trunk, rock or robot."""
        here, there = self.cell(xy), self.cell(goal)
        if not (self.inside(here) and self.inside(there)):
            self._field.pop(robot, None)
            return False
        if walls_only:
            occupied = (self.last_wall[robot] > self.last_free[robot]) | self.blocked[robot]
            if self.outside is not None:
                occupied |= self.outside
        else:
            occupied = self.occupied(robot)
        field = self._distances(occupied, self._disc, here, there)
        if squeeze and self._squeeze is not None and not np.isfinite(field[tuple(here)]):
            self.squeezes[robot] += 1
            field = self._distances(occupied, self._squeeze, here, there)
        self._field[robot] = field
        return True

    def _distances(self, occupied: np.ndarray, disc: np.ndarray, here: np.ndarray,
                   there: np.ndarray) -> np.ndarray:
        """Way lengths (cells) to cell ``there`` with ``occupied`` dilated by ``disc`` closed,
        except the cells around ``here`` and ``there``."""
        closed = binary_dilation(occupied, structure=disc)
        for r, c in (here, there):
            closed[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2] = False
        self._closed = closed
        graph = grid_graph(closed, connectivity=8)
        goal_index = int(there[0] * self.shape[1] + there[1])
        return dijkstra(graph, directed=False, indices=goal_index).reshape(self.shape)

    def side_costs(self, robot: int, xy: np.ndarray, goal: np.ndarray, *,
                   radius_m: float, shared_only: bool = False,
                   unknown_cost: float = 1.0) -> tuple[float, float]:
        """Lengths (m) of the shortest ways from ``xy`` to ``goal`` through robot ``robot``'s map
        that pass the obstacle ahead on its left and on its right.

        The map's closed cells (:meth:`plan`) are cut along the goal line, from ``range_m``
        behind the robot to the first closed cell ahead of it (the obstacle); a way on the left
        then starts through a cell at ``radius_m`` left of that cut and cannot cross it, and
        likewise on the right. Either length is ``radius_m`` plus the least distance to the goal
        from such a cell; inf where there is none (both inf when nothing closed lies ahead
        within ``range_m``, and when ``shared_only`` and no neighbour's segment still in the
        map lies within ``range_m`` of that obstacle: nothing they said is about it). With
        ``unknown_cost`` c, a step into or out of a cell never seen (neither hit nor passed) costs
        (1 + c) / 2 times its length, and a step between two such cells c times: ways through
        seen-free space are preferred to ways through the unknown."""
        check_number("unknown_cost", unknown_cost, low=1.0)
        if not self.plan(robot, xy, goal):
            return math.inf, math.inf
        xy, goal = np.asarray(xy, float), np.asarray(goal, float)
        to_goal = goal - xy
        unit = to_goal / max(float(np.hypot(*to_goal)), 1e-9)
        step = self.res / 2.0
        ahead = self.cell(xy + np.arange(step, self.range_m, step)[:, None] * unit)
        ok = self.inside(ahead)
        hit = np.flatnonzero(ok & self._closed[np.clip(ahead[:, 0], 0, self.shape[0] - 1),
                                               np.clip(ahead[:, 1], 0, self.shape[1] - 1)])
        if not len(hit):
            return math.inf, math.inf
        if shared_only:
            block = ahead[hit[0]]
            span = int(math.ceil(self.range_m / self.res))
            r0, c0 = max(block[0] - span, 0), max(block[1] - span, 0)
            told = (self.last_shared[robot, r0:block[0] + span + 1, c0:block[1] + span + 1]
                    > self.last_free[robot, r0:block[0] + span + 1, c0:block[1] + span + 1])
            if not told.any():
                return math.inf, math.inf
        cut = self.cell(xy + np.arange(-self.range_m, step * (hit[0] + 1), step)[:, None] * unit)
        cut = cut[self.inside(cut)]
        closed = self._closed.copy()
        closed[cut[:, 0], cut[:, 1]] = True
        there = self.cell(goal)
        graph = grid_graph(closed, connectivity=8)
        if unknown_cost != 1.0:  # a move costs more through cells never seen
            weight = np.where((self.last_free[robot] < 0) & (self.last_hit[robot] < 0),
                              unknown_cost, 1.0).ravel()
            graph = graph.tocoo()
            graph.data = graph.data * (weight[graph.row] + weight[graph.col]) / 2.0
            graph = graph.tocsr()
        field = dijkstra(graph, directed=True,
                         indices=int(there[0] * self.shape[1] + there[1])).reshape(self.shape)
        here = self.cell(xy)
        reach = int(math.ceil(radius_m / self.res)) + 1
        r0, c0 = max(here[0] - reach, 0), max(here[1] - reach, 0)
        r1, c1 = min(here[0] + reach + 1, self.shape[0]), min(here[1] + reach + 1, self.shape[1])
        rows, cols = np.mgrid[r0:r1, c0:c1]
        rel = self.lo + (np.stack([cols, rows], axis=-1) + 0.5) * self.res - xy
        lateral = unit[0] * rel[..., 1] - unit[1] * rel[..., 0]
        ring = np.abs(np.hypot(rel[..., 0], rel[..., 1]) - radius_m) <= self.res
        cost = field[r0:r1, c0:c1] * self.res + radius_m
        out = []
        for sign in (1, -1):
            on_side = ring & (sign * lateral > 0) & np.isfinite(cost)
            out.append(float(cost[on_side].min()) if on_side.any() else math.inf)
        return out[0], out[1]

    def way_length(self, robot: int, xy: np.ndarray) -> float:
        """Length (m) of the last planned way from ``xy`` to the goal; inf without one."""
        field = self._field.get(robot)
        here = self.cell(xy)
        if field is None or not self.inside(here):
            return math.inf
        return float(field[tuple(here)]) * self.res

    def block_way(self, robot: int, xy: np.ndarray, length_m: float) -> int:
        """Close, in robot ``robot``'s map, the next ``length_m`` of its last planned way from
        ``xy``, beginning one cell beyond the clearance (so the robot is never shut in); the
        number of cells closed (0 without a way).

        The next :meth:`plan` treats them as occupied (dilated by the clearance like any
        obstacle), so it finds another way, or none."""
        field = self._field.get(robot)
        here = self.cell(xy)
        if field is None or not self.inside(here) or not np.isfinite(field[tuple(here)]):
            return 0
        skip = self._disc.shape[0] // 2 + 1  # cells
        way = self._descent(field, here, skip + max(1, int(round(length_m / self.res))))[skip + 1:]
        for r, c in way:
            self.blocked[robot, r, c] = True
        return len(way)

    def waypoint(self, robot: int, xy: np.ndarray, lookahead_m: float) -> np.ndarray | None:
        """The point (m) about ``lookahead_m`` down the last planned field from ``xy`` (steepest
        descent over the 8 neighbours); None without a field or without a way from ``xy``."""
        field = self._field.get(robot)
        here = self.cell(xy)
        if field is None or not self.inside(here) or not np.isfinite(field[tuple(here)]):
            return None
        cell = self._descent(field, here, max(1, int(round(lookahead_m / self.res))))[-1]
        return self.lo + (cell[::-1] + 0.5) * self.res

    def _descent(self, field: np.ndarray, cell: np.ndarray, steps: int) -> list[np.ndarray]:
        """``cell`` and the cells after it down ``field`` (steepest descent over the 8
        neighbours), at most ``steps`` of them, stopping at the goal cell."""
        way = [cell]
        for _ in range(steps):
            nxt = cell + _NEIGHBOURS
            nxt = nxt[self.inside(nxt)]
            values = field[nxt[:, 0], nxt[:, 1]]
            best = int(np.argmin(values))
            if not values[best] < field[tuple(cell)]:
                break  # at the goal cell
            cell = nxt[best]
            way.append(cell)
        return way


def kernels_available() -> bool:
    """Whether :meth:`OwnMaps.update` marks cells by the compiled loop (numba installed)."""
    return kernels.AVAILABLE

