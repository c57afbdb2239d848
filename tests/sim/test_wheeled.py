"""The optional wheeled embodiment: a URDF with two velocity-controlled wheels (fftnav.sim.swarm)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.config import RobotConfig
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.world import Circle, World

WHEELED = SimConfig(robot=RobotConfig(embodiment="wheeled"))


def _world(starts, obstacles=()):
    starts = np.asarray(starts, dtype=float)
    return World("x", 0, (10.0, 10.0), tuple(obstacles), starts, starts[:, :2])


def test_drives_straight_and_turns_in_place():
    with SwarmSim(_world([[2.0, 2.0, 0.3], [6.0, 6.0, -1.0]]), config=WHEELED) as sim:
        sim.reset(seed=0)
        command = [[0.4, 0.0], [0.0, 1.0]]  # robot 0 straight at 0.4 m/s, robot 1 turns at 1 rad/s
        spun_up = sim.step(command).poses  # the wheels reach their speed within this 0.1 s
        for _ in range(30):  # 3 s more
            obs = sim.step(command)
        states = sim.base_states()
    heading = np.array([math.cos(spun_up[0, 2]), math.sin(spun_up[0, 2])])
    travelled = obs.poses[0, :2] - spun_up[0, :2]
    assert abs(spun_up[0, 2] - 0.3) < 0.03  # spin-up: at most a degree or two
    assert abs(obs.poses[0, 2] - spun_up[0, 2]) < 0.005  # then the heading stays constant
    assert abs(heading[0] * travelled[1] - heading[1] * travelled[0]) < 0.01  # no sideways drift
    assert abs(travelled @ heading - 0.4 * 3.0) < 0.03  # v t
    assert np.hypot(*(obs.poses[1, :2] - spun_up[1, :2])) < 0.02  # position nearly constant
    assert abs(obs.poses[1, 2] - spun_up[1, 2] - 1.0 * 3.0) < 0.05  # yaw changes by w t
    np.testing.assert_allclose(states[:, 2], 0.15, atol=2e-3)  # base at r0: on its wheels


def test_arc_follows_the_differential_drive_kinematics():
    with SwarmSim(_world([[3.0, 3.0, 0.0]]), config=WHEELED) as sim:
        sim.reset(seed=0)
        start = sim.step([[0.3, 0.5]]).poses[0]  # spun up
        for _ in range(20):  # 2 s on an arc of radius v / w = 0.6 m, turning by 1 rad
            end = sim.step([[0.3, 0.5]]).poses[0]
    turn = end[2] - start[2]
    chord = 2 * 0.6 * math.sin(turn / 2)
    assert turn == pytest.approx(1.0, abs=0.03)
    assert np.hypot(*(end[:2] - start[:2])) == pytest.approx(chord, rel=0.03)
    bearing = math.atan2(end[1] - start[1], end[0] - start[0])  # chord at half the turn
    assert bearing == pytest.approx(start[2] + turn / 2, abs=0.02)


def test_lidar_sees_the_chassis_disc_and_contacts_work():
    tree = Circle((4.0, 2.0), 0.2, 2.0)
    world = _world([[2.0, 2.0, 0.0], [3.0, 5.0, math.pi]], [tree])
    with SwarmSim(world, config=WHEELED) as sim:
        obs = sim.reset(seed=0)
        np.testing.assert_allclose(obs.scans[0, 180], 4.0 - 0.2 - 2.0, atol=2e-3)
        contact = []
        for _ in range(80):  # 8 s at 0.5 m/s: would drive 4 m, through the trunk
            obs = sim.step([[0.5, 0.0], [0.0, 0.0]])
            contact.append(obs.obstacle_contact[0])
        assert any(contact) and not obs.robot_contact.any()
        assert world.obstacle_distance(obs.poses[:1, :2])[0] > 0.15 - 0.01


def test_wheeled_robots_see_each_other_as_r0_discs_are_deterministic_and_park():
    starts = [[2.0, 2.0, 0.0], [3.0, 2.0, math.pi]]

    def run():
        with SwarmSim(_world(starts), config=WHEELED) as sim:
            first = sim.reset(seed=0)
            return first, [sim.step([[0.2, 0.3], [0.1, -0.2]]).poses for _ in range(5)]

    (first, a), (_, b) = run(), run()
    np.testing.assert_allclose(first.scans[:, 180], 1.0 - 0.15, atol=2e-3)
    assert np.array(a).tobytes() == np.array(b).tobytes()
    with SwarmSim(_world(starts), config=WHEELED) as sim:
        sim.reset(seed=0)
        sim.park(1)
        obs = sim.step([[0.5, 0.0], [0.5, 0.0]])
    assert obs.scans[0, 180] == 3.0 and np.isnan(obs.scans[1]).all()  # parked: gone
