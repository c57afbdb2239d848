"""Obstacles: vertical prisms over a 2D cross-section; each shape is one class with its geometry.

An obstacle knows everything the rest of fftnav asks of it, so that a new shape is one class
here (plus its tests) and nothing downstream changes:

- ``bounds()``: the axis-aligned box of its cross-section (occupancy grids, world validation);
- ``distance(points)``: Euclidean distance from points to it, 0 inside (grids, start checks);
- ``ray_distances(obstacles, origins, directions)`` (a classmethod, vectorised over every
  obstacle of the class): the exact 2D ray cast (the lidar oracle);
- ``outline()``: a convex counter-clockwise polygon that contains the cross-section, the section
  of the simulator's triangle ``mesh()``; ``bounding_circle()`` and ``cull_vertices()`` let the
  lidar skip rays that cannot hit it;
- ``to_dict()`` / ``from_dict()``: its JSON form in world files, under its registered ``shape``
  name (:data:`SHAPES`); ``moved(offset)`` for generators.

Coordinates in metres, x right, y up. Pure numpy.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from fftnav.errors import FftnavError
from fftnav.limits import MAX_MAP_SIDE_M
from fftnav.registry import Registry
from fftnav.validate import check_number, check_vector

__all__ = ["SHAPES", "Circle", "Obstacle", "Polygon", "combined_mesh", "prism_mesh",
           "rectangle", "register_shape"]

#: Shape classes by their JSON ``shape`` name.
SHAPES: Registry[type[Obstacle]] = Registry("shape", parameter="shape")


def register_shape(cls: type[Obstacle]) -> type[Obstacle]:
    """Class decorator: make ``cls`` readable from world files under ``cls.shape``."""
    return SHAPES.add(cls.shape, cls)


def prism_mesh(outline: np.ndarray, height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Triangle mesh of the vertical prism over a convex CCW outline, from z = 0 to ``height_m``.

    Returns
    -------
    vertices : ndarray, shape (2 n, 3)
        Vertex ``2 i`` is outline point ``i`` at z = 0, ``2 i + 1`` the same point on top.
    indices : ndarray of int, shape (3 T,)
        Outward-facing triangles (sides, then bottom and top caps as fans).
    """
    xy = np.asarray(outline, dtype=float)
    n = len(xy)
    vertices = np.array([[x, y, z] for x, y in xy.tolist() for z in (0.0, float(height_m))])
    sides = [[2 * i, 2 * j, 2 * j + 1, 2 * i, 2 * j + 1, 2 * i + 1]
             for i, j in ((i, (i + 1) % n) for i in range(n))]
    caps = [[0, 2 * i + 2, 2 * i, 1, 2 * i + 1, 2 * i + 3] for i in range(1, n - 1)]
    return vertices, np.array([v for tri in sides + caps for v in tri], dtype=int)


def combined_mesh(obstacles: Sequence[Obstacle]) -> tuple[list[list[float]], list[int]]:
    """One triangle mesh of all ``obstacles`` (their ``mesh()`` concatenated): vertices as
    ``[x, y, z]`` lists (m) and triangle vertex indices, as ``pybullet.createCollisionShape``
    takes them."""
    vertices: list[list[float]] = []
    indices: list[int] = []
    for obstacle in obstacles:
        v, i = obstacle.mesh()
        indices += (i + len(vertices)).tolist()
        vertices += v.tolist()
    return vertices, indices


def _point(name: str, value: Any) -> tuple[float, float]:
    """An (x, y) point of an obstacle: finite numbers within +-MAX_MAP_SIDE_M (farther points
    lie outside every allowed world; bounded, the geometry cannot overflow)."""
    x, y = check_vector(name, value, 2)
    return (check_number(f"{name}[0]", x, low=-MAX_MAP_SIDE_M, high=MAX_MAP_SIDE_M),
            check_number(f"{name}[1]", y, low=-MAX_MAP_SIDE_M, high=MAX_MAP_SIDE_M))


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of (a - o) x (b - o), broadcasting over leading axes."""
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (
        b[..., 0] - o[..., 0]
    )


def _keys(data: dict[str, Any], where: str, required: tuple[str, ...]) -> None:
    """Refuse a missing or an unknown key of an obstacle's JSON object, naming it."""
    for key in required:
        if key not in data:
            raise FftnavError(f"{where}: missing key {key!r}")
    unknown = sorted(set(data) - {"shape", *required})
    if unknown:
        raise FftnavError(f"{where}: unknown key {unknown[0]!r}; a {data['shape']} has the keys "
                          f"{['shape', *required]}")


