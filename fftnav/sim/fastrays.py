"""Bullet's ray-triangle test, compiled, for the lidar's rays that can hit only obstacles.

PyBullet (double precision) answers a ray against the obstacle mesh by walking its bounding
volume hierarchy and running ``btTriangleRaycastCallback::processTriangle`` on the triangles
it meets: the plane distances ``dist_a``, ``dist_b`` of the ray's ends, ``distance = dist_a /
(dist_a - dist_b)``, the hit point ``(1 - distance) from + distance to`` and three edge tests
against ``-1e-4 |n|^2``, keeping the smallest accepted ``distance``. :func:`cast_static` runs
the same arithmetic, operation for operation, on the triangles a ray can meet, so it returns
the same hit fractions bit for bit where it is sure (``tests/sim/test_lidar.py`` compares it
with Bullet on random and corner-aimed rays) at a fraction of the cost: no Python tuple per ray,
no tree walk, and only the side faces of the obstacles near the robot and close to the ray are
tested.

Which triangles a ray can meet: the lidar's rays are horizontal, so a prism's cap triangles
(all vertices at one height) never pass the plane test (``dist_a = dist_b``) and are left out;
a side triangle is tested if the ray passes within ``margin`` of its footprint segment in the
plane (far beyond the edge tolerance's reach, at most ``1e-4`` times the face's width) and its
obstacle's widened bounding circle comes within the ray. A nearest hit close to its triangle's
edges is flagged (``sure`` False): Bullet's tree walk may skip such a triangle (a ray through a
corner), so the caller asks Bullet for that ray. Needs numba (extra ``fast``); without
it :data:`AVAILABLE` is False and the lidar casts these rays in Bullet.
"""

from __future__ import annotations

import numpy as np

# numba or, where it is missing, a stand-in decorator (the optional extra `fast`)
from fftnav.observe.kernels import AVAILABLE, njit

__all__ = ["AVAILABLE", "StaticMesh", "cast_static"]

#: Distance (m) within which a ray must pass a side face's footprint for the face to be tested.
MARGIN_M = 1e-3
#: A hit counts as clear of its triangle's edges when every edge test exceeds ``CLEAR |n|^2``
#: (about 1e-3 of the face's width from every edge); other hits are left to Bullet.
CLEAR = 1e-3


class StaticMesh:
    """The obstacles' side triangles grouped by obstacle, with their footprints.

    Parameters
    ----------
    meshes : sequence of (vertices, indices)
        Each obstacle's triangle mesh (``Obstacle.mesh()``).
    circles : ndarray, shape (N, 3)
        Each obstacle's bounding circle (x, y, radius), m.
    """

    def __init__(self, meshes, circles: np.ndarray) -> None:
        triangles, footprints, first = [], [], [0]
        for vertices, indices in meshes:
            tri = np.asarray(vertices, dtype=float)[np.asarray(indices).reshape(-1, 3)]
            z = tri[:, :, 2]
            side = ~np.all(z == z[:, :1], axis=1)  # caps lie in one horizontal plane
            tri = tri[side]
            xy = tri[:, :, :2]
            # footprint of a vertical triangle: the two farthest-apart of its 2D vertices
            d01 = np.hypot(*(xy[:, 0] - xy[:, 1]).T)
            d02 = np.hypot(*(xy[:, 0] - xy[:, 2]).T)
            d12 = np.hypot(*(xy[:, 1] - xy[:, 2]).T)
            pick = np.argmax(np.c_[d01, d02, d12], axis=1)
            ends = np.array([[0, 1], [0, 2], [1, 2]])[pick]
            rows = np.arange(len(tri))
            a, b = xy[rows, ends[:, 0]], xy[rows, ends[:, 1]]
            footprints.append(np.c_[a, b, np.hypot(*(b - a).T)])
            triangles.append(tri)
            first.append(first[-1] + len(tri))
        self.triangles = (np.concatenate(triangles) if triangles else np.zeros((0, 3, 3)))
        self.footprints = (np.concatenate(footprints) if footprints else np.zeros((0, 5)))
        self.first = np.array(first, dtype=np.int64)
        self.circles = np.asarray(circles, dtype=float).reshape(-1, 3)


