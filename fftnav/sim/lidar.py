"""Simulated 2D lidar for a whole swarm: one batched PyBullet ray test per tick.

Beams lie in the robot's yaw-only frame at the lidar height, ordered from -Theta/2 to +Theta/2
relative to the heading (``fftnav.observe.scan.beam_angles_rad``, paper Sec. IV-B: M = 360, R = 3 m,
Theta = 360 deg, a 15 deg blind sector at the back reading 0).

Only rays that can hit something are cast: a ray whose direction lies outside the angular
sector that every obstacle and every other robot within range R subtends (the exact sector of
a circle, or of a convex polygon's vertices) cannot hit anything, so it reads R without a
Bullet query. The shapes are widened by ``CULL_MARGIN_M``, so the scan is bit-identical to
casting every ray.

With numba and sphere robots (the "body" embodiment), the whole scan is one compiled kernel,
:func:`fftnav.sim.fastrays.scan_swarm`: for each robot, each obstacle and each other robot
within range R picks the rays of its angular span (its bounding circle widened by a margin),
and those rays are answered with Bullet's own arithmetic: the ray-triangle test on the
obstacle's side faces, the ray-sphere cast (``btGjkConvexCast``) on the robot; the nearer hit
is the reading, as Bullet's closest hit. Both copies flag the rare casts whose outcome they
cannot be sure of (a hit near a triangle's edge, a grazing cast that runs out of steps), and
those rays alone go to Bullet. The scan is bit-identical to casting every ray in the full
client (``tests/sim/test_lidar.py``, and ``fftnav bench sim`` checks it on every tick).

Without numba (or for the wheeled robot), rays are culled by the exact sector of every body
within range (``_may_hit``; widened by ``CULL_MARGIN_M``), the rays that can hit an obstacle but
no robot go to a second, static physics client holding only the obstacles' mesh
(``static_client``: about twice as fast as the client where the robots move, the same hit
fraction bit for bit) and the rays in a robot's sector to the full client.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe.scan import angle_increment_rad, beam_angles_rad
from fftnav.sim import fastrays
from fftnav.sim.rays import cast_rays

__all__ = ["CULL_MARGIN_M", "BeamPattern", "Lidar", "RayTargets"]

#: Widening of every body's outline when culling rays (m): far above Bullet's collision margins
#: and floating-point error, so no ray that Bullet would report as a hit is ever culled.
CULL_MARGIN_M = 0.02


@dataclass(frozen=True)
class BeamPattern:
    """The beams of one lidar model.

    Attributes
    ----------
    beams : int
        Number of beams M.
    range_m : float
        Maximum range R in metres; a ray that hits nothing reads R.
    fov_deg : float
        Field of view Theta in degrees (360 for a full circle).
    blind_deg : float
        Width of the blind sector centred on the back (degrees): the beams whose direction lies
        strictly inside it, ``|angle| > 180 - blind_deg / 2``, read 0 (as in ``fftnav.world.scenes``
        and ``fftnav.observe.compress``); a beam on its edge stays live, so with ``blind_deg = 0``
        every beam is live.
    height_m : float
        Height of the beams above the ground, metres.
    start_m : float
        Rays start this far from the robot centre (just outside the robot's own body), so a
        robot never sees itself; the reported range is still measured from the centre:
        ``start + hitFraction * (R - start)``.
    """

    beams: int
    range_m: float
    fov_deg: float
    blind_deg: float
    height_m: float
    start_m: float


@dataclass(frozen=True)
class RayTargets:
    """What the rays of a :class:`Lidar` can hit.

    Attributes
    ----------
    mask : int
        Bullet collision-filter mask of the rays (which body groups they can hit).
    bodies : sequence of (circle, vertices), optional
        Static bodies the rays can hit: a circle ``(x m, y m, radius m)`` whose vertical
        cylinder contains the body, and optionally points ``(n, 2)`` (m) whose angular span,
        seen from outside, covers it (a convex body's outline), or None (the obstacles'
        ``bounding_circle()`` and ``cull_vertices()``).
    robot_radius_m : float, optional
        Radius of a vertical cylinder about each robot's centre that contains every part of the
        robot the rays can hit (m).
    robot_mask : int, optional
        Bullet collision-filter mask that selects the robots alone.
    robot_spheres : bool, optional
        The robots are spheres of radius ``robot_radius_m`` (the "body" embodiment): with numba,
        ``cull``, ``static_mesh`` and ``robot_mask``, and given the spheres' centre heights
        (``scan(..., robot_z=...)``), the scan is :func:`fftnav.sim.fastrays.scan_swarm`.
    """

    mask: int
    bodies: Sequence[tuple[tuple[float, float, float], np.ndarray | None]] = ()
    robot_radius_m: float = 0.0
    robot_mask: int | None = None
    robot_spheres: bool = False


class Lidar:
    """Ray pattern of one lidar model, cast for K robots at once.

    Parameters
    ----------
    client : int
        PyBullet physics client id.
    pattern : BeamPattern
        The beams: number M, range R, field of view, blind sector, height and start.
    targets : RayTargets
        What the rays can hit: their collision mask, the static bodies' outlines and the robots.
    cull : bool, optional
        Cast only the rays that point into a body's sector (default); False casts every live
        beam in ``client`` (same ranges, slower: kept for tests and benchmarks).
    static_client : int, optional
        A physics client holding the same static bodies as ``client`` and no robot: the culled
        rays outside every robot's sector are cast there (faster). None: all in ``client``.
    static_mesh : fftnav.sim.fastrays.StaticMesh, optional
        The static bodies' triangles: with numba and ``robot_mask``, every cast ray is answered
        against them by :func:`fftnav.sim.fastrays.cast_static` (Bullet's arithmetic, bit for
        bit, several times faster), and only the rays in a robot's sector go to Bullet, against
        the robots alone (``targets.robot_mask``); the nearer hit counts, as in Bullet. Set
        ``static_mesh = None`` to cast every ray in Bullet.
    prepare : callable, optional
        Called with the robots' positions ``(K, 2)`` before each scan casts a ray (the
        simulator builds the obstacle tiles within range of them there).
    """

    def __init__(self, client: int, pattern: BeamPattern, targets: RayTargets, *,
                 cull: bool = True, static_client: int | None = None,
                 static_mesh: fastrays.StaticMesh | None = None,
                 prepare: Callable[[np.ndarray], None] | None = None) -> None:
        beams, fov_deg, bodies = pattern.beams, pattern.fov_deg, targets.bodies
        self._client = client
        self._prepare = prepare
        self._static_client = static_client
        self.static_mesh = static_mesh if fastrays.AVAILABLE else None
        self._robot_mask = targets.robot_mask
        self.robot_spheres = bool(targets.robot_spheres)
        self.range_m = float(pattern.range_m)
        self.angles_rad = beam_angles_rad(beams, math.radians(fov_deg))
        #: Beams outside the blind sector (the only ones cast). The edge is compared with a
        #: tolerance of 1e-6 beam, far below the beam spacing and far above rounding errors, so
        #: a beam on the edge (the back beam when blind_deg = 0) is live however it rounds.
        edge = math.pi - math.radians(pattern.blind_deg) / 2.0
        tolerance = 1e-6 * angle_increment_rad(beams, math.radians(fov_deg))
        self.live = np.abs(self.angles_rad) <= edge + tolerance
        self._start_m = float(pattern.start_m)
        self._height_m = float(pattern.height_m)
        self._mask = int(targets.mask)
        # Static bodies as bounding circles (centre, radius), some also by vertices (padded by
        # repeating the first one; NaN rows for bodies without).
        self._circles = np.reshape(np.array([c for c, _ in bodies], dtype=float), (-1, 3))
        outlines = [None if xy is None else np.asarray(xy, dtype=float) for _, xy in bodies]
        size = max((len(xy) for xy in outlines if xy is not None), default=1)
        self._vertices = np.full((len(self._circles), size, 2), np.nan)
        for i, xy in enumerate(outlines):
            if xy is not None:
                self._vertices[i] = np.concatenate([xy, np.repeat(xy[:1], size - len(xy), axis=0)])
        self._robot_radius_m = float(targets.robot_radius_m)
        # the beam pattern for the compiled scan: beam n at first + n step from the heading,
        # and its column among the live beams (-1: blind)
        m = self.angles_rad.size
        self._first_rad = float(self.angles_rad[0])
        self._step_rad = (float(self.angles_rad[-1] - self.angles_rad[0]) / (m - 1) if m > 1
                          else 2.0 * math.pi)
        self._live_index = np.where(self.live, np.cumsum(self.live) - 1, -1).astype(np.int64)
        self.cull = bool(cull)
        #: Wall-clock seconds spent in ``scan`` so far (read by the speed bench).
        self.seconds_spent = 0.0
        #: Rays actually cast so far (after culling), and those of them cast in the static client.
        self.rays_cast = 0
        self.rays_cast_static = 0
        #: Of the rays answered by the compiled obstacle test, those whose hit lay too near a
        #: triangle edge to be sure, re-cast in Bullet's static client.
        self.rays_asked_bullet = 0
        #: Of the rays answered by the compiled sphere cast, those it was unsure of (re-cast in
        #: Bullet against the robots).
        self.robot_rays_asked_bullet = 0

    def scan(self, poses: np.ndarray, robot_z: np.ndarray | None = None) -> np.ndarray:
        """Ranges ``(K, M)`` in metres for robots at ``poses`` ``(K, 3)`` (x m, y m, yaw rad).

        The rays that can hit something (all live beams if ``cull`` is False) of all robots go
        in one ``rayTestBatch`` call (``fftnav.sim.rays.cast_rays``, split only above Bullet's
        batch limit) or to the compiled tests; the other live beams read R and blind-sector
        beams read 0. ``robot_z`` ``(K,)``: height of each robot's sphere centre (m), for the
        compiled sphere cast (``robot_spheres``); None casts robot rays in Bullet.
        """
        tic = time.perf_counter()
        poses = np.asarray(poses, dtype=float)
        k = len(poses)
        if robot_z is not None and np.shape(robot_z) != (k,):
            raise FftnavError(f"robot_z must have shape ({k},), one height per pose, "
                              f"got shape={np.shape(robot_z)}")
        out = np.zeros((k, self.angles_rad.size))
        if k == 0:
            return out
        if self._prepare is not None:
            self._prepare(poses[:, :2])
        theta = poses[:, 2:3] + self.angles_rad[self.live]
        direction = np.stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)], axis=-1)
        centres = np.c_[poses[:, :2], np.full(k, self._height_m)]
        compiled_mesh = (self.cull and self.static_mesh is not None
                         and self._robot_mask is not None)
        if compiled_mesh and self.robot_spheres and robot_z is not None:
            fractions = self._scan_compiled(poses, np.asarray(robot_z, dtype=float), centres,
                                            direction)
        elif compiled_mesh:
            fractions = self._scan_static_compiled(poses, centres, direction)
        else:
            fractions = self._scan_bullet(poses, centres, direction)
        out[:, self.live] = self._start_m + fractions * (self.range_m - self._start_m)
        self.seconds_spent += time.perf_counter() - tic
        return out

    def _scan_static_compiled(self, poses: np.ndarray, centres: np.ndarray,
                              direction: np.ndarray) -> np.ndarray:
        """Hit fractions ``(K, L)`` of every live ray, the culled ones cast: against the
        obstacles by the compiled copy of Bullet's triangle test (:meth:`_cast_static`), the
        rays in a robot's sector also by Bullet against the robots alone; the nearer counts."""
        fractions = np.ones(direction.shape[:2])
        any_body, robots = self._may_hit(poses)
        fractions[any_body] = self._cast_static(centres, poses, direction, any_body)
        if robots.any():
            starts, ends, _ = self._rays(centres, direction, robots)
            fractions[robots] = np.minimum(
                fractions[robots], cast_rays(self._client, starts, ends, mask=self._robot_mask))
        self.rays_cast += int(any_body.sum())
        self.rays_cast_static += int(any_body.sum() - robots.sum())
        return fractions

    def _scan_bullet(self, poses: np.ndarray, centres: np.ndarray,
                     direction: np.ndarray) -> np.ndarray:
        """Hit fractions ``(K, L)`` of every live ray, all cast in Bullet: the culled rays that
        can hit an obstacle but no robot in the static client (if any), the others (every live
        ray without ``cull``) in the full client."""
        fractions = np.ones(direction.shape[:2])
        if self.cull:
            any_body, robots = self._may_hit(poses)
            static = any_body & ~robots if self._static_client is not None else None
            full = robots if static is not None else any_body
        else:
            full, static = np.ones(fractions.shape, dtype=bool), None
        for cast, client in ((full, self._client), (static, self._static_client)):
            if cast is None or not cast.any():
                continue
            starts, ends, _ = self._rays(centres, direction, cast)
            fractions[cast] = cast_rays(client, starts, ends, mask=self._mask)
            self.rays_cast += len(starts)
            if client == self._static_client:
                self.rays_cast_static += len(starts)
        return fractions

    def _rays(self, centres: np.ndarray, direction: np.ndarray,
              cast: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Start and end points of the rays ``cast`` (a ``(K, L)`` mask), and their robots."""
        robot = np.nonzero(cast)[0]
        d, centre = direction[cast], centres[robot]
        return centre + self._start_m * d, centre + self.range_m * d, robot

    def _cast_static(self, centres: np.ndarray, poses: np.ndarray, direction: np.ndarray,
                     cast: np.ndarray) -> np.ndarray:
        """Hit fractions of the rays ``cast`` against the static bodies alone
        (:func:`fftnav.sim.fastrays.cast_static`)."""
        starts, ends, robot = self._rays(centres, direction, cast)
        mesh, hits = self.static_mesh, np.empty(len(starts))
        sure = np.empty(len(starts), dtype=bool)
        fastrays.cast_static(starts, ends, robot, poses[:, :2], mesh.triangles, mesh.footprints,
                             mesh.first, mesh.circles, self.range_m, fastrays.MARGIN_M, hits,
                             sure)
        unsure = ~sure  # a hit near a triangle's edge: Bullet decides (static client)
        if unsure.any():
            client = self._client if self._static_client is None else self._static_client
            hits[unsure] = cast_rays(client, starts[unsure], ends[unsure], mask=self._mask)
            self.rays_asked_bullet += int(unsure.sum())
        return hits

    def _scan_compiled(self, poses: np.ndarray, robot_z: np.ndarray, centres: np.ndarray,
                       direction: np.ndarray) -> np.ndarray:
        """Hit fractions ``(K, L)`` of every live ray, by :func:`fftnav.sim.fastrays.scan_swarm`
        (each body's rays chosen by its angular span; obstacles by Bullet's triangle test,
        robots by Bullet's sphere cast), with Bullet deciding the casts it is unsure of: the
        nearer of the obstacle and robot hits, as Bullet's closest hit."""
        mesh, shape = self.static_mesh, direction.shape[:2]
        obstacle, obstacle_sure = np.ones(shape), np.ones(shape, dtype=bool)
        robots, robot_sure = np.ones(shape), np.ones(shape, dtype=bool)
        cast_obstacle, cast_robot = np.zeros(shape, dtype=bool), np.zeros(shape, dtype=bool)
        fastrays.scan_swarm(np.ascontiguousarray(poses), robot_z, direction, self._live_index,
                            self._first_rad, self._step_rad, self._height_m, self._start_m,
                            self.range_m, mesh.triangles, mesh.footprints,
                            mesh.same_footprint, mesh.first, mesh.circles, fastrays.MARGIN_M,
                            self._robot_radius_m,
                            fastrays.SPHERE_MARGIN_M, obstacle, obstacle_sure, robots,
                            robot_sure, cast_obstacle, cast_robot)
        # obstacles alone: in the static client, or in the full client (a tiled world's)
        obstacles_only = self._mask & ~self._robot_mask
        for sure, hits, client, mask in (
                (obstacle_sure, obstacle, self._static_client, obstacles_only),
                (robot_sure, robots, self._client, self._robot_mask)):
            unsure = ~sure  # near a triangle's edge, or a cast out of steps: Bullet decides
            if unsure.any():
                starts, ends, _ = self._rays(centres, direction, unsure)
                hits[unsure] = cast_rays(self._client if client is None else client, starts,
                                         ends, mask=mask)
                if hits is obstacle:
                    self.rays_asked_bullet += int(unsure.sum())
                else:
                    self.robot_rays_asked_bullet += int(unsure.sum())
        self.rays_cast += int((cast_obstacle | cast_robot).sum())
        self.rays_cast_static += int((cast_obstacle & ~cast_robot).sum())
        return np.minimum(obstacle, robots)

    def _may_hit(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(K, L)`` masks of the live rays that point into the sector of a widened body
        (obstacle or other robot) that comes within range R of the robot, and of those that
        point into another robot's sector."""
        k, margin = len(poses), CULL_MARGIN_M
        centres = np.concatenate([self._circles[:, :2], poses[:, :2]])
        radii = np.concatenate([self._circles[:, 2], np.full(k, self._robot_radius_m)]) + margin
        rel = centres[None, :, :] - poses[:, None, :2]  # (K, N + K, 2)
        dist = np.hypot(rel[..., 0], rel[..., 1])
        near = dist < self.range_m + radii
        near[np.arange(k), len(self._circles) + np.arange(k)] = False  # not itself
        robot, body = np.nonzero(near)
        d, rho = dist[robot, body], radii[body]
        bearing = np.arctan2(rel[robot, body, 1], rel[robot, body, 0])
        # A disc of radius rho at distance d subtends bearing +- asin(rho / d) (from inside it,
        # every direction); if its tangent points lie beyond R, only the rays within
        # +- acos((d^2 + R^2 - rho^2) / (2 d R)), where the circle of radius R crosses the disc,
        # reach it in range. A convex polygon also lies in the sector of its vertices, widened
        # by asin(margin / distance) <= asin(margin / (d - rho + margin)).
        r = self.range_m
        half = np.full(len(d), math.pi)
        outside = d > rho
        half[outside] = np.arcsin(rho[outside] / d[outside])
        far = outside & (d**2 - rho**2 > r**2)
        half[far] = np.arccos((d[far] ** 2 + r**2 - rho[far] ** 2) / (2.0 * d[far] * r))
        low, high = -half, half.copy()
        polygon = np.flatnonzero(outside & (body < len(self._circles)))
        polygon = polygon[~np.isnan(self._vertices[body[polygon], 0, 0])]
        if polygon.size:
            xy = self._vertices[body[polygon]] - poses[robot[polygon], None, :2]
            offset = _wrap(np.arctan2(xy[..., 1], xy[..., 0]) - bearing[polygon, None])
            widen = np.arcsin(margin / (d[polygon] - rho[polygon] + margin))
            low[polygon] = np.maximum(low[polygon], offset.min(axis=1) - widen)
            high[polygon] = np.minimum(high[polygon], offset.max(axis=1) + widen)
        # Beams n = ceil(lo) .. floor(hi) of the evenly spaced pattern lie in the sector; the
        # part of a sector past +pi (relative to the heading) wraps round to -pi.
        m, first = self.angles_rad.size, self.angles_rad[0]
        step = (self.angles_rad[-1] - first) / (m - 1)
        start = _wrap(bearing + low - poses[robot, 2])
        bounds, of_robot = [], []
        is_robot = body >= len(self._circles)
        for shifted in (start, start - 2.0 * math.pi):
            lo = np.clip(np.ceil((shifted - first) / step), 0, m)
            hi = np.clip(np.floor((shifted + high - low - first) / step) + 1, 0, m)
            bounds.append(np.c_[lo, hi][lo < hi].astype(int) + (m + 1) * robot[lo < hi, None])
            of_robot.append(is_robot[lo < hi])
        bounds, of_robot = np.concatenate(bounds), np.concatenate(of_robot)
        masks = []
        for b in (bounds, bounds[of_robot]):  # any body, robots only
            opened, closed = (np.bincount(c, minlength=k * (m + 1)) for c in b.T)
            inside = np.cumsum((opened - closed).reshape(k, m + 1), axis=1)[:, :m] > 0
            masks.append(inside[:, self.live])
        return masks[0], masks[1]


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped into [-pi, pi) (rad)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi
