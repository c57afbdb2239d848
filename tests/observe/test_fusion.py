import math

import numpy as np
import pytest

from fftnav.observe.compress import quadrant_areas
from fftnav.observe.fusion import (
    decide_turn,
    fuse,
    neighbour_input,
    neighbour_probability,
    neighbour_sides,
    own_probability,
    rotate_sigma,
    sigmoid,
)
from fftnav.observe.geometry import SIM_ROBOT
from fftnav.observe.pipeline import Pipeline
from fftnav.world.scenes import trunk_scans


def test_own_probability_by_hand():
    x0 = np.array([0.3, 0.1, 0.2, 0.05])  # W0 = [1, 1, -1, -1] / 2
    assert own_probability(x0) == pytest.approx(1 / (1 + math.exp(-(0.3 + 0.1 - 0.2 - 0.05) / 2)))
    ws = 3.0
    assert own_probability(x0, ws=ws, b0=0.1) == pytest.approx(
        sigmoid((ws * 0.3 + 0.1 - 0.2 - ws * 0.05) / (1 + ws) + 0.1)
    )


def test_mirrored_scans_give_complementary_p_s():
    scans = trunk_scans(np.random.default_rng(0), 10)
    pipe = Pipeline(SIM_ROBOT)
    mirrored = np.roll(scans[:, ::-1], 1, axis=1)  # beam 180 + j <-> 180 - j
    p, q = pipe.process(scans).p_s, pipe.process(mirrored).p_s
    np.testing.assert_allclose(p + q, 1.0, atol=1e-12)
    assert np.ptp(p) > 0.01  # the scenes are not all symmetric


def test_neighbour_input_cases():
    a = math.radians(60)
    sigma = np.array([[-1.0, 1.0], [0.1, 2.4], [0.3, 0.6], [2.0, 3.0]])
    no_min = np.array([False, False, False, False])
    with_min = np.array([False, False, True, False])
    # sector [-30, 30] deg holds extrema 2.4 and 0.6 (0.3 rad < 0.5236)
    assert neighbour_input(
        sigma, no_min, target_rad=0.0, alpha_rad=a, range_m=3.0
    ) == pytest.approx(0.8)
    assert neighbour_input(
        sigma, with_min, target_rad=0.0, alpha_rad=a, range_m=3.0
    ) == pytest.approx((2.4 + 0.6) / 2 / 3)
    # no extremum inside [1.2 - 0.52, 1.2 + 0.52]: the larger interpolated boundary value
    lo, hi = 1.2 - a / 2, 1.2 + a / 2
    d_hi = 0.6 + (3.0 - 0.6) * (hi - 0.3) / (2.0 - 0.3)
    assert neighbour_input(
        sigma, no_min, target_rad=1.2, alpha_rad=a, range_m=3.0
    ) == pytest.approx(d_hi / 3)
    assert lo > 0.3


def test_neighbour_probability_threshold():
    w_n = -(2 * (0.6 + 0.3) + 0.15) / 3.0
    assert neighbour_probability(-w_n, geometry=SIM_ROBOT, range_m=3.0) == pytest.approx(0.5)
    assert neighbour_probability(0.2, geometry=SIM_ROBOT, range_m=3.0) == pytest.approx(
        sigmoid(0.2 + w_n)
    )


def test_neighbour_sides():
    xy = np.array(
        [[1.0, 1.0], [1.0, -0.5], [0.3, 0.3], [-1.0, 1.0], [0.0, 2.0], [5.0, 5.0], [1.0, 0.0]]
    )
    np.testing.assert_array_equal(
        neighbour_sides(xy, r_m=0.3, max_range_m=3.0), [1, -1, 0, 0, 1, 0, 0]
    )


def test_fuse_by_hand():
    # 1 left, 2 right: w0 = 1 / (1 + 3/3) = 0.5, wi = 1/6
    p = fuse(0.4, [0.9], [0.2, 0.7])
    assert p == pytest.approx(0.5 * 0.4 + (0.9 + 0.8 + 0.3) / 6)
    assert fuse(0.7, [], []) == pytest.approx(0.7)


def test_rotate_sigma_keeps_input():
    sigma = np.array([[3.0, 1.0], [-1.0, 2.0]])
    out = rotate_sigma(sigma, 0.5)
    np.testing.assert_allclose(out, [[3.5 - 2 * math.pi, 1.0], [-0.5, 2.0]])
    assert sigma[0, 0] == 3.0


def test_decide_turn_by_hand():
    own = np.array([[-1.0, 1.0], [-0.2, 0.5], [0.6, 2.5], [1.4, 2.0]])
    open_ahead = (np.array([[-0.1, 2.8], [1.0, 1.0]]), np.array([False, True]))
    blocked_ahead = (np.array([[0.0, 0.3], [2.0, 2.0]]), np.array([True, False]))
    poses = np.array([[1.0, 1.0, 0.0], [1.0, -1.0, 0.1], [-1.0, 0.0, 0.0]])
    dec = decide_turn(
        own,
        neighbours=[open_ahead, blocked_ahead, open_ahead],
        rel_poses=poses,
        target_rad=0.0,
        geometry=SIM_ROBOT,
        range_m=3.0,
        max_range_m=5.0,
    )
    p_s = own_probability(
        quadrant_areas(own, alpha_rad=SIM_ROBOT.alpha_rad, range_m=3.0, full_circle=True)
    )
    w_n = -(2 * 0.9 + 0.15) / 3
    p_left = sigmoid(2.8 / 3 + w_n)
    # rotated by 0.1 rad: minimum 0.3 m at 0.1 rad, maximum 2 m at 2.1 rad; the left edge of
    # the sector (+30 deg) interpolates to the larger boundary value
    edge = 0.3 + (2.0 - 0.3) * (SIM_ROBOT.alpha_rad / 2 - 0.1) / 2.0
    p_right = sigmoid(0.5 * (edge + 0.3) / 3 + w_n)
    assert dec.p_s == pytest.approx(p_s)
    np.testing.assert_array_equal(dec.sides, [1, -1, 0])
    assert dec.p_neighbours[0] == pytest.approx(p_left)
    assert dec.p_neighbours[1] == pytest.approx(p_right)
    assert math.isnan(dec.p_neighbours[2])
    assert dec.p == pytest.approx(0.6 * p_s + 0.2 * p_left + 0.2 * (1 - p_right))
    assert dec.turn_left == (dec.p > 0.5)


def test_errors():
    with pytest.raises(ValueError, match=r"x0 must have shape \(..., 4\), got shape=\(3,\)"):
        own_probability(np.ones(3))
    with pytest.raises(ValueError, match="ws must be a finite number > 0, got ws=0"):
        own_probability(np.ones(4), ws=0)
    with pytest.raises(ValueError, match=r"rel_poses must have one row per neighbour \(1\)"):
        decide_turn(
            np.zeros((0, 2)),
            neighbours=[(np.zeros((0, 2)), np.zeros(0, bool))],
            rel_poses=np.zeros((0, 3)),
            target_rad=0.0,
            geometry=SIM_ROBOT,
            range_m=3.0,
            max_range_m=3.0,
        )
