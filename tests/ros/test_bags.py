import io
import json
import math
import os
import re

import numpy as np
import pytest

pytest.importorskip("rosbags")

from fftnav.observe.geometry import REAL_ROBOT, SIM_ROBOT  # noqa: E402
from fftnav.ros import bags  # noqa: E402
from fftnav.ros.bags import scan_bag  # noqa: E402
from tests.observe.test_safe import oracle_mask, piecewise_scan  # noqa: E402
from tests.ros.bagmaker import LASERSCAN, scan_msg, scans_bag, write_bag  # noqa: E402

KINDS = ["bag", "db3", "mcap", "db3-folder", "mcap-folder"]


def run(path, geometry=REAL_ROBOT, **kw):
    out = io.StringIO()
    kw.setdefault("topic", None)
    kw.setdefault("range_m", None)
    scan_bag(path, geometry=geometry, write=out.write, **kw)
    return [json.loads(line) for line in out.getvalue().splitlines()]


def masks(rows):
    return np.array([r["safe_mask"] for r in rows], dtype=bool)


def window(geometry, inc):
    tc = math.ceil(geometry.alpha_rad / inc - 1e-9)
    return tc + 1 - tc % 2


def rep117(d, range_min, range_max, range_m):
    """REP 117 written out case by case, for the oracle."""
    out = np.minimum(d, range_m)
    out[d > range_max] = range_m
    out[np.isnan(d) | np.isneginf(d) | (d < range_min)] = 0.0
    return out


def lidar_scans(rng, k, beams, range_max):
    """Runs of open space and obstacles with a few REP 117 oddities (NaN, +-inf, 0)."""
    out = []
    for _ in range(k):
        d = piecewise_scan(rng, beams, range_max)
        d[np.isnan(d) | (d < 0)] = range_max / 2
        odd = rng.choice(beams, 3, replace=False)
        d[odd] = rng.choice([np.nan, -np.inf, np.inf, 0.0], 3)
        out.append(d)
    return np.vstack(out)


def bag_path(tmp_path, kind, name="s"):
    return tmp_path / (f"{name}.{kind.split('-')[0]}" if "folder" not in kind else name)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize(("fov_deg", "beams"), [(270.0, 1081), (180.0, 361)])
def test_scanners_match_the_sliding_window_minimum(tmp_path, kind, fov_deg, beams):
    rng = np.random.default_rng(beams)
    range_max = 10.0
    scans = lidar_scans(rng, 6, beams, range_max)
    half = math.radians(fov_deg) / 2
    inc = 2 * half / (beams - 1)
    path = scans_bag(bag_path(tmp_path, kind), scans, kind=kind, angle_min=-half,
                     angle_max=half, angle_increment=inc, range_min=0.02, range_max=range_max)
    rows = run(path)
    d = rep117(scans.astype(np.float32).astype(float), 0.02, range_max, range_max)
    expected = oracle_mask(d, l_th=REAL_ROBOT.l_th_m, range_m=range_max,
                           window=window(REAL_ROBOT, inc), circular=False)
    np.testing.assert_array_equal(masks(rows), expected)
    assert 0.05 < expected.mean() < 0.95
    assert [r["index"] for r in rows] == list(range(6))
    assert rows[2]["stamp_sec"] == 1 and rows[2]["stamp_nanosec"] == 200_000_000
    assert rows[0]["frame_id"] == "laser" and rows[0]["topic"] == "/scan"
    for r in rows:
        for lo, hi in r["safe_sectors_deg"]:
            assert -fov_deg / 2 - 1e-3 <= lo <= hi <= fov_deg / 2 + 1e-3


