import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from fftnav.observe.geometry import SIM_ROBOT, RobotGeometry
from fftnav.observe.pipeline import Pipeline
from fftnav.observe.safe import is_safe_direction, nearest_safe_headings, safe_sectors_rad
from fftnav.observe.scan import beam_angles_rad


def oracle_mask(d, *, l_th, range_m, window, circular):
    """Every reading in the centred window >= l_th, computed in metres on raw readings."""
    d = np.where(np.isnan(d) | (d < 0), 0.0, np.minimum(d, range_m))
    h = window // 2
    padded = np.pad(d, [(0, 0), (h, h)], mode="wrap" if circular else "constant")
    windows = np.lib.stride_tricks.sliding_window_view(padded, window, axis=1)
    return windows.min(axis=-1) >= l_th


def piecewise_scan(rng, beams, range_m):
    """Millimetre readings: runs of open space and of obstacles, with sensor oddities."""
    cuts = np.sort(rng.integers(0, beams, rng.integers(1, 12)))
    values = np.round(rng.uniform(0.0, 1.2 * range_m, len(cuts) + 1), 3)
    values[rng.random(len(values)) < 0.5] = np.inf
    d = np.repeat(values, np.diff(np.concatenate([[0], cuts, [beams]])))
    d = d + np.round(rng.normal(0, 0.01, beams), 3) * (rng.random(beams) < 0.3)
    d[rng.random(beams) < 0.01] = np.nan
    d[rng.random(beams) < 0.01] = -1.0
    return d


@settings(max_examples=120, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    r0=st.floats(0.05, 0.5),
    ratio=st.floats(1.05, 3.0),
    beams=st.integers(20, 400),
    fov_frac=st.one_of(st.just(1.0), st.floats(0.2, 0.95)),
    circular=st.booleans(),
    k=st.integers(1, 4),
)
def test_fft_mask_equals_sliding_window_minimum(*, seed, r0, ratio, beams, fov_frac, circular,
                                                k):
    geom = RobotGeometry(r0_m=r0, r_m=r0 * ratio)
    fov = 2 * math.pi * fov_frac
    circular = circular and fov_frac == 1.0
    rng = np.random.default_rng(seed)
    range_m = geom.l_th_m * rng.uniform(1.0, 3.0)
    inc = fov / beams if fov_frac == 1.0 else fov / (beams - 1)
    assume(beams >= math.ceil(geom.alpha_rad / inc - 1e-9))
    d = np.vstack([piecewise_scan(rng, beams, range_m) for _ in range(k)])
    gap = np.abs(d - geom.l_th_m)
    assume(not np.any((gap > 0) & (gap < 1e-6)))
    pipe = Pipeline(
        geom, beams=beams, fov_rad=fov, range_m=range_m, mode="circular" if circular else "linear"
    )
    expected = oracle_mask(
        d, l_th=geom.l_th_m, range_m=range_m, window=pipe.bank.window_beams, circular=circular
    )
    np.testing.assert_array_equal(pipe.safe_mask(d), expected)


def test_window_running_past_the_ends_is_unsafe_only_in_linear_mode():
    d = np.full((1, 360), 3.0)
    lin = Pipeline(SIM_ROBOT, blind_rad=0.0).safe_mask(d)[0]
    circ = Pipeline(SIM_ROBOT, mode="circular").safe_mask(d)[0]
    assert circ.all()
    assert not lin[:30].any() and not lin[-30:].any() and lin[30:330].all()


def test_safe_sectors_merge_through_the_back():
    m = np.zeros(360, bool)
    m[350:] = m[:5] = True
    m[170:190] = True
    sectors = safe_sectors_rad(m, fov_rad=2 * math.pi)
    a = beam_angles_rad(360, 2 * math.pi)
    assert sectors == [(a[170], a[189]), (a[350], a[4])]
    assert safe_sectors_rad(np.ones(360, bool), fov_rad=2 * math.pi) == [(a[0], a[-1])]
    assert safe_sectors_rad(m, fov_rad=math.pi)[0] == pytest.approx(
        (-math.pi / 2, -math.pi / 2 + 4 * math.pi / 359)
    )


