import math

import numpy as np
import pytest

from fftnav.observe.filters import FilterBank
from fftnav.observe.geometry import REAL_ROBOT, SIM_ROBOT, RobotGeometry
from fftnav.observe.scan import beam_angles_rad
from fftnav.ros.laserscan import Layout, layout_of, rep117_ranges, window_beams


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


def test_a_full_circle_from_0_puts_the_heading_on_the_messages_angle_0():
    """TurtleBot3's LDS: angle_min = 0, 360 float32 increments (REP 103: the heading is the
    laser frame's +x axis): the pipeline's straight-ahead beam (M / 2) is the message's beam
    0, its back (beam 0) the message's beam 180, and its angles are the message's."""
    inc = np.float32(2 * math.pi / 720)  # as stored in the message
    lay = layout_of(float(np.float32(0.0)), float(719 * inc), float(inc), 720, where="m")
    assert lay.fov_rad == 2 * math.pi and not lay.clockwise and lay.offset_rad == 0.0
    index = lay.to_pipeline(np.arange(720))
    assert index[360] == 0 and index[0] == 360
    pipe_angles = beam_angles_rad(720, 2 * math.pi)
    assert lay.angles_rad(pipe_angles[360:361])[0] == 0.0
    assert lay.angles_rad(pipe_angles[:1])[0] == -math.pi


def message_angles(angle_min, inc, beams):
    return angle_min + inc * np.arange(beams)


def same_direction(a, b, atol):
    return np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b))))) <= atol


@pytest.mark.parametrize(
    ("angle_min", "inc", "beams"),
    [
        (0.0, 2 * math.pi / 360, 360),  # TurtleBot3 LDS
        (-math.pi, 2 * math.pi / 360, 360),  # the pipeline's own order
        (math.pi / 2, 2 * math.pi / 360, 360),
        (0.3, 2 * math.pi / 500, 500),  # not a whole number of increments from 0
        (0.0, -2 * math.pi / 360, 360),  # clockwise from 0
        (math.pi, -2 * math.pi / 400, 400),  # clockwise from the back
        (-math.pi, 2 * math.pi / 719, 719),  # YDLidar: an odd count
        (0.0, 2 * math.pi / 360, 361),  # closing beam from 0
        (math.pi, -2 * math.pi / 360, 361),  # closing beam, clockwise
    ],
)
def test_full_turns_map_to_the_pipeline_and_back_exactly(angle_min, inc, beams):
    """Wherever a full turn starts and whichever way it turns: the pipeline's beams are the
    message's re-indexed around the heading (beam n at -pi + n 2pi/M' in the message frame),
    its heading the message beam nearest to angle 0, and the maps are inverse."""
    lay = layout_of(angle_min, angle_min + (beams - 1) * inc, inc, beams, where="m")
    m = lay.pipeline_beams
    assert lay.fov_rad == 2 * math.pi and m == beams - (beams == 361)
    theta = message_angles(angle_min, inc, beams)
    index = lay.to_pipeline(np.arange(beams))  # (a closing beam merges into its twin)
    pipe = beam_angles_rad(m, 2 * math.pi)
    assert same_direction(theta[index], lay.angles_rad(pipe), 1e-9).all()
    assert same_direction(theta[index], pipe, abs(inc) / 2 + 1e-12).all()
    assert abs(lay.offset_rad) <= abs(inc) / 2 + 1e-12
    ahead = index[np.argmin(np.abs(pipe))]
    assert np.abs(np.angle(np.exp(1j * theta[ahead]))) <= abs(inc) / 2 + 1e-12
    x = np.random.default_rng(beams).uniform(1, 9, beams)
    if lay.closing:
        x[-1] = x[0]  # both readings of that direction
    np.testing.assert_array_equal(lay.from_pipeline(lay.to_pipeline(x)), x)
    values = np.arange(m)
    np.testing.assert_array_equal(lay.to_pipeline(lay.from_pipeline(values)), values)


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
    assert lay.heading_in_view and lay.shift == 0


