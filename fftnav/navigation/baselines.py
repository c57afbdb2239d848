"""Classic reactive baselines as controllers: ``vfh`` (VFH+), ``ftg`` (Follow-the-Gap) and
``fft-go`` (the FFT safe mask without the Bug planner's memory).

They share the Bug planner's safety rules so that differences come from the choice of
direction: a robot drives only along a heading whose short corridor is free
(:func:`fftnav.navigation.bug.corridor_free`, half width r0 + 3 cm, length r0 + 10 cm), and turns
towards its target heading at most ``w_max`` (closing the error in one control period).
``vfh`` and ``ftg`` drive while turning when the heading error is below ``drive_tol_deg``
(arcs, as their authors' robots did); ``fft-go`` uses the Bug planner's motion
(:func:`~fftnav.navigation.bug.motion_command`), so it differs from the Bug baselines only by
having no memory.

Each class documents its source and parameters; all parameters are class attributes, so a
variant is a subclass (``class WideVFH(VFHController): sector_deg = 10.0``).
"""

from __future__ import annotations

import math

import numpy as np

from fftnav.navigation.bug import corridor_free, motion_command
from fftnav.navigation.controllers import (
    Controller,
    ControllerSetup,
    RobotObservation,
    register_controller,
)
from fftnav.observe.scan import wrap_angle

__all__ = ["FFTGoController", "FTGController", "VFHController", "obstacle_points"]

#: Clearance guard shared with the Bug planner (PlannerParams.clearance_m / lookahead_m).
_CLEARANCE_M, _LOOKAHEAD_M = 0.03, 0.10


