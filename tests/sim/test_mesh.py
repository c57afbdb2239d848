"""Static obstacle meshes below Bullet's limits: tiling keeps the lidar bit-identical, and a
world beyond one mesh (the 60 m x 60 m forest's failure) builds."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from fftnav.sim.mesh import MAX_MESH_INDICES, MAX_MESH_VERTICES, static_meshes
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.world import World, generate_world
from fftnav.world.obstacles import Circle, Polygon, combined_mesh


def _triangles(mesh):
    """The mesh as a sorted array of triangles (3 vertices x 3 coordinates each)."""
    verts, idx = np.asarray(mesh[0]), np.asarray(mesh[1]).reshape(-1, 3)
    tri = verts[idx].reshape(-1, 9)
    return tri[np.lexsort(tri.T[::-1])]


def test_one_mesh_when_it_fits_else_tiles_within_the_limits_holding_every_triangle():
    world = generate_world("rocky", 4, size_m=[12.0, 12.0], goal_y_m=11.0, robots=4)
    whole = combined_mesh(world.obstacles)
    assert static_meshes(world.obstacles) == [whole]
    tiles = static_meshes(world.obstacles, max_vertices=100, max_indices=400, tile_m=3.0)
    assert len(tiles) > 3
    for verts, idx in tiles:
        assert len(verts) <= 100 and len(idx) <= 400 and max(idx) < len(verts)
    merged = np.concatenate([_triangles(t) for t in tiles])
    np.testing.assert_array_equal(merged[np.lexsort(merged.T[::-1])], _triangles(whole))
    assert static_meshes([]) == []


def test_an_obstacle_larger_than_a_mesh_is_refused_naming_it():
    big = Polygon(tuple((np.cos(a), np.sin(a)) for a in np.linspace(0, 6.28, 80, endpoint=False)),
                  1.0)
    with pytest.raises(ValueError, match=r"obstacles\[1\] has a mesh of 160 vertices"):
        static_meshes([Circle((0.0, 0.0), 0.1, 1.0), big], max_vertices=150)


@pytest.mark.parametrize("env", ["forest", "rocky"])
def test_tiled_world_gives_bit_identical_lidar_scans(env):
    """The same ranges, bit for bit, at 300 poses all over the world, from one mesh and from
    tiles of several."""
    world = generate_world(env, 3, size_m=[12.0, 12.0], goal_y_m=11.0, robots=6)
    rng = np.random.default_rng(0)
    poses = np.c_[rng.uniform(0.5, 11.5, (300, 2)), rng.uniform(-np.pi, np.pi, 300)]
    poses = poses[world.obstacle_distance(poses[:, :2]) > 0.2]
    scans, meshes = [], []
    for limits in ({}, {"mesh_max_vertices": 300, "mesh_max_indices": 800}):
        with SwarmSim(world, config=SimConfig(**limits)) as sim:
            sim.reset(seed=1)
            for k in range(sim.num_robots):
                sim.park(k)  # robots out of the way: obstacles only
            scans.append(sim.lidar.scan(poses))
            meshes.append(sim.static_meshes)
    assert meshes[0] == 1 and meshes[1] >= 3 and len(poses) > 200
    assert np.isfinite(scans[0]).all() and (scans[0] < 3.0).any()
    np.testing.assert_array_equal(scans[0], scans[1])


def test_bullet_refuses_one_mesh_beyond_its_limits_and_the_simulator_tiles_it():
    """700 trunks (Bullet's index limit allows 693 per mesh) in one mesh fail to build;
    the simulator builds them as two meshes and its lidar sees them."""
    xy = np.stack(np.meshgrid(np.arange(28) + 1.0, np.arange(25) + 3.0), -1).reshape(-1, 2)
    trunks = tuple(Circle((float(x), float(y)), 0.1, 1.0) for x, y in xy)
    verts, idx = combined_mesh(trunks)
    assert len(verts) <= MAX_MESH_VERTICES and len(idx) > MAX_MESH_INDICES
    cid = p.connect(p.DIRECT)
    try:
        with pytest.raises((p.error, SystemError)):
            p.createCollisionShape(p.GEOM_MESH, vertices=verts, indices=idx, physicsClientId=cid)
    finally:
        p.disconnect(cid)
    world = World("forest", 0, (30.0, 30.0), trunks, np.array([[1.0, 1.0, np.pi / 2]]),
                  np.array([[1.5, 29.0]]))
    with SwarmSim(world) as sim:
        assert sim.static_meshes == 2
        scan = sim.reset(seed=0).scans[0]
        ahead = int(np.argmin(np.abs(sim.lidar.angles_rad)))
    assert sim.lidar.angles_rad[ahead] == 0.0
    assert scan[ahead] == pytest.approx(2.0 - 0.1, abs=1e-3)  # the trunk at (1, 3)