@pytest.mark.parametrize(
    ("lo_deg", "hi_deg", "inside"),
    [(0, 90, True), (-30, 150, True), (-136, 136, True), (90, 270, False), (30, 120, False),
     (-121, -1, True), (-122, -2, False), (170, 260, False)],
)
def test_the_heading_is_in_view_when_the_field_of_view_holds_angle_0(lo_deg, hi_deg, inside):
    """2-degree increments: angle 0 is in view when it lies between the outer beams or within
    half an increment of one (-121..-1 ends 1 degree short of it, -122..-2 a whole increment
    short); the pipeline's 0 is the field of view's centre, in the message frame."""
    beams = (hi_deg - lo_deg) // 2 + 1
    lay = layout_of(math.radians(lo_deg), math.radians(hi_deg), math.radians(2), beams,
                    where="m")
    assert lay.heading_in_view is inside
    assert same_direction(lay.offset_rad, math.radians(lo_deg + hi_deg) / 2, 1e-12)
    assert -math.pi <= lay.offset_rad < math.pi


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((-1.0, 1.0, 0.02, 50), r"m: angle_increment disagrees with the angles and the count: "
                                r"angle_min \+ \(M - 1\) \* angle_increment = -0\.02 rad but "
                                r"angle_max = 1 rad, more than one increment away \(M = 50"),
        ((-1.0, 1.0, 2.0 / 98, 101), "angle_increment disagrees"),  # two increments off
        ((-1.0, 1.0, 2.0 / 100 * 1.02, 101), "angle_increment disagrees"),  # 1.02 increments
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


@pytest.mark.parametrize(
    "case",
    [
        # YDLidar: 719 beams, -pi to +pi: 719 increments make the turn, so the last beam is
        # at pi - inc (float32 fields, as published)
        (-math.pi, math.pi, 2 * math.pi / 719, 719, True, math.pi - 2 * math.pi / 719),
        # angle_max one increment past the last beam of a 180-degree scan
        (-math.pi / 2, math.pi / 2 + math.pi / 180, math.pi / 180, 181, False, math.pi / 2),
        # ... and one increment short
        (-math.pi / 2, math.pi / 2 - math.pi / 180, math.pi / 180, 181, False, math.pi / 2),
        # a clockwise full turn from 0 whose angle_max is one increment too far
        (0.0, -2 * math.pi, -math.pi / 180, 360, True, -359 * math.pi / 180),
    ],
)
def test_angle_max_one_increment_off_is_corrected(case):
    """(angle_min, angle_max as published, angle_increment, M, a full turn, the last beam)"""
    angle_min, angle_max, inc, beams, full, last = case
    f32 = [float(np.float32(v)) for v in (angle_min, angle_max, inc)]
    lay = layout_of(*f32, beams, where="m")
    assert (lay.fov_rad == 2 * math.pi) is full and not lay.closing
    assert lay.angle_max_corrected == pytest.approx(last, abs=1e-5)
    assert layout_of(angle_min, last, inc, beams, where="m").angle_max_corrected is None
    # half an increment off is float32 rounding, not a correction
    half = layout_of(angle_min, last + 0.49 * inc, inc, beams, where="m")
    assert half.angle_max_corrected is None


def test_npy_layouts_are_a_circle_from_minus_pi_or_centred():
    full = Layout.of_fov(360, math.radians(360))
    assert full.fov_rad == 2 * math.pi and full.shift == 0 and full.offset_rad == 0.0
    half = Layout.of_fov(181, math.pi)
    assert half.fov_rad == math.pi and half.heading_in_view and half.offset_rad == 0.0
    with pytest.raises(ValueError, match=r"fov_rad must be in \(0, 2\*pi\], got fov_rad=7\.0"):
        Layout.of_fov(10, 7.0)


@pytest.mark.parametrize("geometry", [REAL_ROBOT, SIM_ROBOT, RobotGeometry(r0_m=0.105, r_m=0.2)])
@pytest.mark.parametrize(("beams", "fov_deg"), [(360, 360.0), (1081, 270.0), (51, 25.0),
                                                 (720, 360.0), (101, 50.0)])
def test_the_window_is_the_filter_banks(geometry, beams, fov_deg):
    """window_beams gives FilterBank's window without designing the filters (a bank of
    fewer beams than Tc cannot be made: those layouts are narrow)."""
    lay = Layout.of_fov(beams, math.radians(fov_deg))
    w = window_beams(geometry, lay)
    try:
        bank = FilterBank(geometry, beams=beams, fov_rad=lay.fov_rad, range_m=10.0)
    except ValueError as exc:
        assert "beams must be an integer >= Tc" in str(exc)
        assert beams < w
    else:
        assert bank.window_beams == w
