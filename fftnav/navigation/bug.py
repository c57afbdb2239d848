"""Bug planner driven by the FFT pipeline's safe directions (paper Sec. IV-B).

The planner never looks at raw ranges to decide where it may go: its input is the safe mask of
:mod:`fftnav.observe.safe` (a beam is safe when the whole safety sector of width alpha around it is
free up to l_th). Each robot is in one state of :class:`fftnav.states.State` (go to goal, follow,
escape, guided, wait, done; its memory, :mod:`fftnav.navigation.memory`). The state machine,
with its leave rule, loop detection, escape and guided ways, stall recovery and the
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
from typing import Any

import numpy as np

from fftnav.config import PlannerConfig, SwarmConfig
from fftnav.errors import FftnavError
from fftnav.navigation import kernels
from fftnav.navigation.memory import (
    FOLLOWING,
    HEADING,
    Follow,
    Hit,
    PlannerStats,
    RobotMemory,
    Ways,
)
from fftnav.navigation.ownmap import OwnMaps
from fftnav.observe.safe import beam_index, nearest_safe_headings
from fftnav.observe.scan import beam_angles_rad, wrap_angle
from fftnav.optimal.astar import octile
from fftnav.states import State
from fftnav.validate import number_field

__all__ = ["PlannerParams", "BugPlanner", "corridor_free", "motion_command"]


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
    if kernels.AVAILABLE:  # the same mask, bit for bit, by a compiled loop
        return kernels.corridor_free_compiled(ranges_m, angles_rad, half_width_m=half_width_m,
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
                   control_hz: float, drive: str = PlannerConfig.drive) -> tuple[float, float]:
    """The planner's motion toward a heading ``target_rad`` (rad, robot frame): ``(v, w)``.

    Beyond ``tol_rad`` of the heading the robot rotates in place,
    ``w = clip(target * control_hz, -w_max, w_max)`` (closing the error in one control period
    where the yaw rate allows). Within it, it drives at ``v_max_mps``, turning toward the
    heading by the same ``w`` (``drive = "steered"``, the default of ``[planner]``,
    :attr:`fftnav.config.PlannerConfig.drive`) or straight (``drive = "straight"``, the paper's
    "move straight or rotate in place").

    >>> motion_command(0.5, tol_rad=0.1, v_max_mps=0.5, w_max_radps=1.5, control_hz=10.0)
    (0.0, 1.5)
    >>> motion_command(0.05, tol_rad=0.1, v_max_mps=0.5, w_max_radps=1.5, control_hz=10.0)
    (0.5, 0.5)
    >>> motion_command(0.05, tol_rad=0.1, v_max_mps=0.5, w_max_radps=1.5, control_hz=10.0,
    ...                drive="straight")
    (0.5, 0.0)
    """
    w = float(np.clip(target_rad * control_hz, -w_max_radps, w_max_radps))
    if abs(target_rad) > tol_rad:
        return (0.0, w)
    return (v_max_mps, w if drive == "steered" else 0.0)


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


def _ahead(beta: float, left: float, right: float) -> bool:
    """Whether the nearest safe heading on either side of the goal bearing ``beta`` (rad, robot
    frame; NaN: none) lies within 90 degrees of it: the robot can go on round what blocks it
    without turning back."""
    return any(abs(float(wrap_angle(h - beta))) <= math.pi / 2 for h in (left, right)
               if not math.isnan(h))


@dataclass(frozen=True)
class _View:
    """What one robot's decision looks at, at one tick (:meth:`_Seen.view`)."""

    pose: np.ndarray  # (3,) x_m, y_m, yaw_rad
    goal: np.ndarray  # (2,)
    safe: np.ndarray  # (M,) its safe mask, clearance guard applied
    dist_m: float  # to the goal
    clear: bool  # the goal direction is safe
    beta: float  # goal bearing, robot frame
    nearest: tuple[float, float]  # the nearest safe headings left and right of the goal




