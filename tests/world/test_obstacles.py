"""Obstacle shapes carry their own geometry (fftnav.world.obstacles), consistently; a new shape is
one class: defined here, it works in world files, grids, the analytic ray cast and the simulator."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from fftnav.validate import check_number, check_vector
from fftnav.world import SHAPES, Circle, Obstacle, Polygon, World, occupancy_grid, raycast_world
from fftnav.world.obstacles import combined_mesh, prism_mesh


def _shapes():
    rng = np.random.default_rng(5)
    out = [Circle((2.0, 3.0), 0.3, 1.0), Circle((1.0, 1.0), 0.05, 2.0)]
    for _ in range(4):
        n = int(rng.integers(3, 9))
        a = np.sort(rng.uniform(0, 2 * math.pi, n))
        pts = np.c_[np.cos(a), np.sin(a)] * rng.uniform(0.2, 1.0, 2) + [3.0, 3.0]
        out.append(Polygon(tuple(map(tuple, pts.tolist())), 1.0))
    return out


@pytest.mark.parametrize("obstacle", _shapes(), ids=lambda o: o.shape)
def test_bounds_outline_and_circle_contain_the_shape(obstacle):
    rng = np.random.default_rng(0)
    lo, hi = obstacle.bounds()
    pts = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), (4000, 2))
    inside = obstacle.distance(pts) == 0
    assert inside.sum() > 100
    assert np.all((pts[inside] >= lo) & (pts[inside] <= hi))
    outline = Polygon(tuple(map(tuple, obstacle.outline().tolist())), 1.0)
    assert np.all(outline.distance(pts[inside]) == 0)
    x, y, r = obstacle.bounding_circle()
    assert np.all(np.hypot(*(obstacle.outline() - [x, y]).T) <= r + 1e-12)


@pytest.mark.parametrize("obstacle", _shapes(), ids=lambda o: o.shape)
def test_ray_distances_agree_with_the_distance_function(obstacle):
    rng = np.random.default_rng(1)
    lo, hi = obstacle.bounds()
    origins = rng.uniform(lo - 2.0, hi + 2.0, (500, 2))
    origins = origins[obstacle.distance(origins) > 0.01]
    aim = np.mean(obstacle.bounds(), axis=0) - origins  # mostly toward the shape
    angles = np.arctan2(aim[:, 1], aim[:, 0]) + rng.normal(0, 0.3, len(origins))
    d = np.c_[np.cos(angles), np.sin(angles)]
    t = type(obstacle).ray_distances([obstacle], origins, d)
    hit = np.isfinite(t)
    assert 20 < hit.sum() < len(t)
    assert np.allclose(obstacle.distance(origins[hit] + t[hit, None] * d[hit]), 0, atol=1e-9)
    for f in (0.25, 0.5, 0.99):  # nothing is hit before the first hit, or on a miss
        before = origins + np.where(hit, t * f, 3.0 * f)[:, None] * d
        assert np.all(obstacle.distance(before) > 0)


@pytest.mark.parametrize("obstacle", _shapes(), ids=lambda o: o.shape)
def test_json_round_trip_and_mesh(obstacle):
    assert SHAPES[obstacle.shape].from_dict(obstacle.to_dict(), "o") == obstacle
    vertices, indices = obstacle.mesh()
    n = len(obstacle.outline())
    assert vertices.shape == (2 * n, 3) and len(indices) == 3 * (2 * n + 2 * (n - 2))
    centre = np.r_[vertices[:, :2].mean(axis=0), obstacle.height / 2]
    tri = vertices[indices.reshape(-1, 3)]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all(np.sum(normal * (tri.mean(axis=1) - centre), axis=1) > 0)  # facing outward


def test_circle_mesh_is_the_circumscribed_64_gon():
    trunk = Circle((1.0, 2.0), 0.3, 2.0)
    outline = trunk.outline()
    assert len(outline) == 64
    assert np.allclose(np.hypot(*(outline - [1.0, 2.0]).T), 0.3 / math.cos(math.pi / 64))
    assert trunk.cull_vertices() is None  # its bounding circle is as tight
    verts, idx = combined_mesh([trunk, trunk.moved(np.array([1.0, 0.0]), decimals=4)])
    assert len(verts) == 256 and max(idx) == 255


def test_prism_mesh_of_a_triangle():
    vertices, indices = prism_mesh(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), 2.0)
    assert vertices.tolist() == [[0, 0, 0], [0, 0, 2], [1, 0, 0], [1, 0, 2], [0, 1, 0], [0, 1, 2]]
    assert len(indices) == 3 * 8


def test_registering_a_name_twice_is_refused():
    from fftnav.world.obstacles import register_shape

    with pytest.raises(ValueError, match="shape 'circle' is already registered"):
        register_shape(Circle)


# ----------------------------------------------------------------------------- a new shape


@dataclass(frozen=True)
class Box(Obstacle):
    """An axis-aligned rectangle: the whole of a new shape is this class."""

    shape: ClassVar[str] = "box"
    center: tuple[float, float]
    half: tuple[float, float]
    height: float

    def bounds(self):
        return np.subtract(self.center, self.half), np.add(self.center, self.half)

    def distance(self, points):
        q = np.abs(np.asarray(points, float).reshape(-1, 2) - self.center) - self.half
        return np.hypot(*np.maximum(q, 0.0).T)

    def outline(self):
        (x, y), (a, b) = self.center, self.half
        return np.array([[x - a, y - b], [x + a, y - b], [x + a, y + b], [x - a, y + b]])

    @classmethod
    def ray_distances(cls, obstacles, origins, directions):
        best = np.full(len(origins), np.inf)
        for box in obstacles:  # slab method
            lo, hi = box.bounds()
            with np.errstate(divide="ignore", invalid="ignore"):
                t1, t2 = (lo - origins) / directions, (hi - origins) / directions
            near = np.nanmax(np.minimum(t1, t2), axis=1)
            far = np.nanmin(np.maximum(t1, t2), axis=1)
            t = np.where(near >= 0, near, np.where(far >= 0, 0.0, np.inf))
            best = np.minimum(best, np.where(near <= far, t, np.inf))
        return best

    def moved(self, offset, *, decimals):
        c = np.round(np.add(self.center, offset), decimals)
        return Box((float(c[0]), float(c[1])), self.half, self.height)

    def to_dict(self):
        return {"shape": "box", "center": list(self.center), "half": list(self.half),
                "height": self.height}

    @classmethod
    def from_dict(cls, data, where):
        return Box(check_vector(f"{where}.center", data["center"], 2),
                   check_vector(f"{where}.half", data["half"], 2),
                   check_number(f"{where}.height", data["height"], low=0, low_open=True))


@pytest.fixture
def box_world(monkeypatch):
    monkeypatch.setitem(SHAPES, "box", Box)
    data = {"env": "custom", "seed": 0, "size": [6.0, 6.0],
            "obstacles": [{"shape": "box", "center": [3.0, 3.0], "half": [1.0, 0.5], "height": 1},
                          {"shape": "circle", "center": [1.0, 4.5], "radius": 0.3, "height": 1}],
            "starts": [[3.0, 1.0, 1.5707963]], "goals": [[3.0, 5.0]]}
    return World.from_json(json.dumps(data))


def test_a_new_shape_class_works_in_files_grids_and_the_oracle(box_world):
    assert World.from_json(box_world.to_json()).obstacles == box_world.obstacles
    grid = occupancy_grid(box_world, resolution_m=0.1)
    assert grid.grid[25:35, 20:40].all() and not grid.grid[:24, :].any()  # rows are y
    got = raycast_world(box_world, [[3.0, 1.0]], [[math.pi / 2, 0.0]], 3.0)
    assert got[0].tolist() == pytest.approx([1.5, 3.0])


def test_a_new_shape_class_works_in_the_simulator(box_world):
    from fftnav.sim.swarm import SimConfig, SwarmSim

    with SwarmSim(box_world, config=SimConfig()) as sim:
        scan = sim.reset(seed=0).scans[0]
        angles = sim.lidar.angles_rad + box_world.starts[0, 2]
    expected = raycast_world(box_world, box_world.starts[:, :2], angles[None], 3.0)[0]
    live = scan > 0
    assert np.abs(scan[live] - expected[live]).max() < 0.01
