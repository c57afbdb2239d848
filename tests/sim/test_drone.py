"""PyBullet 3D forest, spherical depth sensor (rayTestBatch) and collision checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.observe.spherical import SphericalGrid
from fftnav.sim.drone import DroneSim, Forest3D, make_forest3d
from fftnav.sim.rays import MAX_RAYS


def _scene(canopies: list[list[float]], trunks: list[list[float]] | None = None) -> Forest3D:
    return Forest3D(trunks=np.asarray(trunks or np.zeros((0, 4))).reshape(-1, 4),
                    canopies=np.asarray(canopies, dtype=float).reshape(-1, 4),
                    start=np.array([0.0, 0.0, 2.0]), goal=np.array([30.0, 0.0, 2.0]))


def _analytic_depth(
    dirs: np.ndarray, pos: np.ndarray, spheres: np.ndarray, r: float,
    trunks: tuple = (),
) -> tuple[np.ndarray, np.ndarray]:
    """Ray distances to spheres, vertical cylinders (x, y, radius, height: sides only, seen from
    below their tops) and the ground z = 0 (capped at r), and the grazing rays.

    A ray grazes a sphere (a cylinder) when its closest approach to the centre (the axis, in the
    ground plane) is within 3 cm of the radius: tangent rays, where a ray caster's hit/miss
    decision is legitimately ambiguous.
    """
    grazing = np.zeros(dirs.shape[:-1], bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(dirs[..., 2] < 0, -pos[2] / dirs[..., 2], np.inf)
        for cx, cy, cz, rad in spheres:
            oc = np.array([cx, cy, cz]) - pos
            b = dirs @ oc
            disc = b**2 - oc @ oc + rad**2
            hit = b - np.sqrt(disc)
            t = np.minimum(t, np.where((disc >= 0) & (hit > 0), hit, np.inf))
            grazing |= (b > 0) & (np.abs(np.sqrt(np.maximum(oc @ oc - b**2, 0)) - rad) < 0.03)
        for cx, cy, rad, height in np.reshape(trunks, (-1, 4)):
            oc = np.array([cx, cy]) - pos[:2]
            dxy = dirs[..., :2]
            a = np.sum(dxy**2, axis=-1)
            b = dxy @ oc
            disc = b**2 - a * (oc @ oc - rad**2)
            hit = (b - np.sqrt(disc)) / a
            z = pos[2] + hit * dirs[..., 2]
            t = np.minimum(t, np.where((disc >= 0) & (hit > 0) & (z >= 0) & (z <= height),
                                       hit, np.inf))
            miss_xy = np.sqrt(np.maximum(oc @ oc - b**2 / a, 0))
            grazing |= (b > 0) & (np.abs(miss_xy - rad) < 0.03)
    return np.minimum(t, r), grazing


def test_scan_matches_ray_sphere_geometry_with_chunked_batches() -> None:
    spheres = [[4.0, 1.0, 2.5, 1.5], [-3.0, -2.0, 1.0, 0.8], [0.0, 6.0, 6.0, 2.0]]
    grid = SphericalGrid(90, 360)  # 32,400 rays
    with DroneSim(_scene(spheres), grid=grid, range_m=10.0) as sim:
        assert grid.rows * grid.cols > MAX_RAYS  # more than one rayTestBatch call
        depth = sim.scan(np.array([0.0, 0.0, 2.0]), 0.0)
    expected, grazing = _analytic_depth(grid.directions(), np.array([0.0, 0.0, 2.0]),
                                        np.array(spheres), 10.0)
    assert depth.shape == (90, 360) and grazing.mean() < 0.02
    np.testing.assert_allclose(depth[~grazing], expected[~grazing], rtol=1e-3, atol=1e-3)
    assert (depth == 10.0).mean() > 0.2  # misses read R


def test_trunk_mesh_matches_ray_cylinder_geometry() -> None:
    trunks = [[3.0, 0.5, 0.3, 5.0], [-2.0, -2.5, 0.15, 4.0], [1.0, -4.0, 0.25, 6.0]]
    spheres = [[3.0, 0.5, 5.0, 1.2]]
    grid = SphericalGrid(45, 180)
    pos = np.array([0.0, 0.0, 2.0])
    expected, grazing = _analytic_depth(grid.directions(), pos, np.array(spheres), 10.0,
                                        np.array(trunks))
    for shape in ("mesh", "cylinder"):
        with DroneSim(_scene(spheres, trunks), grid=grid, trunk_shape=shape) as sim:
            depth = sim.scan(pos, 0.0)
        # the 64-gon prisms circumscribe the circles: readings at most ~1 mm short
        np.testing.assert_allclose(depth[~grazing], expected[~grazing], rtol=1e-3, atol=2e-3)
    assert (expected[~grazing] < 6.0).mean() > 0.3  # the trunks and ground fill the image


def test_scan_rotates_with_yaw() -> None:
    grid = SphericalGrid(18, 72)
    with DroneSim(_scene([[3.0, 0.0, 2.0, 1.0]]), grid=grid) as sim:
        pos = np.array([0.0, 0.0, 2.0])
        ahead = sim.scan(pos, 0.0)
        turned = sim.scan(pos, math.pi / 2)  # the sphere is now on the right, azimuth -90 deg
    np.testing.assert_allclose(turned, np.roll(ahead, -18, axis=1), atol=1e-6)
    eq = 9
    assert ahead[eq, 36] == pytest.approx(2.0, abs=0.05)


def test_trunk_is_seen_and_collisions_detected() -> None:
    scene = _scene([[5.0, 0.0, 6.0, 1.0]], trunks=[[5.0, 0.0, 0.3, 6.0]])
    grid = SphericalGrid(18, 72)
    with DroneSim(scene, grid=grid, r0_m=0.15) as sim:
        depth = sim.scan(np.array([0.0, 0.0, 2.0]), 0.0)
        assert depth[9, 36] == pytest.approx(4.7, abs=0.05)  # trunk surface at x = 4.7
        assert not sim.collides(np.array([0.0, 0.0, 2.0]))
        assert not sim.collides(np.array([5.0 - 0.3 - 0.2, 0.0, 2.0]))
        assert sim.collides(np.array([5.0 - 0.3 - 0.1, 0.0, 2.0]))  # 0.1 < r0 from the trunk
        assert sim.collides(np.array([5.0, 0.0, 6.9]))  # inside the canopy
        assert sim.collides(np.array([1.0, 1.0, 0.1]))  # the ground
        assert not sim.collides(np.array([1.0, 1.0, 0.2]))
        # margin_m: within 5 cm of the trunk (0.17 m from its surface) but not touching it
        assert not sim.collides(np.array([5.0 - 0.3 - 0.17, 0.0, 2.0]))
        assert sim.collides(np.array([5.0 - 0.3 - 0.17, 0.0, 2.0]), margin_m=0.05)
        assert not sim.collides(np.array([5.0 - 0.3 - 0.17, 0.0, 2.0]), margin_m=0.01)


def test_forest_is_seeded_and_keeps_start_and_goal_clear() -> None:
    a = make_forest3d(np.random.default_rng(5))
    b = make_forest3d(np.random.default_rng(5))
    c = make_forest3d(np.random.default_rng(6))
    np.testing.assert_array_equal(a.trunks, b.trunks)
    assert a.trunks.shape != c.trunks.shape or not np.array_equal(a.trunks, c.trunks)
    xy = a.trunks[:, :2]
    assert len(xy) > 100
    for p in (a.start, a.goal):
        assert np.hypot(*(xy - p[:2]).T).min() >= 2.5
    gaps = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1))
    assert gaps[np.triu_indices(len(xy), 1)].min() >= 1.5
    np.testing.assert_array_equal(a.canopies[:, 2], a.trunks[:, 3])
    assert np.linalg.norm(a.goal - a.start) == pytest.approx(30.0)


def test_errors() -> None:
    rng = np.random.default_rng(0)
    for kwargs, match in [
        ({"distance_m": 4}, r"distance_m must be finite and > 2 \* clearance_m \(clearance_m=2.5\)"
                            r", got distance_m=4"),
        ({"distance_m": 9, "clearance_m": 5.0}, r"\(clearance_m=5.0\), got distance_m=9"),
        ({"altitude_m": -1}, r"altitude_m must be a finite number > 0, got altitude_m=-1"),
        ({"trees_per_100m2": -1.0}, r"trees_per_100m2 must be a finite number >= 0, "
                                    r"got trees_per_100m2=-1.0"),
        ({"trees_per_100m2": math.nan}, r"got trees_per_100m2=nan"),
        ({"min_spacing_m": math.inf}, r"min_spacing_m must be a finite number >= 0, "
                                      r"got min_spacing_m=inf"),
        ({"clearance_m": -0.5}, r"clearance_m must be a finite number >= 0, got clearance_m=-0.5"),
        ({"distance_m": "far"}, r"distance_m must be a finite number, got distance_m='far'"),
    ]:
        with pytest.raises(ValueError, match=match):
            make_forest3d(rng, **kwargs)
    assert len(make_forest3d(rng, trees_per_100m2=0.0).trunks) == 0
    grid = SphericalGrid(4, 8)
    for kwargs, match in [
        ({"range_m": 0.1}, r"range_m must be finite and > r0_m=0.15, got range_m=0.1"),
        ({"r0_m": 0.0}, r"r0_m must be a finite number > 0, got r0_m=0.0"),
        ({"r0_m": -1.0, "range_m": 10.0}, r"r0_m must be a finite number > 0, got r0_m=-1.0"),
        ({"range_m": None}, r"range_m must be a finite number, got range_m=None"),
        ({"trunk_shape": "box"}, r"trunk_shape must be one of \['mesh', 'cylinder'\], "
                                   r"got trunk_shape='box'"),
    ]:
        with pytest.raises(ValueError, match=match):
            DroneSim(_scene([]), grid=grid, **kwargs)
