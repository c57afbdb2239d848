import gzip
import math

import numpy as np
import pytest

from fftnav.observe.scanio import read_scans


def test_npy_and_csv(tmp_path):
    a = np.array([[1.0, np.inf, 2.5], [np.nan, 0.5, -1.0]])
    np.save(tmp_path / "s.npy", a)
    np.savetxt(tmp_path / "s.csv", a, delimiter=",")
    np.save(tmp_path / "one.npy", a[0])
    for name in ("s.npy", "s.csv"):
        got = read_scans(tmp_path / name)
        np.testing.assert_array_equal(got.ranges, a)
        assert got.fov_rad is None
    assert read_scans(tmp_path / "one.npy").ranges.shape == (1, 3)
    assert read_scans(tmp_path / "s.csv", format="csv").format == "csv"


def test_carmen_log(tmp_path):
    lines = [
        "# comment",
        "PARAM robot_front_laser_max 50 host 0",
        "ODOM 0 0 0 0 0 0 0 host 0",
        "FLASER 3 1.5 81.91 0.2 0 0 0 0 0 0 1.0 host 1.0",
        "FLASER 3 50 2.0 3.0 0 0 0 0 0 0 2.0 host 2.0",
    ]
    path = tmp_path / "x.log.gz"
    with gzip.open(path, "wt") as fh:
        fh.write("\n".join(lines) + "\n")
    got = read_scans(path)
    np.testing.assert_array_equal(got.ranges, [[1.5, np.inf, 0.2], [np.inf, 2.0, 3.0]])
    assert got.fov_rad == pytest.approx(math.pi) and got.format == "carmen"


@pytest.mark.parametrize(
    ("name", "content", "kwargs", "match"),
    [
        ("a.txt", "1,2", {}, r"cannot tell the format of .*a.txt"),
        ("a.csv", "1,2\n3\n", {}, r"a\.csv:2: 1 values, earlier rows have 2"),
        ("a.log", "ODOM 1 2 3\n", {}, r"no FLASER scan in"),
        ("a.log", "FLASER 3 1 2\n", {}, r"a.log:1: FLASER line with fewer than n=3 ranges"),
        ("a.log", "FLASER 2 1 2\nFLASER 3 1 2 3\n", {}, r"a.log:2: FLASER with n=3 beams"),
        ("a.log", "FLASER x 1 2\n", {}, r"a.log:1: bad FLASER line"),
        ("a.log", "FLASER 2 1 b\n", {}, r"a\.log:1: FLASER range is not a number, got 'b'"),
        ("a.csv", "1,2\n", {"format": "xml"}, "format must be one of .* got format='xml'"),
        ("a.npy", "not numpy", {}, r"a\.npy: not a \.npy array"),
    ],
)
def test_bad_files(tmp_path, name, content, kwargs, match):
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(ValueError, match=match):
        read_scans(path, **kwargs)


def test_missing_file_is_oserror(tmp_path):
    with pytest.raises(OSError):
        read_scans(tmp_path / "none.npy")


def test_a_log_that_is_not_text_lines_is_refused_reading_one_bounded_line(tmp_path):
    """A file of zeros named .log: refused at its first line, which is read no further than
    MAX_LOG_LINE characters (memory stays bounded, as for .csv)."""
    import tracemalloc

    from fftnav.observe.scanio import MAX_LOG_LINE, iter_scans, read_scans

    path = tmp_path / "zeros.log"
    path.write_bytes(b"\x00" * (8 * MAX_LOG_LINE))
    for read in (read_scans, lambda p: next(iter_scans(p).chunks)):
        tracemalloc.start()
        with pytest.raises(ValueError, match=rf"zeros\.log:1: a line longer than "
                                             rf"{MAX_LOG_LINE:,} characters"):
            read(path)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 24 * MAX_LOG_LINE  # the line's characters, not the file's


def test_a_log_streams_in_chunks_equal_to_the_whole(tmp_path):
    from fftnav.observe.scanio import iter_scans, read_scans

    lines = ["PARAM robot_front_laser_max 5.0\n"]
    rng = np.random.default_rng(0)
    scans = rng.uniform(0.1, 6.0, (10, 7)).round(3)
    lines += [f"FLASER 7 {' '.join(map(str, row))} 0 0 0 0 0 0 0 host 0\n" for row in scans]
    path = tmp_path / "s.log"
    path.write_text("".join(lines))
    chunks = list(iter_scans(path, rows=3).chunks)
    assert [len(c) for c in chunks] == [3, 3, 3, 1]
    whole = read_scans(path).ranges
    np.testing.assert_array_equal(np.concatenate(chunks), whole)
    np.testing.assert_array_equal(whole, np.where(scans >= 5.0, np.inf, scans))
