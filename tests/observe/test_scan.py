import math

import numpy as np
import pytest

from fftnav.observe.scan import angle_increment_rad, as_scan_batch, beam_angles_rad, sanitize_ranges


def test_full_circle_angles_put_heading_in_the_middle():
    a = beam_angles_rad(360, 2 * math.pi)
    assert a[0] == pytest.approx(-math.pi)
    assert a[180] == pytest.approx(0.0, abs=1e-12)
    assert np.diff(a) == pytest.approx(np.full(359, math.radians(1.0)))


def test_partial_fov_includes_both_endpoints():
    a = beam_angles_rad(181, math.pi)
    assert (a[0], a[90], a[-1]) == pytest.approx((-math.pi / 2, 0.0, math.pi / 2))
    assert angle_increment_rad(181, math.pi) == pytest.approx(math.radians(1.0))


def test_sanitize_maps_sensor_values_and_keeps_input():
    raw = np.array([np.inf, 3.0, 5.0, np.nan, -1.0, 1.25, -np.inf, 0.0])
    keep = raw.copy()
    out = sanitize_ranges(raw, range_m=3.0)
    np.testing.assert_array_equal(out, [3.0, 3.0, 3.0, 0.0, 0.0, 1.25, 0.0, 0.0])
    np.testing.assert_array_equal(raw, keep)


def test_as_scan_batch_shapes():
    batch, single = as_scan_batch(np.arange(4))
    assert batch.shape == (1, 4) and single
    batch, single = as_scan_batch(np.ones((3, 4)), beams=4)
    assert batch.shape == (3, 4) and not single


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: as_scan_batch(np.ones((2, 2, 2))), r"ranges must have shape \(M,\) or \(K, M\)"),
        (lambda: as_scan_batch(np.array([])), r"got shape=\(0,\)"),
        (lambda: as_scan_batch(np.array(["a"])), "ranges must be a numeric array"),
        (lambda: as_scan_batch(np.ones((2, 5)), beams=4), r"beams=4 readings per scan"),
        (lambda: sanitize_ranges(np.ones(3), range_m=0.0), r"range_m must be .* got range_m=0.0"),
        (lambda: beam_angles_rad(1, math.pi), "beams must be an integer >= 2, got beams=1"),
        (lambda: beam_angles_rad(10, 7.0), r"fov_rad must be in \(0, 2\*pi\], got fov_rad=7.0"),
    ],
)
def test_errors_name_the_parameter(call, match):
    with pytest.raises(ValueError, match=match):
        call()
