import math

import numpy as np
import pytest

from fftnav.observe.filters import FilterBank
from fftnav.observe.geometry import DRONE, REAL_ROBOT, SIM_ROBOT, RobotGeometry


@pytest.mark.parametrize(
    ("geom", "l_th", "alpha_deg"),
    [(SIM_ROBOT, 0.60, 60.0), (REAL_ROBOT, 1.69, 49.0), (DRONE, 2.82, 26.7)],
)
def test_paper_geometry_values(geom, l_th, alpha_deg):
    assert geom.l_th_m == pytest.approx(l_th, abs=0.005)
    assert geom.alpha_deg == pytest.approx(alpha_deg, abs=0.5)


def test_paper_filter_parameters_for_the_simulated_lidar():
    b = FilterBank(SIM_ROBOT, beams=360, range_m=3.0)
    assert (b.tc, b.window_beams, b.n1, b.n2, b.n0) == (60, 61, 361, 361, 1024)
    assert b.fc == pytest.approx(1 / 60) and b.f0 == pytest.approx(6.0)
    assert b.threshold == pytest.approx(0.2)
    assert b.h1.sum() == pytest.approx(1.0) and np.count_nonzero(b.h1) == 61
    assert b.h2.sum() == pytest.approx(1.0, abs=1e-12)
    assert len(b.H1) == len(b.H2) == 513


def _dtft_gain(h, f):
    n = np.arange(len(h))
    return abs(np.sum(h * np.exp(-2j * np.pi * f * n))) / abs(h.sum())


def test_measured_cutoffs_are_minus_3db():
    b = FilterBank(SIM_ROBOT)
    for h, f in ((b.h1, b.cutoff_3db_h1), (b.h2, b.cutoff_3db_h2)):
        assert 20 * np.log10(_dtft_gain(h, f)) == pytest.approx(-3.0, abs=0.01)
        assert 20 * np.log10(_dtft_gain(h, 0.9 * f)) > -3.0
    assert 0.6 * b.fc < b.cutoff_3db_h2 < b.fc


