"""Static obstacle meshes below Bullet's limits: every mesh made once and equal to the
obstacle's own, tiling keeps the lidar bit-identical, a world beyond one mesh (a 60 m x 60 m
forest) builds, its tiles only near the robots, and episodes in it repeat bitwise."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from fftnav.config import RobotConfig
from fftnav.sim.mesh import (
    MAX_MESH_INDICES,
    MAX_MESH_VERTICES,
    obstacle_meshes,
    static_meshes,
    static_tiles,
)
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.world import World, generate_world
from fftnav.world.obstacles import Circle, Polygon, combined_mesh, rectangle


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
        assert sim.static_meshes == 9  # 10 m tiles of 3 x 3, each one mesh
        assert sim.tiles_built == (1, 9)  # the robot's, in the lower left
        scan = sim.reset(seed=0).scans[0]
        ahead = int(np.argmin(np.abs(sim.lidar.angles_rad)))
    assert sim.lidar.angles_rad[ahead] == 0.0
    assert scan[ahead] == pytest.approx(2.0 - 0.1, abs=1e-3)  # the trunk at (1, 3)


def test_every_obstacle_mesh_is_made_once_and_equals_its_own_mesh_bit_for_bit():
    rng = np.random.default_rng(5)
    obstacles = [Circle((float(x), float(y)), float(r), float(h)) for x, y, r, h in
                 np.round(np.c_[rng.uniform(1, 9, (40, 2)), rng.uniform(0.01, 0.5, 40),
                                rng.uniform(0.5, 3, 40)], 4)]
    obstacles[3:3] = [rectangle(1.0, 2.0, 3.5, 2.25, 1.0), Circle((2.0, 2.0), 0.1, 2.0)]
    obstacles.append(generate_world("rocky", 1).obstacles[0])
    parts = obstacle_meshes(obstacles)
    assert len(parts) == len(obstacles)
    for obstacle, (vertices, indices) in zip(obstacles, parts, strict=True):
        want_v, want_i = obstacle.mesh()
        assert vertices.tobytes() == want_v.tobytes() and vertices.shape == want_v.shape
        np.testing.assert_array_equal(indices, want_i)
    assert parts[0][1] is parts[1][1]  # the trunks share one index array
    assert static_meshes(obstacles) == [combined_mesh(obstacles)]


def test_tiles_hold_every_obstacle_once_each_mesh_within_the_limits():
    world = generate_world("forest", 2, size_m=[30.0, 30.0], goal_y_m=29.0)
    tiles = static_tiles(world.obstacles, max_vertices=1500, max_indices=9000)
    held = np.concatenate([m for t in tiles for m in t.meshes])
    np.testing.assert_array_equal(np.sort(held), np.arange(len(world.obstacles)))
    assert len(tiles) == 9 and sum(len(t.meshes) for t in tiles) > 9
    for tile in tiles:
        for mesh in tile.meshes:
            assert len(mesh) * 128 <= 1500 and len(mesh) * 756 <= 9000
        x0, y0, x1, y1 = tile.box
        cells = set()
        for k in np.concatenate(tile.meshes):
            cx, cy, r = world.obstacles[k].bounding_circle()
            assert x0 <= cx - r and cx + r <= x1 and y0 <= cy - r and cy + r <= y1
            cells.add((cx // 10.0, cy // 10.0))
        assert len(cells) == 1  # one 10 m square holds the centres of a tile's obstacles


@pytest.mark.parametrize("embodiment", ["body", "wheeled"])
def test_tiles_are_built_on_approach_and_episodes_repeat_bitwise(embodiment):
    """A tiled forest: only the tiles near the robots are built, driving builds more, and an
    episode repeats bit for bit in a fresh simulator and in one reused after a different
    episode (the tiles built during an episode are taken out again by reset)."""
    xy = np.stack(np.meshgrid(np.arange(1.0, 30.0, 2.0), np.arange(3.0, 30.0, 2.0)), -1)
    trunks = tuple(Circle((float(x), float(y)), 0.2, 1.0) for x, y in xy.reshape(-1, 2))
    sx = np.array([2.0, 3.0, 7.0, 9.0, 12.0, 13.0, 18.0, 21.0, 24.0, 27.0])  # odd x: a trunk ahead
    k = len(sx)
    world = World("forest", 0, (30.0, 30.0), trunks, np.c_[sx, np.full(k, 4.0), np.full(k, 1.57)],
                  np.c_[sx, np.full(k, 29.0)])
    config = SimConfig(robot=RobotConfig(embodiment=embodiment), mesh_max_vertices=3000,
                       mesh_max_indices=18000)  # 23 trunks a mesh

    def episode(sim, park=(), seed=3):
        rng = np.random.default_rng(seed)
        obs = [sim.reset(seed=1)]
        built = [sim.tiles_built[0]]
        for tick in range(70):
            cmd = np.c_[np.full(k, 0.5), rng.uniform(-0.5, 0.5, k)]
            if tick == 5:
                for i in park:
                    sim.park(i)
            obs.append(sim.step(cmd))
            built.append(sim.tiles_built[0])
        return (np.array([o.poses for o in obs]).tobytes(),
                np.array([o.scans for o in obs]).tobytes(),
                sum(o.obstacle_contact.sum() for o in obs), built)

    with SwarmSim(world, config=config) as sim:
        assert sim.tiles_built == (3, 9)  # the first row
        fresh = episode(sim)
    assert fresh[2] > 50 and fresh[3][0] == 3 and fresh[3][-1] == 6  # contacts; 2nd row built
    with SwarmSim(world, config=config) as sim:
        assert episode(sim, park=(1,), seed=4)[0] != fresh[0]
        assert episode(sim) == fresh
        assert episode(sim) == fresh
