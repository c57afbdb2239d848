"""LaserScans in every layout real drivers publish (REP 103, REP 117), through ``scan_bag``,
against the sliding-window minimum computed in each message's own frame and beam order: wrapping
around for a full turn, zero-padded for a partial field of view (so nothing is safe in a segment
narrower than the window). Each case names the convention it builds."""

import math

import numpy as np
import pytest
from scipy.ndimage import minimum_filter1d

pytest.importorskip("rosbags")

from fftnav.observe.compress import quadrant_areas  # noqa: E402
from fftnav.observe.fusion import own_probability  # noqa: E402
from fftnav.observe.geometry import REAL_ROBOT, RobotGeometry  # noqa: E402
from tests.ros.bagmaker import LASERSCAN, scan_msg, scans_bag, write_bag  # noqa: E402
from tests.ros.test_bags import lidar_scans, masks, rep117, run, window  # noqa: E402

TURN = 2 * math.pi
#: Two robot geometries, wide and narrow: the safety windows whose wrap-around a full turn
#: read from the wrong start gets wrong on the most beams.
ROBOTS = [RobotGeometry(r0_m=0.2, r_m=0.5), RobotGeometry(r0_m=0.105, r_m=0.2)]


def oracle(sent, *, geometry, inc, full, closing=False, range_max=10.0):
    """The safe beams of the scans as sent (message order, float32 as stored): every REP 117
    reading in the centred window reaches l_th, the window wrapping around a full turn (one
    of whose ``closing`` beams repeats the first direction: the nearer reading counts for
    both), zero-padded otherwise."""
    d = rep117(np.asarray(sent, np.float32).astype(float), 0.0, range_max, range_max)
    if not full:
        low = minimum_filter1d(d, window(geometry, inc), axis=1, mode="constant", cval=0.0)
        return low >= geometry.l_th_m
    if closing:
        d = d[:, :-1].copy()
        d[:, 0] = np.minimum(d[:, 0], np.asarray(sent, np.float32)[:, -1].astype(float))
    m = d.shape[1]
    safe = minimum_filter1d(d, window(geometry, TURN / m), axis=1, mode="wrap") >= geometry.l_th_m
    return np.concatenate([safe, safe[:, :1]], axis=1) if closing else safe


def beam_deg(angle_min, inc, beams):
    """Beam angles of a message in degrees, wrapped to [-180, 180)."""
    return (np.degrees(angle_min + inc * np.arange(beams)) + 180.0) % 360.0 - 180.0


def in_sectors(angle_deg, sectors, tol=0.01):
    """Whether an angle lies in one of the CCW sectors [lo, hi] (lo > hi: through the back)."""
    for lo, hi in sectors:
        if lo <= hi and lo - tol <= angle_deg <= hi + tol:
            return True
        if lo > hi and (angle_deg >= lo - tol or angle_deg <= hi + tol):
            return True
    return False


#: (convention, angle_min, angle_increment, beams, angle_max as published or None: the last
#: beam's angle)
FULL_TURNS = [
    ("TurtleBot3 LDS: 360 beams from 0", 0.0, TURN / 360, 360, None),
    ("from -pi", -math.pi, TURN / 360, 360, None),
    ("from pi/2", math.pi / 2, TURN / 360, 360, None),
    ("from 0.3 rad, not a whole number of increments from 0", 0.3, TURN / 500, 500, None),
    ("clockwise from 0", 0.0, -TURN / 360, 360, None),
    ("clockwise from pi/2, 720 beams", math.pi / 2, -TURN / 720, 720, None),
    ("M + 1 beams from 0, the last closing the turn", 0.0, TURN / 360, 361, None),
    ("M + 1 beams clockwise from pi, closing", math.pi, -TURN / 360, 361, None),
    ("YDLidar: 719 beams, angle_max = +pi one increment off", -math.pi, TURN / 719, 719,
     math.pi),
    ("720 beams from 0, angle_max = 2 pi one increment off", 0.0, TURN / 720, 720, TURN),
]