def test_a_one_tap_filter_cuts_off_at_nyquist_without_a_warning():
    """Two beams over 360 degrees: alpha spans less than a beam, h1 and h2 are one tap (all
    frequencies pass), so the -3 dB point is Nyquist (the dense FFT never falls below it)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        b = FilterBank(SIM_ROBOT, beams=2)
    assert np.count_nonzero(np.abs(b.h1) > 1e-12) == 1
    assert b.cutoff_3db_h1 == b.cutoff_3db_h2 == 0.5
    assert _dtft_gain(b.h1, 0.5) == pytest.approx(1.0)


@pytest.mark.parametrize("beams", [360, 361, 100])
def test_linear_filtering_equals_direct_convolution(beams):
    rng = np.random.default_rng(beams)
    b = FilterBank(SIM_ROBOT, beams=beams)
    s = rng.uniform(0, 1, (3, beams))
    y1, y2 = b.filter(s)
    for k in range(3):
        full1 = np.convolve(np.minimum(s[k], b.threshold), b.h1)
        full2 = np.convolve(s[k], b.h2)
        np.testing.assert_allclose(y1[k], full1[b.tau : b.tau + beams], atol=1e-12)
        np.testing.assert_allclose(y2[k], full2[b.tau : b.tau + beams], atol=1e-12)


def test_circular_filtering_equals_wrapped_convolution():
    rng = np.random.default_rng(1)
    b = FilterBank(SIM_ROBOT, beams=120, mode="circular")
    s = rng.uniform(0, 1, (2, 120))
    _, y2 = b.filter(s)
    for k in range(2):
        tiled = np.tile(s[k], 3)
        full = np.convolve(tiled, b.h2)
        np.testing.assert_allclose(y2[k], full[120 + b.tau : 240 + b.tau], atol=1e-12)


def test_scan_symmetric_about_heading_gives_symmetric_outputs():
    rng = np.random.default_rng(2)
    b = FilterBank(SIM_ROBOT, beams=360)
    half = rng.uniform(0, 1, 179)
    s = np.concatenate([[0.0], half, [rng.uniform()], half[::-1]])  # s[180 + j] = s[180 - j]
    y1, y2 = b.filter(s[None])
    for y in (y1[0], y2[0]):
        np.testing.assert_allclose(y[181:], y[179:0:-1], atol=1e-12)


def test_partial_fov_parameters():
    b = FilterBank(REAL_ROBOT, beams=180, fov_rad=math.pi, range_m=10.0)
    assert b.tc == math.ceil(REAL_ROBOT.alpha_rad / (math.pi / 179))
    assert b.blind_rad == 0.0 and not b.full_circle


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (
            {"beams": 10, "fov_rad": math.radians(30)},
            "beams must be an integer >= Tc=18, got beams=10",
        ),
        ({"range_m": 0.5}, r"range_m must be finite and >= l_th_m=0.6, got range_m=0.5"),
        ({"mode": "wrap"}, r"mode must be one of .* got mode='wrap'"),
        ({"mode": "circular", "fov_rad": 3.0}, r"full 360 degree .* got fov_rad=3.0"),
        ({"blind_rad": -0.1}, r"blind_rad must be a finite number >= 0, got blind_rad=-0.1"),
    ],
)
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FilterBank(SIM_ROBOT, **kwargs)


def test_bad_geometry():
    with pytest.raises(ValueError, match="geometry must be a RobotGeometry, got geometry=0.3"):
        FilterBank(0.3)
    with pytest.raises(ValueError, match=r"r_m must be finite and > r0_m=0.3, got r_m=0.2"):
        RobotGeometry(r0_m=0.3, r_m=0.2)


@pytest.mark.parametrize("mode", ["linear", "circular"])
def test_filter_h1_alone_equals_the_stacked_filter(mode):
    b = FilterBank(SIM_ROBOT, mode=mode)
    s = np.random.default_rng(4).uniform(0, 1, (4, 360))
    np.testing.assert_allclose(b.filter_h1(s), b.filter(s)[0], atol=1e-13)


@pytest.mark.parametrize("mode", ["linear", "circular"])
def test_filter_ranges_equals_filtering_the_sanitised_normalised_scans(mode):
    from fftnav.observe.scan import sanitize_ranges

    rng = np.random.default_rng(5)
    b = FilterBank(SIM_ROBOT, mode=mode, range_m=3.0)
    d = rng.uniform(-1.0, 4.0, (6, 360))
    d[rng.random(d.shape) < 0.05] = np.nan
    d[rng.random(d.shape) < 0.05] = np.inf
    d[0, :5] = -np.inf
    keep = d.copy()
    got = b.filter_ranges(d)
    expected = b.filter(sanitize_ranges(d, range_m=3.0) / 3.0)
    np.testing.assert_array_equal(d, keep)  # input untouched
    for g, e in zip(got, expected, strict=True):
        np.testing.assert_array_equal(g, e)  # bit for bit: the same arithmetic


def test_results_do_not_depend_on_the_batch_sizes_seen_before():
    """The bank keeps repeated spectra for a few batch sizes: any call order, any K, gives
    the direct convolution."""
    rng = np.random.default_rng(6)
    b = FilterBank(SIM_ROBOT, beams=100)
    for k in (1, 3, 1, 2, 4, 5, 6, 7, 8, 9, 10, 3, 1):  # more sizes than the bank keeps
        s = rng.uniform(0, 1, (k, 100))
        y1, y2 = b.filter(s)
        assert y1.shape == y2.shape == (k, 100)
        for row in range(k):
            full = np.convolve(s[row], b.h2)
            np.testing.assert_allclose(y2[row], full[b.tau : b.tau + 100], atol=1e-12)
            full = np.convolve(np.minimum(s[row], b.threshold), b.h1)
            np.testing.assert_allclose(y1[row], full[b.tau : b.tau + 100], atol=1e-12)
