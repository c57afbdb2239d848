"""World model: seeded forest / rocky-ruin generation, JSON files, validation, analytic ray casts.

A world is a flat rectangle ``[0, w] x [0, h]`` (metres, x right, y up, yaw CCW from +x) holding
vertical extrusions of circles (tree trunks) and convex polygons (rocks, wall fragments), plus one
start pose and one goal per robot (paper Sec. IV-B: 20 m x 20 m, about one obstacle per 5 m^2,
15 robots). Pure numpy (the reachability check uses :mod:`fftnav.world.grid`, numpy + scipy).

World file (JSON)::

    {"env": "forest", "seed": 3, "size": [20.0, 20.0],
     "obstacles": [{"shape": "circle", "center": [x, y], "radius": r, "height": h},
                   {"shape": "polygon", "vertices": [[x, y], ...], "height": h}],
     "starts": [[x, y, yaw], ...], "goals": [[x, y], ...]}
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

__all__ = [
    "Circle",
    "Polygon",
    "World",
    "ENVS",
    "load_preset",
    "generate_world",
    "save_world",
    "load_world",
    "raycast_world",
    "obstacle_distance",
    "point_obstacle_distance",
]

#: Environments with a preset in ``worlds/<env>.toml``.
ENVS: tuple[str, ...] = ("forest", "rocky")
_PRESET_DIR = Path(__file__).resolve().parents[2] / "worlds"
#: Coordinates of generated worlds are rounded to this many decimals (0.1 mm), so that a world
#: is identical on every machine and survives a JSON round trip bit for bit.
_DECIMALS = 4


@dataclass(frozen=True)
class Circle:
    """Vertical cylinder (tree trunk): ``center`` (x, y) m, ``radius`` m, ``height`` m."""

    center: tuple[float, float]
    radius: float
    height: float

    def to_dict(self) -> dict[str, Any]:
        """JSON form ``{"shape": "circle", "center", "radius", "height"}``."""
        return {"shape": "circle", "center": list(self.center), "radius": self.radius,
                "height": self.height}


@dataclass(frozen=True)
class Polygon:
    """Vertical prism over a convex polygon: CCW ``vertices`` (x, y) m, ``height`` m."""

    vertices: tuple[tuple[float, float], ...]
    height: float

    def to_dict(self) -> dict[str, Any]:
        """JSON form ``{"shape": "polygon", "vertices", "height"}``."""
        return {"shape": "polygon", "vertices": [list(v) for v in self.vertices],
                "height": self.height}


Obstacle = Circle | Polygon


@dataclass(frozen=True)
class World:
    """A world: environment name, generating seed, size (w, h) m, obstacles, robot starts and goals.

    ``starts`` is ``(N, 3)`` (x m, y m, yaw rad) and ``goals`` ``(N, 2)`` (x m, y m); robot i
    starts at ``starts[i]`` and drives to ``goals[i]``.
    """

    env: str
    seed: int
    size_m: tuple[float, float]
    obstacles: tuple[Obstacle, ...]
    starts: np.ndarray
    goals: np.ndarray

    def to_json(self) -> str:
        """The documented JSON text of this world (see the module docstring)."""
        return json.dumps({
            "env": self.env, "seed": self.seed, "size": list(self.size_m),
            "obstacles": [o.to_dict() for o in self.obstacles],
            "starts": self.starts.tolist(), "goals": self.goals.tolist(),
        })

    @classmethod
    def from_json(cls, text: str) -> World:
        """Parse and validate a world's JSON text; errors name the offending entry."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"world file is not valid JSON: {exc}") from None
        return _parse_world(data)


# ----------------------------------------------------------------------------- validation