@pytest.mark.parametrize("geometry", ROBOTS, ids=["r0=0.2,r=0.5", "r0=0.105,r=0.2"])
@pytest.mark.parametrize("case", FULL_TURNS, ids=[c[0].split(":")[0] for c in FULL_TURNS])
def test_full_turns_wrap_around_wherever_they_start(tmp_path, geometry, case):
    _, angle_min, inc, beams, angle_max = case
    rng = np.random.default_rng(beams)
    sent = lidar_scans(rng, 4, beams, 10.0)
    last = angle_min + (beams - 1) * inc
    path = scans_bag(tmp_path / "t.mcap", sent, angle_min=angle_min,
                     angle_max=last if angle_max is None else angle_max, angle_increment=inc,
                     range_min=0.0, range_max=10.0)
    rows = run(path, geometry=geometry)
    expected = oracle(sent, geometry=geometry, inc=abs(inc), full=True, closing=beams == 361)
    got = masks(rows)
    assert got.shape == expected.shape and (got == expected).mean() >= 0.9999
    np.testing.assert_array_equal(got, expected)
    assert 0.05 < expected.mean() < 0.95
    for row in rows:  # the safe beams' own angles lie in the sectors given for them
        theta = beam_deg(angle_min, inc, beams)[np.array(row["safe_mask"], bool)]
        assert all(in_sectors(t, row["safe_sectors_deg"]) for t in theta)
        assert 0.0 < row["p_left"] < 1.0 and "reason" not in row
        if angle_max is None:
            assert "angle_max_corrected" not in row
        else:
            assert row["angle_max_corrected"] == pytest.approx(last, abs=1e-5)


#: A partial field of view: (convention, angle_min, angle_increment, beams).
PARTIAL = [
    ("180 degrees centred", -math.pi / 2, math.pi / 180, 181),
    ("90 degrees from 0, off centre", 0.0, math.pi / 360, 181),
    ("clockwise, 240 degrees from 150", math.radians(150), -math.pi / 360, 481),
    ("behind the robot: 90 to 270 degrees", math.pi / 2, math.pi / 180, 181),
]


@pytest.mark.parametrize(("name", "angle_min", "inc", "beams"), PARTIAL,
                         ids=[c[0] for c in PARTIAL])
def test_partial_fields_of_view_keep_the_zero_padded_window(tmp_path, name, angle_min, inc,
                                                            beams):
    """The mask is the zero-padded window's on the beams the scanner has, whatever their
    direction; P_s is computed around angle 0, so a field of view without it has none."""
    geometry = ROBOTS[0]
    rng = np.random.default_rng(beams)
    sent = lidar_scans(rng, 4, beams, 10.0)
    path = scans_bag(tmp_path / "p.mcap", sent, angle_min=angle_min,
                     angle_max=angle_min + (beams - 1) * inc, angle_increment=inc,
                     range_min=0.0, range_max=10.0)
    rows = run(path, geometry=geometry)
    expected = oracle(sent, geometry=geometry, inc=abs(inc), full=False)
    np.testing.assert_array_equal(masks(rows), expected)
    assert expected.any() and not expected.all()
    behind = name.startswith("behind")
    for row in rows:
        theta = beam_deg(angle_min, inc, beams)[np.array(row["safe_mask"], bool)]
        assert all(in_sectors(t, row["safe_sectors_deg"]) for t in theta)
        if behind:
            assert row["p_left"] is None
            assert row["reason"] == "the field of view does not contain the heading (angle 0)"
        else:
            assert "reason" not in row
            # P_s around angle 0 from the line's own extrema, in the message frame
            ext = np.array(row["extrema"]).reshape(-1, 2)
            sigma = np.column_stack([np.radians(ext[:, 0]), ext[:, 1]])
            x0 = quadrant_areas(sigma, alpha_rad=geometry.alpha_rad, range_m=10.0,
                                full_circle=False)
            assert row["p_left"] == pytest.approx(float(own_probability(x0)), abs=2e-4)


