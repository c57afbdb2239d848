import math

import numpy as np
import pytest
from scipy.signal import argrelextrema

from fftnav.observe.compress import find_extrema, quadrant_areas, quadrant_areas_batch, reconstruct
from fftnav.observe.geometry import SIM_ROBOT
from fftnav.observe.pipeline import Pipeline
from fftnav.observe.scan import beam_angles_rad
from fftnav.world.scenes import trunk_scans

ANGLES = beam_angles_rad(360, 2 * math.pi)


def test_extrema_match_scipy_on_signals_without_plateaus():
    rng = np.random.default_rng(0)
    y = np.cumsum(rng.normal(size=(5, 360)), axis=1)
    y = (y - y.min()) / np.ptp(y)
    sig, mins = find_extrema(y, angles_rad=ANGLES, range_m=2.0)
    for k in range(5):
        hi = argrelextrema(y[k], np.greater)[0]
        lo = argrelextrema(y[k], np.less)[0]
        idx = np.sort(np.concatenate([hi, lo]))
        np.testing.assert_array_equal(sig[k][:, 0], ANGLES[idx])
        np.testing.assert_allclose(sig[k][:, 1], 2.0 * y[k, idx])
        np.testing.assert_array_equal(mins[k], np.isin(idx, lo))


def test_plateaus_give_one_extremum_at_their_middle_and_blind_sector_is_dropped():
    y = np.full((1, 360), 0.5)
    y[0, 100:111] = 0.9  # plateau maximum, beams 100..110 -> 105
    y[0, 200:204] = 0.1  # plateau minimum, beams 200..203 -> 201
    y[0, 355] = 0.8  # a peak inside the 15 degree blind sector
    sig, mins = find_extrema(y, angles_rad=ANGLES, range_m=1.0, blind_rad=math.radians(15))
    np.testing.assert_array_equal(sig[0][:, 0], ANGLES[[105, 201]])
    np.testing.assert_array_equal(mins[0], [False, True])
    sig, _ = find_extrema(y, angles_rad=ANGLES, range_m=1.0)
    assert len(sig[0]) == 3


def test_circular_extrema_wrap_around():
    y = np.full((1, 360), 0.5)
    y[0, 0] = 0.9
    y[0, 180] = 0.2
    sig, mins = find_extrema(y, angles_rad=ANGLES, range_m=1.0, circular=True)
    np.testing.assert_array_equal(sig[0][:, 0], ANGLES[[0, 180]])
    np.testing.assert_array_equal(mins[0], [False, True])
    assert len(find_extrema(y, angles_rad=ANGLES, range_m=1.0)[0][0]) == 1


def test_reconstruction_interpolates_between_extrema_periodically():
    sigma = np.array([[-3.0, 1.0], [0.0, 2.0], [3.0, 0.5]])
    got = reconstruct(sigma, np.array([-3.0, -1.5, 0.0, 3.0, math.pi]), full_circle=True)
    gap = 2 * math.pi - 6.0  # from 3.0 to -3.0 through the back
    at_pi = 0.5 + (1.0 - 0.5) * (math.pi - 3.0) / gap
    np.testing.assert_allclose(got, [1.0, 1.5, 2.0, 0.5, at_pi])
    partial = reconstruct(sigma, np.array([-3.1, 3.1]), full_circle=False)
    np.testing.assert_allclose(partial, [1.0, 0.5])
    assert not reconstruct(np.empty((0, 2)), ANGLES, full_circle=True).any()


def shoelace(phi, d):
    """Area of the polygon (origin, vertices...) from Cartesian coordinates."""
    x = np.concatenate([[0.0], d * np.cos(phi)])
    y = np.concatenate([[0.0], d * np.sin(phi)])
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def test_quadrant_areas_equal_the_shoelace_area_of_each_quadrant_polygon():
    rng = np.random.default_rng(1)
    a = SIM_ROBOT.alpha_rad
    bounds = [(0, a / 2), (a / 2, math.pi / 2), (-math.pi / 2, -a / 2), (-a / 2, 0)]
    phi = np.concatenate(
        [
            [-math.pi / 2, -a / 2, 0.0, a / 2, math.pi / 2],
            rng.uniform(-math.pi / 2, math.pi / 2, 12),
            [2.0, -2.5],
        ]
    )
    d = rng.uniform(0.2, 3.0, len(phi))
    sigma = np.column_stack([phi, d])
    x0 = quadrant_areas(sigma, alpha_rad=a, range_m=3.0, full_circle=True)
    for k, (lo, hi) in enumerate(bounds):
        sel = (phi >= lo) & (phi <= hi)
        order = np.argsort(phi[sel])
        assert x0[k] == pytest.approx(shoelace(phi[sel][order], d[sel][order] / 3.0))


def test_paper_example_sigma_areas_are_positive():
    beams = np.array([26, 67, 125, 183, 229, 267, 294, 342])
    dist = np.array([0.42, 0.074, 0.598, 0.208, 0.606, 0.358, 0.542, 0.08]) * 3.0
    sigma = np.column_stack([ANGLES[beams], dist])
    x0 = quadrant_areas(sigma, alpha_rad=SIM_ROBOT.alpha_rad, range_m=3.0, full_circle=True)
    assert (x0 > 0).all() and x0.sum() < math.pi / 2 * 0.61**2


