"""Quadrotor flight through a 3D forest steered by the FFT safe domain (beyond the paper).

Each control tick the drone takes a spherical depth image, filters it with the 2D disc filter
(:class:`fftnav.observe.spherical.DiscFilterBank`) and flies, at constant speed, along the safe
direction
nearest to the goal direction. Directions whose swept body (a cylinder of radius r0) would pass
a reading closer than the protective radius r are never taken (see ``swept_clear``). If no
direction is safe it creeps (a quarter of the speed) towards the largest filtered value y1 (the
least obstructed disc) among the directions that pass that test, the one nearest the target on
ties; if none passes, it hovers. The body is kinematic: its position integrates the commanded 3D
velocity, and collisions are checked along the whole path (``collides_along``).
The simulator is reached only through :mod:`fftnav.sim.drone`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe.geometry import DRONE, RobotGeometry
from fftnav.observe.safe import safe_tolerance
from fftnav.observe.spherical import DiscFilterBank, SphericalGrid
from fftnav.sim.drone import DroneSim, Forest3D, make_forest3d
from fftnav.validate import Checked, check_multiple, number_field

__all__ = ["FlightConfig", "FlightResult", "FLIGHT_COLUMNS", "fly", "summarize", "swept_clear",
           "collides_along"]

#: Columns of the per-seed table written by ``fftnav fly3d``.
FLIGHT_COLUMNS = ("seed", "arrived", "collided", "path_length_m", "straight_line_m", "ratio",
                  "time_s")


@dataclass(frozen=True)
class FlightConfig(Checked):
    """Sensor, controller and episode parameters (SI units, radians).

    Attributes
    ----------
    rows, cols : int
        Spherical image resolution (default 90 x 360: 1 degree steps).
    fov_el_rad, fov_az_rad : float
        Sensor field of view (default 90 x 360 degrees).
    range_m : float
        Sensor range R, metres (default 10).
    geometry : RobotGeometry
        Drone model (default the paper's: l_th = 2.82 m, alpha = 26.7 deg).
    speed_mps : float
        Cruise speed, m/s (default 3).
    control_period_s : float
        Time between depth images, s (default 0.2: the drone moves 0.6 m, well inside l_th - r0);
        an integer multiple of ``step_s``.
    step_s : float
        Integration step, s (default 0.05); collisions are checked along each step.
    max_time_s : float
        Flight time limit, s (default 60).
    arrive_radius_m : float
        Distance to the goal counted as arrival, metres (default 0.5); the straight-line
        reference of a flight is the start-goal distance minus this radius.
    distance_m : float
        Start-goal distance of the generated forest, metres (default 30).
    momentum : float
        Weight of the last commanded velocity direction added to the goal direction to form the
        target direction, finite and ``>= 0`` (default 0.5); damps oscillation in front of
        obstacles.
    """

    rows: int = 90
    cols: int = 360
    fov_el_rad: float = math.pi / 2
    fov_az_rad: float = 2 * math.pi
    range_m: float = 10.0
    geometry: RobotGeometry = DRONE
    speed_mps: float = number_field(3.0, low=0, low_open=True)
    control_period_s: float = number_field(0.2, low=0, low_open=True)
    step_s: float = number_field(0.05, low=0, low_open=True)
    max_time_s: float = number_field(60.0, low=0, low_open=True)
    arrive_radius_m: float = number_field(0.5, low=0, low_open=True)
    distance_m: float = number_field(30.0, low=0, low_open=True)
    momentum: float = number_field(0.5, low=0)

    def _check_together(self) -> None:
        if self.step_s > self.control_period_s:
            raise FftnavError(f"step_s must be <= control_period_s={self.control_period_s}, "
                              f"got step_s={self.step_s}")
        check_multiple("control_period_s", self.control_period_s, "step_s", self.step_s)
        self.filter_bank()  # the sensor grid, the geometry and the range, checked together

    @property
    def substeps(self) -> int:
        """Integration steps per control period."""
        return round(self.control_period_s / self.step_s)

    def filter_bank(self) -> DiscFilterBank:
        """The 2D disc filter bank of this sensor and drone."""
        grid = SphericalGrid(self.rows, self.cols, self.fov_el_rad, self.fov_az_rad)
        return DiscFilterBank(grid, geometry=self.geometry, range_m=self.range_m)


@dataclass(frozen=True)
class FlightResult:
    """Outcome of one flight: ``trajectory`` (n, 3) positions in metres, and its ``forest``."""

    seed: int
    arrived: bool
    collided: bool
    path_length_m: float
    straight_line_m: float
    time_s: float
    trajectory: np.ndarray
    forest: Forest3D

    @property
    def ratio(self) -> float:
        """Path length over the straight start-goal line (dimensionless)."""
        return self.path_length_m / self.straight_line_m

    def row(self) -> dict:
        """One table row with the :data:`FLIGHT_COLUMNS`."""
        return {k: getattr(self, k) for k in FLIGHT_COLUMNS}


def _world_direction(el: float, az: float) -> np.ndarray:
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def swept_clear(
    dirs: np.ndarray, depth_m: np.ndarray, *, r_m: float, r0_m: float, margin_rad: float
) -> np.ndarray:
    """Directions whose swept body clears every reading closer than the protective radius.

    Flying along the unit vector ``u``, a body of radius ``r0`` sweeps a cylinder about the ray
    ``t u, t >= 0``. A reading at distance ``rho < r`` in direction ``p`` lies inside it iff the
    angle between ``u`` and ``p`` is below ``asin(min(1, r0 / rho))``; such ``u`` (plus
    ``margin_rad``, the image's angular sampling) are refused. Each reading is tested on its own,
    so readings on opposite sides (a gap narrower than the body) block both ways. Readings
    farther than r are the disc test's job: its cone of half-angle ``alpha / 2 = asin(r0 / r)``
    keeps them ``>= r0`` from the ray (paper eqs. (1)-(2)).

    Parameters
    ----------
    dirs : numpy.ndarray
        Unit ray directions of the image pixels, shape ``(rows, cols, 3)``.
    depth_m : numpy.ndarray
        Depth image in metres, shape ``(rows, cols)``.
    r_m, r0_m : float
        Protective radius r and body radius r0, metres.
    margin_rad : float
        Extra angle added to each reading's blocking cone, radians.

    Returns
    -------
    numpy.ndarray
        Boolean ``(rows, cols)``: True where the direction is clear.
    """
    close = depth_m < r_m
    clear = np.ones(depth_m.shape, bool)
    if not close.any():
        return clear
    points = dirs[close]
    half = np.arcsin(r0_m / np.maximum(depth_m[close], r0_m)) + margin_rad
    cos_lim = np.cos(np.minimum(half, math.pi))
    flat = dirs.reshape(-1, 3)
    for idx in np.array_split(np.arange(len(points)), -(-len(points) // 256)):  # bounded memory
        clear &= ~np.any(flat @ points[idx].T > cos_lim[idx], axis=1).reshape(clear.shape)
    return clear


def _command(bank: DiscFilterBank, dirs: np.ndarray, depth_m: np.ndarray, target: np.ndarray, *,
             yaw: float, speed: float) -> np.ndarray:
    """Velocity (world frame, m/s) along the safe direction nearest the ``target`` direction.

    ``dirs`` are the grid's unit ray directions (sensor frame, shape (rows, cols, 3)). Only
    directions passing :func:`swept_clear` are taken; with none safe, a quarter speed towards
    the largest y1 among them (nearest the target on ties), and with none at all, zero (hover).
    """
    el_t = math.atan2(target[2], math.hypot(target[0], target[1]))
    az_t = math.atan2(target[1], target[0]) - yaw
    grid, g = bank.grid, bank.geometry
    y1 = bank.filter(depth_m)
    clear = swept_clear(dirs, depth_m, r_m=g.r_m, r0_m=g.r0_m,
                        margin_rad=max(grid.el_step_rad, grid.az_step_rad))
    tol = safe_tolerance(bank.threshold)
    best = bank.nearest_direction(clear & (y1 >= bank.threshold - tol), el_t, az_t)
    if best is None:  # nothing safe: creep towards the least obstructed clear disc
        if not clear.any():
            return np.zeros(3)
        top = np.max(y1[clear])
        best = bank.nearest_direction(clear & (y1 >= top - tol), el_t, az_t)
        speed /= 4
    return speed * _world_direction(best[0], best[1] + yaw)


def collides_along(sim: DroneSim, start: np.ndarray, end: np.ndarray) -> bool:
    """True if the body touches anything anywhere on the segment ``start -> end`` (metres).

    Bodies are placed at most ``d = r0 / 4`` apart, each inflated by the sliver
    ``r0 - sqrt(r0^2 - (d / 2)^2)`` (1.2 mm for r0 = 0.15 m) that the spheres leave uncovered
    between them, so the swept capsule is covered entirely.
    """
    r0 = sim.r0_m
    n = max(1, math.ceil(float(np.linalg.norm(end - start)) / (r0 / 4)))
    d = float(np.linalg.norm(end - start)) / n
    margin = r0 - math.sqrt(r0**2 - (d / 2) ** 2)
    return any(sim.collides(start + (end - start) * (k / n), margin_m=margin)
               for k in range(1, n + 1))


def fly(
    seed: int, config: FlightConfig = FlightConfig(), *, forest: Forest3D | None = None
) -> FlightResult:
    """Fly one seeded forest from start to goal (see the module docstring).

    Parameters
    ----------
    seed : int
        Seed of the forest (``numpy.random.default_rng(seed)``).
    config : FlightConfig, optional
        Sensor, controller and episode parameters.
    forest : Forest3D, optional
        Fly this scene instead of the seeded one (``seed`` is then only recorded).

    Returns
    -------
    FlightResult
        The flight ends on arrival, on the first collision or at ``max_time_s``.
    """
    if forest is None:
        forest = make_forest3d(np.random.default_rng(seed), distance_m=config.distance_m)
    bank = config.filter_bank()
    grid = bank.grid
    dirs = grid.directions()
    pos, yaw, t, v = forest.start.copy(), 0.0, 0.0, np.zeros(3)
    path, arrived, collided = [pos.copy()], False, False
    with DroneSim(forest, grid=grid, range_m=config.range_m, r0_m=config.geometry.r0_m) as sim:
        while t < config.max_time_s and not (arrived or collided):
            to_goal = forest.goal - pos
            target = to_goal / np.linalg.norm(to_goal) + config.momentum * v / config.speed_mps
            v = _command(bank, dirs, sim.scan(pos, yaw), target, yaw=yaw, speed=config.speed_mps)
            if math.hypot(v[0], v[1]) > 1e-6:
                yaw = math.atan2(v[1], v[0])
            for _ in range(config.substeps):
                start, pos = pos, pos + v * config.step_s
                t += config.step_s
                path.append(pos.copy())
                collided = collides_along(sim, start, pos)
                arrived = np.linalg.norm(forest.goal - pos) <= config.arrive_radius_m
                if arrived or collided:
                    break
    traj = np.asarray(path)
    return FlightResult(
        seed=seed, arrived=bool(arrived), collided=bool(collided),
        path_length_m=float(np.sum(np.linalg.norm(np.diff(traj, axis=0), axis=1))),
        straight_line_m=float(np.linalg.norm(forest.goal - forest.start)) - config.arrive_radius_m,
        time_s=round(t, 9), trajectory=traj, forest=forest)


def summarize(results: list[FlightResult]) -> dict:
    """Arrival rate, collision rate and path-length ratio (mean and max over arrived flights)."""
    if not results:
        raise FftnavError("results must hold at least one flight, got results=[]")
    ratios = [r.ratio for r in results if r.arrived]
    return {
        "flights": len(results),
        "arrival_rate": sum(r.arrived for r in results) / len(results),
        "collisions": sum(r.collided for r in results),
        "mean_ratio_arrived": float(np.mean(ratios)) if ratios else math.nan,
        "max_ratio_arrived": float(np.max(ratios)) if ratios else math.nan,
        "mean_time_s_arrived": float(np.mean([r.time_s for r in results if r.arrived]))
        if ratios else math.nan,
    }