class Obstacle(ABC):
    """A vertical prism of height ``height`` (m) over a 2D cross-section (the shape)."""

    #: Name of the shape in world files (``{"shape": NAME, ...}``).
    shape: ClassVar[str]
    height: float

    @abstractmethod
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower-left and upper-right corners ``(2,)``, ``(2,)`` (m) of the cross-section."""

    @abstractmethod
    def distance(self, points: np.ndarray) -> np.ndarray:
        """Euclidean distance (m) from each point ``(P, 2)`` to the cross-section, 0 inside."""

    @abstractmethod
    def outline(self) -> np.ndarray:
        """Convex CCW polygon ``(n, 2)`` (m) that contains the cross-section: the section of the
        simulator's mesh."""

    @classmethod
    @abstractmethod
    def ray_distances(cls, obstacles: Sequence[Obstacle], origins: np.ndarray,
                      directions: np.ndarray) -> np.ndarray:
        """Distance (m) along each ray ``origins[k] + t directions[k]`` (unit directions, both
        ``(N, 2)``) to the first boundary point of any of ``obstacles`` (all of this class):
        ``inf`` if none is hit, 0 for an origin inside one."""

    @abstractmethod
    def moved(self, offset: np.ndarray, *, decimals: int) -> Obstacle:
        """The same obstacle translated by ``offset`` (m), coordinates rounded to ``decimals``."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """JSON form ``{"shape": NAME, ...}``."""

    @classmethod
    @abstractmethod
    def from_dict(cls, data: dict[str, Any], where: str) -> Obstacle:
        """Parse and validate the JSON form; errors name ``where`` (e.g. ``obstacles[3]``)."""

    def bounding_circle(self) -> tuple[float, float, float]:
        """A circle ``(x, y, radius)`` (m) containing the outline, centred on its vertex mean."""
        xy = self.outline()
        middle = xy.mean(axis=0)
        return (*middle.tolist(), float(np.hypot(*(xy - middle).T).max()))

    def cull_vertices(self) -> np.ndarray | None:
        """Points ``(n, 2)`` whose angular span, seen from outside, covers the outline (the
        lidar casts only rays within it); None when the bounding circle is as tight."""
        return self.outline()

    def mesh(self) -> tuple[np.ndarray, np.ndarray]:
        """Triangle mesh of the prism over the outline (:func:`prism_mesh`)."""
        return prism_mesh(self.outline(), self.height)


@register_shape
@dataclass(frozen=True)
class Circle(Obstacle):
    """Vertical cylinder (tree trunk): ``center`` (x, y) m, ``radius`` m, ``height`` m.

    Its mesh is the regular ``SIDES``-gon circumscribing the circle: it contains the trunk and
    lies within ``radius (1 / cos(pi / SIDES) - 1)`` of it (0.36 mm for a 0.3 m trunk);
    Bullet ray-casts a triangle mesh faster than its own cylinder.
    """

    shape: ClassVar[str] = "circle"
    #: Sides of the polygon that models the cylinder in the simulator (128: 11 % slower lidar).
    SIDES: ClassVar[int] = 64

    center: tuple[float, float]
    radius: float
    height: float

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.subtract(self.center, self.radius), np.add(self.center, self.radius)

    def distance(self, points: np.ndarray) -> np.ndarray:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        return np.maximum(np.hypot(*(pts - self.center).T) - self.radius, 0.0)

    def outline(self) -> np.ndarray:
        a = np.arange(self.SIDES) * (2.0 * math.pi / self.SIDES)
        radius = self.radius / math.cos(math.pi / self.SIDES)
        return np.array(self.center) + radius * np.c_[np.cos(a), np.sin(a)]

    def bounding_circle(self) -> tuple[float, float, float]:
        return (*self.center, self.radius / math.cos(math.pi / self.SIDES))

    def cull_vertices(self) -> None:
        return None

    @classmethod
    def ray_distances(cls, obstacles: Sequence[Obstacle], origins: np.ndarray,
                      directions: np.ndarray) -> np.ndarray:
        """|p + t d - c| = r: the nearest root t >= 0 over all circles (vectorised)."""
        centers = np.array([o.center for o in obstacles]).reshape(-1, 2)  # type: ignore[attr-defined]
        radii = np.array([o.radius for o in obstacles])  # type: ignore[attr-defined]
        f = origins[:, None, :] - centers
        bb = np.sum(f * directions[:, None, :], axis=2)
        cc = np.sum(f * f, axis=2) - radii**2
        disc = bb**2 - cc
        with np.errstate(invalid="ignore"):
            t = -bb - np.sqrt(disc)
        t = np.where((disc >= 0) & (t >= 0), t, np.inf)
        t = np.where(cc < 0, 0.0, t)
        return t.min(axis=1, initial=np.inf)

    def moved(self, offset: np.ndarray, *, decimals: int) -> Circle:
        c = np.round(np.add(self.center, offset), decimals)
        return Circle((float(c[0]), float(c[1])), self.radius, self.height)

    def to_dict(self) -> dict[str, Any]:
        return {"shape": "circle", "center": list(self.center), "radius": self.radius,
                "height": self.height}

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str) -> Circle:
        _keys(data, where, ("center", "radius", "height"))
        height = check_number(f"{where}.height", data["height"], low=0, low_open=True)
        center = _point(f"{where}.center", data["center"])
        radius = check_number(f"{where}.radius", data["radius"], low=0, low_open=True,
                              high=MAX_MAP_SIDE_M)
        return Circle(center, radius, height)  # type: ignore[arg-type]


@register_shape
@dataclass(frozen=True)
class Polygon(Obstacle):
    """Vertical prism over a convex polygon: CCW ``vertices`` (x, y) m, ``height`` m."""

    shape: ClassVar[str] = "polygon"

    vertices: tuple[tuple[float, float], ...]
    height: float

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.min(self.vertices, axis=0), np.max(self.vertices, axis=0)

    def distance(self, points: np.ndarray) -> np.ndarray:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        a = np.asarray(self.vertices)
        e = np.roll(a, -1, axis=0) - a
        rel = pts[:, None, :] - a
        u = np.clip(np.sum(rel * e, axis=2) / np.sum(e * e, axis=1), 0.0, 1.0)
        dist = np.hypot(*(rel - u[..., None] * e).transpose(2, 0, 1)).min(axis=1)
        inside = np.all(e[:, 0] * rel[..., 1] - e[:, 1] * rel[..., 0] > 0, axis=1)
        return np.where(inside, 0.0, dist)

    def outline(self) -> np.ndarray:
        return np.array(self.vertices, dtype=float)

    @classmethod
    def ray_distances(cls, obstacles: Sequence[Obstacle], origins: np.ndarray,
                      directions: np.ndarray) -> np.ndarray:
        """p + t d = a + u (b - a) with t >= 0, 0 <= u <= 1 over every edge (vectorised); 0 for
        an origin inside a polygon."""
        polys = [np.asarray(o.vertices) for o in obstacles]  # type: ignore[attr-defined]
        a = np.concatenate(polys)
        b = np.concatenate([np.roll(v, -1, axis=0) for v in polys])
        first = np.cumsum([0] + [len(v) for v in polys[:-1]])
        ps, ds = origins[:, None, :], directions[:, None, :]
        e = b - a
        denom = ds[..., 0] * e[:, 1] - ds[..., 1] * e[:, 0]
        ap = a - ps
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (ap[..., 0] * e[:, 1] - ap[..., 1] * e[:, 0]) / denom
            u = (ap[..., 0] * ds[..., 1] - ap[..., 1] * ds[..., 0]) / denom
        t = np.where((t >= 0) & (u >= 0) & (u <= 1), t, np.inf)
        inside = np.minimum.reduceat(_cross(a, b, ps), first, axis=1).max(axis=1) > 0
        return np.where(inside, 0.0, t.min(axis=1))

    def moved(self, offset: np.ndarray, *, decimals: int) -> Polygon:
        verts = np.round(np.asarray(self.vertices) + offset, decimals)
        return Polygon(tuple(map(tuple, verts.tolist())), self.height)

    def to_dict(self) -> dict[str, Any]:
        return {"shape": "polygon", "vertices": [list(v) for v in self.vertices],
                "height": self.height}

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str) -> Polygon:
        _keys(data, where, ("vertices", "height"))
        height = check_number(f"{where}.height", data["height"], low=0, low_open=True)
        raw = data["vertices"]
        if not isinstance(raw, list) or len(raw) < 3:
            raise FftnavError(f"{where}.vertices must be a list of >= 3 [x, y] points, "
                              f"got {raw!r:.80}")
        verts = np.array([_point(f"{where}.vertices[{i}]", v) for i, v in enumerate(raw)])
        verts = convex_ccw(verts, f"{where}.vertices")
        return Polygon(tuple(map(tuple, verts.tolist())), height)


def rectangle(x0: float, y0: float, x1: float, y1: float, height_m: float, *,
              yaw_rad: float = 0.0) -> Polygon:
    """The box ``[x0, x1] x [y0, y1]`` (m, ``x0 < x1``, ``y0 < y1``) turned by ``yaw_rad`` about
    the origin (CCW), as a :class:`Polygon` of height ``height_m``.

    >>> rectangle(0, 0, 2, 1, 1.0).vertices
    ((0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0))
    """
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    if yaw_rad:
        corners = corners @ np.array([[c, s], [-s, c]])
    return Polygon(tuple(map(tuple, corners.tolist())), float(height_m))


def convex_ccw(vertices: np.ndarray, where: str) -> np.ndarray:
    """Return the vertices counter-clockwise; raise if the polygon is not strictly convex."""
    turns = _cross(vertices, np.roll(vertices, -1, axis=0), np.roll(vertices, -2, axis=0))
    if not (np.all(turns > 0) or np.all(turns < 0)):
        raise FftnavError(f"{where}: polygon is not convex (or has repeated/collinear vertices)")
    edges = np.roll(vertices, -1, axis=0) - vertices
    heading = np.arctan2(edges[:, 1], edges[:, 0])
    winding = np.sum(np.angle(np.exp(1j * (np.roll(heading, -1) - heading)))) / (2 * math.pi)
    if abs(abs(winding) - 1.0) > 1e-6:
        raise FftnavError(f"{where}: polygon is self-intersecting (winds {abs(winding):.0f} times)")
    return vertices if turns[0] > 0 else vertices[::-1]
