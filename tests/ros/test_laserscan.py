import math

import numpy as np
import pytest

from fftnav.observe.scan import beam_angles_rad
from fftnav.ros.laserscan import layout_of, rep117_ranges


def test_rep117_values():
    d = np.array([np.inf, -np.inf, np.nan, 0.05, 0.1, 1.0, 29.0, 30.0, 35.0])
    got = rep117_ranges(d, range_min=0.1, range_max=30.0, range_m=8.0)
    # +inf: no return (R); -inf: closer than range_min (0); NaN: invalid (0); below range_min:
    # invalid (0); above range_max: no return (R); the rest clipped to R
    np.testing.assert_array_equal(got, [8.0, 0.0, 0.0, 0.0, 0.1, 1.0, 8.0, 8.0, 8.0])
    assert np.isnan(d[2])  # the input is left alone


@pytest.mark.parametrize(("fov_deg", "beams"), [(270.0, 1081), (180.0, 361), (90.0, 2)])
def test_partial_fields_of_view_come_from_the_message(fov_deg, beams):
    half = math.radians(fov_deg) / 2
    lay = layout_of(-half, half, 2 * half / (beams - 1), beams, where="m")
    assert lay.beams == beams and not lay.clockwise
    assert lay.fov_rad == pytest.approx(math.radians(fov_deg), abs=1e-12)
    assert lay.offset_rad == 0.0


def test_a_full_circle_is_exactly_two_pi_and_its_angles_are_the_messages():
    inc = np.float32(2 * math.pi / 720)  # as stored in the message
    lay = layout_of(float(np.float32(0.0)), float(719 * inc), float(inc), 720, where="m")
    assert lay.fov_rad == 2 * math.pi and not lay.clockwise
    # the pipeline's first beam is at -pi: in the message frame it is angle_min = 0
    pipe_angles = beam_angles_rad(720, 2 * math.pi)
    assert lay.angles_rad(pipe_angles[:1])[0] == pytest.approx(0.0, abs=1e-6)
    assert lay.angles_rad(pipe_angles[360:361])[0] == pytest.approx(-math.pi, abs=1e-6)


def test_a_clockwise_scanner_is_reversed_for_the_pipeline_and_back():
    lay = layout_of(math.pi / 2, -math.pi / 2, -math.pi / 180, 181, where="m")
    assert lay.clockwise and lay.fov_rad == pytest.approx(math.pi)
    x = np.arange(181.0)
    np.testing.assert_array_equal(lay.to_pipeline(x), x[::-1])
    np.testing.assert_array_equal(lay.from_pipeline(lay.to_pipeline(x)), x)
    assert lay.offset_rad == 0.0


def test_an_off_centre_scan_reports_angles_in_its_own_frame():
    lay = layout_of(0.0, math.pi / 2, math.pi / 180, 91, where="m")
    pipe_angles = beam_angles_rad(91, math.pi / 2)
    np.testing.assert_allclose(lay.angles_rad(pipe_angles), np.radians(np.arange(91.0)),
                               atol=1e-12)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((-1.0, 1.0, 0.02, 50), r"m: angle_increment disagrees with the angles and the count: "
                                r"angle_min \+ \(M - 1\) \* angle_increment = -0\.02 rad but "
                                r"angle_max = 1 rad \(M = 50"),
        ((-1.0, 1.0, 2.0 / 99, 101), "angle_increment disagrees"),
        ((-1.0, 1.0, 0.0, 50), "angle_increment nonzero, got angle_min=-1.0"),
        ((-1.0, math.nan, 0.1, 21), "must be finite"),
        ((0.0, 0.0, 0.1, 1), "at least 2 ranges, got 1"),
        ((-math.pi, math.pi + 0.1, (2 * math.pi + 0.1) / 99, 100), "span more than a full turn"),
    ],
)
def test_inconsistent_layouts_are_refused(args, match):
    with pytest.raises(ValueError, match=match):
        layout_of(*args, where="m")


def test_a_closing_beam_makes_a_full_circle_of_one_beam_fewer():
    lay = layout_of(-math.pi, math.pi, 2 * math.pi / 360, 361, where="scan 0")
    assert lay.closing and lay.fov_rad == 2 * math.pi and lay.pipeline_beams == 360
    ranges = np.arange(361.0)
    ranges[0] = 400.0  # the first direction's nearer reading is the closing beam's
    seen = lay.to_pipeline(ranges)
    assert seen.shape == (360,) and seen[0] == 360.0 and seen[1] == 1.0
    back = lay.from_pipeline(np.arange(360))
    assert back.shape == (361,) and back[360] == back[0] == 0 and back[359] == 359
    assert not layout_of(-math.pi, math.pi - 2 * math.pi / 360, 2 * math.pi / 360, 360,
                         where="s").closing