def obstacle_points(ranges_m: np.ndarray, angles_rad: np.ndarray, *, range_m: float,
                    window_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Distances and angles of the scan's returns closer than ``window_m`` (and than R).

    Zero readings (blind sector, invalid beams) and misses (R) are not obstacles.

    >>> d, a = obstacle_points(np.array([0.0, 1.0, 3.0, 2.5]), np.arange(4.0), range_m=3.0,
    ...                        window_m=2.0)
    >>> d.tolist(), a.tolist()
    ([1.0], [1.0])
    """
    hit = (ranges_m > 0) & (ranges_m < range_m) & (ranges_m < window_m)
    return ranges_m[hit], angles_rad[hit]


class _Reactive(Controller):
    """Shared motion: corridor guard, heading control, no-way-out rotation."""

    #: Drive while turning when the heading error is below this (degrees).
    drive_tol_deg: float = 10.0

    def __init__(self, setup: ControllerSetup) -> None:
        super().__init__(setup)
        cfg = setup.config
        self.r0_m, self.range_m = cfg.robot.r0_m, cfg.sensor.range_m
        self.control_hz = cfg.episode.control_hz

    def _free(self, obs: RobotObservation) -> np.ndarray:
        """Headings (one per beam) whose short straight corridor is free."""
        return corridor_free(obs.ranges_m[None], obs.angles_rad,
                             half_width_m=self.r0_m + _CLEARANCE_M,
                             lookahead_m=self.r0_m + _LOOKAHEAD_M)[0]

    def _steer(self, obs: RobotObservation, target_rad: float, free: np.ndarray
               ) -> tuple[float, float]:
        """Turn toward ``target_rad``; drive when nearly aligned and the way ahead is free."""
        err = float(wrap_angle(target_rad))
        w = float(np.clip(err * self.control_hz, -self.w_max_radps, self.w_max_radps))
        ahead = int(np.argmin(np.abs(wrap_angle(obs.angles_rad))))
        if abs(err) <= math.radians(self.drive_tol_deg) and free[ahead]:
            return self.v_max_mps, w
        return 0.0, w


@register_controller("vfh")
class VFHController(_Reactive):
    """VFH+: the Vector Field Histogram of Ulrich and Borenstein (1998) on the lidar scan.

    I. Ulrich and J. Borenstein, "VFH+: Reliable obstacle avoidance for fast mobile robots",
    IEEE ICRA 1998, pp. 1572-1577. Steps, per robot and tick:

    1. *Primary polar histogram* over sectors of ``sector_deg``: every return at distance
       ``d < window_m`` has magnitude ``m = 1 - (d / window_m)^2`` (the paper's ``a - b d^2``
       with certainty 1, scaled to [0, 1]) and is enlarged by ``gamma = asin(r_rs / d)``,
       ``r_rs = r0 + safety_m``; a sector holds the largest magnitude whose enlarged interval
       covers it.
    2. *Binary histogram* with hysteresis: blocked above ``tau_high``, free below ``tau_low``,
       else as in the previous tick (per robot).
    3. *Masked histogram*: the robot turns in place, so no trajectory mask (curvature 0).
    4. *Candidates*: in each opening (run of free sectors), its centre if narrower than
       ``s_max`` sectors, else the sectors ``s_max / 2`` inside either border, plus the goal
       sector if it lies in the opening.
    5. *Cost* ``mu1 D(c, goal) + mu2 D(c, heading) + mu3 D(c, previous)`` (D in sectors,
       circular); the cheapest candidate is steered to. The paper's rule ``mu1 > mu2 + mu3``
       holds for the defaults 5, 2, 2.

    With every sector blocked the robot rotates in place towards its previous direction.

    Parameters (class attributes): ``sector_deg`` = 5, ``window_m`` = 2.0, ``safety_m`` = 0.1,
    ``tau_low`` = 0.64 and ``tau_high`` = 0.84 (returns beyond 1.2 m never block, nearer than
    0.8 m always do), ``s_max`` = 16, ``mu`` = (5, 2, 2), ``drive_tol_deg`` = 10.
    """

    sector_deg: float = 5.0
    window_m: float = 2.0
    safety_m: float = 0.10
    tau_low: float = 0.64
    tau_high: float = 0.84
    s_max: int = 16
    mu: tuple[float, float, float] = (5.0, 2.0, 2.0)
    uses_pipeline = False

    def __init__(self, setup: ControllerSetup) -> None:
        super().__init__(setup)
        self.sectors = int(round(360.0 / self.sector_deg))
        self.alpha = 2.0 * math.pi / self.sectors
        self.binary = np.zeros((setup.n_robots, self.sectors), dtype=bool)
        self.previous = np.full(setup.n_robots, -1, dtype=np.int64)  # last chosen sector

    def _sector(self, angle: np.ndarray | float) -> np.ndarray:
        """Sector index of angles (sector k is centred on angle ``k * sector_deg``)."""
        return np.rint(np.asarray(wrap_angle(angle)) / self.alpha).astype(np.int64) % self.sectors

    def histogram(self, ranges_m: np.ndarray, angles_rad: np.ndarray) -> np.ndarray:
        """The primary polar histogram of returns at ``angles_rad``, shape ``(sectors,)``;
        sector k is centred on angle ``k * sector_deg`` (CCW, in the frame of the angles)."""
        d, theta = obstacle_points(ranges_m, angles_rad, range_m=self.range_m,
                                   window_m=self.window_m)
        hist = np.zeros(self.sectors)
        if len(d) == 0:
            return hist
        m = 1.0 - (d / self.window_m) ** 2
        gamma = np.arcsin(np.minimum(1.0, (self.r0_m + self.safety_m) / d))
        width = int(math.ceil(math.pi / 2 / self.alpha)) + 1
        offsets = np.arange(-width, width + 1)
        centre = np.rint(wrap_angle(theta) / self.alpha).astype(np.int64)
        sector = centre[:, None] + offsets[None, :]
        covered = np.abs(wrap_angle(sector * self.alpha - theta[:, None])) <= gamma[:, None]
        np.maximum.at(hist, sector[covered] % self.sectors,
                      np.broadcast_to(m[:, None], covered.shape)[covered])
        return hist

    def act(self, obs: RobotObservation) -> tuple[float, float]:
        # The histogram is kept in the world frame, as in the paper (it does not turn with the
        # robot, so the hysteresis and the previous direction keep their meaning).
        i, n, yaw = obs.robot, self.sectors, float(obs.pose[2])
        hist = self.histogram(obs.ranges_m, obs.angles_rad + yaw)
        binary = self.binary[i]
        binary[hist > self.tau_high] = True
        binary[hist < self.tau_low] = False
        free = self._free(obs)
        goal = int(self._sector(yaw + obs.goal_bearing_rad))
        heading = int(self._sector(yaw))
        prev = goal if self.previous[i] < 0 else int(self.previous[i])
        if binary.all():
            side = float(np.sign(wrap_angle(prev * self.alpha - yaw)) or 1.0)
            return 0.0, side * self.w_max_radps
        candidates = self._candidates(binary, goal)

        def dist(a: np.ndarray, b: int) -> np.ndarray:
            delta = np.abs(a - b) % n
            return np.minimum(delta, n - delta)

        c = np.array(candidates)
        cost = (self.mu[0] * dist(c, goal) + self.mu[1] * dist(c, heading)
                + self.mu[2] * dist(c, prev))
        best = int(c[int(np.argmin(cost))])
        self.previous[i] = best
        target = best * self.alpha - yaw
        if best == goal:
            target = obs.goal_bearing_rad
        return self._steer(obs, float(wrap_angle(target)), free)

    def _candidates(self, binary: np.ndarray, goal: int) -> list[int]:
        """Candidate sectors of the openings of a binary histogram (not all blocked)."""
        n = self.sectors
        start = int(np.argmax(binary)) if binary.any() else 0  # begin at a blocked sector
        order = (start + np.arange(n)) % n
        out: list[int] = []
        run: list[int] = []
        for k in [*order.tolist(), start]:
            if not binary[k] and not (run and k == start):
                run.append(k)
                continue
            if run:
                size = len(run)
                if size <= self.s_max:
                    out.append(run[size // 2])
                else:
                    out += [run[self.s_max // 2], run[-1 - self.s_max // 2]]
                    if goal in run:
                        out.append(goal)
                run = []
        return out


@register_controller("ftg")
class FTGController(_Reactive):
    """Follow-the-Gap (Sezer and Gokasan 2012) on the lidar scan.

    V. Sezer and M. Gokasan, "A novel obstacle avoidance algorithm: Follow the Gap Method",
    Robotics and Autonomous Systems 60(9), 2012, pp. 1123-1134. Per robot and tick:

    1. Every return closer than ``window_m`` blocks the beams within
       ``asin((r0 + safety_m) / d)`` of it (the obstacle enlarged by the robot's radius).
    2. The gaps are the runs of unblocked beams within ``fov_deg`` (the paper's robot looks
       forward over 180 deg); the widest is chosen and its centre angle ``phi_gap`` is the
       bisector of its borders.
    3. The final heading blends the gap centre with the goal bearing ``phi_goal``:
       ``(alpha / d_min * phi_gap + beta * phi_goal) / (alpha / d_min + beta)``, with
       ``d_min`` the nearest return (paper eq. 5): near obstacles the gap wins, in the open the
       goal. If the blended heading's corridor is not free, the gap centre is used.

    With no gap the robot rotates in place towards the goal side.

    Parameters (class attributes): ``window_m`` = 2.0, ``safety_m`` = 0.1, ``fov_deg`` = 180,
    ``alpha`` = 1.0 (m), ``beta`` = 1.0, ``drive_tol_deg`` = 10.
    """

    window_m: float = 2.0
    safety_m: float = 0.10
    fov_deg: float = 180.0
    alpha: float = 1.0
    beta: float = 1.0
    uses_pipeline = False

    def blocked(self, ranges_m: np.ndarray, angles_rad: np.ndarray) -> np.ndarray:
        """Beams blocked by the enlarged returns within the window, shape ``(M,)``."""
        d, theta = obstacle_points(ranges_m, angles_rad, range_m=self.range_m,
                                   window_m=self.window_m)
        if len(d) == 0:
            return np.zeros(len(angles_rad), dtype=bool)
        half = np.arcsin(np.minimum(1.0, (self.r0_m + self.safety_m) / d))
        return (np.abs(wrap_angle(angles_rad[:, None] - theta[None, :])) <= half).any(axis=1)

    def widest_gap(self, ranges_m: np.ndarray, angles_rad: np.ndarray) -> float | None:
        """Centre angle (rad) of the widest gap within the field of view, None if none."""
        inside = np.abs(wrap_angle(angles_rad)) <= math.radians(self.fov_deg) / 2.0 + 1e-9
        open_ = inside & ~self.blocked(ranges_m, angles_rad) & (ranges_m > 0)
        best, best_width = None, -1.0
        idx = np.flatnonzero(open_)
        if len(idx) == 0:
            return None
        for run in np.split(idx, np.flatnonzero(np.diff(idx) != 1) + 1):
            a, b = float(angles_rad[run[0]]), float(angles_rad[run[-1]])
            if b - a > best_width:
                best, best_width = 0.5 * (a + b), b - a
        return best

    def act(self, obs: RobotObservation) -> tuple[float, float]:
        goal = obs.goal_bearing_rad
        gap = self.widest_gap(obs.ranges_m, obs.angles_rad)
        if gap is None:
            return 0.0, math.copysign(self.w_max_radps, goal)
        d, _ = obstacle_points(obs.ranges_m, obs.angles_rad, range_m=self.range_m,
                               window_m=self.range_m)
        free = self._free(obs)
        if len(d) == 0:
            target = goal
        else:
            weight = self.alpha / float(d.min())
            target = (weight * gap + self.beta * goal) / (weight + self.beta)
        beam = int(np.argmin(np.abs(wrap_angle(obs.angles_rad - target))))
        if not free[beam]:
            target = gap
        return self._steer(obs, target, free)


@register_controller("fft-go")
class FFTGoController(_Reactive):
    """Drive to the safe heading of the FFT mask nearest the goal, with no Bug memory.

    The paper's observation (Sec. III-C: the safe mask of the FFT-filtered scan, with the Bug
    planner's clearance guard) without its planner: each tick the robot steers to the goal
    bearing if it is safe, else to the safe beam nearest the goal bearing on either side, ties
    (within ``turn_weight`` times the turn) going to the smaller turn: without that rule a
    robot facing an obstacle straight on turns back and forth between two equally good beams.
    It uses the Bug planner's motion (:func:`~fftnav.navigation.bug.motion_command` with the
    config's ``planner.heading_tol_deg`` and ``planner.drive``). Near the goal (closer than
    l_th) the goal counts as reachable when the three beams around it reach past it, as in the
    planner. With no safe beam it heads
    for the most open drivable beam (largest y1) or rotates in place. It is the ablation "FFT
    mask, no Bug state machine": no follow mode, no leave rule, no loop detection.

    Parameter (class attribute): ``turn_weight`` = 0.1 (cost of a beam: its angle to the goal
    plus ``turn_weight`` times its angle to the heading).
    """

    turn_weight: float = 0.1
    uses_pipeline = True

    def act(self, obs: RobotObservation) -> tuple[float, float]:
        free = self._free(obs)
        safe = obs.safe_mask & free
        beams = len(obs.angles_rad)
        beta, dist = obs.goal_bearing_rad, obs.goal_distance_m
        diff = np.abs(wrap_angle(obs.angles_rad - beta))
        goal_beam = int(np.argmin(diff))
        clear = bool(safe[goal_beam]) and diff[goal_beam] <= math.pi / beams * 2
        if not clear and dist < self.config.geometry.l_th_m:
            around = obs.ranges_m[[(goal_beam + o) % beams for o in (-1, 0, 1)]]
            clear = bool(free[goal_beam]) and float(around.min()) > dist
        if clear:
            target = beta
        elif safe.any():  # nearest the goal; the smaller turn breaks (near) ties
            cost = diff + self.turn_weight * np.abs(obs.angles_rad)
            target = float(obs.angles_rad[int(np.argmin(np.where(safe, cost, np.inf)))])
        else:
            drivable = free & (obs.ranges_m > self.config.geometry.l_th_m / 2.0)
            if not drivable.any():
                return 0.0, math.copysign(self.w_max_radps, beta)
            target = float(obs.angles_rad[int(np.argmax(np.where(drivable, obs.y1, -np.inf)))])
        planner = self.config.planner
        return motion_command(target, tol_rad=math.radians(planner.heading_tol_deg),
                              v_max_mps=self.v_max_mps, w_max_radps=self.w_max_radps,
                              control_hz=self.control_hz, drive=planner.drive)
