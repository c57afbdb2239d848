"""The classic baselines on hand-made scans: VFH+ histograms and choices, Follow-the-Gap gaps and
blending, fft-go's nearest safe beam against a brute-force search."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.config import SwarmConfig
from fftnav.navigation.baselines import FFTGoController, FTGController, VFHController
from fftnav.navigation.controllers import ControllerSetup, RobotObservation
from fftnav.observe.scan import beam_angles_rad, wrap_angle

CFG = SwarmConfig()
ANGLES = beam_angles_rad(360, 2 * math.pi)  # beam 180 is the heading, 1 degree apart
R = CFG.sensor.range_m


def _setup(n=1):
    return ControllerSetup(n, CFG, np.random.default_rng(0))


def _scan(blocks=()):
    """Open scan (R) with returns at distance d over degree ranges [a0, a1] (inclusive)."""
    ranges = np.full(360, R)
    for a0, a1, d in blocks:
        deg = np.degrees(ANGLES)
        ranges[(deg >= a0 - 1e-9) & (deg <= a1 + 1e-9)] = d
    return ranges


def _obs(ranges, goal_deg, *, goal_dist=5.0, yaw=0.0, safe=None, y1=None, robot=0):
    g = math.radians(goal_deg) + yaw
    return RobotObservation(robot, 0, 0.0, np.array([0.0, 0.0, yaw]),
                            np.array([goal_dist * math.cos(g), goal_dist * math.sin(g)]),
                            ranges, ANGLES, safe, y1, None, ())


def test_vfh_histogram_of_one_return_is_its_enlarged_sector_span():
    vfh = VFHController(_setup())
    hist = vfh.histogram(_scan([(0, 0, 1.0)]), ANGLES)
    gamma = math.degrees(math.asin((CFG.robot.r0_m + vfh.safety_m) / 1.0))  # 14.48 deg
    centres = np.arange(vfh.sectors) * vfh.sector_deg
    covered = np.abs((centres + 180) % 360 - 180) <= gamma
    assert covered.sum() == 5  # sectors at -10, -5, 0, 5, 10 deg
    assert np.array_equal(hist > 0, covered)
    assert hist[covered] == pytest.approx(1 - (1.0 / vfh.window_m) ** 2)


def test_vfh_drives_to_an_open_goal_and_turns_to_one_beside_it():
    vfh = VFHController(_setup())
    assert vfh.act(_obs(_scan(), 0.0)) == (CFG.robot.v_max_mps, 0.0)
    v, w = vfh.act(_obs(_scan(), 40.0))
    assert v == 0.0 and w == pytest.approx(CFG.robot.w_max_radps)


def test_vfh_avoids_a_wall_in_front_and_keeps_its_choice():
    vfh = VFHController(_setup())
    wall = _scan([(-30, 30, 0.5)])
    v, w = vfh.act(_obs(wall, 0.0))
    assert v == 0.0 and w != 0.0  # turns away from the wall, does not drive into it
    chosen = wrap_angle(vfh.previous[0] * vfh.alpha)
    half = math.radians(30) + math.asin((CFG.robot.r0_m + vfh.safety_m) / 0.5)
    assert abs(chosen) > half  # outside the enlarged wall
    first = vfh.previous[0]
    vfh.act(_obs(wall, 0.0))  # same scan: hysteresis and the previous-direction cost agree
    assert vfh.previous[0] == first


def test_vfh_rotates_in_place_when_every_sector_is_blocked():
    vfh = VFHController(_setup())
    v, w = vfh.act(_obs(np.full(360, 0.3), 10.0))
    assert v == 0.0 and abs(w) == pytest.approx(CFG.robot.w_max_radps)


def test_ftg_blocks_the_enlarged_returns_and_picks_the_widest_gap():
    ftg = FTGController(_setup())
    blocked = ftg.blocked(_scan([(0, 0, 1.0)]), ANGLES)
    half = math.degrees(math.asin((CFG.robot.r0_m + ftg.safety_m) / 1.0))
    assert np.array_equal(blocked, np.abs(np.degrees(ANGLES)) <= half)
    # returns on [-90, -60] and [30, 90] at 1 m: the free front gap is
    # (-60 + half, 30 - half) -> its bisector, by hand
    scan = _scan([(-90, -60, 1.0), (30, 90, 1.0)])
    lo, hi = math.ceil(-60 + half), math.floor(30 - half)
    assert math.degrees(ftg.widest_gap(scan, ANGLES)) == pytest.approx((lo + hi) / 2)


def test_ftg_blends_gap_and_goal_by_the_nearest_distance():
    ftg = FTGController(_setup())
    scan = _scan([(-90, -60, 1.0), (30, 90, 1.0)])
    gap = ftg.widest_gap(scan, ANGLES)
    goal = math.radians(-20)
    v, w = ftg.act(_obs(scan, -20.0))
    weight = ftg.alpha / 1.0
    target = (weight * gap + ftg.beta * goal) / (weight + ftg.beta)
    assert w == pytest.approx(np.clip(target * CFG.episode.control_hz, -1.5, 1.5))
    assert ftg.widest_gap(np.full(360, 0.2), ANGLES) is None


def _pipeline_outputs(ranges):
    pipe = CFG.pipeline()
    res = pipe.process(ranges, with_p_s=False)
    return res.safe_mask[0], res.y1[0], pipe


def test_fft_go_steers_to_the_nearest_safe_beam_of_the_fft_mask():
    trunk = _scan([(-8, 12, 0.5)])  # an obstacle across the goal direction, more on the left
    safe, y1, _ = _pipeline_outputs(trunk)
    assert not safe[180] and safe.any()
    ctl = FFTGoController(_setup())
    v, w = ctl.act(_obs(trunk, 0.0, safe=safe, y1=y1))
    # the oracle: the safe beam nearest the goal bearing (0), by brute force over beams
    free = ctl._free(_obs(trunk, 0.0))
    ok = [k for k in range(360) if safe[k] and free[k]]
    best = min(ok, key=lambda k: abs(ANGLES[k]))
    assert ANGLES[best] < 0  # the right side is nearer (the obstacle extends further left)
    assert v == 0.0 and w == pytest.approx(max(-1.5, ANGLES[best] * 10))


def test_fft_go_uses_the_planners_motion_from_the_config():
    """At a goal 5 degrees off the heading fft-go drives turning toward it by default
    (``drive = "steered"``), turns in place with straight motion at 3 degrees, and drives
    straight at 10 degrees."""
    safe, y1, _ = _pipeline_outputs(_scan())
    obs = _obs(_scan(), 5.0, safe=safe, y1=y1)
    turn = math.radians(5.0) * 10.0
    narrow = CFG.replace({"planner.heading_tol_deg": 3, "planner.drive": "straight"})
    wide = narrow.replace({"planner.heading_tol_deg": 10})
    assert FFTGoController(_setup()).act(obs) == (0.5, pytest.approx(turn))
    assert FFTGoController(ControllerSetup(1, narrow, np.random.default_rng(0))).act(obs) == (
        0.0, pytest.approx(turn))
    assert FFTGoController(ControllerSetup(1, wide, np.random.default_rng(0))).act(obs) == (0.5, 0.0)


def test_fft_go_drives_straight_at_an_open_goal():
    safe, y1, _ = _pipeline_outputs(_scan())
    assert FFTGoController(_setup()).act(_obs(_scan(), 0.0, safe=safe, y1=y1)) == (0.5, 0.0)