@njit(cache=True, nogil=True)
def _process_triangle(tri, t, fx, fy, fz, tx, ty, tz, hit, clear):
    """``btTriangleRaycastCallback::processTriangle`` (no back-face filtering): the smaller of
    ``hit`` and this triangle's accepted distance, and whether that hit is clear of the
    triangle's edges (``clear``: kept from the caller if this triangle does not win)."""
    v0x, v0y, v0z = tri[t, 0, 0], tri[t, 0, 1], tri[t, 0, 2]
    v1x, v1y, v1z = tri[t, 1, 0], tri[t, 1, 1], tri[t, 1, 2]
    v2x, v2y, v2z = tri[t, 2, 0], tri[t, 2, 1], tri[t, 2, 2]
    ax, ay, az = v1x - v0x, v1y - v0y, v1z - v0z
    bx, by, bz = v2x - v0x, v2y - v0y, v2z - v0z
    nx = ay * bz - az * by
    ny = az * bx - ax * bz
    nz = ax * by - ay * bx
    dist = v0x * nx + v0y * ny + v0z * nz
    da = nx * fx + ny * fy + nz * fz
    da -= dist
    db = nx * tx + ny * ty + nz * tz
    db -= dist
    if da * db >= 0.0:
        return hit, clear
    proj = da - db
    d = da / proj
    if not d < hit:
        return hit, clear
    n2 = nx * nx + ny * ny + nz * nz
    tol = n2
    tol *= -0.0001
    s = 1.0 - d
    px = s * fx + d * tx
    py = s * fy + d * ty
    pz = s * fz + d * tz
    p0x, p0y, p0z = v0x - px, v0y - py, v0z - pz
    p1x, p1y, p1z = v1x - px, v1y - py, v1z - pz
    cx = p0y * p1z - p0z * p1y
    cy = p0z * p1x - p0x * p1z
    cz = p0x * p1y - p0y * p1x
    e0 = cx * nx + cy * ny + cz * nz
    if not e0 >= tol:
        return hit, clear
    p2x, p2y, p2z = v2x - px, v2y - py, v2z - pz
    cx = p1y * p2z - p1z * p2y
    cy = p1z * p2x - p1x * p2z
    cz = p1x * p2y - p1y * p2x
    e1 = cx * nx + cy * ny + cz * nz
    if not e1 >= tol:
        return hit, clear
    cx = p2y * p0z - p2z * p0y
    cy = p2z * p0x - p2x * p0z
    cz = p2x * p0y - p2y * p0x
    e2 = cx * nx + cy * ny + cz * nz
    if not e2 >= tol:
        return hit, clear
    # clear of every edge by CLEAR |n|^2 (CLEAR / 1e-4 times the tolerance's reach): the
    # triangle's bounding box holds the point with room to spare, so Bullet's tree walk
    # surely reaches this triangle; nearer an edge, Bullet may skip it (a ray grazing a
    # corner): the caller asks Bullet
    room = CLEAR * n2
    return d, e0 >= room and e1 >= room and e2 >= room


@njit(cache=True, nogil=True)
def _near_footprint(foot, t, sx, sy, ux, uy, length, margin):
    """Whether the ray (start s, unit direction u, ``length``) and the footprint ``t`` (a-b,
    its length) come within ``margin`` of each other in the plane (conservative: False only
    when one lies wholly beyond the other's line, or wholly before or after the ray)."""
    ax, ay, bx, by, foot_len = foot[t, 0], foot[t, 1], foot[t, 2], foot[t, 3], foot[t, 4]
    # distances of a and b from the ray's line
    da = ux * (ay - sy) - uy * (ax - sx)
    db = ux * (by - sy) - uy * (bx - sx)
    if (da > margin and db > margin) or (da < -margin and db < -margin):
        return False
    # along the ray: the footprint's projection must overlap [-margin, length + margin]
    ta = ux * (ax - sx) + uy * (ay - sy)
    tb = ux * (bx - sx) + uy * (by - sy)
    if (ta < -margin and tb < -margin) or (ta > length + margin and tb > length + margin):
        return False
    if foot_len > 0.0:  # distances of the ray's ends from the footprint's line
        fx, fy = (bx - ax) / foot_len, (by - ay) / foot_len
        ds = fx * (sy - ay) - fy * (sx - ax)
        ex, ey = sx + length * ux, sy + length * uy
        de = fx * (ey - ay) - fy * (ex - ax)
        if (ds > margin and de > margin) or (ds < -margin and de < -margin):
            return False
    return True


@njit(cache=True, nogil=True)
def cast_static(starts, ends, robot, centres, triangles, footprints, first, circles, reach,
                margin, out, sure):
    """Hit fractions ``out`` of rays ``starts[i] -> ends[i]`` of robot ``robot[i]`` (centre
    ``centres[robot]``, x y) against the obstacles, as Bullet computes them (1: no hit), and
    ``sure[i]``: False where the nearest hit lies near its triangle's edges, where Bullet's tree
    walk may skip that triangle (ask Bullet for those rays). ``reach`` (m) bounds the distance
    from a robot's centre to anything its rays reach."""
    n_obstacles = circles.shape[0]
    n_robots = centres.shape[0]
    near = np.empty((n_robots, n_obstacles), dtype=np.int64)
    count = np.zeros(n_robots, dtype=np.int64)
    for k in range(n_robots):
        for j in range(n_obstacles):
            dx = circles[j, 0] - centres[k, 0]
            dy = circles[j, 1] - centres[k, 1]
            r = reach + circles[j, 2] + margin
            if dx * dx + dy * dy <= r * r:
                near[k, count[k]] = j
                count[k] += 1
    for i in range(starts.shape[0]):
        fx, fy, fz = starts[i, 0], starts[i, 1], starts[i, 2]
        tx, ty, tz = ends[i, 0], ends[i, 1], ends[i, 2]
        ux, uy = tx - fx, ty - fy
        length = np.sqrt(ux * ux + uy * uy)
        ux, uy = ux / length, uy / length
        hit = 1.0
        clear = True
        k = robot[i]
        for c in range(count[k]):
            j = near[k, c]
            # the ray must pass the obstacle's widened bounding circle
            qx, qy = circles[j, 0] - fx, circles[j, 1] - fy
            along = qx * ux + qy * uy
            rho = circles[j, 2] + margin
            if along < -rho or along > length + rho:
                continue
            across = qx * uy - qy * ux
            if across > rho or across < -rho:
                continue
            for t in range(first[j], first[j + 1]):
                if _near_footprint(footprints, t, fx, fy, ux, uy, length, margin):
                    hit, clear = _process_triangle(triangles, t, fx, fy, fz, tx, ty, tz, hit,
                                                   clear)
        out[i] = hit
        sure[i] = hit == 1.0 or clear
