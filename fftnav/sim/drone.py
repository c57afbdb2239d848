"""PyBullet 3D forest, spherical depth sensor and kinematic quadrotor (paper Sec. IV-A).

The paper tested its 3D extension with a depth-camera quadrotor in a Unity forest; this module is
the project's PyBullet stand-in: a seeded forest of trunks (vertical cylinders, built as one static
triangle mesh of 64-gon prisms like the 2D simulator's: Bullet ray-casts it several times faster
than its cylinder primitive) and canopies (spheres) on a ground plane, a spherical depth sensor
built on ``rayTestBatch`` and a free-flying quadrotor body whose position is integrated by
:mod:`fftnav.episode.flight3d` from commanded velocities.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p

from fftnav.errors import FftnavError
from fftnav.observe.spherical import SphericalGrid
from fftnav.sim.mesh import static_meshes
from fftnav.sim.rays import cast_rays
from fftnav.validate import check_choice, check_number
from fftnav.world.obstacles import Circle

__all__ = ["Forest3D", "make_forest3d", "DroneSim"]


@dataclass(frozen=True)
class Forest3D:
    """A 3D forest: trunks, canopies, a ground plane at z = 0, and a start and goal.

    Attributes
    ----------
    trunks : numpy.ndarray
        Shape (n, 4): ``x, y, radius, height`` in metres (vertical cylinders standing on z = 0).
    canopies : numpy.ndarray
        Shape (n, 4): ``x, y, z, radius`` in metres (spheres; centre at the top of the trunk).
    start, goal : numpy.ndarray
        Shape (3,): positions in metres.
    """

    trunks: np.ndarray
    canopies: np.ndarray
    start: np.ndarray
    goal: np.ndarray


def make_forest3d(
    rng: np.random.Generator,
    *,
    distance_m: float = 30.0,
    altitude_m: float = 2.0,
    trees_per_100m2: float = 20.0,
    min_spacing_m: float = 1.5,
    clearance_m: float = 2.5,
) -> Forest3D:
    """Seeded 3D forest around a start-goal segment along +x.

    Trees are dart-thrown in ``x in [-5, distance + 5]``, ``y in [-10, 10]`` with trunks at least
    ``min_spacing_m`` apart and none within ``clearance_m`` (horizontally) of the start or goal.
    Trunk radius U(0.1, 0.3) m; canopy radius U(0.8, 1.8) m centred at height U(2, 6) m, so many
    canopies reach down to the flight altitude and some can be passed over or under.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of all randomness.
    distance_m : float, optional
        Start-goal distance in metres (default 30); start at ``(0, 0, altitude)``.
    altitude_m : float, optional
        Start and goal height in metres (default 2).
    trees_per_100m2 : float, optional
        Target density (default 20 per 100 m^2, the paper's one tree per 5 m^2); dart
        throwing may place fewer.
    min_spacing_m, clearance_m : float, optional
        Minimum trunk spacing and start/goal clearance in metres, finite and ``>= 0``.

    Returns
    -------
    Forest3D
    """
    check_number("trees_per_100m2", trees_per_100m2, low=0)
    check_number("min_spacing_m", min_spacing_m, low=0)
    check_number("clearance_m", clearance_m, low=0)
    if check_number("distance_m", distance_m) <= 2 * clearance_m:
        raise FftnavError(f"distance_m must be finite and > 2 * clearance_m (clearance_m="
                          f"{clearance_m!r}), got distance_m={distance_m!r}")
    check_number("altitude_m", altitude_m, low=0, low_open=True)
    start = np.array([0.0, 0.0, altitude_m])
    goal = np.array([distance_m, 0.0, altitude_m])
    lo, hi = np.array([-5.0, -10.0]), np.array([distance_m + 5.0, 10.0])
    n_target = int(trees_per_100m2 * np.prod(hi - lo) / 100)
    xy: list[np.ndarray] = []
    for cand in rng.uniform(lo, hi, size=(20 * n_target, 2)):
        if len(xy) == n_target:
            break
        if min(np.hypot(*(cand - start[:2])), np.hypot(*(cand - goal[:2]))) < clearance_m:
            continue
        if xy and np.min(np.hypot(*(np.asarray(xy) - cand).T)) < min_spacing_m:
            continue
        xy.append(cand)
    pts = np.asarray(xy).reshape(-1, 2)
    n = len(pts)
    height = rng.uniform(2.0, 6.0, n)
    trunks = np.column_stack([pts, rng.uniform(0.1, 0.3, n), height])
    canopies = np.column_stack([pts, height, rng.uniform(0.8, 1.8, n)])
    return Forest3D(trunks=trunks, canopies=canopies, start=start, goal=goal)


class DroneSim:
    """A PyBullet (DIRECT) scene: forest, ground plane and a spherical quadrotor body.

    Parameters
    ----------
    forest : Forest3D
        Obstacles to build.
    grid : SphericalGrid
        Ray pattern of the spherical depth sensor (e.g. 90 x 360 over 90 x 360 degrees).
    range_m : float, optional
        Maximum range R in metres (default 10); a ray that hits nothing reads R.
    r0_m : float, optional
        Collision radius of the quadrotor body (a sphere), metres (default 0.15, the paper's drone).
    trunk_shape : {"mesh", "cylinder"}, optional
        ``"mesh"`` (default): all trunks as one static triangle mesh of prisms over 64-gons
        circumscribing their circles (readings at most 0.12 % of the radius short);
        ``"cylinder"``: one Bullet cylinder primitive per trunk (exact, slower to ray-cast; kept
        for the side-by-side measurement in ``experiments/3d_measurements.py``).

    Notes
    -----
    Use as a context manager (or call :meth:`close`) to release the physics client.
    """

    def __init__(
        self, forest: Forest3D, *, grid: SphericalGrid, range_m: float = 10.0, r0_m: float = 0.15,
        trunk_shape: str = "mesh",
    ) -> None:
        check_number("r0_m", r0_m, low=0, low_open=True)
        if check_number("range_m", range_m) <= r0_m:
            raise FftnavError(f"range_m must be finite and > r0_m={r0_m}, got range_m={range_m!r}")
        check_choice("trunk_shape", trunk_shape, ("mesh", "cylinder"))
        self.forest, self.grid, self.range_m, self.r0_m = forest, grid, float(range_m), float(r0_m)
        self.cid = c = p.connect(p.DIRECT)
        shape = p.createCollisionShape
        p.createMultiBody(0, shape(p.GEOM_PLANE, physicsClientId=c), physicsClientId=c)
        if trunk_shape == "cylinder":
            for x, y, radius, height in forest.trunks:
                col = shape(p.GEOM_CYLINDER, radius=radius, height=height, physicsClientId=c)
                p.createMultiBody(0, col, basePosition=[x, y, height / 2], physicsClientId=c)
        else:
            for verts, triangles in static_meshes(
                    [Circle((x, y), radius, height) for x, y, radius, height in forest.trunks]):
                col = shape(p.GEOM_MESH, vertices=verts, indices=triangles, physicsClientId=c)
                p.createMultiBody(0, col, physicsClientId=c)
        for x, y, z, radius in forest.canopies:
            col = shape(p.GEOM_SPHERE, radius=radius, physicsClientId=c)
            p.createMultiBody(0, col, basePosition=[x, y, z], physicsClientId=c)
        body = shape(p.GEOM_SPHERE, radius=self.r0_m, physicsClientId=c)
        self.drone = p.createMultiBody(1.0, body, basePosition=forest.start.tolist(),
                                       physicsClientId=c)
        self._dirs = grid.directions().reshape(-1, 3)

    def close(self) -> None:
        """Disconnect the physics client."""
        if p.isConnected(self.cid):
            p.disconnect(self.cid)

    def __enter__(self) -> DroneSim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def scan(self, position: np.ndarray, yaw_rad: float) -> np.ndarray:
        """Spherical depth image (metres) seen from ``position`` with heading ``yaw_rad``.

        Rays start on the body's surface (so they never hit the drone itself) and are cast with
        :func:`fftnav.sim.rays.cast_rays` (``rayTestBatch`` in chunks Bullet accepts); the
        reading is the distance from the body centre, ``R`` for a miss (hit fraction 1).

        Returns
        -------
        numpy.ndarray
            Shape ``(grid.rows, grid.cols)``, layout of
            :class:`~fftnav.observe.spherical.SphericalGrid`.
        """
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        world = self._dirs @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        r_start = self.r0_m + 1e-3
        frm = np.asarray(position, dtype=float) + r_start * world
        to = np.asarray(position, dtype=float) + self.range_m * world
        frac = cast_rays(self.cid, frm, to)
        return (r_start + frac * (self.range_m - r_start)).reshape(self.grid.rows, self.grid.cols)

    def collides(self, position: np.ndarray, *, margin_m: float = 0.0) -> bool:
        """Move the body to ``position``; True if it comes within ``margin_m`` (metres, default 0:
        touching) of an obstacle or the ground."""
        p.resetBasePositionAndOrientation(self.drone, list(position), [0, 0, 0, 1],
                                          physicsClientId=self.cid)
        lo, hi = p.getAABB(self.drone, physicsClientId=self.cid)
        near = p.getOverlappingObjects(np.subtract(lo, margin_m).tolist(),
                                       np.add(hi, margin_m).tolist(),
                                       physicsClientId=self.cid) or []
        return any(
            p.getClosestPoints(self.drone, body, margin_m, physicsClientId=self.cid)
            for body, _ in near if body != self.drone
        )
