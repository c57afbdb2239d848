"""Bullet's ray tests, compiled: triangles (the obstacles) and spheres (the body robots).

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
corner), so the caller asks Bullet for that ray.

The robots of the "body" embodiment are spheres; :func:`cast_spheres` answers the rays in a
robot's sector against them with Bullet's own ray-versus-convex arithmetic (PyBullet's
``rayTestBatch`` uses ``btGjkConvexCast``: conservative advancement to within 1 mm of the
surface, so its hits lie up to about a millimetre short of the exact entry point, more for
grazing rays), operation for operation (``tests/sim/test_lidar.py`` compares it with Bullet on
random and grazing rays). Needs numba (extra ``fast``); without it :data:`AVAILABLE` is False
and the lidar casts these rays in Bullet.
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
#: Obstacles whose triangles :class:`StaticMesh` sorts at a time.
_CHUNK = 4096


class StaticMesh:
    """The obstacles' side triangles grouped by obstacle, with their footprints.

    Parameters
    ----------
    meshes : sequence of (vertices, indices)
        Each obstacle's triangle mesh (``Obstacle.mesh()``).
    circles : ndarray, shape (N, 3)
        Each obstacle's bounding circle (x, y, radius), m.
    lazy : bool, optional
        Hold no obstacle's triangles until :meth:`add` names it (the simulator adds a tile's
        obstacles when it builds the tile; an obstacle not added is never hit). Default: all.
    """

    def __init__(self, meshes, circles: np.ndarray, *, lazy: bool = False) -> None:
        self._meshes = meshes
        self.circles = np.asarray(circles, dtype=float).reshape(-1, 3)
        self._added = np.zeros(len(meshes), dtype=bool)
        self._owner = np.zeros(0, dtype=np.int64)
        self.triangles = np.zeros((0, 3, 3))
        self.footprints = np.zeros((0, 5))
        self._assemble()
        if not lazy:
            self.add(range(len(meshes)))

    def add(self, obstacles) -> None:
        """Hold the triangles of ``obstacles`` (indices) too, in obstacle order."""
        todo = np.unique(np.asarray(list(obstacles), dtype=np.int64))
        todo = todo[~self._added[todo]]
        if not todo.size:
            return
        self._added[todo] = True
        # (in chunks of obstacles, so that the cap triangles, a half of all, are never held
        # for the whole world at once)
        owners, triangles, footprints = [self._owner], [self.triangles], [self.footprints]
        for start in range(0, len(todo), _CHUNK):
            which = todo[start:start + _CHUNK]
            chunk = [self._meshes[k] for k in which]
            sizes = [np.size(i) // 3 for _, i in chunk]
            offsets = np.cumsum([0] + [len(v) for v, _ in chunk[:-1]])
            vertices = np.concatenate([np.asarray(v, dtype=float).reshape(-1, 3)
                                       for v, _ in chunk])
            indices = np.concatenate([np.asarray(i).ravel() + o
                                      for (_, i), o in zip(chunk, offsets, strict=True)])
            tri = vertices[indices.reshape(-1, 3)]
            owner = np.repeat(which, sizes)
            z = tri[:, :, 2]
            side = ~np.all(z == z[:, :1], axis=1)  # caps lie in one horizontal plane
            tri, owner = tri[side], owner[side]
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
            owners.append(owner)
        owner = np.concatenate(owners)
        order = np.argsort(owner, kind="stable")  # by obstacle, each in its mesh's order
        self._owner = owner[order]
        self.triangles = np.concatenate(triangles)[order]
        self.footprints = np.concatenate(footprints)[order]
        self._assemble()

    def _assemble(self) -> None:
        """``first`` (each obstacle's first triangle) and ``same_footprint``."""
        counts = np.bincount(self._owner, minlength=len(self.circles))
        self.first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        #: Whether a triangle has the footprint of the one before it (of the same obstacle): the
        #: two triangles of a side face; the compiled scan tests that footprint once.
        self.same_footprint = np.zeros(len(self.footprints), dtype=bool)
        if len(self.footprints) > 1:
            self.same_footprint[1:] = np.all(self.footprints[1:] == self.footprints[:-1], axis=1)
        self.same_footprint[self.first[:-1][self.first[:-1] < len(self.footprints)]] = False


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


# ----------------------------------------------------------------------------- robot spheres
#
# PyBullet's rayTestBatch answers a ray against a convex shape (the robots of the "body"
# embodiment are spheres) with btGjkConvexCast: conservative advancement of the ray's point
# towards the shape, each step a btGjkPairDetector query, until the point is within 1 mm of the
# surface. Between a point and a sphere the GJK query has a closed form (both shapes' supports
# without margin are their centres, so the simplex is one vertex w = a - c, and the distance is
# |w| - r0 along w / |w|); :func:`cast_sphere` runs that arithmetic operation for operation.

#: Bullet's SIMD_EPSILON (double precision: DBL_EPSILON).
_SIMD_EPSILON = float(np.finfo(np.float64).eps)
#: btGjkConvexCast: the cast stops within this distance (m) of the surface ("radius")...
_GJK_CAST_RADIUS = 0.001
#: ...or gives up after this many steps (MAX_ITERATIONS, double precision).
_GJK_CAST_ITERATIONS = 64
#: btPointCollector's initial distance and ClosestPointInput's maximum distance (BT_LARGE_FLOAT).
_LARGE = 1e30
#: A sphere is tested only if the ray passes within this distance (m) of its surface: Bullet's
#: cast reports hits only where the ray comes within ``_GJK_CAST_RADIUS`` of it.
SPHERE_MARGIN_M = 0.01


@njit(cache=True, nogil=True)
def _gjk_point_sphere(ax, ay, az, bx, by, bz, radius):
    """``btGjkPairDetector::getClosestPointsNonVirtual`` for a point at ``a`` and a sphere of
    ``radius`` centred at ``b``: (distance, normal on B); both centred on their midpoint first
    (``positionOffset``)."""
    ox, oy, oz = (ax + bx) * 0.5, (ay + by) * 0.5, (az + bz) * 0.5
    wx = (ax - ox) - (bx - ox)
    wy = (ay - oy) - (by - oy)
    wz = (az - oz) - (bz - oz)
    rlen = 1.0 / np.sqrt(wx * wx + wy * wy + wz * wz)
    return (1.0 / rlen) - (0.0 + radius), wx * rlen, wy * rlen, wz * rlen


@njit(cache=True, nogil=True)
def cast_sphere(fx, fy, fz, tx, ty, tz, cx, cy, cz, radius):
    """Bullet's ray test of ``from -> to`` against a sphere of ``radius`` centred at ``c``
    (``btGjkConvexCast::calcTimeOfImpact`` of a point): ``(hit, fraction, sure)``; ``sure`` is
    False where the cast ran out of steps or started at the sphere's centre (ask Bullet)."""
    rx, ry, rz = (tx - fx) - (cx - cx), (ty - fy) - (cy - cy), (tz - fz) - (cz - cz)
    if fx == cx and fy == cy and fz == cz:
        return False, 1.0, False
    # btPointCollector: keeps the smallest distance reported
    dist, nx, ny, nz = _gjk_point_sphere(fx, fy, fz, cx, cy, cz, radius)
    if not dist < _LARGE:
        return False, 1.0, False
    lam = 0.0
    last = 0.0
    steps = 0
    while dist > _GJK_CAST_RADIUS:
        steps += 1
        if steps > _GJK_CAST_ITERATIONS:
            return False, 1.0, False
        projected = rx * nx + ry * ny + rz * nz
        lam = lam - dist / projected
        if lam > 1.0 or lam < 0.0 or lam <= last:
            return False, 1.0, True
        last = lam
        s = 1.0 - lam
        ax, ay, az = s * fx + lam * tx, s * fy + lam * ty, s * fz + lam * tz
        bx, by, bz = s * cx + lam * cx, s * cy + lam * cy, s * cz + lam * cz
        if ax == bx and ay == by and az == bz:
            return False, 1.0, False
        d, mx, my, mz = _gjk_point_sphere(ax, ay, az, bx, by, bz, radius)
        if d < dist:  # the collector keeps the nearer result only
            if d < 0.0:
                return True, last, True
            dist, nx, ny, nz = d, mx, my, mz
    if nx * rx + ny * ry + nz * rz >= -0.0:
        return False, 1.0, True
    return True, lam, True


@njit(cache=True, nogil=True)
def cast_spheres(starts, ends, robot, centres, radius, reach, margin, out, sure):
    """Hit fractions ``out`` of rays ``starts[i] -> ends[i]`` of robot ``robot[i]`` against the
    robot spheres (centres ``(K, 3)``, one ``radius``) as Bullet's
    closest-hit ray test computes them (1: no hit), and ``sure[i]`` (False: ask Bullet). Every
    sphere the ray passes within ``margin`` of is tested, the ray's own robot included, as in
    Bullet; ``reach`` (m) bounds the distance from a robot's centre to its rays' ends."""
    k_robots = centres.shape[0]
    near = np.empty((k_robots, k_robots), dtype=np.int64)
    count = np.zeros(k_robots, dtype=np.int64)
    r = reach + radius + margin
    for k in range(k_robots):
        for j in range(k_robots):
            dx = centres[j, 0] - centres[k, 0]
            dy = centres[j, 1] - centres[k, 1]
            dz = centres[j, 2] - centres[k, 2]
            if dx * dx + dy * dy + dz * dz <= r * r:
                near[k, count[k]] = j
                count[k] += 1
    rho = radius + margin
    for i in range(starts.shape[0]):
        fx, fy, fz = starts[i, 0], starts[i, 1], starts[i, 2]
        tx, ty, tz = ends[i, 0], ends[i, 1], ends[i, 2]
        ux, uy, uz = tx - fx, ty - fy, tz - fz
        length = np.sqrt(ux * ux + uy * uy + uz * uz)
        ux, uy, uz = ux / length, uy / length, uz / length
        best = 1.0
        ok = True
        k = robot[i]
        for c in range(count[k]):
            j = near[k, c]
            qx, qy, qz = centres[j, 0] - fx, centres[j, 1] - fy, centres[j, 2] - fz
            along = qx * ux + qy * uy + qz * uz
            if along < -rho or along > length + rho:
                continue
            ex, ey, ez = qx - along * ux, qy - along * uy, qz - along * uz
            if ex * ex + ey * ey + ez * ez > rho * rho:
                continue
            hit, fraction, certain = cast_sphere(fx, fy, fz, tx, ty, tz, centres[j, 0],
                                                 centres[j, 1], centres[j, 2], radius)
            if not certain:
                ok = False
            elif hit and fraction < best:
                best = fraction
        out[i] = best
        sure[i] = ok


@njit(cache=True, nogil=True)
def _beam_span(bearing, half, first, step, beams):
    """Indices ``lo .. hi`` (clipped to the pattern) of the beams ``first + n step`` whose angle
    lies within ``half`` (+ a 1e-9 rad pad) of ``bearing`` (rad, relative to the heading, any
    turn); ``hi < lo`` for none."""
    lo = max(int(np.ceil((bearing - half - 1e-9 - first) / step)), 0)
    hi = min(int(np.floor((bearing + half + 1e-9 - first) / step)), beams - 1)
    return lo, hi


@njit(cache=True, nogil=True)
def _span(px, py, yaw, bx, by, rho, range_m, first, step, beams, out):
    """Write into ``out`` the beams (indices) of a robot at ``(px, py)`` heading ``yaw`` whose
    rays can pass within ``rho`` of the point ``b`` (none if it lies beyond ``range_m + rho``):
    the beams within ``asin(rho / d)`` of its bearing, the sector also taken one turn either way
    (the pattern starts at -pi); return how many. A beam on the seam may come twice: testing a
    ray twice against one body changes nothing."""
    dx, dy = bx - px, by - py
    reach = range_m + rho
    if dx * dx + dy * dy > reach * reach:
        return 0
    d = np.sqrt(dx * dx + dy * dy)
    if d <= rho:
        for n in range(beams):
            out[n] = n
        return beams
    half = np.arcsin(rho / d)
    bearing = np.arctan2(dy, dx) - yaw
    bearing = (bearing + np.pi) % (2.0 * np.pi) - np.pi
    count = 0
    for turn in (-2.0 * np.pi, 0.0, 2.0 * np.pi):
        lo, hi = _beam_span(bearing + turn, half, first, step, beams)
        for n in range(lo, hi + 1):
            out[count] = n
            count += 1
    return count


@njit(cache=True, nogil=True)
def _enters_beyond(qx, qy, qz, ux, uy, uz, rho, distance):
    """Whether a ray from the origin along the unit vector ``u`` enters the ball of radius
    ``rho`` about ``q`` only beyond ``distance`` (m) plus 1 um, or misses it."""
    along = qx * ux + qy * uy + qz * uz
    gap = rho * rho - (qx * qx + qy * qy + qz * qz - along * along)
    return gap < 0.0 or along - np.sqrt(gap) > distance + 1e-6


@njit(cache=True, nogil=True)
def _ray(px, py, height, u, start_m, range_m):
    """Start and end of the ray of unit direction ``u`` from the lidar at ``(px, py, height)``,
    as :meth:`fftnav.sim.lidar.Lidar._rays` computes them (centre + distance * direction)."""
    return (px + start_m * u[0], py + start_m * u[1], height + start_m * u[2],
            px + range_m * u[0], py + range_m * u[1], height + range_m * u[2])


@njit(cache=True, nogil=True)
def scan_swarm(poses, robot_z, direction, live_index, first, step, height, start_m, range_m,
               triangles, footprints, same_footprint, first_triangle, circles, margin, radius,
               sphere_margin, obstacle, obstacle_sure, robots, robot_sure, cast_obstacle,
               cast_robot):
    """Every live ray of a swarm's scan against the obstacles' side triangles and the robot
    spheres, the rays chosen per body by its angular span (a superset of the rays that can
    reach it), with the arithmetic of :func:`cast_static` and :func:`cast_sphere`.

    ``poses`` ``(K, 3)``, ``robot_z`` ``(K,)``: robots (x, y, yaw; sphere centre heights);
    ``direction`` ``(K, L, 3)``: the live rays' unit directions, as the caller computes them;
    ``live_index`` ``(M,)``: each beam's column among the L live ones (-1: blind); beam n points
    at ``first + n step`` from the heading. Outputs ``(K, L)``: hit fractions against the
    obstacles (``obstacle``, 1: none; ``obstacle_sure`` False where Bullet must decide) and the
    robots (``robots``, ``robot_sure``), and which rays were tested against each
    (``cast_obstacle``, ``cast_robot``)."""
    k_robots = poses.shape[0]
    beams = live_index.shape[0]
    n_obstacles = circles.shape[0]
    span = np.empty(3 * beams, dtype=np.int64)
    near_obstacles = np.empty(n_obstacles, dtype=np.int64)
    near_robots = np.empty(k_robots, dtype=np.int64)
    distances = np.empty(max(n_obstacles, k_robots))
    # a sphere's cast stops within _GJK_CAST_RADIUS of its surface: a ray that stays farther
    # than this from the centre never hits it (with room for rounding)
    stop = radius + _GJK_CAST_RADIUS + 1e-4
    for k in range(k_robots):
        px, py, yaw = poses[k, 0], poses[k, 1], poses[k, 2]
        # obstacles within reach, nearest first: their side triangles on the rays of their
        # span; an obstacle whose widened circle a ray enters only beyond the ray's best hit so
        # far cannot change it (its triangles lie in the circle), nor can a tie: the first
        # triangle to reach the smallest distance keeps it, as in Bullet's smallest-hit rule
        count = 0
        for j in range(n_obstacles):
            dx, dy, reach = circles[j, 0] - px, circles[j, 1] - py, range_m + circles[j, 2] + margin
            if dx * dx + dy * dy <= reach * reach:  # (first, without a call: most are far)
                near_obstacles[count] = j
                distances[count] = dx * dx + dy * dy
                count += 1
        for j in near_obstacles[:count][np.argsort(distances[:count])]:
            rho = circles[j, 2] + margin
            for i in range(_span(px, py, yaw, circles[j, 0], circles[j, 1], rho, range_m, first,
                                 step, beams, span)):
                col = live_index[span[i]]
                if col < 0:
                    continue
                cast_obstacle[k, col] = True
                fx, fy, fz, tx, ty, tz = _ray(px, py, height, direction[k, col], start_m,
                                              range_m)
                vx, vy = tx - fx, ty - fy
                length = np.sqrt(vx * vx + vy * vy)
                vx, vy = vx / length, vy / length
                hit, clear = obstacle[k, col], obstacle_sure[k, col]
                if _enters_beyond(circles[j, 0] - fx, circles[j, 1] - fy, 0.0, vx, vy, 0.0,
                                  rho, hit * length):
                    continue
                near = False
                for t in range(first_triangle[j], first_triangle[j + 1]):
                    if not same_footprint[t]:  # else: the face's other triangle's answer
                        near = _near_footprint(footprints, t, fx, fy, vx, vy, length, margin)
                    if near:
                        hit, clear = _process_triangle(triangles, t, fx, fy, fz, tx, ty, tz,
                                                       hit, clear)
                obstacle[k, col], obstacle_sure[k, col] = hit, clear
        # other robots within reach, nearest first: Bullet's sphere cast on the rays of their
        # span, unless the ray comes within the cast's stopping distance of the sphere only
        # beyond its best sure hit so far (or never)
        count = 0
        for j in range(k_robots):
            dx, dy, reach = poses[j, 0] - px, poses[j, 1] - py, range_m + radius + sphere_margin
            if j != k and dx * dx + dy * dy <= reach * reach:  # (a ray leaves its own robot's
                near_robots[count] = j  # sphere: Bullet's cast never hits it)
                distances[count] = dx * dx + dy * dy
                count += 1
        for j in near_robots[:count][np.argsort(distances[:count])]:
            cx, cy, cz = poses[j, 0], poses[j, 1], robot_z[j]
            for i in range(_span(px, py, yaw, cx, cy, radius + sphere_margin, range_m, first,
                                 step, beams, span)):
                col = live_index[span[i]]
                if col < 0:
                    continue
                cast_robot[k, col] = True
                u = direction[k, col]
                fx, fy, fz, tx, ty, tz = _ray(px, py, height, u, start_m, range_m)
                best = robots[k, col]
                if obstacle_sure[k, col] or obstacle[k, col] == 1.0:  # a sure obstacle hit
                    best = min(best, obstacle[k, col])
                if _enters_beyond(cx - fx, cy - fy, cz - fz, u[0], u[1], u[2], stop,
                                  best * (range_m - start_m)):
                    continue
                hit, fraction, certain = cast_sphere(fx, fy, fz, tx, ty, tz, cx, cy, cz, radius)
                if not certain:
                    robot_sure[k, col] = False
                elif hit and fraction < robots[k, col]:
                    robots[k, col] = fraction
    # a hit counts as sure when it is clear of its triangle's edges (cast_static's rule)
    for k in range(k_robots):
        for col in range(direction.shape[1]):
            obstacle_sure[k, col] = obstacle[k, col] == 1.0 or obstacle_sure[k, col]
