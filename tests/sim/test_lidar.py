"""The PyBullet lidar against exact analytic ray casts (fftnav.sim.lidar via SwarmSim)."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from fftnav.config import SensorConfig
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.world import World, generate_world
from tests.sim.lidar_oracle import assert_ranges_match_analytic


def _free_poses(world, rng, n, clearance):
    """n random poses at least ``clearance`` from obstacles and 2 * R from each other."""
    poses = []
    while len(poses) < n:
        x, y = rng.uniform([1.0, 1.0], np.subtract(world.size_m, 1.0))
        if world.obstacle_distance([[x, y]])[0] < clearance:
            continue
        if all(math.hypot(x - a, y - b) > 6.5 for a, b, _ in poses):
            poses.append((x, y, rng.uniform(-math.pi, math.pi)))
    return np.array(poses)


@pytest.mark.parametrize("env", ["forest", "rocky", "walls", "traps"])
def test_ranges_equal_analytic_intersections_within_1cm(env):
    world = generate_world(env, 4)
    rng = np.random.default_rng(1)
    poses = _free_poses(world, rng, 5, clearance=0.16)  # robots far apart: only obstacles seen
    probe = World(env, 4, world.size_m, world.obstacles, poses, poses[:, :2], world.boundary)
    with SwarmSim(probe) as sim:
        obs = sim.reset(seed=0)
        live = sim.lidar.live
        angles = poses[:, 2:3] + sim.lidar.angles_rad[live]
    assert obs.scans.shape == (5, 360)
    assert np.all(obs.scans[:, ~live] == 0.0)
    expected = assert_ranges_match_analytic(world, poses[:, :2], angles, obs.scans[:, live])
    assert 0.05 < (expected < 3.0).mean() < 0.95  # the comparison saw hits and misses


@pytest.mark.parametrize("env", ["forest", "rocky", "walls", "traps"])
def test_culled_scan_is_bitwise_equal_to_casting_every_ray(env):
    world = generate_world(env, 7)
    rng = np.random.default_rng(2)
    for _ in range(3):  # 15 robots anywhere (near obstacles and each other), any heading
        poses = np.c_[rng.uniform(0.0, 20.0, (15, 2)), rng.uniform(-math.pi, math.pi, 15)]
        probe = World(env, 7, world.size_m, world.obstacles, poses, poses[:, :2],
                          world.boundary)
        with SwarmSim(probe) as sim:
            obs = sim.reset(seed=0)
            lidar = sim.lidar
            cast, static = lidar.rays_cast, lidar.rays_cast_static
            lidar.cull = False
            full = lidar.scan(obs.poses)
            assert lidar.rays_cast_static == static  # unculled: all in the full client
        culled = obs.scans
        assert culled.tobytes() == full.tobytes()
        # both clients served rays: the static one those outside every robot's sector
        assert 0.3 * cast < static < cast
        ratio = 1.4 if world.boundary == "open" else 1.1  # walls within R of half the map
        assert lidar.rays_cast - cast == 15 * lidar.live.sum() > ratio * cast  # culling culls
        assert (culled[:, lidar.live] < 3.0).sum() > 500  # with many returns


def test_blind_sector_beam_order_and_robots_see_each_other():
    # two robots facing each other 1 m apart, no obstacles: each sees the other dead ahead
    starts = np.array([[2.0, 2.0, 0.0], [3.0, 2.0, math.pi]])
    world = World("x", 0, (5.0, 4.0), (), starts, starts[:, :2])
    with SwarmSim(world) as sim:
        obs = sim.reset(seed=0)
        angles = np.degrees(sim.lidar.angles_rad)
    assert angles[0] == -180 and angles[180] == 0 and angles[-1] == 179
    blind = np.abs(angles) >= 180 - 7.5
    assert blind.sum() == 15
    np.testing.assert_array_equal(obs.scans[:, blind], 0.0)
    np.testing.assert_allclose(obs.scans[:, 180], 1.0 - 0.15, atol=1e-3)  # sphere of radius r0
    # a beam at +/- 5 deg grazes the other robot's disc at the analytic distance
    half_chord = math.sqrt(0.15**2 - math.sin(math.radians(5)) ** 2)
    np.testing.assert_allclose(obs.scans[:, [175, 185]], math.cos(math.radians(5)) - half_chord,
                               atol=1e-3)
    np.testing.assert_array_equal(obs.scans[:, 90], 3.0)  # a miss reads R


@pytest.mark.parametrize(("beams", "blind_deg"), [(360, 0.0), (360, 15.0), (360, 14.0),
                                                 (720, 15.0), (180, 15.0)])
def test_blind_sector_holds_the_beams_strictly_inside_it(beams, blind_deg):
    # robot 1 stands 1 m straight behind robot 0: the back beam sees it unless it is blind
    starts = np.array([[2.0, 2.0, 0.0], [1.0, 2.0, 0.0]])
    world = World("x", 0, (5.0, 4.0), (), starts, starts[:, :2])
    with SwarmSim(world, config=SimConfig(sensor=SensorConfig(beams=beams, blind_deg=blind_deg))) as sim:
        scan = sim.reset(seed=0).scans[0]
        live = sim.lidar.live
    # exact oracle: beam n at -180 + 360 n / M deg is blind iff |angle| > 180 - blind / 2
    angles = [Fraction(-180) + Fraction(360 * n, beams) for n in range(beams)]
    blind = np.array([abs(a) > 180 - Fraction(blind_deg) / 2 for a in angles])
    np.testing.assert_array_equal(live, ~blind)
    np.testing.assert_array_equal(scan[blind], 0.0)
    assert np.all(scan[~blind] > 0)
    assert scan[0] == (0.0 if blind_deg else pytest.approx(1.0 - 0.15, abs=1e-3))


def test_noise_and_dropout_follow_the_episode_seed():
    world = generate_world("forest", 0)
    config = SimConfig(sensor=SensorConfig(noise_std_m=0.02, dropout=0.1))
    with SwarmSim(world, config=config) as sim:
        a, b, c = (sim.reset(seed=s).scans for s in (5, 5, 6))
    with SwarmSim(world) as clean_sim:
        clean = clean_sim.reset(seed=5).scans
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    hits = (clean > 0) & (clean < 3.0)
    dropped = hits & (a == 3.0)
    assert hits.sum() > 100 and 0.05 < dropped.sum() / hits.sum() < 0.15
    np.testing.assert_array_equal(a[clean == 0], 0.0)  # blind beams stay 0
    returns = hits & ~dropped
    assert 0.01 < np.std(a[returns] - clean[returns]) < 0.03


@pytest.mark.parametrize("env", ["forest", "rocky"])
def test_compiled_obstacle_rays_equal_bullets_bit_for_bit(env):
    """fastrays.cast_static against Bullet's rayTestBatch in the static client, on random rays
    and on rays aimed at obstacle vertices (grazing corners, the edge-tolerance cases)."""
    from fftnav.sim import fastrays
    from fftnav.sim.rays import cast_rays

    if not fastrays.AVAILABLE:
        pytest.skip("numba is not installed")
    world = generate_world(env, 5)
    rng = np.random.default_rng(4)
    n = 4000
    centres = rng.uniform(0.0, 20.0, (40, 2))
    robot = rng.integers(0, 40, n)
    angle = rng.uniform(-math.pi, math.pi, n)
    # half the rays aim at a vertex of an obstacle outline, nudged by 0 or a few ulps
    outlines = np.concatenate([o.outline() for o in world.obstacles])
    aim = rng.random(n) < 0.5
    target = outlines[rng.integers(0, len(outlines), n)]
    rel = target - centres[robot]
    angle[aim] = np.arctan2(rel[aim, 1], rel[aim, 0]) + rng.choice([0.0, 1e-15, -1e-15, 1e-9],
                                                                    aim.sum())
    direction = np.c_[np.cos(angle), np.sin(angle), np.zeros(n)]
    starts = np.c_[centres[robot], np.full(n, 0.15)] + 0.155 * direction
    ends = np.c_[centres[robot], np.full(n, 0.15)] + 3.0 * direction
    with SwarmSim(World(env, 5, world.size_m, world.obstacles, world.starts[:1],
                        world.goals[:1])) as sim:
        expected = cast_rays(sim._static_client, starts, ends, mask=2 | 4)
        mesh = sim.lidar.static_mesh
        got, sure = np.empty(n), np.empty(n, dtype=bool)
        fastrays.cast_static(starts, ends, robot, centres, mesh.triangles, mesh.footprints,
                             mesh.first, mesh.circles, 3.0, fastrays.MARGIN_M, got, sure)
    # every answer the kernel is sure of is Bullet's, bit for bit; the others (hits near a
    # triangle's edge, where Bullet's tree walk may skip the triangle) go to Bullet
    assert got[sure].tobytes() == expected[sure].tobytes()
    assert sure.mean() > 0.8 and sure[~aim].mean() > 0.99
    assert 0.2 < (expected < 1.0).mean() < 0.95  # hits and misses


def test_a_ray_grazing_a_corner_is_left_to_bullet():
    """Regression (rocky map 1001 of Table I): a ray through a wall's corner, where Bullet's
    tree walk skips the triangle that the edge tolerance would accept. The compiled test must
    not be sure of it, and the lidar's answer must be Bullet's."""
    from fftnav.sim import fastrays
    from fftnav.sim.rays import cast_rays
    from fftnav.world.obstacles import Polygon

    if not fastrays.AVAILABLE:
        pytest.skip("numba is not installed")
    wall = Polygon(((0.4612, 11.2063), (1.1352, 10.354), (1.273, 10.463), (0.599, 11.3153)), 1.0)
    start = np.array([[0.41913908, 10.95357162, 0.15]])  # aimed exactly at the corner
    corner = np.array([0.4612, 11.2063, 0.15])
    direction = (corner - start[0]) / np.linalg.norm(corner - start[0])
    end = start + 2.845 * direction
    far = np.array([[10.0, 1.0, math.pi / 2]])
    with SwarmSim(World("rocky", 0, (20.0, 20.0), (wall,), far, far[:, :2])) as sim:
        mesh = sim.lidar.static_mesh
        got, sure = np.empty(1), np.empty(1, dtype=bool)
        fastrays.cast_static(start, end, np.array([0]), start[:, :2], mesh.triangles,
                             mesh.footprints, mesh.first, mesh.circles, 3.0, fastrays.MARGIN_M,
                             got, sure)
        assert got[0] < 1.0 and not sure[0]  # a corner hit is never taken on its word
        # through the lidar: the kernel's unsure answer is replaced by Bullet's
        lidar = sim.lidar
        centre = start - lidar._start_m * direction
        pose = np.c_[centre[:, :2], [0.0]]
        cast = np.ones((1, 1), dtype=bool)
        s, e, _ = lidar._rays(centre, direction[None, None], cast)
        expected = cast_rays(sim._static_client, s, e, mask=2 | 4)
        assert lidar._cast_static(centre, pose, direction[None, None], cast).tobytes() \
            == expected.tobytes()
        assert lidar.rays_asked_bullet == 1


def test_compiled_sphere_rays_equal_bullets_bit_for_bit():
    """fastrays.cast_spheres against Bullet's rayTestBatch on sphere robots (the body
    embodiment), on random rays and on rays that graze a sphere within a few mm of its tangent
    (where Bullet's 1 mm conservative advancement reports hits short of, or beside, the sphere)."""
    from fftnav.sim import fastrays
    from fftnav.sim.rays import cast_rays

    if not fastrays.AVAILABLE:
        pytest.skip("numba is not installed")
    rng = np.random.default_rng(11)
    k, r0 = 40, 0.15
    xy = rng.uniform(0.5, 5.5, (k, 2))
    world = World("x", 0, (6.0, 6.0), (), np.c_[xy, rng.uniform(-3, 3, k)], xy)
    with SwarmSim(world) as sim:
        sim.reset(seed=0)
        for _ in range(3):  # spin and move the robots: orientations and positions are Bullet's
            sim.step(np.c_[rng.uniform(0.0, 0.5, k), rng.uniform(-1.0, 1.0, k)])
        centres = sim.base_states()[:, :3]
        n = 20000
        robot = rng.integers(0, k, n)
        angle = rng.uniform(-math.pi, math.pi, n)
        # half the rays aim at the tangent of another robot's sphere, offset by up to +-5 mm
        other = rng.integers(0, k, n)
        rel = centres[other, :2] - centres[robot, :2]
        dist = np.hypot(rel[:, 0], rel[:, 1])
        graze = (rng.random(n) < 0.5) & (dist > r0 + 0.01)
        offset = np.arcsin((r0 + rng.uniform(-0.005, 0.005, n)) / np.maximum(dist, r0 + 0.01))
        angle[graze] = (np.arctan2(rel[graze, 1], rel[graze, 0])
                        + rng.choice([-1.0, 1.0], graze.sum()) * offset[graze])
        direction = np.c_[np.cos(angle), np.sin(angle), np.zeros(n)]
        origin = np.c_[centres[robot, :2], np.full(n, r0)]
        starts, ends = origin + (r0 + 0.005) * direction, origin + 3.0 * direction
        expected = cast_rays(sim._client, starts, ends, mask=4)  # the robots alone
    got, sure = np.empty(n), np.empty(n, dtype=bool)
    fastrays.cast_spheres(starts, ends, robot, centres, r0, 3.0, fastrays.SPHERE_MARGIN_M, got,
                          sure)
    # every answer the kernel is sure of is Bullet's, bit for bit (the others go to Bullet)
    assert got[sure].tobytes() == expected[sure].tobytes()
    assert sure.mean() > 0.99
    assert 0.3 < (expected < 1.0).mean() < 0.9  # hits and misses
    # Bullet's answer is its 1 mm conservative advancement, not the exact entry point: some
    # grazing rays hit short of the sphere, or beside it
    exact = np.ones(n)
    for c in centres:
        q = c - starts
        along = (q * direction).sum(axis=1)
        h = r0**2 - ((q * q).sum(axis=1) - along**2)
        t = along - np.sqrt(np.maximum(h, 0.0))
        exact = np.where((h >= 0) & (t >= 0) & (t < 2.845), np.minimum(exact, t / 2.845), exact)
    assert np.any(np.abs(got - exact)[sure] > 1e-4)


@pytest.mark.parametrize(("env", "beams", "fov_deg", "blind_deg"),
                         [("forest", 360, 360.0, 15.0), ("rocky", 360, 360.0, 15.0),
                          ("forest", 720, 360.0, 0.0), ("rocky", 200, 270.0, 0.0)])
def test_dense_swarm_scan_is_bitwise_equal_to_casting_every_ray(env, beams, fov_deg, blind_deg):
    # 60 robots packed on a 6 m x 6 m patch: most rays in another robot's span; the compiled
    # scan (fastrays.scan_swarm) against every live ray cast in Bullet's full client
    world = generate_world(env, 3)
    rng = np.random.default_rng(5)
    xy = rng.uniform(7.0, 13.0, (60, 2))
    poses = np.c_[xy, rng.uniform(-math.pi, math.pi, 60)]
    probe = World(env, 3, world.size_m, world.obstacles, poses, poses[:, :2], world.boundary)
    sensor = SensorConfig(beams=beams, fov_deg=fov_deg, blind_deg=blind_deg)
    with SwarmSim(probe, config=SimConfig(sensor=sensor)) as sim:
        lidar = sim.lidar
        assert lidar.robot_spheres
        obs = sim.reset(seed=0)
        for _ in range(5):
            obs = sim.step(np.c_[rng.uniform(0.0, 0.5, 60), rng.uniform(-1.0, 1.0, 60)])
            lidar.cull = False
            full = lidar.scan(obs.poses)  # every live beam in the full client
            lidar.cull = True
            assert obs.scans.tobytes() == full.tobytes()
            assert (obs.scans[:, lidar.live] < 2.9).mean() > 0.3  # mostly robots in view


@pytest.mark.parametrize("path", ["compiled scan", "culled, compiled obstacles", "culled, Bullet"])
@pytest.mark.parametrize("env", ["forest", "rocky"])
def test_every_lidar_path_equals_casting_every_ray(env, path):
    # the fallbacks of the compiled scan (the wheeled robot, no numba) stay bit-identical too
    world = generate_world(env, 8)
    rng = np.random.default_rng(9)
    poses = np.c_[rng.uniform(2.0, 18.0, (25, 2)), rng.uniform(-math.pi, math.pi, 25)]
    probe = World(env, 8, world.size_m, world.obstacles, poses, poses[:, :2], world.boundary)
    with SwarmSim(probe) as sim:
        obs = sim.reset(seed=0)
        lidar, z = sim.lidar, sim.base_states()[:, 2]
        if path != "compiled scan":
            lidar.robot_spheres = False
        if path == "culled, Bullet":
            lidar.static_mesh = None
        before = lidar.rays_cast
        culled = lidar.scan(obs.poses, robot_z=z)
        assert lidar.rays_cast > before
        lidar.cull = False
        full = lidar.scan(obs.poses)
    assert culled.tobytes() == full.tobytes()
    assert (culled[:, lidar.live] < 3.0).sum() > 500


def test_robot_heights_of_another_length_are_refused():
    """The compiled swarm scan reads one sphere height per pose: a shorter array would be read
    past its end, so it is refused."""
    world = generate_world("forest", 0, robots=3)
    with SwarmSim(world) as sim:
        poses = sim.reset(seed=0).poses
        with pytest.raises(ValueError, match=r"robot_z must have shape \(3,\), one height per "
                                             r"pose, got shape=\(1,\)"):
            sim.lidar.scan(poses, robot_z=np.zeros(1))