def test_trunk_scene_extrema_count_is_near_the_cutoff_f0():
    res = Pipeline(SIM_ROBOT).process(trunk_scans(np.random.default_rng(2), 20))
    counts = np.array([len(s) for s in res.sigma])
    assert 4 <= counts.mean() <= 3 * 6  # the paper: "around the cutoff frequency f0 = 6"
    for sig, mins in zip(res.sigma, res.is_min, strict=True):
        assert (np.abs(sig[:, 0]) <= math.pi - math.radians(7.5)).all()
        assert not (mins[1:] & mins[:-1]).any()  # maxima and minima alternate


def test_plateau_path_agrees_with_the_sign_change_path():
    rng = np.random.default_rng(3)
    y = np.cumsum(rng.normal(size=(4, 360)), axis=1)
    with_plateau = y.copy()
    with_plateau[3, 50:60] = with_plateau[3, 50]  # forces the general (plateau) path
    fast = find_extrema(y[:3], angles_rad=ANGLES, range_m=1.0)
    general = find_extrema(with_plateau, angles_rad=ANGLES, range_m=1.0)
    for k in range(3):
        np.testing.assert_array_equal(fast[0][k], general[0][k])
        np.testing.assert_array_equal(fast[1][k], general[1][k])


def loop_quadrant_areas(sigma, *, alpha, range_m, full_circle):
    """Per-quadrant polygon areas with boundary values from reconstruct() and explicit loops."""
    out = []
    for lo, hi in [
        (0, alpha / 2),
        (alpha / 2, math.pi / 2),
        (-math.pi / 2, -alpha / 2),
        (-alpha / 2, 0),
    ]:
        ends = reconstruct(sigma, np.array([lo, hi]), full_circle=full_circle)
        verts = [(lo, ends[0])] + sorted((p, d) for p, d in sigma if lo < p < hi) + [(hi, ends[1])]
        out.append(
            sum(
                0.5 * d0 * d1 * math.sin(p1 - p0) / range_m**2
                for (p0, d0), (p1, d1) in zip(verts[:-1], verts[1:], strict=True)
            )
        )
    return out


@pytest.mark.parametrize("full_circle", [True, False])
def test_batched_quadrant_areas_equal_per_scan_loops(full_circle):
    rng = np.random.default_rng(4)
    sigmas = [
        np.column_stack([np.sort(rng.uniform(-math.pi, math.pi, n)), rng.uniform(0, 3, n)])
        for n in (0, 1, 2, 9, 0, 5, 30)
    ]
    offsets = np.cumsum([0] + [len(s) for s in sigmas])
    x = quadrant_areas_batch(
        np.vstack(sigmas), offsets, alpha_rad=1.0, range_m=3.0, full_circle=full_circle
    )
    for k, sig in enumerate(sigmas):
        expected = loop_quadrant_areas(sig, alpha=1.0, range_m=3.0, full_circle=full_circle)
        np.testing.assert_allclose(x[k], expected, atol=1e-12)


def test_circular_sign_change_path_matches_scipy_with_wrap():
    rng = np.random.default_rng(8)
    y = np.cumsum(rng.normal(size=(3, 360)), axis=1)  # no plateau, a jump at the wrap
    sig, mins = find_extrema(y, angles_rad=ANGLES, range_m=1.0, circular=True)
    for k in range(3):
        hi = argrelextrema(y[k], np.greater, mode="wrap")[0]
        lo = argrelextrema(y[k], np.less, mode="wrap")[0]
        idx = np.sort(np.concatenate([hi, lo]))
        np.testing.assert_array_equal(sig[k][:, 0], ANGLES[idx])
        np.testing.assert_array_equal(mins[k], np.isin(idx, lo))


def test_quadrant_areas_with_an_extremum_within_rounding_of_the_side_bound():
    """An extremum one ulp inside -pi/2 (beam 25 of a 100-beam circle) makes a zero-length
    edge at the bound: the areas must stay continuous (this used to raise)."""
    a = SIM_ROBOT.alpha_rad
    phi = np.array([-2.4, -math.pi + 25 * (2 * math.pi / 100), -1.0, -0.4, 0.2, 0.8, 1.9])
    assert phi[1] > -math.pi / 2
    sigma = np.column_stack([phi, np.linspace(0.5, 2.5, len(phi))])
    outside = sigma.copy()
    outside[1, 0] = np.nextafter(-math.pi / 2, -4.0)  # just outside quadrant III
    got = quadrant_areas(sigma, alpha_rad=a, range_m=3.0, full_circle=True)
    ref = quadrant_areas(outside, alpha_rad=a, range_m=3.0, full_circle=True)
    np.testing.assert_allclose(got, ref, atol=1e-12)
    expected = loop_quadrant_areas(sigma, alpha=a, range_m=3.0, full_circle=True)
    np.testing.assert_allclose(got, expected, atol=1e-12)
