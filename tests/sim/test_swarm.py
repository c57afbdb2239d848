"""SwarmSim: driving, determinism, contacts, parking, stability (fftnav.sim.swarm)."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from fftnav.config import RobotConfig, SensorConfig
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.world import Circle, World, generate_world


def _open_world(starts, obstacles=()):
    starts = np.asarray(starts, dtype=float)
    return World("x", 0, (10.0, 10.0), tuple(obstacles), starts, starts[:, :2])


def test_drives_straight_and_turns_in_place_at_the_commanded_rates():
    with SwarmSim(_open_world([[2.0, 2.0, 0.0], [5.0, 5.0, 0.0]])) as sim:
        sim.reset(seed=0)
        for _ in range(20):  # 2 s: robot 0 straight at 0.5 m/s, robot 1 turns at 1.5 rad/s
            obs = sim.step([[0.5, 0.0], [0.0, 1.5]])
        np.testing.assert_allclose(obs.poses[0], [3.0, 2.0, 0.0], atol=1e-6)
        np.testing.assert_allclose(obs.poses[1, :2], [5.0, 5.0], atol=1e-6)
        assert obs.poses[1, 2] == pytest.approx(3.0, abs=1e-6)
        np.testing.assert_allclose(obs.odometer_m, [1.0, 0.0], atol=1e-6)
        assert obs.time_s == pytest.approx(2.0)
        obs = sim.step([[9.0, -9.0], [-9.0, 0.0]])  # clipped to the limits
        radius = 0.5 / 1.5  # an arc of v / w = 1/3 m turning right by 0.15 rad
        arc = [3.0 + radius * math.sin(0.15), 2.0 - radius * (1 - math.cos(0.15)), -0.15]
        np.testing.assert_allclose(obs.poses[0], arc, atol=3e-4)
        np.testing.assert_allclose(obs.odometer_m, [1.05, 0.05], atol=1e-4)  # reversing counts


def test_same_seed_and_commands_give_bitwise_equal_trajectories():
    world = generate_world("rocky", 2)
    config = SimConfig(sensor=SensorConfig(noise_std_m=0.01, dropout=0.05))

    def run(seed):
        rng = np.random.default_rng(3)
        with SwarmSim(world, config=config) as sim:
            obs = [sim.reset(seed=seed)]
            for _ in range(30):  # arcs, straight runs and turns in place
                cmd = np.c_[rng.uniform(0, 0.5, 15), rng.uniform(-1.5, 1.5, 15)]
                cmd[rng.random((15, 2)) < 0.3] = 0.0
                obs.append(sim.step(cmd))
        return np.array([o.poses for o in obs]), np.array([o.scans for o in obs])

    (pa, sa), (pb, sb), (pc, sc) = run(1), run(1), run(2)
    assert pa.tobytes() == pb.tobytes() and sa.tobytes() == sb.tobytes()
    assert pa.tobytes() == pc.tobytes() and sa.tobytes() != sc.tobytes()  # seed: sensors only


def test_robot_driven_into_a_tree_collides_and_does_not_pass_through():
    tree = Circle((3.0, 2.0), 0.2, 2.0)
    world = _open_world([[1.0, 2.0, 0.0], [1.0, 5.0, 0.0]], [tree])
    with SwarmSim(world) as sim:
        sim.reset(seed=0)
        contact = []
        for _ in range(100):  # 10 s at full speed: would travel 5 m
            obs = sim.step([[0.5, 0.0], [0.5, 0.0]])
            contact.append(obs.obstacle_contact.copy())
            gap = world.obstacle_distance(obs.poses[:1, :2])[0]
            assert gap > 0.15 - 0.005  # never deeper than 5 mm into the trunk
    contact = np.array(contact)
    assert contact[:, 0].any() and not contact[:, 1].any()
    first = np.argmax(contact[:, 0])
    assert 0.5 * (first + 1) * 0.1 == pytest.approx(3.0 - 0.2 - 0.15 - 1.0, abs=0.06)
    assert obs.poses[0, 0] < 3.0 - 0.2 - 0.15 + 0.005 and obs.poses[1, 0] > 5.5
    assert not obs.robot_contact.any()


def test_robot_robot_contact_is_recorded_for_both():
    world = _open_world([[2.0, 2.0, 0.0], [3.0, 2.0, math.pi]])
    with SwarmSim(world) as sim:
        sim.reset(seed=0)
        hits = [sim.step([[0.5, 0.0], [0.5, 0.0]]).robot_contact for _ in range(12)]
        obs = sim.step([[0.0, 0.0], [0.0, 0.0]])
    assert np.array(hits)[-1].all() and not np.array(hits)[0].any()
    assert obs.poses[1, 0] - obs.poses[0, 0] > 0.3 - 0.005


@pytest.mark.slow
@pytest.mark.parametrize(("embodiment", "seconds", "height_m", "tilt_rad"), [
    # The planar sphere cannot tip (its vertical velocity is held at 0): checked all the same.
    ("body", 60, 2e-3, 1e-3),
    # The wheeled robot can: its casters, 1 mm clear of the ground at +-0.1 m from the axle,
    # stop the pitch at 0.01 rad, and contacts with trunks and other robots add some compliance;
    # tipping over would take the base far beyond 0.05 rad and off its height. 30 s, not 60 s:
    # 60 s of 15 wheeled robots took 13.7 s here (30 s: about 7 s).
    ("wheeled", 30, 5e-3, 0.05),
])
def test_fifteen_robots_under_random_commands_stay_upright_on_the_ground(
        embodiment, seconds, height_m, tilt_rad):
    world = generate_world("forest", 6)
    rng = np.random.default_rng(0)
    contacts = 0
    with SwarmSim(world, config=SimConfig(robot=RobotConfig(embodiment=embodiment))) as sim:
        sim.reset(seed=0)
        for tick in range(10 * seconds):
            if tick % 10 == 0:  # a new random command every second
                cmd = np.c_[rng.uniform(-0.5, 0.5, 15), rng.uniform(-1.5, 1.5, 15)]
            obs = sim.step(cmd)
            contacts += obs.obstacle_contact.sum() + obs.robot_contact.sum()
            state = sim.base_states()
            assert np.all(np.abs(state[:, 2] - 0.15) < height_m), tick  # on the ground, at r0
            tilt = 2 * np.hypot(state[:, 3], state[:, 4])  # roll/pitch angle (small-angle)
            assert np.all(tilt < tilt_rad), tick
    assert contacts > 20  # the robots did bump into trunks and each other


@pytest.mark.parametrize("embodiment", ["body", "wheeled"])
def test_reset_reuses_the_world_built_once_and_repeats_an_episode_bitwise(embodiment, monkeypatch):
    world = generate_world("rocky", 2)
    config = SimConfig(robot=RobotConfig(embodiment=embodiment),
                       sensor=SensorConfig(noise_std_m=0.01, dropout=0.05))
    built = []  # every body Bullet creates
    for name in ("createMultiBody", "loadURDF"):
        create = getattr(p, name)
        monkeypatch.setattr(p, name, lambda *a, _f=create, **k: built.append(1) or _f(*a, **k))

    def episode(sim, park=()):
        rng = np.random.default_rng(3)
        obs = [sim.reset(seed=1)]
        for tick in range(20):  # arcs, straight runs, turns in place, contacts after parking
            cmd = np.c_[rng.uniform(0, 0.5, 15), rng.uniform(-1.5, 1.5, 15)]
            cmd[rng.random((15, 2)) < 0.3] = 0.0
            if tick == 5:
                for i in park:
                    sim.park(i)
            obs.append(sim.step(cmd))
        return np.array([o.poses for o in obs]).tobytes(), np.array([o.scans for o in obs]).tobytes()

    with SwarmSim(world, config=config) as sim:
        fresh = episode(sim)
    with SwarmSim(world, config=config) as sim:
        assert episode(sim, park=(3, 7)) != fresh
        again = episode(sim)  # same sim after a different episode with parked robots
        assert episode(sim) == again
    assert again == fresh
    # obstacle mesh (in the full and the lidar's static client), robots, ground plane
    per_build = 2 + 15 + (embodiment == "wheeled")
    assert len(built) == 2 * per_build  # two simulators, each built once


def test_parked_robot_leaves_the_world():
    world = _open_world([[2.0, 2.0, 0.0], [3.0, 2.0, math.pi]])
    with SwarmSim(world) as sim:
        before = sim.reset(seed=0)
        assert before.scans[0, 180] < 1.0  # robot 1 is in front of robot 0
        sim.park(1)
        sim.park(1)  # idempotent
        obs = sim.step([[0.5, 0.0], [0.5, 0.0]])
        assert obs.scans[0, 180] == 3.0 and np.isnan(obs.scans[1]).all()
        np.testing.assert_array_equal(obs.poses[1], before.poses[1])
        np.testing.assert_array_equal(obs.active, [True, False])
        for _ in range(20):
            obs = sim.step([[0.5, 0.0], [0.5, 0.0]])
        assert not obs.robot_contact.any() and obs.poses[0, 0] > 3.0
        with pytest.raises(ValueError, match=r"i must be an integer in \[0, 1\], got i=2"):
            sim.park(2)
        with pytest.raises(ValueError, match=r"commands must be a finite array of shape \(2, 2\)"):
            sim.step([[0.5, 0.0]])


@pytest.mark.parametrize(("make", "message"), [
    (lambda: RobotConfig(r0_m=0.0), r"r0_m must be a finite number > 0, got r0_m=0\.0"),
    (lambda: RobotConfig(v_max_mps=-1.0), r"v_max_mps must be a finite number in \(0, 100\], got v_max_mps=-1.0"),
    (lambda: SimConfig(physics_hz=100.0, control_hz=30.0),
     "physics_hz must be an integer multiple of control_hz=30.0, got physics_hz=100.0"),
    (lambda: SensorConfig(beams=1), r"beams must be an integer in \[2, 100000\], got beams=1"),
    (lambda: SensorConfig(blind_deg=400.0), "blind_deg must be < fov_deg=360.0, got blind_deg=400.0"),
    (lambda: SensorConfig(dropout=1.5), r"dropout must be a finite number in \[0, 1\), got dropout=1.5"),
    (lambda: RobotConfig(embodiment="legs"),
     r"embodiment must be one of \['body', 'wheeled'\], got embodiment='legs'"),
    (lambda: SimConfig(solver_iterations=0), "solver_iterations must be an integer >= 1"),
    (lambda: SimConfig(lidar_height_m=-1.0), "lidar_height_m must be a finite number >= 0"),
])
def test_config_errors_name_the_parameter(make, message):
    assert SimConfig().substeps == 24
    with pytest.raises(ValueError, match=message):
        make()


def test_sim_config_checks_its_rates_without_an_episode_time_limit():
    # 1 MHz physics for 120 s would exceed the episode's step limit; the simulator has no time
    # limit, so only the rates' own rule applies.
    config = SimConfig(physics_hz=1_000_000, control_hz=10)
    assert config.substeps == 100_000 and config.physics_hz == 1e6
    assert isinstance(config.physics_hz, float) and isinstance(config.control_hz, float)
    with pytest.raises(ValueError, match=r"physics_hz must be an integer multiple of "
                                         r"control_hz=10\.0, got physics_hz=5\.0"):
        SimConfig(physics_hz=5.0)
    with pytest.raises(ValueError, match=r"physics_hz must be a finite number > 0, "
                                         r"got physics_hz=nan"):
        SimConfig(physics_hz=float("nan"))
    assert SimConfig(lidar_height_m=None).lidar_height_m is None
    assert SimConfig(lidar_height_m=1).lidar_height_m == 1.0


def test_a_long_control_period_runs_in_bounded_memory():
    """1 MHz physics at 10 Hz control: 100,000 physics steps per tick. The planar velocities
    are made 4,096 robot-steps at a time, so the tick's Python memory stays small (a table of
    the whole period as lists takes tens of MB)."""
    import tracemalloc

    config = SimConfig(physics_hz=1_000_000, control_hz=10)
    with SwarmSim(_open_world([[2.0, 2.0, 0.0], [5.0, 5.0, 0.0], [8.0, 8.0, 0.0]]),
                  config=config) as sim:
        sim.reset(seed=0)
        tracemalloc.start()
        try:
            obs = sim.step([[0.5, 0.5], [0.3, -0.5], [0.5, 0.0]])  # two arcs, one line
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    assert peak < 5e6, peak
    assert obs.time_s == pytest.approx(0.1)
    radius = 0.5 / 0.5  # robot 0: 0.05 m along an arc of radius 1 m, turning 0.05 rad left
    np.testing.assert_allclose(obs.poses[0], [2.0 + radius * math.sin(0.05),
                                              2.0 + radius * (1 - math.cos(0.05)), 0.05],
                               atol=1e-6)
    np.testing.assert_allclose(obs.poses[2], [8.05, 8.0, 0.0], atol=1e-9)


def test_velocity_blocks_do_not_change_a_single_bit(monkeypatch):
    """The same arcs with the velocities made 7 robot-steps at a time (blocks of 2 physics
    steps for 3 robots) and all at once."""
    import fftnav.sim.swarm as swarm

    def drive() -> np.ndarray:
        with SwarmSim(_open_world([[2.0, 2.0, 0.0], [5.0, 5.0, 1.0], [8.0, 8.0, 0.0]])) as sim:
            sim.reset(seed=0)
            for _ in range(5):
                obs = sim.step([[0.5, 1.5], [0.3, -0.7], [0.5, 0.0]])
            return obs.poses

    whole = drive()
    monkeypatch.setattr(swarm, "_VELOCITY_BLOCK", 7)
    assert np.array_equal(drive(), whole)