def half_open_scene(beams, rng):
    """Physical readings at -pi + n 2pi/M: open (8 m) on the left half (0, pi), a wall at
    1.2 m on the right half, with millimetre noise."""
    phi = -math.pi + TURN / beams * np.arange(beams)
    d = np.where((phi > 0) & (phi < math.pi), 8.0, 1.2)
    return np.round(d + rng.normal(0, 0.02, (3, beams)), 3)


def test_p_left_is_the_same_wherever_the_same_turn_starts(tmp_path):
    """One physical scan published from -pi, from 0 (TurtleBot3), clockwise from 0 and with a
    closing beam from 0: the same P_s, extrema and sectors, and turning left (the left half is
    open). Read from message angle pi, as if the turn started at -pi, it would turn right."""
    beams = 360
    inc = TURN / beams
    scene = half_open_scene(beams, np.random.default_rng(11))  # index n: angle -pi + n inc
    n = np.arange(beams)
    published = {
        "from -pi": (scene, -math.pi, inc),
        "from 0": (scene[:, (n + 180) % beams], 0.0, inc),
        "clockwise from 0": (scene[:, (180 - n) % beams], 0.0, -inc),
        "closing from 0": (scene[:, (np.arange(beams + 1) + 180) % beams], 0.0, inc),
    }
    lines = {}
    for k, (name, (sent, lo, step)) in enumerate(published.items()):
        m = sent.shape[1]
        path = scans_bag(tmp_path / f"{k}.mcap", sent, angle_min=lo,
                         angle_max=lo + (m - 1) * step, angle_increment=step, range_min=0.0,
                         range_max=10.0)
        lines[name] = run(path)
    want = lines["from -pi"]
    assert all(r["p_left"] > 0.55 for r in want)  # turn left: the decision is p_left > 0.5
    for name, rows in lines.items():
        for r, w in zip(rows, want, strict=True):
            assert (r["p_left"], r["extrema"], r["safe_sectors_deg"]) == (
                w["p_left"], w["extrema"], w["safe_sectors_deg"]), name
    backwards = run(scans_bag(tmp_path / "b.mcap", scene[:, (n + 180) % beams],
                              angle_min=-math.pi, angle_max=math.pi - inc, angle_increment=inc,
                              range_min=0.0, range_max=10.0))
    assert all(r["p_left"] < 0.45 for r in backwards)


def pilz_segments(rng, k):
    """A Pilz PSENscan-like topic: 25 and 50 degree segments of 0.5 degree beams, alternately,
    whose angle_min moves on every message (clockwise every third), open at 6 m with a few
    obstacles. The real robot's window at 0.5 degrees is 99 beams: a 25-degree segment (51
    beams) is narrower, a 50-degree one (101) is not."""
    out = []
    inc = math.radians(0.5)
    for i in range(k):
        beams = 51 if i % 2 == 0 else 101
        d = np.full(beams, 6.0)
        d[rng.integers(0, beams, 2)] = rng.choice([0.5, 3.0, np.nan], 2)
        lo = math.radians(-135 + 10 * i)
        step = -inc if i % 3 == 2 else inc
        out.append((d, lo, step))
    return out


