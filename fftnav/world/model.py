"""The world model: a rectangle of obstacles with one start pose and one goal per robot; JSON files.

A world is a flat rectangle ``[0, w] x [0, h]`` (metres, x right, y up, yaw CCW from +x) holding
vertical prisms (:mod:`fftnav.world.obstacles`: tree trunks, rocks, wall fragments, any
registered shape), plus one start pose and one goal per robot (paper Sec. IV-B: 20 m x 20 m,
about one obstacle per 5 m^2, 15 robots). Its ``boundary`` is ``"open"`` (the paper: nothing
stops a robot at the map edge) or ``"walls"`` (the edge is an obstacle for the robots, the lidar,
grids and A*: :attr:`World.solids` adds four walls just outside the rectangle). Pure numpy.

World file (JSON); every key but ``boundary`` is required (a file without it is ``"open"``) and
no other key is accepted::

    {"env": "forest", "seed": 3, "size": [20.0, 20.0],
     "obstacles": [{"shape": "circle", "center": [x, y], "radius": r, "height": h},
                   {"shape": "polygon", "vertices": [[x, y], ...], "height": h}],
     "starts": [[x, y, yaw], ...], "goals": [[x, y], ...], "boundary": "walls"}

``boundary`` is written only when it is ``"walls"``, so an open world's file is unchanged.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.files import parse_json, read_text, write_atomic
from fftnav.limits import MAX_MAP_SIDE_M, MAX_OBSTACLES, check_limit
from fftnav.validate import (
    Checked,
    check_choice,
    check_integer,
    check_number,
    check_vector,
    choice_field,
    integer_field,
)
from fftnav.world.obstacles import SHAPES, Obstacle, rectangle

__all__ = ["BOUNDARIES", "OPTIONAL_WORLD_KEYS", "WORLD_KEYS", "World", "load_world",
           "save_world"]

#: The required keys of a world file, in the order they are written.
WORLD_KEYS: tuple[str, ...] = ("env", "seed", "size", "obstacles", "starts", "goals")
#: Optional keys of a world file (written after the required ones when not at their default).
OPTIONAL_WORLD_KEYS: tuple[str, ...] = ("boundary",)
#: Map boundaries: ``open`` (nothing at the edge) or ``walls`` (the edge is an obstacle).
BOUNDARIES: tuple[str, ...] = ("open", "walls")
#: Thickness and height (m) of the boundary walls, which lie just outside the map.
_BOUNDARY_THICKNESS_M = 1.0
_BOUNDARY_HEIGHT_M = 2.0
_BOUNDARY_PIECE_M = 2.5


@dataclass(frozen=True)
class World(Checked):
    """A world: environment name, generating seed, size (w, h) m, obstacles, robot starts and goals.

    ``starts`` is ``(N, 3)`` (x m, y m, yaw rad) and ``goals`` ``(N, 2)`` (x m, y m); robot i
    starts at ``starts[i]`` and drives to ``goals[i]``. ``boundary`` is ``"open"`` or
    ``"walls"`` (:data:`BOUNDARIES`).
    """

    env: str
    seed: int = integer_field()
    size_m: tuple[float, float]
    obstacles: tuple[Obstacle, ...]
    starts: np.ndarray
    goals: np.ndarray
    boundary: str = choice_field("open", BOUNDARIES)

    @property
    def boundary_walls(self) -> tuple[Obstacle, ...]:
        """The walls of a ``"walls"`` boundary, bottom, top, left, right: 1 m thick rectangles
        just outside ``[0, w] x [0, h]`` (the bottom and top ones covering the corners), each
        cut into pieces at most 2.5 m long so that the lidar's ray culling stays effective;
        empty for ``"open"``."""
        if self.boundary == "open":
            return ()
        w, h = self.size_m
        t = _BOUNDARY_THICKNESS_M
        boxes = ((-t, -t, w + t, 0.0), (-t, h, w + t, h + t),  # bottom, top
                 (-t, 0.0, 0.0, h), (w, 0.0, w + t, h))  # left, right
        walls = []
        for x0, y0, x1, y1 in boxes:
            along_x = x1 - x0 > y1 - y0
            cuts = np.linspace(*((x0, x1) if along_x else (y0, y1)),
                               math.ceil(max(x1 - x0, y1 - y0) / _BOUNDARY_PIECE_M) + 1)
            for a, b in zip(cuts[:-1], cuts[1:], strict=True):
                box = (a, y0, b, y1) if along_x else (x0, a, x1, b)
                walls.append(rectangle(*map(float, box), _BOUNDARY_HEIGHT_M))
        return tuple(walls)

    @property
    def solids(self) -> tuple[Obstacle, ...]:
        """Everything that stops a robot or a lidar beam: the obstacles, then the boundary
        walls. The simulator, the ray-cast oracle, grids and A* all use this."""
        return self.obstacles + self.boundary_walls

    def to_json(self) -> str:
        """The documented JSON text of this world (see the module docstring)."""
        data = {
            "env": self.env, "seed": self.seed, "size": list(self.size_m),
            "obstacles": [o.to_dict() for o in self.obstacles],
            "starts": self.starts.tolist(), "goals": self.goals.tolist(),
        }
        if self.boundary != "open":
            data["boundary"] = self.boundary
        return json.dumps(data)

    @classmethod
    def from_json(cls, text: str, *, where: str = "world file") -> World:
        """Parse and validate a world's JSON text; errors name ``where`` (the file) and the
        offending entry."""
        data = parse_json(text, where=where)
        try:
            return _parse_world(data)
        except ValueError as exc:
            if where == "world file":
                raise
            raise FftnavError(f"{where}: {exc}") from None

    def obstacle_distance(self, points: np.ndarray) -> np.ndarray:
        """Euclidean distance (m) from each point ``(P, 2)`` to the nearest solid (obstacle or
        boundary wall), 0 inside one, ``inf`` in an open world without obstacles."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        best = np.full(len(pts), np.inf)
        for obstacle in self.solids:
            best = np.minimum(best, obstacle.distance(pts))
        return best

    def with_robots(self, starts: np.ndarray, goals: np.ndarray) -> World:
        """The same obstacles with other robots: ``starts`` ``(N, 3)`` and ``goals`` ``(N, 2)``."""
        return World(self.env, self.seed, self.size_m, self.obstacles,
                     np.asarray(starts, dtype=float).reshape(-1, 3),
                     np.asarray(goals, dtype=float).reshape(-1, 2), self.boundary)