def test_rep117_cases_through_a_bag(tmp_path):
    # range_min 2.5 m: a reading of 2 m, past l_th = 1.69 m, is invalid (reads 0, blocked);
    # readings above range_max and +inf read R; -inf and NaN read 0
    beams = 361
    rng = np.random.default_rng(5)
    scans = np.full((5, beams), 6.0)
    scans[0, 100:110] = 2.0
    scans[1, 200:204] = np.nan
    scans[2, 50:53] = -np.inf
    scans[3] = np.inf
    scans[4] = np.repeat(rng.choice([0.5, 2.0, 3.0, 25.0, np.inf, -np.inf, np.nan], 19), 19)
    path = scans_bag(tmp_path / "r.mcap", scans, range_min=2.5, range_max=20.0)
    rows = run(path, range_m=8.0)
    d = rep117(scans, 2.5, 20.0, 8.0)
    expected = oracle_mask(d, l_th=REAL_ROBOT.l_th_m, range_m=8.0,
                           window=window(REAL_ROBOT, math.pi / 360), circular=False)
    np.testing.assert_array_equal(masks(rows), expected)
    assert not expected[0, 100:110].any() and expected[3, 180]  # 2 m blocks; inf is open
    naive = oracle_mask(np.where(np.isnan(scans), 0, scans), l_th=REAL_ROBOT.l_th_m,
                        range_m=8.0, window=window(REAL_ROBOT, math.pi / 360), circular=False)
    assert (naive != expected).any()  # the REP 117 rules decide some beams


def test_clockwise_full_circle_and_mixed_layouts_in_one_topic(tmp_path):
    rng = np.random.default_rng(2)
    a = lidar_scans(rng, 3, 181, 10.0)
    b = lidar_scans(rng, 3, 720, 10.0)
    items = []
    for i in range(3):
        # counter-clockwise and clockwise halves of the same scan, then a full circle
        items.append((LASERSCAN, lambda s, r=a[i]: scan_msg(s, r)))
        items.append((LASERSCAN, lambda s, r=a[i]: scan_msg(
            s, r[::-1], angle_min=math.pi / 2, angle_max=-math.pi / 2)))
        items.append((LASERSCAN, lambda s, r=b[i]: scan_msg(
            s, r, angle_min=-math.pi, angle_max=math.pi - math.pi / 360,
            angle_increment=math.pi / 360)))
    rows = run(write_bag(tmp_path / "m.bag", {"/scan": items}), geometry=SIM_ROBOT)
    got = masks(rows[0::3]), masks(rows[1::3])
    np.testing.assert_array_equal(got[0], got[1][:, ::-1])  # beam order of each message
    assert [r["extrema"] for r in rows[0::3]] == [r["extrema"] for r in rows[1::3]]
    full = np.array([r["safe_mask"] for r in rows[2::3]], dtype=bool)
    d = rep117(b.astype(np.float32).astype(float), 0.0, 10.0, 10.0)
    expected = oracle_mask(d, l_th=SIM_ROBOT.l_th_m, range_m=10.0,
                           window=window(SIM_ROBOT, math.pi / 360), circular=True)
    np.testing.assert_array_equal(full, expected)


def test_batches_do_not_change_the_lines(tmp_path, monkeypatch):
    rng = np.random.default_rng(3)
    scans = lidar_scans(rng, 25, 361, 10.0)
    path = scans_bag(tmp_path / "b.db3", scans)
    whole = run(path)
    monkeypatch.setattr(bags, "BATCH_READINGS", 3 * 361)
    assert run(path) == whole


def test_capitalised_names_are_read(tmp_path):
    scans = np.full((2, 181), 5.0)
    for kind in ("bag", "mcap", "db3"):
        lower = scans_bag(tmp_path / f"x.{kind}", scans)
        upper = lower.rename(tmp_path / f"X.{kind.upper()}")
        assert masks(run(upper)).sum() > 0


