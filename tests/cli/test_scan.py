import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fftnav.observe.geometry import REAL_ROBOT
from fftnav.observe.scanio import read_scans

RADISH = sorted(Path("/work/shared/data/radish").glob("*.log.gz"))


def run(*args):
    return subprocess.run(
        [sys.executable, "-m", "fftnav", "scan", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=120,
    )


def window_min_oracle(ranges, *, l_th, range_m, window):
    d = np.where(np.isnan(ranges) | (ranges < 0), 0.0, np.minimum(ranges, range_m))
    h = window // 2
    padded = np.pad(d, [(0, 0), (h, h)])
    return np.lib.stride_tricks.sliding_window_view(padded, window, axis=1).min(-1) >= l_th


def test_radish_logs_are_all_there():
    assert len(RADISH) == 4


@pytest.mark.parametrize("log", RADISH, ids=lambda p: p.name.split("-")[0])
def test_every_radish_scan_matches_the_oracle(log):
    proc = run(log)
    assert proc.returncode == 0, proc.stderr
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    ranges = read_scans(log).ranges
    assert [r["index"] for r in rows] == list(range(len(ranges)))
    beams = ranges.shape[1]
    tc = math.ceil(REAL_ROBOT.alpha_rad / (math.pi / (beams - 1)))
    expected = window_min_oracle(
        ranges, l_th=REAL_ROBOT.l_th_m, range_m=10.0, window=tc + 1 - tc % 2
    )
    got = np.array([r["safe_mask"] for r in rows], dtype=bool)
    np.testing.assert_array_equal(got, expected)
    assert 0.01 < got.mean() < 0.99
    for r in rows[:: max(1, len(rows) // 50)]:
        assert r["message_bytes"] == 4 + 3 * len(r["extrema"])
        assert 0.0 < r["p_left"] < 1.0
        assert all(-90.0 <= a <= 90.0 and 0.0 <= d <= 10.0 for a, d in r["extrema"])
        for lo, hi in r["safe_sectors_deg"]:
            assert -90.0 <= lo <= hi <= 90.0


def test_npy_defaults_are_the_simulated_robot_on_a_full_turn(tmp_path):
    """360 beams from -180 degrees, r0 = 0.15 m, r = 0.3 m (l_th = 0.6 m, a 61-beam window),
    R = 3 m: the turn wraps around, so an open scan is safe everywhere, and 20 beams at 0.5 m
    ahead (170..189) block the 80 beams 140..219 whose windows reach them."""
    scan = np.full((2, 360), np.inf)
    scan[1, 170:190] = 0.5
    np.save(tmp_path / "s.npy", scan)
    proc = run(tmp_path / "s.npy")
    assert proc.returncode == 0, proc.stderr
    a, b = (json.loads(line) for line in proc.stdout.splitlines())
    assert sum(a["safe_mask"]) == 360 and a["safe_sectors_deg"] == [[-180.0, 179.0]]
    blocked = np.flatnonzero(np.array(b["safe_mask"]) == 0)
    np.testing.assert_array_equal(blocked, np.arange(140, 220))
    assert b["safe_sectors_deg"] == [[40.0, -41.0]]  # through the back


def wrap_oracle(ranges, *, l_th, range_m, window):
    """The sliding-window minimum around the circle (scipy's, an independent code)."""
    from scipy.ndimage import minimum_filter1d

    d = np.where(np.isnan(ranges) | (ranges < 0), 0.0, np.minimum(ranges, range_m))
    return minimum_filter1d(d, window, axis=1, mode="wrap") >= l_th


@pytest.mark.parametrize(("suffix", "beams", "fov"), [(".npy", 360, []), (".csv", 720, ["360"]),
                                                      (".npy", 719, ["--fov", "360"])])
def test_a_full_turn_wraps_around(tmp_path, suffix, beams, fov):
    from tests.observe.test_safe import piecewise_scan

    rng = np.random.default_rng(beams)
    scans = np.array([piecewise_scan(rng, beams, 3.0) for _ in range(6)])
    scans[:3, : beams // 8] = scans[:3, -beams // 8 :] = np.inf  # open behind
    path = tmp_path / f"s{suffix}"
    if suffix == ".npy":
        np.save(path, scans)
    else:
        path.write_text("\n".join(",".join(repr(float(v)) for v in row) for row in scans))
    proc = run(path, *(["--fov", *fov] if fov == ["360"] else fov))
    assert proc.returncode == 0, proc.stderr
    got = np.array([json.loads(line)["safe_mask"] for line in proc.stdout.splitlines()], bool)
    tc = math.ceil(math.radians(60.0) / (2 * math.pi / beams) - 1e-9)
    expected = wrap_oracle(scans, l_th=0.6, range_m=3.0, window=tc + 1 - tc % 2)
    np.testing.assert_array_equal(got, expected)
    assert 0.05 < expected.mean() < 0.95
    assert (expected[:, 0] | expected[:, -1]).any()  # some window through the back is safe


def test_a_field_of_view_narrower_than_the_window_answers_every_scan(tmp_path):
    """A 20-degree segment of 21 beams: the simulated robot's window there is 61 beams, so no
    beam is safe; every scan gets its line, with the reason, and the command exits 0."""
    np.save(tmp_path / "seg.npy", np.full((3, 21), np.inf))
    proc = run(tmp_path / "seg.npy", "--fov", "20")
    assert proc.returncode == 0, proc.stderr
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [r["index"] for r in rows] == [0, 1, 2]
    for r in rows:
        assert r == {"index": r["index"], "safe_mask": [0] * 21, "safe_sectors_deg": [],
                     "extrema": [], "extrema_is_min": [], "message_bytes": 4, "p_left": None,
                     "reason": "segment narrower than the safety window"}
    # alpha = 2 asin(r0 / r) = 9.6 deg: an 11-beam window fits
    wide = run(tmp_path / "seg.npy", "--fov", "20", "--r0", "0.05", "--r", "0.6", "--range", "10")
    assert wide.returncode == 0 and "reason" not in wide.stdout
    assert all(sum(json.loads(line)["safe_mask"]) == 11 for line in wide.stdout.splitlines())
    refused = run(tmp_path / "seg.npy", "--fov", "20", "--range", "0.5")
    assert refused.returncode == 2 and refused.stdout == ""
    assert refused.stderr.strip().endswith(
        "range_m must be finite and >= l_th_m=0.6, got range_m=0.5"), refused.stderr


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["missing.npy"], "No such file"),
        (
            ["{tmp}/s.npy", "--range", "-1"],
            r"range_m must be finite and >= l_th_m=0.6, got range_m=-1.0",
        ),
        (
            ["{tmp}/s.npy", "--r0", "0.3", "--r", "0.2"],
            "r_m must be finite and > r0_m=0.3, got r_m=0.2",
        ),
        (["{tmp}/s.npy", "--fov", "400"], r"fov_rad must be in \(0, 2\*pi\]"),
        (["{tmp}/s.npy", "--format", "csv"], r"s\.npy:1: not utf-8 text"),
        (["{tmp}/s.txt"], "cannot tell the format"),
        (["{tmp}/s.npy", "--format", "xml"], "invalid choice"),
    ],
)
def test_bad_input_exits_2_with_one_line(tmp_path, args, match):
    np.save(tmp_path / "s.npy", np.ones((1, 360)))
    (tmp_path / "s.txt").write_text("1,2\n")
    proc = run(*[a.format(tmp=tmp_path) for a in args])
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert re.search(match, lines[0]), lines[0]


def _whole_file_lines(path, fov=2 * math.pi):
    """The JSON lines of every scan processed in one batch (the whole-file path)."""
    from fftnav.cli.scan import _json_lines
    from fftnav.observe.geometry import SIM_ROBOT
    from fftnav.ros.laserscan import Layout, LayoutPipelines

    ranges = read_scans(path).ranges
    layout = Layout.of_fov(ranges.shape[1], fov)
    pipe = LayoutPipelines(SIM_ROBOT).get(layout, 3.0)
    return "".join(_json_lines(layout, pipe, ranges, 0))


def _random_scans(k, m=360, seed=0):
    rng = np.random.default_rng(seed)
    scans = rng.uniform(0.1, 4.0, (k, m))
    scans[rng.random((k, m)) < 0.05] = np.inf
    return scans


@pytest.mark.parametrize("suffix", [".npy", ".csv"])
def test_streamed_chunks_print_the_whole_file_lines_byte_for_byte(tmp_path, suffix):
    """10,000 scans: three chunks of at most 4,096 from the installed command, the same bytes
    as one batch of the whole file."""
    scans = _random_scans(10_000)
    path = tmp_path / f"s{suffix}"
    if suffix == ".npy":
        np.save(path, scans.astype(np.float32))
    else:
        path.write_text("# ranges\n" + "\n".join(",".join(f"{v:.4f}" for v in row)
                                                 for row in scans) + "\n\n")
    proc = run(path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == _whole_file_lines(path)
    assert len(proc.stdout.splitlines()) == 10_000


@pytest.mark.parametrize("chunk", [1, 3, 7])
def test_chunk_boundaries_do_not_change_a_line(tmp_path, monkeypatch, capsys, chunk):
    from fftnav.cli import main

    np.save(tmp_path / "s.npy", _random_scans(20, seed=chunk))
    monkeypatch.setattr("fftnav.cli.scan.CHUNK_SCANS", chunk)
    assert main(["scan", str(tmp_path / "s.npy")]) == 0
    assert capsys.readouterr().out == _whole_file_lines(tmp_path / "s.npy")


def test_chunks_hold_at_most_4096_by_360_readings(tmp_path):
    from fftnav.observe.scanio import iter_scans

    np.save(tmp_path / "wide.npy", np.ones((30, 100_000), dtype=np.float32))
    sizes = [len(c) for c in iter_scans(tmp_path / "wide.npy").chunks]
    assert sizes == [14, 14, 2]  # 4096 x 360 // 100,000 = 14 scans of 100,000 beams
    (tmp_path / "wide.csv").write_text("\n".join([",".join(["1"] * 5000)] * 700))
    sizes = [len(c) for c in iter_scans(tmp_path / "wide.csv").chunks]
    assert sizes == [294, 294, 112]  # 4096 x 360 // 5000 = 294 scans of 5,000 beams


def test_a_huge_csv_line_is_refused_by_its_beams_before_it_is_parsed(tmp_path):
    """A 200 MB line of 100 million values: refused from its first bytes, under a 1 GB address
    space limit that parsing it would exceed (no MemoryError)."""
    path = tmp_path / "wide.csv"
    with open(path, "wb") as fh:
        fh.write(b"1,2\n" + b"1," * 100_000_000 + b"1\n")
    code = ("import resource; resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30)); "
            f"from fftnav.cli import main; raise SystemExit(main(['scan', {str(path)!r}]))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert re.fullmatch(r"fftnav scan: error: .*wide\.csv:2: values on one line \(beams\): "
                        r"[\d,]+ estimated, above the limit of 100,000\n", proc.stderr)


def test_a_truncated_npy_is_refused_when_its_chunk_is_read(tmp_path):
    from fftnav.files import iter_npy_rows

    np.save(tmp_path / "t.npy", np.ones((100, 360)))
    data = (tmp_path / "t.npy").read_bytes()
    (tmp_path / "t.npy").write_bytes(data[: len(data) - 360 * 8 * 10])
    with pytest.raises(ValueError, match=r"t\.npy: damaged \.npy array: the file ends at row "
                                         r"90 of the 100 its header claims"):
        list(iter_npy_rows(tmp_path / "t.npy", rows=64))


def test_fortran_ordered_npy_streams_the_same_rows(tmp_path):
    from fftnav.files import iter_npy_rows

    scans = _random_scans(50)
    np.save(tmp_path / "f.npy", np.asfortranarray(scans))
    np.testing.assert_array_equal(np.concatenate(list(iter_npy_rows(tmp_path / "f.npy",
                                                                    rows=16))), scans)