def _parse_obstacle(data: Any, where: str, size: tuple[float, float]) -> Obstacle:
    if not isinstance(data, dict) or data.get("shape") not in SHAPES:
        raise FftnavError(f"{where}: shape must be one of {sorted(SHAPES)}, got {data!r:.80}")
    obstacle = SHAPES[data["shape"]].from_dict(data, where)
    lo, hi = obstacle.bounds()
    if np.any(lo < 0) or hi[0] > size[0] or hi[1] > size[1]:
        raise FftnavError(f"{where}: obstacle lies (partly) outside the world [0, {size[0]:g}] x "
                          f"[0, {size[1]:g}]: it spans [{lo[0]:g}, {hi[0]:g}] x "
                          f"[{lo[1]:g}, {hi[1]:g}]")
    return obstacle


def _points(value: Any, n: int, where: str, size: tuple[float, float]) -> np.ndarray:
    if not isinstance(value, list) or not value:
        raise FftnavError(f"{where} must be a non-empty list, got {value!r:.80}")
    pts = np.array([check_vector(f"{where}[{i}]", v, n) for i, v in enumerate(value)])
    outside = np.flatnonzero((pts[:, 0] < 0) | (pts[:, 0] > size[0]) | (pts[:, 1] < 0)
                             | (pts[:, 1] > size[1]))
    if outside.size:
        raise FftnavError(f"{where}[{outside[0]}] lies outside the world, got {value[outside[0]]}")
    return pts


def _check_free(where: str, points: np.ndarray, obstacles: tuple[Obstacle, ...],
                n_obstacles: int) -> None:
    """Raise if a start or goal lies inside an obstacle (or boundary wall) or on its boundary (a
    robot would be spawned inside the obstacle's mesh)."""
    if not obstacles:
        return
    distance = np.array([o.distance(points[:, :2]) for o in obstacles])  # (N, P)
    blocked = np.flatnonzero(distance.min(axis=0) <= 0)
    if blocked.size:
        i = blocked[0]
        j = int(np.argmin(distance[:, i]))
        what = f"obstacles[{j}]" if j < n_obstacles else "a boundary wall"
        raise FftnavError(f"{where}[{i}] lies inside {what}, got {points[i].tolist()}")


def _parse_world(data: Any) -> World:
    if not isinstance(data, dict):
        raise FftnavError(f"world file must hold a JSON object, got {type(data).__name__}")
    for key in WORLD_KEYS:
        if key not in data:
            raise FftnavError(f"world file is missing key {key!r}")
    unknown = [key for key in data if key not in WORLD_KEYS + OPTIONAL_WORLD_KEYS]
    if unknown:
        raise FftnavError(f"world file has an unknown key {unknown[0]!r}; its keys are "
                          f"{list(WORLD_KEYS + OPTIONAL_WORLD_KEYS)}")
    boundary = check_choice("boundary", data.get("boundary", "open"), BOUNDARIES)
    if not isinstance(data["env"], str):
        raise FftnavError(f"env must be a string, got env={data['env']!r}")
    check_integer("seed", data["seed"])
    size = check_vector("size", data["size"], 2)
    for i, side in enumerate(size):
        check_number(f"size[{i}]", side, low=0, low_open=True, high=MAX_MAP_SIDE_M)
    if not isinstance(data["obstacles"], list):
        raise FftnavError(f"obstacles must be a list, got {data['obstacles']!r:.80}")
    check_limit("obstacles", len(data["obstacles"]), MAX_OBSTACLES)
    obstacles = tuple(
        _parse_obstacle(o, f"obstacles[{i}]", size) for i, o in enumerate(data["obstacles"])
    )
    starts = _points(data["starts"], 3, "starts", size)
    goals = _points(data["goals"], 2, "goals", size)
    if len(starts) != len(goals):
        raise FftnavError(f"starts and goals must have the same length, got {len(starts)} starts "
                          f"and {len(goals)} goals")
    world = World(data["env"], data["seed"], size, obstacles, starts, goals,  # type: ignore[arg-type]
                  boundary)
    for name, pts in (("starts", starts), ("goals", goals)):
        _check_free(name, pts, world.solids, len(obstacles))
    return world


def save_world(world: World, path: str | Path) -> None:
    """Write ``world`` to ``path`` as the documented JSON."""
    write_atomic(path, world.to_json() + "\n")


def load_world(path: str | Path) -> World:
    """Read and fully validate a world file; ``ValueError`` names the file and the problem
    (damaged text or JSON too, and sizes above :mod:`fftnav.limits`), ``OSError`` if the file
    cannot be read."""
    return World.from_json(read_text(path), where=str(path))