def test_annotated_bag_read_back(tmp_path):
    from rosbags.highlevel import AnyReader

    rng = np.random.default_rng(4)
    scans = lidar_scans(rng, 4, 361, 10.0)
    odo = [("std_msgs/msg/String", lambda s, i=i: s.types["std_msgs/msg/String"](f"m{i}"))
           for i in range(7)]
    items = [(LASERSCAN, lambda s, r=r, i=i: scan_msg(s, r, i=i)) for i, r in enumerate(scans)]
    for kind, out in (("bag", "a.bag"), ("mcap", "a.mcap"), ("db3-folder", "afolder"),
                      ("bag", "b.mcap")):
        src = write_bag(bag_path(tmp_path, kind, "in_" + out.replace(".", "_")),
                        {"/scan": items, "/note": odo}, kind=kind)
        rows = run(src, out_bag=tmp_path / out)
        with AnyReader([tmp_path / out]) as reader:
            topics = {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}
            assert topics == {"/scan": (LASERSCAN, 4), "/note": ("std_msgs/msg/String", 7),
                              "/fftnav/safe_scan": (LASERSCAN, 4),
                              "/fftnav/safe_directions": ("visualization_msgs/msg/MarkerArray", 4)}
            conns = [c for c in reader.connections if c.topic.startswith("/fftnav")]
            got = {"/fftnav/safe_scan": [], "/fftnav/safe_directions": []}
            for conn, _, raw in reader.messages(connections=conns):
                got[conn.topic].append(reader.deserialize(raw, conn.msgtype))
        for row, safe, arr in zip(rows, *got.values(), strict=True):
            mask = np.array(row["safe_mask"], dtype=bool)
            ranges = np.asarray(safe.ranges)
            np.testing.assert_array_equal(np.isnan(ranges), ~mask)
            assert (ranges[mask] >= REAL_ROBOT.l_th_m - 1e-4).all()
            assert (ranges[mask] <= 10.0 + 1e-4).all()
            assert safe.header.stamp.sec == row["stamp_sec"]
            (marker,) = arr.markers
            assert marker.type == 11 and len(marker.points) == 3 * mask.sum()
            assert marker.header.frame_id == "laser"
        assert not list(tmp_path.glob(".*tmp"))


def refused(match, path, **kw):
    with pytest.raises(ValueError, match=re.escape(match)):
        run(path, **kw)


def test_missing_and_wrong_topics_list_the_laserscan_topics(tmp_path):
    items = {"/front": [(LASERSCAN, lambda s: scan_msg(s, np.full(181, 5.0)))],
             "/rear": [(LASERSCAN, lambda s: scan_msg(s, np.full(181, 5.0)))],
             "/chatter": [("std_msgs/msg/String",
                           lambda s: s.types["std_msgs/msg/String"]("hi"))]}
    path = write_bag(tmp_path / "t.mcap", items)
    refused("t.mcap has no topic '/scan'; its LaserScan topics: /front, /rear", path,
            topic="/scan")
    refused("t.mcap is not a LaserScan topic '/chatter'; its LaserScan topics: /front, /rear",
            path, topic="/chatter")
    refused("pass --topic, one of the LaserScan topics: /front, /rear", path)
    empty = write_bag(tmp_path / "e.bag", {"/chatter": items["/chatter"]})
    refused("e.bag has no topic '/scan'; its LaserScan topics: none", empty, topic="/scan")
    refused("e.bag holds no sensor_msgs/LaserScan topic to scan (its topics' types: "
            "std_msgs/msg/String)", empty)


@pytest.mark.parametrize("kind", ["db3", "mcap"])
def test_a_bag_that_cannot_be_written_is_one_line_and_leaves_nothing(tmp_path, kind,
                                                                     monkeypatch):
    """A full disk under the writer (sqlite's "database or disk is full", or ENOSPC): one
    ValueError naming the output, and no bag under its name."""
    import errno
    import sqlite3

    from fftnav.ros import bags

    src = scans_bag(tmp_path / "in.mcap", np.full((5, 181), 5.0))
    real = bags.AnnotatedBag.annotate
    calls = []

    def full(self, scan):
        calls.append(1)
        if len(calls) == 3:
            raise (sqlite3.OperationalError("database or disk is full") if kind == "db3"
                   else OSError(errno.ENOSPC, "No space left on device"))
        return real(self, scan)

    monkeypatch.setattr(bags.AnnotatedBag, "annotate", full)
    out = tmp_path / f"out.{kind}"
    with pytest.raises(ValueError, match=rf"^{re.escape(str(out))}: the bag could not be written "
                                         r"\(no space left on device\); nothing was kept$"):
        run(src, out_bag=out)
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.mcap"]