def _number(value: Any, where: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{where} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{where} must be > 0, got {value!r}")
    return float(value)


def _vector(value: Any, n: int, where: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ValueError(f"{where} must be a list of {n} numbers, got {value!r}")
    return tuple(_number(v, f"{where}[{i}]") for i, v in enumerate(value))


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of (a - o) x (b - o), broadcasting over leading axes."""
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (
        b[..., 0] - o[..., 0]
    )


def _convex_ccw(vertices: np.ndarray, where: str) -> np.ndarray:
    """Return the vertices counter-clockwise; raise if the polygon is not strictly convex."""
    turns = _cross(vertices, np.roll(vertices, -1, axis=0), np.roll(vertices, -2, axis=0))
    if not (np.all(turns > 0) or np.all(turns < 0)):
        raise ValueError(f"{where}: polygon is not convex (or has repeated/collinear vertices)")
    edges = np.roll(vertices, -1, axis=0) - vertices
    heading = np.arctan2(edges[:, 1], edges[:, 0])
    winding = np.sum(np.angle(np.exp(1j * (np.roll(heading, -1) - heading)))) / (2 * math.pi)
    if abs(abs(winding) - 1.0) > 1e-6:
        raise ValueError(f"{where}: polygon is self-intersecting (winds {abs(winding):.0f} times)")
    return vertices if turns[0] > 0 else vertices[::-1]


def _parse_obstacle(data: Any, where: str, size: tuple[float, float]) -> Obstacle:
    if not isinstance(data, dict) or data.get("shape") not in ("circle", "polygon"):
        raise ValueError(f"{where}: shape must be 'circle' or 'polygon', got {data!r:.80}")
    required = {"circle": ("center", "radius", "height"), "polygon": ("vertices", "height")}
    for key in required[data["shape"]]:
        if key not in data:
            raise ValueError(f"{where}: missing key {key!r}")
    height = _number(data["height"], f"{where}.height", positive=True)
    if data["shape"] == "circle":
        center = _vector(data["center"], 2, f"{where}.center")
        radius = _number(data["radius"], f"{where}.radius", positive=True)
        lo, hi = np.subtract(center, radius), np.add(center, radius)
        obstacle: Obstacle = Circle(center, radius, height)  # type: ignore[arg-type]
    else:
        raw = data["vertices"]
        if not isinstance(raw, list) or len(raw) < 3:
            raise ValueError(f"{where}.vertices must be a list of >= 3 [x, y] points, "
                             f"got {raw!r:.80}")
        verts = np.array([_vector(v, 2, f"{where}.vertices[{i}]") for i, v in enumerate(raw)])
        verts = _convex_ccw(verts, f"{where}.vertices")
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        obstacle = Polygon(tuple(map(tuple, verts.tolist())), height)
    if np.any(lo < 0) or hi[0] > size[0] or hi[1] > size[1]:
        raise ValueError(f"{where}: obstacle lies (partly) outside the world [0, {size[0]:g}] x "
                         f"[0, {size[1]:g}]: it spans [{lo[0]:g}, {hi[0]:g}] x "
                         f"[{lo[1]:g}, {hi[1]:g}]")
    return obstacle


def _points(value: Any, n: int, where: str, size: tuple[float, float]) -> np.ndarray:
    if not isinstance(value, list) or not value:
        raise ValueError(f"{where} must be a non-empty list, got {value!r:.80}")
    pts = np.array([_vector(v, n, f"{where}[{i}]") for i, v in enumerate(value)])
    outside = np.flatnonzero((pts[:, 0] < 0) | (pts[:, 0] > size[0]) | (pts[:, 1] < 0)
                             | (pts[:, 1] > size[1]))
    if outside.size:
        raise ValueError(f"{where}[{outside[0]}] lies outside the world, got {value[outside[0]]}")
    return pts


def _check_free(where: str, points: np.ndarray, obstacles: tuple[Obstacle, ...]) -> None:
    """Raise if a start or goal lies inside an obstacle or on its boundary (a robot would be
    spawned inside the obstacle's mesh)."""
    if not obstacles:
        return
    distance = np.array([obstacle_distance(o, points[:, :2]) for o in obstacles])  # (N, P)
    blocked = np.flatnonzero(distance.min(axis=0) <= 0)
    if blocked.size:
        i = blocked[0]
        j = int(np.argmin(distance[:, i]))
        raise ValueError(f"{where}[{i}] lies inside obstacles[{j}], got {points[i].tolist()}")


def _parse_world(data: Any) -> World:
    if not isinstance(data, dict):
        raise ValueError(f"world file must hold a JSON object, got {type(data).__name__}")
    for key in ("env", "seed", "size", "obstacles", "starts", "goals"):
        if key not in data:
            raise ValueError(f"world file is missing key {key!r}")
    if not isinstance(data["env"], str):
        raise ValueError(f"env must be a string, got {data['env']!r}")
    if isinstance(data["seed"], bool) or not isinstance(data["seed"], int):
        raise ValueError(f"seed must be an integer, got {data['seed']!r}")
    size = _vector(data["size"], 2, "size")
    if min(size) <= 0:
        raise ValueError(f"size must be two numbers > 0, got {data['size']!r}")
    if not isinstance(data["obstacles"], list):
        raise ValueError(f"obstacles must be a list, got {data['obstacles']!r:.80}")
    obstacles = tuple(
        _parse_obstacle(o, f"obstacles[{i}]", size) for i, o in enumerate(data["obstacles"])
    )
    starts = _points(data["starts"], 3, "starts", size)
    goals = _points(data["goals"], 2, "goals", size)
    if len(starts) != len(goals):
        raise ValueError(f"starts and goals must have the same length, got {len(starts)} starts "
                         f"and {len(goals)} goals")
    for name, pts in (("starts", starts), ("goals", goals)):
        _check_free(name, pts, obstacles)
    return World(data["env"], data["seed"], size, obstacles, starts, goals)  # type: ignore[arg-type]


def save_world(world: World, path: str | Path) -> None:
    """Write ``world`` to ``path`` as the documented JSON."""
    Path(path).write_text(world.to_json() + "\n")


def load_world(path: str | Path) -> World:
    """Read and fully validate a world file; ``ValueError`` names the problem, ``OSError`` if
    the file cannot be read."""
    return World.from_json(Path(path).read_text())


# ----------------------------------------------------------------------------- generation


def load_preset(env_or_path: str | Path) -> dict[str, Any]:
    """Generation parameters from ``worlds/<env>.toml`` or from a TOML file path."""
    path = Path(env_or_path)
    if str(env_or_path) in ENVS:
        path = _PRESET_DIR / f"{env_or_path}.toml"
    elif not path.suffix == ".toml":
        raise ValueError(f"env_or_path must be one of {list(ENVS)} or a .toml path, "
                         f"got {env_or_path!r}")
    with path.open("rb") as fh:
        return tomllib.load(fh)


def _check_params(env: str, p: dict[str, Any]) -> None:
    if env not in ENVS:
        raise ValueError(f"env must be one of {list(ENVS)}, got env={env!r}")
    w, h = p["size_m"]
    if not (w > 0 and h > 0):
        raise ValueError(f"size_m must be two numbers > 0, got size_m={p['size_m']!r}")
    if not 0 <= p["density_per_m2"] <= 1:
        raise ValueError(f"density_per_m2 must be in [0, 1], got density_per_m2="
                         f"{p['density_per_m2']!r}")
    n = p["robots"]
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"robots must be an integer >= 1, got robots={n!r}")
    if w / n < 2.5 * p["robot_radius_m"]:
        raise ValueError(f"robots={n} robots of radius {p['robot_radius_m']} m do not fit side by "
                         f"side in a {w:g} m wide world")
    clear = p["strip_half_width_m"]
    if not (clear <= p["start_y_m"] < p["goal_y_m"] - 2 * clear and p["goal_y_m"] + clear <= h):
        raise ValueError(f"start_y_m={p['start_y_m']} and goal_y_m={p['goal_y_m']} with "
                         f"strip_half_width_m={clear} must leave both strips inside the world")


def _make_obstacle(env: str, p: dict[str, Any], rng: np.random.Generator) -> tuple[Obstacle, float]:
    """One obstacle centred at the origin and its bounding radius (m)."""
    height = p["obstacle_height_m"]
    if env == "forest":
        r = round(float(rng.uniform(*p["trunk_radius_m"])), _DECIMALS)
        return Circle((0.0, 0.0), r, height), r
    if rng.random() < p["wall_fraction"]:  # a thin rectangular wall fragment
        half = np.array([rng.uniform(*p["wall_length_m"]), rng.uniform(*p["wall_thickness_m"])]) / 2
        local = half * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    else:  # a rock: 5 to 9 points on an ellipse, always in convex position
        sides = int(rng.integers(p["rock_sides"][0], p["rock_sides"][1] + 1))
        gaps = 1.0 + rng.random(sides)  # irregular angular gaps, none below 1/2 of the mean
        angles = 2 * math.pi * (np.cumsum(gaps) - gaps[0]) / gaps.sum()
        # Both ends of the major axis are vertices (angles 0 and pi: the vertex nearest to pi
        # moves there, by less than half a gap), so the rock is exactly as wide as drawn.
        angles[1 + np.argmin(np.abs(angles[1:] - math.pi))] = math.pi
        axes = rng.uniform(*p["rock_size_m"]) / 2 * np.array([1.0, rng.uniform(*p["rock_aspect"])])
        local = axes * np.c_[np.cos(angles), np.sin(angles)]
    yaw = rng.uniform(0, 2 * math.pi)
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    verts = local @ rot.T
    return Polygon(tuple(map(tuple, verts.tolist())), height), float(np.hypot(*verts.T).max())


def _translate(obstacle: Obstacle, xy: np.ndarray) -> Obstacle:
    if isinstance(obstacle, Circle):
        c = np.round(xy, _DECIMALS)
        return Circle((float(c[0]), float(c[1])), obstacle.radius, obstacle.height)
    verts = np.round(np.asarray(obstacle.vertices) + xy, _DECIMALS)
    return Polygon(tuple(map(tuple, verts.tolist())), obstacle.height)


def _place(env: str, seed: int, p: dict[str, Any], rng: np.random.Generator) -> World | None:
    """One draw of a world from ``rng``; None if an obstacle found no free spot in
    ``placement_tries`` tries (the caller then draws again with the next attempt's seed)."""
    w, h = (float(v) for v in p["size_m"])
    clear = p["strip_half_width_m"]
    band = (p["start_y_m"] + clear, p["goal_y_m"] - clear)  # obstacles live between the strips
    count = round(p["density_per_m2"] * w * h)
    placed: list[Obstacle] = []
    centers = np.zeros((0, 2))
    radii = np.zeros(0)
    for _ in range(count):
        shape, rad = _make_obstacle(env, p, rng)
        for _attempt in range(p["placement_tries"]):
            xy = rng.uniform([rad, band[0] + rad], [w - rad, band[1] - rad])
            if np.all(np.hypot(*(centers - xy).T) >= radii + rad + p["min_gap_m"]):
                break
        else:
            return None
        placed.append(_translate(shape, xy))
        centers = np.vstack([centers, xy])
        radii = np.append(radii, rad)
    n = p["robots"]
    xs = np.round((np.arange(n) + 0.5) * w / n, _DECIMALS)
    starts = np.c_[xs, np.full(n, p["start_y_m"]), np.full(n, round(math.pi / 2, _DECIMALS))]
    goals = np.c_[xs, np.full(n, p["goal_y_m"])]
    return World(env, seed, (w, h), tuple(placed), starts.astype(float), goals.astype(float))


def world_parameters(env: str, *, preset: dict[str, Any] | None = None,
                     **overrides: Any) -> dict[str, Any]:
    """The preset of ``env`` with ``overrides`` applied, validated: every override must be a
    preset key and have the preset value's type (a number for a number, an integer for an
    integer, a list of as many numbers for a list); then the values are checked together."""
    params = dict(load_preset(env) if preset is None else preset)
    unknown = sorted(set(overrides) - set(params))
    if unknown:
        raise ValueError(f"unknown world parameter(s) {unknown}; expected some of {sorted(params)}")
    for key, value in overrides.items():
        default = params[key]
        if isinstance(default, (list, tuple)):
            ok = (isinstance(value, (list, tuple)) and len(value) == len(default)
                  and all(_is_number(v) for v in value))
            kind = f"a list of {len(default)} numbers"
        elif isinstance(default, bool) or isinstance(default, str):
            ok, kind = type(value) is type(default), type(default).__name__
        elif isinstance(default, int):
            ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
            kind = "an integer"
        else:
            ok, kind = _is_number(value), "a number"
        if not ok:
            raise ValueError(f"{key} must be {kind}, got {key}={value!r}")
    params.update(overrides)
    _check_params(env, params)
    return params


def _is_number(value: Any) -> bool:
    return (isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
            and math.isfinite(value))


def generate_world(env: str, seed: int, *, preset: dict[str, Any] | None = None,
                   **overrides: Any) -> World:
    """Generate a seeded forest or rocky-ruin world (paper Sec. IV-B).

    Parameters
    ----------
    env : {"forest", "rocky"}
        Environment kind: trunks (circles) or rocks and wall fragments (convex polygons).
    seed : int
        Seed of the world's ``numpy.random.Generator``; the same seed gives the same world on
        every machine.
    preset : dict, optional
        Generation parameters; default ``load_preset(env)`` (``worlds/<env>.toml``).
    **overrides
        Replace preset keys, e.g. ``size_m=(30, 30)``, ``density_per_m2=0.1``, ``robots=10``.

    Returns
    -------
    World
        ``round(density_per_m2 * w * h)`` obstacles (the density is counted over the whole
        world area), all placed between the start strip ``|y - start_y_m| <= strip_half_width_m``
        and the goal strip, which stay clear. Robot i starts at
        ``((i + 0.5) w / N, start_y_m)`` facing +y and drives to ``((i + 0.5) w / N, goal_y_m)``.
        Every goal is reachable from its start for a disc of radius ``robot_radius_m``
        (4-connected free space of the occupancy grid inflated by that radius); if not, or if an
        obstacle finds no free spot in ``placement_tries`` tries, the world is redrawn from the
        generator seeded ``[seed, attempt]`` for the next attempt, up to ``max_attempts``.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got seed={seed!r}")
    params = world_parameters(env, preset=preset, **overrides)
    from fftnav.world.grid import unreachable_robots

    for attempt in range(params["max_attempts"]):
        world = _place(env, int(seed), params, np.random.default_rng([int(seed), attempt]))
        if world is not None and not unreachable_robots(
            world, radius_m=params["robot_radius_m"],
            resolution_m=params["reachability_resolution_m"],
        ):
            return world
    raise ValueError(f"no world with every obstacle placed and every goal reachable after "
                     f"max_attempts={params['max_attempts']} (seed={seed}); lower density_per_m2="
                     f"{params['density_per_m2']} or min_gap_m={params['min_gap_m']}")


# ----------------------------------------------------------------------------- analytic geometry


def _polygon_arrays(world: World) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Edge starts (E, 2), edge ends (E, 2) and each polygon's first edge index (P,)."""
    polys = [np.asarray(o.vertices) for o in world.obstacles if isinstance(o, Polygon)]
    if not polys:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, dtype=int)
    a = np.concatenate(polys)
    b = np.concatenate([np.roll(v, -1, axis=0) for v in polys])
    first = np.cumsum([0] + [len(v) for v in polys[:-1]])
    return a, b, first


def _circle_arrays(world: World) -> tuple[np.ndarray, np.ndarray]:
    circles = [o for o in world.obstacles if isinstance(o, Circle)]
    return (np.array([c.center for c in circles]).reshape(-1, 2),
            np.array([c.radius for c in circles]))


def raycast_world(world: World, origins: np.ndarray, angles: np.ndarray, range_m: float,
                  *, chunk: int = 2048) -> np.ndarray:
    """Exact 2D ray casts against the world's circles and convex polygons (numpy oracle).

    Parameters
    ----------
    world : World
        Obstacles to cast against (robots are not included).
    origins : array_like, shape (K, 2)
        Ray origins (x, y) in metres, world frame.
    angles : array_like, shape (K, M)
        Ray directions in radians, world frame (CCW from +x).
    range_m : float
        Maximum range R in metres, > 0.
    chunk : int, optional
        Rays processed per vectorised block (memory bound).

    Returns
    -------
    numpy.ndarray, shape (K, M)
        Distance from the origin to the first obstacle boundary along each ray, ``range_m``
        for a miss (as the lidar reports), 0 for an origin inside an obstacle.
    """
    origins = np.asarray(origins, dtype=float)
    angles = np.asarray(angles, dtype=float)
    if origins.ndim != 2 or origins.shape[1] != 2:
        raise ValueError(f"origins must have shape (K, 2), got shape={origins.shape}")
    if angles.ndim != 2 or angles.shape[0] != origins.shape[0]:
        raise ValueError(f"angles must have shape (K={origins.shape[0]}, M), got "
                         f"shape={angles.shape}")
    if not (math.isfinite(range_m) and range_m > 0):
        raise ValueError(f"range_m must be a finite number > 0, got range_m={range_m!r}")
    p = np.repeat(origins, angles.shape[1], axis=0)
    d = np.c_[np.cos(angles.ravel()), np.sin(angles.ravel())]
    centers, radii = _circle_arrays(world)
    a, b, first = _polygon_arrays(world)
    out = np.full(len(p), float(range_m))
    for s in range(0, len(p), chunk):
        ps, ds = p[s:s + chunk, None, :], d[s:s + chunk, None, :]
        best = out[s:s + chunk]
        if len(radii):  # ray-circle: |p + t d - c| = r, nearest root t >= 0
            f = ps - centers
            bb = np.sum(f * ds, axis=2)
            cc = np.sum(f * f, axis=2) - radii**2
            disc = bb**2 - cc
            with np.errstate(invalid="ignore"):
                t = -bb - np.sqrt(disc)
            t = np.where((disc >= 0) & (t >= 0), t, np.inf)
            t = np.where(cc < 0, 0.0, t)
            best = np.minimum(best, t.min(axis=1))
        if len(a):  # ray-segment: p + t d = a + u (b - a), t >= 0, 0 <= u <= 1
            e = b - a
            denom = ds[..., 0] * e[:, 1] - ds[..., 1] * e[:, 0]
            ap = a - ps
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (ap[..., 0] * e[:, 1] - ap[..., 1] * e[:, 0]) / denom
                u = (ap[..., 0] * ds[..., 1] - ap[..., 1] * ds[..., 0]) / denom
            t = np.where((t >= 0) & (u >= 0) & (u <= 1), t, np.inf)
            inside = np.minimum.reduceat(_cross(a, b, ps), first, axis=1).max(axis=1) > 0
            best = np.minimum(best, np.where(inside, 0.0, t.min(axis=1)))
        out[s:s + chunk] = best
    return out.reshape(angles.shape)


def obstacle_distance(obstacle: Obstacle, points: np.ndarray) -> np.ndarray:
    """Euclidean distance (m) from each point ``(P, 2)`` to one obstacle, 0 inside it."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if isinstance(obstacle, Circle):
        return np.maximum(np.hypot(*(pts - obstacle.center).T) - obstacle.radius, 0.0)
    a = np.asarray(obstacle.vertices)
    e = np.roll(a, -1, axis=0) - a
    rel = pts[:, None, :] - a
    u = np.clip(np.sum(rel * e, axis=2) / np.sum(e * e, axis=1), 0.0, 1.0)
    dist = np.hypot(*(rel - u[..., None] * e).transpose(2, 0, 1)).min(axis=1)
    inside = np.all(e[:, 0] * rel[..., 1] - e[:, 1] * rel[..., 0] > 0, axis=1)
    return np.where(inside, 0.0, dist)


def point_obstacle_distance(world: World, points: np.ndarray) -> np.ndarray:
    """Euclidean distance (m) from each point ``(P, 2)`` to the nearest obstacle, 0 inside one,
    ``inf`` in a world without obstacles."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    best = np.full(len(pts), np.inf)
    for obstacle in world.obstacles:
        best = np.minimum(best, obstacle_distance(obstacle, pts))
    return best