def test_narrow_segments_are_answered_with_no_safe_beam(tmp_path):
    rng = np.random.default_rng(8)
    segs = pilz_segments(rng, 12)
    items = [(LASERSCAN, lambda s, d=d, lo=lo, step=step, i=i: scan_msg(
        s, d, i=i, angle_min=lo, angle_max=lo + (len(d) - 1) * step, angle_increment=step,
        range_min=0.0, range_max=10.0)) for i, (d, lo, step) in enumerate(segs)]
    path = write_bag(tmp_path / "pilz.bag", {"/scan": items})
    rows = run(path, out_bag=tmp_path / "pilz.mcap")
    assert [r["index"] for r in rows] == list(range(12))  # every message answered
    for row, (d, lo, step) in zip(rows, segs, strict=True):
        expected = oracle(d[None], geometry=REAL_ROBOT, inc=abs(step), full=False)[0]
        ends = sorted([lo, lo + (len(d) - 1) * step])
        heading = ends[0] - abs(step) / 2 <= 0.0 <= ends[1] + abs(step) / 2
        np.testing.assert_array_equal(np.array(row["safe_mask"], bool), expected)
        if len(d) == 51:
            assert not expected.any()
            assert row["reason"] == "segment narrower than the safety window"
            assert row["p_left"] is None and row["extrema"] == [] and row["message_bytes"] == 4
            assert row["safe_sectors_deg"] == []
        elif heading:
            assert "reason" not in row and 0.0 < row["p_left"] < 1.0
        else:
            assert row["reason"] == "the field of view does not contain the heading (angle 0)"
            assert row["p_left"] is None and row["message_bytes"] == 4 + 3 * len(row["extrema"])
    assert any(any(r["safe_mask"]) for r in rows[1::2])  # the 50-degree segments see a way
    safe_scans = read_topic(tmp_path / "pilz.mcap", "/fftnav/safe_scan")
    for row, msg in zip(rows, safe_scans, strict=True):
        np.testing.assert_array_equal(~np.isnan(np.asarray(msg.ranges)), row["safe_mask"])


def read_topic(path, topic):
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        return [reader.deserialize(raw, c.msgtype)
                for c, _, raw in reader.messages(connections=conns)]


@pytest.mark.parametrize("case", [FULL_TURNS[0], FULL_TURNS[7], FULL_TURNS[8],
                                  PARTIAL[2] + (None,)],
                         ids=["from 0", "closing clockwise", "YDLidar", "clockwise partial"])
def test_the_annotated_safe_scan_is_in_the_messages_order_and_frame(tmp_path, case):
    """/fftnav/safe_scan: the oracle's safe beams in the message's own order, with its angles
    (angle_max the last beam's); each wedge of /fftnav/safe_directions points along a safe
    beam of the message's frame."""
    _, angle_min, inc, beams, angle_max = case
    geometry = ROBOTS[0]
    sent = lidar_scans(np.random.default_rng(beams + 1), 3, beams, 10.0)
    last = angle_min + (beams - 1) * inc
    src = scans_bag(tmp_path / "in.bag", sent, angle_min=angle_min,
                    angle_max=last if angle_max is None else angle_max, angle_increment=inc,
                    range_min=0.0, range_max=10.0, frame_id="base_scan")
    rows = run(src, geometry=geometry, out_bag=tmp_path / "out.mcap")
    expected = oracle(sent, geometry=geometry, inc=abs(inc), full=beams != 481,
                      closing=beams == 361)
    safe = read_topic(tmp_path / "out.mcap", "/fftnav/safe_scan")
    wedges = read_topic(tmp_path / "out.mcap", "/fftnav/safe_directions")
    for msg, marker, row, want in zip(safe, wedges, rows, expected, strict=True):
        ranges = np.asarray(msg.ranges)
        np.testing.assert_array_equal(~np.isnan(ranges), want)
        assert msg.header.frame_id == "base_scan"
        assert msg.angle_min == pytest.approx(angle_min, abs=1e-6)
        assert msg.angle_increment == pytest.approx(inc, abs=1e-7)
        assert msg.angle_max == pytest.approx(last, abs=1e-5)
        points = marker.markers[0].points
        tips = np.array([[p.x, p.y] for p in points]).reshape(-1, 3, 2)[:, 1:].mean(axis=1)
        theta = np.degrees(np.arctan2(tips[:, 1], tips[:, 0]))
        off = (theta - beam_deg(angle_min, inc, beams)[want] + 180.0) % 360.0 - 180.0
        assert len(off) == want.sum() and (np.abs(off) < 1e-3).all()
        assert row["safe_mask"] == want.astype(int).tolist()
