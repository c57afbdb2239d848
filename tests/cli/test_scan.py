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


def test_npy_defaults_are_the_simulated_robot(tmp_path):
    scan = np.full((2, 360), np.inf)
    scan[1, 170:190] = 0.5
    np.save(tmp_path / "s.npy", scan)
    proc = run(tmp_path / "s.npy")
    assert proc.returncode == 0, proc.stderr
    a, b = (json.loads(line) for line in proc.stdout.splitlines())
    assert sum(a["safe_mask"]) == 300  # 360 minus 30 beams at each zero-padded end
    assert b["safe_mask"][180] == 0 and sum(b["safe_mask"]) == 300 - 80
    assert a["safe_sectors_deg"] == [[-150.0, 149.0]]


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