@pytest.mark.parametrize("kind", ["bag", "db3", "mcap"])
def test_damaged_and_truncated_bags_are_refused(tmp_path, kind):
    good = scans_bag(tmp_path / f"g.{kind}", np.full((40, 361), 5.0))
    data = good.read_bytes()
    for name, cut in (("half", data[: len(data) // 2]), ("head", data[:30]),
                      ("noise", b"\x00garbage" * 50)):
        path = tmp_path / f"{name}.{kind}"
        path.write_bytes(cut)
        with pytest.raises(ValueError, match=re.escape(f"{path}: damaged")) as info:
            run(path)
        assert "\n" not in str(info.value) and len(str(info.value)) < 300


def test_a_truncated_db3_is_checked_against_its_header(tmp_path):
    good = scans_bag(tmp_path / "g.db3", np.full((200, 361), 5.0))
    cut = tmp_path / "cut.db3"
    cut.write_bytes(good.read_bytes()[:-4096])  # whole pages gone: rosbags alone reads on
    refused(f"{cut}: damaged bag: truncated ({cut.stat().st_size} bytes, its SQLite header "
            f"states {good.stat().st_size})", cut)


def test_a_damaged_bag_folder_is_refused(tmp_path):
    folder = scans_bag(tmp_path / "f", np.full((2, 181), 5.0), kind="mcap-folder")
    (folder / "metadata.yaml").write_text("rosbag2_bagfile_information: [")
    refused(f"{folder}: damaged or unreadable bag", folder)


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"angle_increment": math.pi / 90},
         "message 1: angle_increment disagrees with the angles and the count: angle_min + "
         "(M - 1) * angle_increment = 4.71239 rad but angle_max = 1.5708 rad, more than one "
         "increment away (M = 181"),
        ({"range_min": 5.0, "range_max": 5.0},
         "message 1: range_min and range_max must be finite with 0 <= range_min < range_max, "
         "got range_min=5.0, range_max=5.0"),
        ({"range_min": 6.0, "range_max": 2.0}, "message 1: range_min and range_max must be "
         "finite with 0 <= range_min < range_max, got range_min=6.0, range_max=2.0"),
        ({"range_max": 1.0}, "message 1: range_m must be finite and >= l_th_m=1.69"),
    ],
)
def test_bad_messages_are_refused_by_index(tmp_path, fields, match):
    items = [(LASERSCAN, lambda s: scan_msg(s, np.full(181, 5.0))),
             (LASERSCAN, lambda s: scan_msg(s, np.full(181, 5.0), **fields))]
    path = write_bag(tmp_path / "b.bag", {"/scan": items})
    lines = []
    with pytest.raises(ValueError, match=re.escape(f"{path}: {match}")):
        scan_bag(path, topic=None, geometry=REAL_ROBOT, range_m=None, write=lines.append)
    assert [json.loads(line)["index"] for line in lines] == [0]  # the line before is kept


def test_special_files_are_refused_without_opening_them(tmp_path):
    fifo = tmp_path / "live.bag"
    os.mkfifo(fifo)
    refused(f"{fifo}: a bag must be a regular file or a ROS 2 bag folder, not a pipe", fifo)
    folder = tmp_path / "folder"
    folder.mkdir()
    (folder / "metadata.yaml").write_text("x")
    os.mkfifo(folder / "x.db3")
    refused("x.db3: a bag must be a regular file", folder)