def brute_nearest(mask, j, full):
    m = len(mask)
    out = []
    for step in (1, -1):
        found = math.nan
        for o in range(m):
            i = j + step * o
            if full:
                i %= m
            elif not 0 <= i < m:
                break
            if mask[i]:
                found = i
                break
        out.append(found)
    return out


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("fov", [2 * math.pi, math.radians(200)])
def test_nearest_safe_headings_match_a_brute_force_walk(fov, compiled, monkeypatch):
    """Both paths (the compiled walk when numba is installed, and numpy's)."""
    from fftnav.observe import kernels

    if compiled and not kernels.AVAILABLE:
        pytest.skip("numba is not installed")
    monkeypatch.setattr(kernels, "AVAILABLE", compiled)
    rng = np.random.default_rng(3)
    masks = rng.random((40, 72)) < 0.1
    masks[0] = False
    a = beam_angles_rad(72, fov)
    j = rng.integers(0, 72, 40)
    left, right = nearest_safe_headings(masks, a[j], fov_rad=fov)
    for k in range(40):
        lj, rj = brute_nearest(masks[k], j[k], fov > 6)
        assert (math.isnan(left[k]) and math.isnan(lj)) or left[k] == a[lj]
        assert (math.isnan(right[k]) and math.isnan(rj)) or right[k] == a[rj]
    np.testing.assert_array_equal(
        is_safe_direction(masks, a[j], fov_rad=fov), masks[np.arange(40), j]
    )
    single = nearest_safe_headings(masks[1], a[j[1]], fov_rad=fov)
    np.testing.assert_array_equal(single, (left[1], right[1]))
    # one scan and one target (the planner's call, its own code path), at any angle (also
    # between beams and beyond a partial field of view): the same beams as the batch
    targets = rng.uniform(-math.pi, math.pi, 40)
    left, right = nearest_safe_headings(masks, targets, fov_rad=fov)
    for k in range(40):
        one = nearest_safe_headings(masks[k], float(targets[k]), fov_rad=fov)
        np.testing.assert_array_equal(one, (left[k], right[k]))
        assert np.ndim(one[0]) == 0 and np.ndim(one[1]) == 0


def test_safe_sectors_error():
    with pytest.raises(ValueError, match=r"mask must be 1-D \(one scan\), got shape=\(2, 3\)"):
        safe_sectors_rad(np.ones((2, 3), bool), fov_rad=math.pi)


def scaled_robot(range_m, l_th_m):
    """A robot of l_th = min(l_th_m, R) (the pipelines refuse R < l_th): r = 2 r0. At R below
    l_th_m, l_th is R less a part in 1e9: the geometry's own l_th (from r0 and r) may round
    above R otherwise (R = 0.1 m gave l_th = 0.1 + 1 ulp, refused)."""
    l_th = min(l_th_m, range_m * (1.0 - 1e-9))
    return RobotGeometry(r0_m=l_th / 4, r_m=l_th / 2)


@settings(max_examples=60, deadline=None)
@given(log_r=st.floats(-3.0, 12.0), frac=st.floats(0.0, 0.99), seed=st.integers(0, 2**16))
@example(log_r=-1.0, frac=0.0, seed=0)  # R = 0.1 m: l_th rounded above R, found by hypothesis
def test_safety_is_scale_free_over_the_range(log_r, frac, seed):
    """Relative tolerance: a scan blocked everywhere (every beam below l_th = 0.6 m, or R when
    R is smaller) is never safe and an open one (every beam "no return") is safe everywhere, at
    any R from 1 mm to 1e12 m; a random scan agrees with the metre-level oracle at every R."""
    range_m = 10.0**log_r
    geom = scaled_robot(range_m, 0.6)
    pipe = Pipeline(geom, beams=360, range_m=range_m, mode="circular")
    assert not pipe.safe_mask(np.full((1, 360), frac * geom.l_th_m)).any()
    assert pipe.safe_mask(np.full((1, 360), np.inf)).all()
    d = piecewise_scan(np.random.default_rng(seed), 360, range_m)
    gap = np.abs(d - geom.l_th_m)
    assume(not np.any((gap > 0) & (gap < 1e-6 * geom.l_th_m)))
    expected = oracle_mask(d[None], l_th=geom.l_th_m, range_m=range_m,
                           window=pipe.bank.window_beams, circular=True)
    np.testing.assert_array_equal(pipe.safe_mask(d[None]), expected)


def test_every_beam_at_a_third_of_l_th_is_unsafe_at_a_billion_metres():
    """The reported case: 0.2 m everywhere, l_th = 0.6 m, R = 1e9 m (was 360 of 360 safe)."""
    pipe = Pipeline(RobotGeometry(r0_m=0.15, r_m=0.3), beams=360, range_m=1e9)
    assert pipe.safe_mask(np.full((1, 360), 0.2)).sum() == 0


@settings(max_examples=25, deadline=None)
@given(log_r=st.floats(-3.0, 12.0), frac=st.floats(0.0, 0.99))
def test_scan3d_safety_is_scale_free_over_the_range(log_r, frac):
    """The spherical filter likewise: a wall closer than l_th in every direction is never safe,
    open space everywhere is safe away from the poles."""
    from fftnav.observe.spherical import DiscFilterBank, SphericalGrid

    range_m = 10.0**log_r
    grid = SphericalGrid(18, 72, math.radians(90), 2 * math.pi)
    geom = scaled_robot(range_m / 1.01, 2.82)  # the filter wants R > l_th
    bank = DiscFilterBank(grid, geometry=geom, range_m=range_m)
    assert not bank.safe_mask(np.full((18, 72), frac * geom.l_th_m)).any()
    assert bank.safe_mask(np.full((18, 72), np.inf)).any()
