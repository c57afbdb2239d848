"""Bug planner driven by the FFT pipeline's safe directions (paper Sec. IV-B).

The planner never looks at raw ranges to decide where it may go: its input is the safe mask of
:mod:`fftnav.observe.safe` (a beam is safe when the whole safety sector of width alpha around it is
free up to l_th). The state machine, with its leave rule, loop detection, stall recovery and the
no-safe-direction fallback, is documented in ``docs/planner.md``.

Commands (:func:`motion_command`) are rotation in place ``(0, w)`` beyond the heading tolerance
and, within it, motion at ``v_max`` turning toward the heading (``drive = "steered"``, the
default) or straight ``(v_max, 0)`` (``"straight"``: the paper's robots "move straight or
rotate in place").
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

import numpy as np

from fftnav.config import PlannerConfig, SwarmConfig
from fftnav.navigation import corridor
from fftnav.navigation.ownmap import OwnMaps
from fftnav.observe.safe import beam_index, nearest_safe_headings
from fftnav.observe.scan import beam_angles_rad, wrap_angle
from fftnav.optimal.astar import octile
from fftnav.validate import number_field

__all__ = ["Mode", "PlannerParams", "BugPlanner", "corridor_free", "motion_command"]


def corridor_free(
    ranges_m: np.ndarray, angles_rad: np.ndarray, *, half_width_m: float, lookahead_m: float
) -> np.ndarray:
    """Headings along which a short straight move cannot touch anything seen by the scan.

    Heading ``h`` (each beam angle) is free when no scan point ``(d, theta)`` lies in the
    rectangle ``0 < d cos(theta - h) <= lookahead_m``, ``|d sin(theta - h)| < half_width_m``
    ahead of the robot. Zero readings (blind sector, invalid beams) are not points.

    Parameters
    ----------
    ranges_m : ndarray, shape (K, M)
        Sanitised ranges (m).
    angles_rad : ndarray, shape (M,)
        Beam angles (rad, CCW from the heading).
    half_width_m, lookahead_m : float
        Corridor half width (the robot radius plus a margin) and length (m).

    Returns
    -------
    ndarray of bool, shape (K, M)
    """
    reach = math.hypot(lookahead_m, half_width_m)
    if corridor.AVAILABLE:  # the same mask, bit for bit, by a compiled loop
        return corridor.corridor_free_compiled(ranges_m, angles_rad, half_width_m=half_width_m,
                                               lookahead_m=lookahead_m, reach_m=reach)
    free = np.ones(ranges_m.shape, dtype=bool)
    near_all = (ranges_m > 0) & (ranges_m < reach)
    cos_h, sin_h = np.cos(angles_rad)[:, None], np.sin(angles_rad)[:, None]
    for k in np.flatnonzero(near_all.any(axis=1)):
        d, theta = ranges_m[k, near_all[k]], angles_rad[near_all[k]]
        px, py = d * np.cos(theta), d * np.sin(theta)
        x = cos_h * px + sin_h * py  # (headings, points): the points in each heading's frame
        y = cos_h * py - sin_h * px
        free[k] = ~((x > 0) & (x <= lookahead_m) & (np.abs(y) < half_width_m)).any(axis=1)
    return free


def motion_command(target_rad: float, *, tol_rad: float, v_max_mps: float, w_max_radps: float,
                   control_hz: float, drive: str = "straight") -> tuple[float, float]:
    """The planner's motion toward a heading ``target_rad`` (rad, robot frame): ``(v, w)``.

    Beyond ``tol_rad`` of the heading the robot rotates in place,
    ``w = clip(target * control_hz, -w_max, w_max)`` (closing the error in one control period
    where the yaw rate allows). Within it, it drives at ``v_max_mps``: straight (``drive =
    "straight"``, the paper's "move straight or rotate in place"), or turning toward the
    heading by the same ``w`` (``drive = "steered"``).

    >>> motion_command(0.5, tol_rad=0.1, v_max_mps=0.5, w_max_radps=1.5, control_hz=10.0)
    (0.0, 1.5)
    >>> motion_command(0.05, tol_rad=0.1, v_max_mps=0.5, w_max_radps=1.5, control_hz=10.0)
    (0.5, 0.0)
    >>> motion_command(0.05, tol_rad=0.1, v_max_mps=0.5, w_max_radps=1.5, control_hz=10.0,
    ...                drive="steered")
    (0.5, 0.5)
    """
    w = float(np.clip(target_rad * control_hz, -w_max_radps, w_max_radps))
    if abs(target_rad) > tol_rad:
        return (0.0, w)
    return (v_max_mps, w if drive == "steered" else 0.0)


class Mode(IntEnum):
    """Planner state of one robot."""

    GO_TO_GOAL = 0
    FOLLOW = 1
    DONE = 2
    WAIT = 3  # not departed yet


def _positive(default: float) -> Any:
    return number_field(default, low=0, low_open=True)


@dataclass(frozen=True)
class PlannerParams(PlannerConfig):
    """The planner's constants (:class:`~fftnav.config.PlannerConfig`, the ``[planner]``
    section, SI units) with its speed limits and control rate.

    Attributes
    ----------
    v_max_mps, w_max_radps : float
        Speed limits: straight motion at ``v_max_mps``, rotation at most ``w_max_radps``.
    control_hz : float
        Control rate; a rotation command aims to close the heading error in one period.
    """

    v_max_mps: float = _positive(0.5)
    w_max_radps: float = _positive(1.5)
    control_hz: float = _positive(10.0)

    @property
    def heading_tol_rad(self) -> float:
        """``heading_tol_deg`` in radians."""
        return math.radians(self.heading_tol_deg)

    @property
    def way_heading_tol_rad(self) -> float:
        """``way_heading_tol_deg`` in radians."""
        return math.radians(self.way_heading_tol_deg)

    @classmethod
    def for_swarm(cls, config: SwarmConfig, **constants: Any) -> PlannerParams:
        """The ``[planner]`` constants, speed limits and control rate of a swarm configuration;
        ``constants`` override the ``[planner]`` constants.

        >>> from fftnav.config import SwarmConfig
        >>> cfg = SwarmConfig().replace({"planner.heading_tol_deg": 10})
        >>> p = PlannerParams.for_swarm(cfg, replan_s=2)
        >>> round(math.degrees(p.heading_tol_rad), 6), p.replan_s, p.v_max_mps
        (10.0, 2.0, 0.5)
        """
        return cls(v_max_mps=config.robot.v_max_mps, w_max_radps=config.robot.w_max_radps,
                   control_hz=config.episode.control_hz,
                   **{**dataclasses.asdict(config.planner), **constants})


@dataclass
class _Memory:
    mode: Mode = Mode.GO_TO_GOAL
    side: int = 0  # +1 left, -1 right
    hit_dist_m: float = math.inf
    best_dist_m: float = math.inf
    best_time_s: float = 0.0
    flips: int = 0  # loop detections in this follow
    reconsidered: bool = False  # the side was changed by reconsider in this follow
    escape: bool = False  # steering along the own map's way to the goal
    planned_s: float = -math.inf  # when the escape way was last planned
    turn: int = 0  # escape: the side turned to while the way's bearing is unsafe (0: none)
    way_best_m: float = math.inf  # escape: the shortest planned way so far (m) ...
    way_best_s: float = 0.0  # ... and since when
    guided: bool = False  # heading for the goal along the own map's way (the planner's guide)
    guide_s: float = -math.inf  # when that way was last planned
    guide_best_m: float = math.inf  # the shortest guided way so far (m) ...
    guide_best_s: float = 0.0  # ... and since when
    guide_quit_m: float = math.inf  # guidance gave up at this goal distance (m; inf: never)
    on_way: bool = False  # this tick's heading is along the own map's way (escape, guided)
    #: Where the robot was when it last got more than 2 r0 from the previous such point, and
    #: when (the squeezed plan's timer).
    still_xy: tuple[float, float] = (math.nan, math.nan)
    still_s: float = 0.0
    #: Hit points: (x m, y m, goal distance m, side taken).
    hits: list[tuple[float, float, float, int]] = field(default_factory=list)


def _ahead(beta: float, left: float, right: float) -> bool:
    """Whether the nearest safe heading on either side of the goal bearing ``beta`` (rad, robot
    frame; NaN: none) lies within 90 degrees of it: the robot can go on round what blocks it
    without turning back."""
    return any(abs(float(wrap_angle(h - beta))) <= math.pi / 2 for h in (left, right)
               if not math.isnan(h))


@dataclass(frozen=True)
class _View:
    """What one robot's decision looks at, at one tick (arguments of ``_target`` and
    ``_escape_heading``)."""

    pose: np.ndarray  # (3,) x_m, y_m, yaw_rad
    goal: np.ndarray  # (2,)
    safe: np.ndarray  # (M,) its safe mask, clearance guard applied
    dist_m: float  # to the goal
    clear: bool  # the goal direction is safe
    beta: float  # goal bearing, robot frame
    nearest: tuple[float, float]  # the nearest safe headings left and right of the goal


@dataclass
class BugPlanner:
    """Bug planner for ``n_robots`` robots sharing one set of parameters.

    Parameters
    ----------
    n_robots : int
        Number of robots.
    l_th_m : float
        Planning distance of the robot geometry (used only near the goal, see ``step``).
    r0_m : float
        Robot collision radius (the clearance guard's corridor).
    fov_rad : float
        Field of view of the scans whose masks are passed to ``step``.
    params : PlannerParams
        Speed limits and state-machine constants.
    decide : callable
        ``decide(robot) -> +1 (left) | -1 (right)``, called once per decision.
    reconsider : callable, optional
        ``reconsider(robot, side) -> side``, called on the ticks a robot follows a boundary
        before any loop detection and outside escape (policies that revise a side when news
        arrives: ``collab``); a different side is taken at once (the loop-detection timer
        restarts), at most once per follow. None: never.
    wait : callable, optional
        ``wait(robot) -> bool``, asked when a robot heading for its goal finds its goal
        direction blocked with no safe heading within 90 degrees of it (going on would mean
        turning back), while it has stood less than ``give_way_s`` within 2 r0 of one point:
        whether it waits (zero command) for the robots in its way to clear it, having the
        right of way over them (policies with ``walls`` messages). None: never waits.
    guide : callable, optional
        ``guide(robot) -> bool``, asked when a robot heads for its goal: whether it steers
        along its way through the walls of its own map (which may hold what its neighbours saw)
        while that way is more than ``guide_margin_m`` longer than the 8-connected grid
        distance (``collab`` once its gate is open). None: never.
    range_m : float
        Lidar range R (readings of R are "no return" in the robots' own maps).
    area_m : (float, float), optional
        Width and height (m) of the mission area, corner at the origin. The robots' own maps
        cover it, the starts and the goals, and ``map_margin_m`` around them.
    walled : bool
        Whether walls enclose the mission area: the ways through the walls only then stay
        inside it (:class:`OwnMaps`, ``walled_m``).
    """

    n_robots: int
    l_th_m: float
    r0_m: float
    fov_rad: float
    decide: Callable[[int], int]
    params: PlannerParams = field(default_factory=PlannerParams)
    reconsider: Callable[[int, int], int] | None = None
    wait: Callable[[int], bool] | None = None
    guide: Callable[[int], bool] | None = None
    range_m: float = 3.0
    area_m: tuple[float, float] | None = None
    walled: bool = False

    @classmethod
    def for_swarm(cls, n_robots: int, config: SwarmConfig, decide: Callable[[int], int],
                  reconsider: Callable[[int, int], int] | None = None, *,
                  area_m: tuple[float, float] | None = None,
                  wait: Callable[[int], bool] | None = None,
                  guide: Callable[[int], bool] | None = None,
                  walled: bool = False) -> BugPlanner:
        """The planner of ``n_robots`` robots of a swarm configuration (its geometry, lidar field
        of view, speed limits and control rate) in a mission area ``area_m`` (``walled`` or
        not), with the hooks ``decide``, ``reconsider``, ``wait`` and ``guide`` of
        :class:`BugPlanner`."""
        return cls(n_robots, l_th_m=config.geometry.l_th_m, r0_m=config.robot.r0_m,
                   fov_rad=config.sensor.fov_rad, decide=decide,
                   params=PlannerParams.for_swarm(config), reconsider=reconsider, wait=wait,
                   guide=guide, range_m=config.sensor.range_m, area_m=area_m, walled=walled)

    def __post_init__(self) -> None:
        self.memory = [_Memory() for _ in range(self.n_robots)]
        self.decisions = np.zeros((self.n_robots, 2), dtype=np.int64)  # [left, right]
        #: Per robot: control ticks spent following a boundary, ticks in the stall fallback
        #: (both while moving), and loop detections (diagnostics, docs/planner.md).
        self.follow_ticks = np.zeros(self.n_robots, dtype=np.int64)
        self.stall_ticks = np.zeros(self.n_robots, dtype=np.int64)
        self.loop_flips = np.zeros(self.n_robots, dtype=np.int64)
        #: Side changes by ``reconsider``.
        self.reconsidered = np.zeros(self.n_robots, dtype=np.int64)
        #: Ticks in escape; decisions taken from the tried-sides memory.
        self.escape_ticks = np.zeros(self.n_robots, dtype=np.int64)
        self.sides_remembered = np.zeros(self.n_robots, dtype=np.int64)
        #: Ticks waiting for robots in the way (the right of way, ``wait``).
        self.wait_ticks = np.zeros(self.n_robots, dtype=np.int64)
        #: Ticks heading for the goal along the own map's way (``guide``), and the times a
        #: robot gave that way up.
        self.guided_ticks = np.zeros(self.n_robots, dtype=np.int64)
        self.guides_quit = np.zeros(self.n_robots, dtype=np.int64)
        #: Each robot's map of its own scans (made at the first step, over the starts and goals).
        self.maps: OwnMaps | None = None
        self._tick = 0

    def finish(self, robot: int) -> None:
        """Mark a robot as done (arrived or failed): it gets zero commands from now on."""
        self.memory[robot].mode = Mode.DONE

    def hold(self, robot: int) -> None:
        """Keep a robot at its start (zero commands) until :meth:`release`."""
        self.memory[robot].mode = Mode.WAIT

    def release(self, robot: int) -> None:
        """Let a held robot depart toward its goal."""
        self.memory[robot].mode = Mode.GO_TO_GOAL

    def step(
        self,
        time_s: float,
        poses: np.ndarray,
        goals: np.ndarray,
        safe: np.ndarray,
        ranges_m: np.ndarray,
        y1: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Commands for every robot for one control period.

        Parameters
        ----------
        time_s : float
            Episode time.
        poses : ndarray, shape (K, 3)
            ``x_m, y_m, yaw_rad`` of every robot.
        goals : ndarray, shape (K, 2)
            Goal positions.
        safe : ndarray of bool, shape (K, M)
            Safe masks of the robots' current scans.
        ranges_m : ndarray, shape (K, M)
            Sanitised ranges (used only for the near-goal test and the fallback drive check).
        y1 : ndarray, shape (K, M)
            Filtered clipped scan (fallback when no beam is safe: the most open direction).

        Returns
        -------
        commands : ndarray, shape (K, 2)
            ``(v_mps, w_radps)``.
        goal_blocked : ndarray of bool, shape (K,)
            Whether the goal direction was blocked this tick (the robot "meets an obstacle":
            the paper's trigger for broadcasting its observation).
        """
        p = self.params
        k, beams = safe.shape
        angles = beam_angles_rad(beams, self.fov_rad)
        free = corridor_free(ranges_m, angles, half_width_m=self.r0_m + p.clearance_m,
                             lookahead_m=self.r0_m + p.lookahead_m)
        safe = safe & free
        delta = goals - poses[:, :2]
        dist = np.hypot(delta[:, 0], delta[:, 1])
        beta = wrap_angle(np.arctan2(delta[:, 1], delta[:, 0]) - poses[:, 2])
        # A goal outside a partial field of view is neither clear nor blocked: turn to see it.
        visible = np.abs(beta) <= self.fov_rad / 2.0 + 1e-9
        goal_beam = beam_index(beta, beams=beams, fov_rad=self.fov_rad)
        clear = visible & safe[np.arange(k), goal_beam]
        # Near the goal, an obstacle behind the goal must not block it: the beam toward the goal
        # and its two neighbours only need to reach past the goal (and be drivable).
        near = visible & (dist < self.l_th_m)
        if near.any():
            around = np.stack([ranges_m[np.arange(k), np.clip(goal_beam + o, 0, beams - 1)]
                               for o in (-1, 0, 1)])
            clear |= near & free[np.arange(k), goal_beam] & (around.min(axis=0) > dist)
        left, right = nearest_safe_headings(safe, beta, fov_rad=self.fov_rad)
        # contour headings: the first safe beam turning from the right side (passing on the
        # left, obstacle on the right) counter-clockwise, or from the left side clockwise
        moving = np.array([m.mode in (Mode.GO_TO_GOAL, Mode.FOLLOW) for m in self.memory])
        if self.maps is None:
            self.maps = self.new_maps(poses, goals)
        if self._tick % p.map_every == 0:
            self.maps.update(self._tick, np.flatnonzero(moving), poses, ranges_m, angles,
                             beam_step=2)
        self._tick += 1
        commands = np.zeros((k, 2))
        for i in range(k):
            mem = self.memory[i]
            if mem.mode in (Mode.DONE, Mode.WAIT):
                continue
            if not visible[i] and mem.mode == Mode.GO_TO_GOAL:
                commands[i] = self._command(float(beta[i]))
                continue
            x, y = float(poses[i, 0]), float(poses[i, 1])
            if not math.hypot(x - mem.still_xy[0], y - mem.still_xy[1]) <= 2 * self.r0_m:
                mem.still_xy, mem.still_s = (x, y), time_s  # moved (NaN at first: starts here)
            if (self.wait is not None and mem.mode == Mode.GO_TO_GOAL and not clear[i]
                    and time_s - mem.still_s < p.give_way_s - 1e-9
                    and not _ahead(beta[i], left[i], right[i]) and self.wait(i)):
                self.wait_ticks[i] += 1  # the robots in its way give way to it
                continue
            view = _View(poses[i], goals[i], safe[i], float(dist[i]), bool(clear[i]), beta[i],
                         (left[i], right[i]))
            mem.on_way = False
            target = self._target(i, mem, time_s, view)
            self.follow_ticks[i] += mem.mode == Mode.FOLLOW
            if math.isnan(target):  # no safe heading on the chosen side: stall fallback
                self.stall_ticks[i] += 1
                commands[i] = self._stall_command(mem.side, angles, y1[i], ranges_m[i], free[i])
            else:
                commands[i] = self._command(
                    target, p.way_heading_tol_rad if mem.on_way else p.heading_tol_rad)
        return commands, visible & ~clear

    def _target(self, i: int, mem: _Memory, t: float, view: _View) -> float:
        """Heading (rad, robot frame) to steer to; NaN if the chosen side has no safe beam."""
        p = self.params
        left, right = view.nearest
        xy, dist, clear, beta = view.pose[:2], view.dist_m, view.clear, view.beta
        if mem.mode == Mode.FOLLOW:
            if clear and dist < mem.hit_dist_m - p.progress_m:
                mem.mode = Mode.GO_TO_GOAL  # leave rule: goal direction safe and progress made
            else:
                if (self.reconsider is not None and not mem.reconsidered and not mem.escape
                        and mem.flips == 0):
                    side = self.reconsider(i, mem.side)
                    if side != mem.side:  # at most once per follow, before any loop trouble
                        self.reconsidered[i] += 1
                        mem.side, mem.best_time_s, mem.reconsidered = side, t, True
                if dist < mem.best_dist_m - p.progress_m:
                    mem.best_dist_m, mem.best_time_s = dist, t
                looping = t - mem.best_time_s > p.loop_timeout_s
                if not mem.escape and (looping or dist > mem.best_dist_m + p.retreat_m):
                    self.loop_flips[i] += looping  # loop detection
                    mem.flips += looping
                    mem.escape, mem.planned_s, mem.turn = True, -math.inf, 0
                    mem.way_best_m, mem.way_best_s = math.inf, t
                if mem.escape:  # until the leave rule (no way: follow side s meanwhile)
                    heading = self._escape_heading(i, mem, t, view)
                    if heading is not None:
                        self.escape_ticks[i] += 1
                        mem.on_way = True
                        return heading
                if clear:
                    return beta
                return left if mem.side > 0 else right
        if self.guide is not None and self.guide(i):
            heading = self._guided_heading(i, mem, t, view)
            if heading is not None:
                self.guided_ticks[i] += 1
                mem.on_way = True
                return heading
        if clear:
            return beta
        side = self._tried_side(mem, xy, dist)
        if side is None:
            side = self.decide(i)
            if side not in (1, -1):
                raise ValueError(
                    f"a policy must return +1 (left) or -1 (right), got {side!r} for robot {i}"
                )
        else:
            self.sides_remembered[i] += 1
        self.decisions[i, 0 if side > 0 else 1] += 1
        mem.mode, mem.side = Mode.FOLLOW, side
        mem.hit_dist_m = mem.best_dist_m = dist
        mem.best_time_s = t
        mem.flips, mem.escape, mem.reconsidered = 0, False, False
        mem.hits.append((float(xy[0]), float(xy[1]), dist, side))
        return left if side > 0 else right

    def new_maps(self, poses: np.ndarray, goals: np.ndarray) -> OwnMaps:
        """Empty own maps of the robots at ``poses`` ``(n, 3)`` with ``goals`` ``(n, 2)``: they
        cover the mission area, the poses and the goals, and ``map_margin_m`` around them, at
        the planner's cell size and clearances (the maps :meth:`step` makes at its first call)."""
        p = self.params
        reach = np.concatenate([np.asarray(poses, float)[:, :2], np.asarray(goals, float)]
                               + ([[[0.0, 0.0], list(self.area_m)]] if self.area_m else []))
        return OwnMaps(len(poses), reach.min(axis=0) - p.map_margin_m,
                       reach.max(axis=0) + p.map_margin_m,
                       resolution_m=p.map_resolution_m, range_m=self.range_m,
                       clearance_m=p.map_clearance_m, squeeze_m=p.map_squeeze_m,
                       walled_m=self.area_m if self.walled else None)

    def _escape_heading(self, i: int, mem: _Memory, t: float, view: _View) -> float | None:
        """Heading toward the point ``escape_lookahead_m`` along the way to the goal through
        robot ``i``'s own map (replanned every ``replan_s``; through its walls only where the
        planner may guide it): that bearing if it is safe, else the nearest safe heading to it
        on either side; None without a way (or a safe heading)."""
        p, maps = self.params, self.maps
        assert maps is not None
        xy = view.pose[:2]
        if t - mem.planned_s >= p.replan_s - 1e-9:
            mem.planned_s = t
            squeeze = t - mem.still_s >= p.squeeze_after_s - 1e-9
            walls = self.guide is not None and self.guide(i)
            bound_s = p.guide_bound_s if walls else p.escape_bound_s
            maps.plan(i, xy, view.goal, squeeze=squeeze, walls_only=walls)
            way = maps.way_length(i, xy)
            if way < mem.way_best_m - p.progress_m:
                mem.way_best_m, mem.way_best_s = way, t
            elif t - mem.way_best_s > bound_s and maps.block_way(i, xy, p.escape_block_m):
                self.loop_flips[i] += 1  # the way leads nowhere: close it, plan another
                mem.flips += 1
                maps.plan(i, xy, view.goal, squeeze=squeeze, walls_only=walls)
                mem.way_best_m, mem.way_best_s, mem.turn = maps.way_length(i, xy), t, 0
        return self._steer(i, mem, view)

    def _guided_heading(self, i: int, mem: _Memory, t: float, view: _View) -> float | None:
        """Heading toward the point ``escape_lookahead_m`` along robot ``i``'s way to the goal
        through the walls of its own map (``OwnMaps.plan(..., walls_only=True)``, replanned
        every ``replan_s``) while that way is more than ``guide_margin_m`` longer than the grid
        distance, as :meth:`_escape_heading` steers; None otherwise (the robot heads for its
        goal), and until it is R closer than where it gave up a way that led nowhere."""
        p, maps = self.params, self.maps
        assert maps is not None
        xy = view.pose[:2]
        if view.dist_m > mem.guide_quit_m - self.range_m:
            return None
        if t - mem.guide_s >= p.replan_s - 1e-9:
            mem.guide_s = t
            maps.plan(i, xy, view.goal, walls_only=True)
            way = maps.way_length(i, xy)
            grid = octile(maps.cell(view.goal), maps.cell(xy)) * maps.res
            guided = math.isfinite(way) and way > grid + p.guide_margin_m
            if guided and not mem.guided:
                mem.turn, mem.guide_best_m, mem.guide_best_s = 0, way, t
            mem.guided = guided
            if not guided:
                return None
            if way < mem.guide_best_m - p.progress_m:
                mem.guide_best_m, mem.guide_best_s = way, t
            elif t - mem.guide_best_s > p.guide_bound_s:  # the way leads nowhere: give up
                mem.guided, mem.guide_quit_m = False, view.dist_m
                self.guides_quit[i] += 1
                return None
        if not mem.guided:
            return None
        return self._steer(i, mem, view)

    def _steer(self, i: int, mem: _Memory, view: _View) -> float | None:
        """Heading toward the point ``escape_lookahead_m`` down robot ``i``'s last planned
        field: its bearing if safe, else the nearest safe heading on the side kept in
        ``mem.turn``; None without a way (or a safe heading)."""
        p, maps = self.params, self.maps
        assert maps is not None
        safe = view.safe
        xy, yaw = view.pose[:2], float(view.pose[2])
        point = maps.waypoint(i, xy, p.escape_lookahead_m)
        if point is None:
            return None
        bearing = float(wrap_angle(math.atan2(point[1] - xy[1], point[0] - xy[0]) - yaw))
        if abs(bearing) <= self.fov_rad / 2.0 + 1e-9:
            if safe[beam_index(np.array([bearing]), beams=len(safe), fov_rad=self.fov_rad)[0]]:
                mem.turn = 0
                return bearing
        left, right = (float(h[0]) for h in nearest_safe_headings(
            safe[None, :], np.array([bearing]), fov_rad=self.fov_rad))
        if mem.turn == 0:  # the nearer side, kept until the bearing is safe (no dithering)
            dev = [abs(float(wrap_angle(h - bearing))) if not math.isnan(h) else math.inf
                   for h in (left, right)]
            if min(dev) == math.inf:
                return None
            mem.turn = 1 if dev[0] <= dev[1] else -1
        heading = left if mem.turn > 0 else right
        return None if math.isnan(heading) else heading

    def _tried_side(self, mem: _Memory, xy: np.ndarray, dist: float) -> int | None:
        """The side not taken at the latest earlier hit point within ``memory_radius_m`` from
        which the robot has not got closer to the goal (it came back); None if there is none."""
        p = self.params
        for hx, hy, hit_dist, side in reversed(mem.hits):
            if (math.hypot(xy[0] - hx, xy[1] - hy) < p.memory_radius_m
                    and dist > hit_dist - p.progress_m):
                return -side
        return None

    def _stall_command(
        self, side: int, angles: np.ndarray, y1: np.ndarray, ranges_m: np.ndarray,
        free: np.ndarray,
    ) -> tuple[float, float]:
        """No safe beam on side ``side``: head for the most open drivable direction that is
        straight ahead or on that side (largest y1 among beams reading more than l_th / 2);
        if there is none, rotate in place toward ``side``. Only directions on one side are
        considered, so the robot never turns back and forth."""
        p = self.params
        ahead_on_side = angles * side >= -p.heading_tol_rad
        candidates = ahead_on_side & free & (ranges_m > self.l_th_m / 2.0)
        if candidates.any():
            best = int(np.argmax(np.where(candidates, y1, -np.inf)))
            return self._command(float(angles[best]))
        return (0.0, side * p.w_max_radps)

    def _command(self, target_rad: float, tol_rad: float | None = None) -> tuple[float, float]:
        """:func:`motion_command` toward ``target_rad`` with tolerance ``tol_rad`` (default
        ``heading_tol_rad``)."""
        p = self.params
        return motion_command(target_rad, tol_rad=p.heading_tol_rad if tol_rad is None
                              else tol_rad, v_max_mps=p.v_max_mps, w_max_radps=p.w_max_radps,
                              control_hz=p.control_hz, drive=p.drive)