def test_out_bag_never_overwrites_the_input(tmp_path):
    single = scans_bag(tmp_path / "s.mcap", np.full((2, 181), 5.0))
    folder = scans_bag(tmp_path / "in", np.full((2, 181), 5.0), kind="db3-folder")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    for src, out in ((single, single), (folder, folder), (folder, folder / "x.db3"),
                     (folder, tmp_path), (single, tmp_path), (single, tmp_path / ".")):
        refused("--out-bag must not be the input bag, a path inside it or a folder holding it",
                src, out_bag=out)
    assert before == {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    fifo = tmp_path / "out.mcap"
    os.mkfifo(fifo)
    refused("--out-bag must be a regular file", single, out_bag=fifo)


@pytest.mark.parametrize("clockwise", [False, True])
def test_a_closing_beam_is_read_as_a_full_circle(tmp_path, clockwise):
    """361 beams from -pi to pi inclusive (the last points where the first does, as some
    drivers publish): the masks of the 360-beam full circle whose first reading is the nearer
    of the two, against the sliding-window minimum that wraps around, and the closing beam
    gets the first's."""
    rng = np.random.default_rng(7)
    scans = lidar_scans(rng, 4, 361, 10.0)
    inc = 2 * math.pi / 360
    lo, hi = (math.pi, -math.pi) if clockwise else (-math.pi, math.pi)
    sent = scans[:, ::-1] if clockwise else scans  # message order
    path = scans_bag(tmp_path / "c.mcap", sent, angle_min=lo, angle_max=hi,
                     angle_increment=-inc if clockwise else inc, range_min=0.0, range_max=10.0)
    got = masks(run(path, geometry=SIM_ROBOT))
    got = got[:, ::-1] if clockwise else got  # counter-clockwise from -pi
    d = rep117(scans.astype(np.float32).astype(float), 0.0, 10.0, 10.0)
    circle = d[:, :360].copy()
    circle[:, 0] = np.minimum(d[:, 0], d[:, 360])
    expected = oracle_mask(circle, l_th=SIM_ROBOT.l_th_m, range_m=10.0,
                           window=window(SIM_ROBOT, inc), circular=True)
    np.testing.assert_array_equal(got[:, :360], expected)
    np.testing.assert_array_equal(got[:, 360], got[:, 0])
    assert 0.05 < expected.mean() < 0.95


def test_other_types_on_the_scan_topic_are_copied_not_read_and_a_bad_copy_is_named(
        tmp_path, monkeypatch):
    """A String connection on /scan beside the LaserScans: the scans are read, the strings
    only copied into the annotated bag. A message rosbags cannot convert while copying is a
    damaged input: one ValueError naming the bag, and no bag or temporary folder is left."""
    from rosbags.highlevel import AnyReader
    from rosbags.serde import SerdeError

    rng = np.random.default_rng(6)
    scans = lidar_scans(rng, 3, 181, 10.0)
    items = [(LASERSCAN, lambda s, r=r, i=i: scan_msg(s, r, i=i)) for i, r in enumerate(scans)]
    items += [("std_msgs/msg/String", lambda s, i=i: s.types["std_msgs/msg/String"](f"m{i}"))
              for i in range(2)]
    src = write_bag(tmp_path / "in.mcap", {"/scan": items})
    rows = run(src, topic="/scan", out_bag=tmp_path / "out.mcap")
    assert len(rows) == 3
    with AnyReader([tmp_path / "out.mcap"]) as reader:
        counts = sorted((c.msgtype, c.msgcount) for c in reader.connections if c.topic == "/scan")
    assert counts == [(LASERSCAN, 3), ("std_msgs/msg/String", 2)]

    setup = bags.AnnotatedBag.setup

    def damaged(self):
        setup(self)

        def fail(raw):
            raise SerdeError("Invalid string length")

        self.convmap = {k: fail for k in self.convmap}

    monkeypatch.setattr(bags.AnnotatedBag, "setup", damaged)
    refused("in.mcap: damaged or unreadable bag: Invalid string length", src,
            topic="/scan", out_bag=tmp_path / "bad.mcap")
    assert not (tmp_path / "bad.mcap").exists() and not list(tmp_path.glob(".*tmp"))


def test_a_killed_writers_bag_folder_is_swept_by_the_next_bag_of_that_name(tmp_path):
    import subprocess
    import sys

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    src = scans_bag(tmp_path / "in.mcap", np.full((3, 181), 5.0))
    stale = tmp_path / f".out.mcap.{dead}.tmp"
    (stale / "out.mcap").mkdir(parents=True)
    run(src, out_bag=tmp_path / "out.mcap")
    assert (tmp_path / "out.mcap").is_file() and not stale.exists()