@dataclass(frozen=True)
class _Seen:
    """What the planner makes of the swarm's scans at one tick (``BugPlanner._perceive``), one
    row per robot."""

    poses: np.ndarray  # (K, 3)
    goals: np.ndarray  # (K, 2)
    ranges_m: np.ndarray  # (K, M) sanitised ranges
    y1: np.ndarray  # (K, M) filtered clipped scans
    angles: np.ndarray  # (M,) beam angles
    free: np.ndarray  # (K, M) drivable headings (the clearance guard)
    safe: np.ndarray  # (K, M) safe and drivable
    dist: np.ndarray  # (K,) goal distances
    beta: np.ndarray  # (K,) goal bearings, robot frame
    visible: np.ndarray  # (K,) the goal lies in the field of view
    clear: np.ndarray  # (K,) the goal direction is safe
    left: np.ndarray  # (K,) the nearest safe headings left ...
    right: np.ndarray  # (K,) ... and right of the goal bearing (NaN: none)

    def view(self, i: int) -> _View:
        """Robot ``i``'s part."""
        return _View(self.poses[i], self.goals[i], self.safe[i], float(self.dist[i]),
                     bool(self.clear[i]), self.beta[i], (self.left[i], self.right[i]))


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
        (``FOLLOW``) before any loop detection (policies that revise a side when news arrives:
        ``collab``); a different side is taken at once (the loop-detection timer restarts), at
        most once per follow. None: never.
    wait : callable, optional
        ``wait(robot) -> bool``, asked when a robot heading for its goal finds its goal
        direction blocked with no safe heading within 90 degrees of it (going on would mean
        turning back), while it has stood less than ``give_way_s`` within 2 r0 of one point:
        whether it waits (``WAIT``, zero command) for the robots in its way to clear it, having
        the right of way over them (policies with ``walls`` messages). None: never waits.
    guide : callable, optional
        ``guide(robot) -> bool``, asked when a robot heads for its goal: whether it steers
        along its way through the walls of its own map (which may hold what its neighbours saw)
        while that way is more than ``guide_margin_m`` longer than the 8-connected grid
        distance (``GUIDED``; ``collab`` once its gate is open). None: never.
    range_m : float
        Lidar range R (readings of R are "no return" in the robots' own maps).
    area_m : (float, float), optional
        Width and height (m) of the mission area, corner at the origin. The robots' own maps
        cover it, the starts and the goals, and ``map_margin_m`` around them.
    walled : bool
        Whether walls enclose the mission area: the ways through the walls only then stay
        inside it (:class:`OwnMaps`, ``walled_m``).

    Attributes
    ----------
    memory : list of RobotMemory
        Each robot's state (:class:`fftnav.states.State`) and what the states need
        (:mod:`fftnav.navigation.memory`).
    stats : PlannerStats
        The diagnostic counters (decisions, follow, stall, escape, wait and guided ticks, loop
        detections, ...).
    maps : OwnMaps or None
        Each robot's map of its own scans (made at the first step, over the starts and goals).
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
        self.memory = [RobotMemory() for _ in range(self.n_robots)]
        self.stats = PlannerStats(self.n_robots)
        self.maps: OwnMaps | None = None
        self._tick = 0

    def state(self, robot: int) -> State:
        """Robot ``robot``'s state after its last tick."""
        return self.memory[robot].state

    def finish(self, robot: int) -> None:
        """Robot ``robot`` is ``DONE`` (arrived or failed): zero commands from now on."""
        self.memory[robot].state = State.DONE

    def hold(self, robot: int) -> None:
        """Keep a robot at its start (``WAIT``, zero commands) until :meth:`release`."""
        memory = self.memory[robot]
        memory.state, memory.held = State.WAIT, True

    def release(self, robot: int) -> None:
        """Let a held robot depart toward its goal (``GOAL``)."""
        memory = self.memory[robot]
        memory.state, memory.held = State.GOAL, False

    def step(self, time_s: float, poses: np.ndarray, goals: np.ndarray, *, safe: np.ndarray,
             ranges_m: np.ndarray, y1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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
        seen = self._perceive(poses, goals, safe, ranges_m, y1)
        self._map(poses, goals, ranges_m, seen.angles)
        commands = np.zeros((len(safe), 2))
        for i, memory in enumerate(self.memory):
            if memory.state is not State.DONE and not memory.held:
                commands[i] = self._drive(i, memory, time_s, seen)
        return commands, seen.visible & ~seen.clear

    def _perceive(self, poses: np.ndarray, goals: np.ndarray, safe: np.ndarray,
                  ranges_m: np.ndarray, y1: np.ndarray) -> _Seen:
        """The goal distances and bearings, the safe and drivable headings (the clearance guard
        applied to the safe masks), whether each goal direction is clear, and the nearest safe
        headings on either side of it."""
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
        # contour headings: the first safe beam turning from the right side (passing on the
        # left, obstacle on the right) counter-clockwise, or from the left side clockwise
        left, right = nearest_safe_headings(safe, beta, fov_rad=self.fov_rad)
        return _Seen(poses, goals, ranges_m, y1, angles, free, safe, dist, beta, visible, clear,
                     left, right)

    def _map(self, poses: np.ndarray, goals: np.ndarray, ranges_m: np.ndarray,
             angles: np.ndarray) -> None:
        """Make the own maps at the first tick; add the scans of the robots in the world (not
        done, not held) every ``map_every`` ticks."""
        moving = [i for i, m in enumerate(self.memory) if m.state is not State.DONE
                  and not m.held]
        if self.maps is None:
            self.maps = self.new_maps(poses, goals)
        if self._tick % self.params.map_every == 0:
            self.maps.update(self._tick, np.array(moving, dtype=np.int64), poses, ranges_m,
                             angles, beam_step=2)
        self._tick += 1

    def _drive(self, i: int, memory: RobotMemory, time_s: float,
               seen: _Seen) -> tuple[float, float]:
        """Robot ``i``'s command at this tick (it is neither done nor held); its state after
        the tick in ``memory``."""
        p, stats = self.params, self.stats
        if not seen.visible[i] and memory.state in HEADING:
            memory.state = State.GOAL  # it turns to see its goal, neither clear nor blocked
            return self._command(float(seen.beta[i]))
        memory.still.update(float(seen.poses[i, 0]), float(seen.poses[i, 1]), time_s,
                            radius_m=2 * self.r0_m)
        if memory.state in HEADING and self._yields(i, memory, time_s, seen):
            memory.state = State.WAIT  # the robots in its way give way to it
            stats.wait_ticks[i] += 1
            return (0.0, 0.0)
        target, on_way = self._target(i, memory, time_s, seen.view(i))
        stats.follow_ticks[i] += memory.state in FOLLOWING
        if math.isnan(target):  # no safe heading on the follow's side: stall fallback
            stats.stall_ticks[i] += 1
            return self._stall_command(memory.follow.side, seen.angles, seen.y1[i],
                                       seen.ranges_m[i], seen.free[i])
        return self._command(target, p.way_heading_tol_rad if on_way else p.heading_tol_rad)

    def _yields(self, i: int, memory: RobotMemory, time_s: float, seen: _Seen) -> bool:
        """Whether robot ``i``, heading for its goal, waits for the robots in its way: its goal
        direction is blocked, it could go on only by turning back, it has stood less than
        ``give_way_s`` in one place, and ``wait`` says it has the right of way."""
        return (self.wait is not None and not seen.clear[i]
                and time_s - memory.still.since_s < self.params.give_way_s - 1e-9
                and not _ahead(seen.beta[i], seen.left[i], seen.right[i]) and self.wait(i))

    def _target(self, i: int, memory: RobotMemory, time_s: float,
                view: _View) -> tuple[float, bool]:
        """Heading (rad, robot frame) to steer to, NaN if the follow's side has no safe beam;
        and whether it lies along a way through the own map (escape, guided). The leave rule
        ends a follow: the goal direction is safe and the robot got ``progress_m`` closer than
        at the hit point; it then heads for its goal in the same tick."""
        if memory.state in FOLLOWING:
            if view.clear and view.dist_m < memory.follow.hit_m - self.params.progress_m:
                memory.state = State.GOAL
            else:
                return self._follow_target(i, memory, time_s, view)
        return self._heading_target(i, memory, time_s, view)

    def _follow_target(self, i: int, memory: RobotMemory, time_s: float,
                       view: _View) -> tuple[float, bool]:
        """``FOLLOW`` or ``ESCAPE``: a follow escapes once it is ``retreat_m`` farther from the
        goal than its best, or has not beaten its best for ``loop_timeout_s`` (a loop
        detection); an escape steers along its way through the own map, else (no way) goes on
        round the obstacle on its side."""
        p, follow = self.params, memory.follow
        if memory.state is State.FOLLOW:
            self._reconsider(i, follow, time_s)
        follow.progress(view.dist_m, time_s, progress_m=p.progress_m)
        looping = time_s - follow.best_s > p.loop_timeout_s
        if memory.state is State.FOLLOW and (looping or view.dist_m > follow.best_m + p.retreat_m):
            self.stats.loop_flips[i] += looping
            follow.flips += looping
            memory.state = State.ESCAPE
            memory.ways.start_escape(time_s)
        if memory.state is State.ESCAPE:
            heading = self._escape_heading(i, memory, time_s, view)
            if heading is not None:
                self.stats.escape_ticks[i] += 1
                return heading, True
        if view.clear:
            return view.beta, False
        return view.nearest[0] if follow.side > 0 else view.nearest[1], False

    def _reconsider(self, i: int, follow: Follow, time_s: float) -> None:
        """Ask ``reconsider`` for robot ``i``'s side, before any loop detection of the follow
        and at most once per follow; a new side restarts the loop-detection timer."""
        if self.reconsider is None or follow.reconsidered or follow.flips:
            return
        side = self.reconsider(i, follow.side)
        if side != follow.side:
            self.stats.reconsidered[i] += 1
            follow.side, follow.best_s, follow.reconsidered = side, time_s, True

    def _heading_target(self, i: int, memory: RobotMemory, time_s: float,
                        view: _View) -> tuple[float, bool]:
        """``GOAL`` or ``GUIDED``: along the guided way where the planner may guide the robot
        and that way leads round walls; else the goal bearing if the goal direction is safe;
        else a decision (``FOLLOW``) and the nearest safe heading on the side decided."""
        if self.guide is not None and self.guide(i):
            heading = self._guided_heading(i, memory, time_s, view)
            if heading is not None:
                self.stats.guided_ticks[i] += 1
                memory.state = State.GUIDED
                return heading, True
        if view.clear:
            memory.state = State.GOAL
            return view.beta, False
        side = self._decide(i, memory, view)
        memory.state = State.FOLLOW
        memory.follow = Follow.start(side, dist_m=view.dist_m, time_s=time_s)
        memory.hits.append(Hit(float(view.pose[0]), float(view.pose[1]), view.dist_m, side))
        return view.nearest[0] if side > 0 else view.nearest[1], False

    def _decide(self, i: int, memory: RobotMemory, view: _View) -> int:
        """The side of robot ``i``'s new follow: the one not taken at an earlier hit point it
        came back to (the tried-sides memory), else the policy's."""
        p = self.params
        side = memory.tried_side(view.pose[:2], view.dist_m, radius_m=p.memory_radius_m,
                                 progress_m=p.progress_m)
        if side is None:
            side = self.decide(i)
            if side not in (1, -1):
                raise FftnavError(
                    f"a policy must return +1 (left) or -1 (right), got {side!r} for robot {i}"
                )
        else:
            self.stats.sides_remembered[i] += 1
        self.stats.decisions[i, 0 if side > 0 else 1] += 1
        return side

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

    def _escape_heading(self, i: int, memory: RobotMemory, time_s: float,
                        view: _View) -> float | None:
        """Heading toward the point ``escape_lookahead_m`` along the way to the goal through
        robot ``i``'s own map (replanned every ``replan_s``; through its walls only where the
        planner may guide it; closed and planned again when it has not become shorter for
        ``escape_bound_s``, or ``guide_bound_s`` through the walls): that bearing if it is safe,
        else the nearest safe heading to it on either side; None without a way (or a safe
        heading)."""
        p, maps, way = self.params, self.maps, memory.ways.escape
        assert maps is not None
        xy = view.pose[:2]
        if way.due(time_s, p.replan_s):
            way.planned_s = time_s
            squeeze = time_s - memory.still.since_s >= p.squeeze_after_s - 1e-9
            walls = self.guide is not None and self.guide(i)
            bound_s = p.guide_bound_s if walls else p.escape_bound_s
            maps.plan(i, xy, view.goal, squeeze=squeeze, walls_only=walls)
            if (not way.shortened(maps.way_length(i, xy), time_s, progress_m=p.progress_m)
                    and way.stale(time_s, bound_s) and maps.block_way(i, xy, p.escape_block_m)):
                self.stats.loop_flips[i] += 1  # the way leads nowhere: close it, plan another
                memory.follow.flips += 1
                maps.plan(i, xy, view.goal, squeeze=squeeze, walls_only=walls)
                way.best_m, way.best_s, memory.ways.turn = maps.way_length(i, xy), time_s, 0
        return self._steer(i, memory.ways, view)

    def _guided_heading(self, i: int, memory: RobotMemory, time_s: float,
                        view: _View) -> float | None:
        """Heading toward the point ``escape_lookahead_m`` along robot ``i``'s way to the goal
        through the walls of its own map (replanned every ``replan_s``, :meth:`_plan_guide`)
        while that way leads round walls, as :meth:`_escape_heading` steers; None otherwise
        (the robot heads for its goal), and until it is R closer than where it gave up a way
        that led nowhere."""
        ways = memory.ways
        if view.dist_m > ways.quit_m - self.range_m:
            return None
        if ways.guide.due(time_s, self.params.replan_s):
            self._plan_guide(i, ways, time_s, view)
        return self._steer(i, ways, view) if ways.guided else None

    def _plan_guide(self, i: int, ways: Ways, time_s: float, view: _View) -> None:
        """Plan robot ``i``'s way through the walls of its map: it leads round walls when it is
        more than ``guide_margin_m`` longer than the grid distance; it is given up when it has
        not become shorter for ``guide_bound_s``."""
        p, maps = self.params, self.maps
        assert maps is not None
        xy = view.pose[:2]
        ways.guide.planned_s = time_s
        maps.plan(i, xy, view.goal, walls_only=True)
        length = maps.way_length(i, xy)
        grid = octile(maps.cell(view.goal), maps.cell(xy)) * maps.res
        guided = math.isfinite(length) and length > grid + p.guide_margin_m
        if guided and not ways.guided:  # a new guided way: timed from now
            ways.turn, ways.guide.best_m, ways.guide.best_s = 0, length, time_s
        ways.guided = guided
        if (guided and not ways.guide.shortened(length, time_s, progress_m=p.progress_m)
                and ways.guide.stale(time_s, p.guide_bound_s)):
            ways.guided, ways.quit_m = False, view.dist_m  # the way leads nowhere: give up
            self.stats.guides_quit[i] += 1

    def _steer(self, i: int, ways: Ways, view: _View) -> float | None:
        """Heading toward the point ``escape_lookahead_m`` down robot ``i``'s last planned
        field: its bearing if safe, else the nearest safe heading on the side kept in
        ``ways.turn``; None without a way (or a safe heading)."""
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
                ways.turn = 0
                return bearing
        left, right = (float(h[0]) for h in nearest_safe_headings(
            safe[None, :], np.array([bearing]), fov_rad=self.fov_rad))
        if ways.turn == 0:  # the nearer side, kept until the bearing is safe (no dithering)
            dev = [abs(float(wrap_angle(h - bearing))) if not math.isnan(h) else math.inf
                   for h in (left, right)]
            if min(dev) == math.inf:
                return None
            ways.turn = 1 if dev[0] <= dev[1] else -1
        heading = left if ways.turn > 0 else right
        return None if math.isnan(heading) else heading

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
