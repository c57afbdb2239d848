"""``fftnav scan BAG`` as a subprocess: the output lines, every refusal, the Radish logs."""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from fftnav.observe.scanio import CARMEN_NO_RETURN_M, read_scans  # noqa: E402
from tests.ros.bagmaker import scans_bag  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
#: The Radish CARMEN logs: shared/ beside the clone (CI), or the workplace's.
RADISH_DIRS = [ROOT.parent / "shared" / "data" / "radish", Path("/work/shared/data/radish")]
RADISH = next((sorted(d.glob("*.log.gz")) for d in RADISH_DIRS if d.is_dir()), [])


def run(*args, timeout=120):
    return subprocess.run([sys.executable, "-m", "fftnav", "scan", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def refused(proc, match):
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    assert proc.stdout == ""
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert match in lines[0], lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bags")
    scans = np.full((3, 181), 6.0)
    scans[1, 80:100] = 1.0
    return scans_bag(tmp / "s.bag", scans, frame_id="base_laser")


def test_lines_carry_todays_fields_and_the_messages_own(bag):
    proc = run(bag, "--topic", "/scan")
    assert proc.returncode == 0, proc.stderr
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(rows) == 3
    assert list(rows[0]) == ["index", "safe_mask", "safe_sectors_deg", "extrema",
                             "extrema_is_min", "message_bytes", "p_left", "topic", "stamp_sec",
                             "stamp_nanosec", "frame_id"]
    assert [(r["stamp_sec"], r["stamp_nanosec"]) for r in rows] == [
        (1, 0), (1, 100_000_000), (1, 200_000_000)]
    assert rows[0]["frame_id"] == "base_laser" and rows[0]["topic"] == "/scan"
    assert sum(rows[1]["safe_mask"]) < sum(rows[0]["safe_mask"])


def test_out_bag_then_its_safe_scan_topic(bag, tmp_path):
    out = tmp_path / "ann.mcap"
    first = run(bag, "--out-bag", out)
    assert first.returncode == 0, first.stderr
    again = run(out, "--topic", "/scan")
    assert again.stdout.replace('"topic":"/scan"', "") == first.stdout.replace(
        '"topic":"/scan"', "")
    refused(run(out), "pass --topic, one of the LaserScan topics: /fftnav/safe_scan, /scan")


def test_a_missing_topic_and_a_damaged_bag_are_one_line(tmp_path, bag):
    refused(run(bag, "--topic", "/nope"), "s.bag has no topic '/nope'; its LaserScan topics: /scan")
    cut = tmp_path / "cut.bag"
    cut.write_bytes(bag.read_bytes()[:300])
    refused(run(cut), f"{cut}: damaged or unreadable bag")


def test_a_fifo_is_refused_without_opening_it(tmp_path):
    fifo = tmp_path / "live.bag"
    os.mkfifo(fifo)
    refused(run(fifo, timeout=60), "not a pipe, FIFO, socket or device")


def test_out_bag_equal_to_the_input_is_refused(bag):
    before = bag.read_bytes()
    refused(run(bag, "--out-bag", bag),
            "--out-bag must not be the input bag, a path inside it or a folder holding it")
    assert bag.read_bytes() == before


def test_capital_names_read_and_write(tmp_path, bag):
    big = tmp_path / "A.MCAP"
    assert run(bag, "--out-bag", big).returncode == 0
    proc = run(big, "--topic", "/scan")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.count("\n") == 3  # .BAG and .DB3 inputs: tests/ros/test_bags.py


def test_without_rosbags_one_line_says_how_to_install(bag):
    code = ("import sys; sys.modules['rosbags'] = None; from fftnav.cli import main; "
            f"sys.exit(main(['scan', {str(bag)!r}]))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60)
    refused(proc, "pip install 'fftnav[ros]'")


def test_bag_options_with_other_inputs_are_refused(tmp_path, bag):
    np.save(tmp_path / "s.npy", np.full(360, 3.0))
    refused(run(tmp_path / "s.npy", "--topic", "/scan"), "--topic and --out-bag need a bag")
    refused(run(bag, "--fov", "180"), "--fov and --format do not apply to bags")


def test_radish_logs_are_there_or_skipped():
    if not RADISH:
        pytest.skip("the Radish logs (shared/data/radish) are not beside this clone")
    assert len(RADISH) == 4


@pytest.mark.parametrize("log", RADISH, ids=lambda p: p.name.split("-")[0])
def test_radish_logs_as_bags_give_the_masks_of_the_log(tmp_path, log):
    scans = read_scans(log)
    beams = scans.ranges.shape[1]
    fields = {"angle_min": -math.pi / 2, "angle_max": math.pi / 2,
              "angle_increment": math.pi / (beams - 1), "range_min": 0.0,
              "range_max": CARMEN_NO_RETURN_M, "frame_id": "front_laser"}
    expected = run(log)
    assert expected.returncode == 0, expected.stderr
    want = [json.loads(line)["safe_mask"] for line in expected.stdout.splitlines()]
    for name in ("radish.bag", "radish.mcap"):
        path = scans_bag(tmp_path / name, scans.ranges, **fields)
        proc = run(path, "--range", "10")
        assert proc.returncode == 0, proc.stderr
        got = [json.loads(line)["safe_mask"] for line in proc.stdout.splitlines()]
        assert len(got) == len(want) == len(scans.ranges)
        assert got == want, name


def test_every_convention_in_one_topic_is_answered(tmp_path):
    """One topic mixing what real drivers publish: a TurtleBot3 full turn from 0, a YDLidar
    turn of 719 beams whose angle_max = +pi is one increment off, a 25-degree Pilz segment
    narrower than the window, and a centred 180-degree scan: exit 0, a line per message, the
    masks of the sliding-window minimum in each message's frame (wrapping for the turns), the
    correction and the reason in the lines, and the annotated bag written."""
    from fftnav.observe.geometry import REAL_ROBOT
    from tests.ros.bagmaker import LASERSCAN, scan_msg, write_bag
    from tests.ros.test_bags import lidar_scans
    from tests.ros.test_scan_layouts import oracle

    geometry = REAL_ROBOT
    rng = np.random.default_rng(41)
    turn = 2 * math.pi
    lds = lidar_scans(rng, 1, 360, 10.0)[0]
    lds[:45] = lds[-45:] = np.inf  # open ahead, around message angle 0
    cases = [  # (readings, angle_min, angle_increment, angle_max, full)
        (lds, 0.0, turn / 360, 359 * turn / 360, True),
        (lidar_scans(rng, 1, 719, 10.0)[0], -math.pi, turn / 719, math.pi, True),
        (np.full(51, 6.0), 0.3, math.radians(0.5), 0.3 + math.radians(25), False),
        (lidar_scans(rng, 1, 181, 10.0)[0], -math.pi / 2, math.pi / 180, math.pi / 2, False),
    ]
    items = [(LASERSCAN, lambda s, c=c, i=i: scan_msg(
        s, c[0], i=i, angle_min=c[1], angle_increment=c[2], angle_max=c[3], range_min=0.0,
        range_max=10.0)) for i, c in enumerate(cases)]
    src = write_bag(tmp_path / "mixed.bag", {"/scan": items})
    proc = run(src, "--out-bag", tmp_path / "mixed.mcap")
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [r["index"] for r in rows] == [0, 1, 2, 3]
    for row, (d, _, inc, _, full) in zip(rows, cases, strict=True):
        want = oracle(d[None], geometry=geometry, inc=inc, full=full)[0]
        np.testing.assert_array_equal(np.array(row["safe_mask"], bool), want)
    assert [k for k in rows[1] if k not in rows[0]] == ["angle_max_corrected"]
    assert rows[1]["angle_max_corrected"] == pytest.approx(math.pi - turn / 719, abs=1e-5)
    assert rows[2]["reason"] == "segment narrower than the safety window"
    assert "reason" not in rows[0] and "reason" not in rows[3]
    assert rows[0]["safe_mask"][0] == 1  # straight ahead is safe
    again = run(tmp_path / "mixed.mcap", "--topic", "/fftnav/safe_scan", "--range", "10")
    assert again.returncode == 0 and again.stdout.count("\n") == 4, again.stderr
    (corrected,) = [json.loads(line) for line in again.stdout.splitlines()][1:2]
    assert "angle_max_corrected" not in corrected  # the annotated scan's angle_max is exact
