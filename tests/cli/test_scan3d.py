"""``fftnav scan3d`` and ``fftnav figure depth3d`` as subprocesses."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest

from fftnav.observe.geometry import RobotGeometry
from fftnav.observe.spherical import DiscFilterBank, SphericalGrid


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fftnav", *args], capture_output=True, text=True,
                          timeout=120)


def _corridor(rows: int, cols: int, fov_el_deg: float = 90.0, fov_az_deg: float = 360.0
              ) -> np.ndarray:
    d = SphericalGrid(rows, cols, math.radians(fov_el_deg), math.radians(fov_az_deg)).directions()
    with np.errstate(divide="ignore"):
        return np.minimum(1.2 / np.abs(d[..., 1]), 1.0 / np.abs(d[..., 2]))


def test_scan3d_prints_the_safe_mask_in_the_image_layout(tmp_path) -> None:
    depth = _corridor(90, 360)
    depth[0, :] = np.nan  # invalid readings in the top row: blocked, and harmless there
    path = tmp_path / "corridor.npy"
    np.save(path, depth)
    proc = _run("scan3d", str(path))
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    mask = np.array(out["safe_mask"])
    assert mask.shape == (90, 360) and set(np.unique(mask)) == {0, 1}
    expected = DiscFilterBank(SphericalGrid(90, 360)).safe_mask(depth)
    np.testing.assert_array_equal(mask, expected.astype(int))
    assert out["safe_fraction"] == pytest.approx(expected.mean())
    assert out["l_th_m"] == pytest.approx(2.8167, abs=1e-4)
    assert out["alpha_deg"] == pytest.approx(26.7, abs=0.05)
    # column 0 is azimuth -180 (back of the corridor), column 180 straight ahead
    eq = 44
    assert mask[eq, 0] == mask[eq, 180] == 1 and mask[eq, 90] == mask[eq, 270] == 0
    assert [b["rows"] for b in out["bands"]] == [b.rows.size for b in
                                                 DiscFilterBank(SphericalGrid(90, 360)).bands]


def test_scan3d_layout_of_an_asymmetric_obstacle(tmp_path) -> None:
    # open space but a wall filling azimuth +60..+120 deg and elevation +10..+40 deg
    grid = SphericalGrid(90, 360)
    el = np.degrees(grid.elevations_rad())[:, None]
    az = np.degrees(grid.azimuths_rad())[None, :]
    depth = np.where((az >= 60) & (az <= 120) & (el >= 10) & (el <= 40), 1.0, np.inf)
    path = tmp_path / "wall.npy"
    np.save(path, depth)
    proc = _run("scan3d", str(path))
    assert proc.returncode == 0, proc.stderr
    mask = np.array(json.loads(proc.stdout)["safe_mask"], bool)
    # row 0 is the top (+45 deg), column 0 azimuth -180: the wall is in the upper right part
    # of the image (rows 5..35, columns 240..300), its mirror images are open
    assert not mask[20, 270] and not mask[25, 250]
    for row, col in ((90 - 1 - 20, 270), (20, 360 - 270), (90 - 1 - 20, 360 - 270), (60, 270)):
        assert mask[row, col], (row, col)
    # away from the top and bottom edges, the unsafe pixels surround the wall (within the
    # widest band footprint: 16 columns = 16 deg, 13 rows)
    i, j = np.nonzero(~mask & (np.abs(el) < 31))
    assert i.size and az[0, j].min() >= 60 - 16 and az[0, j].max() <= 120 + 16
    assert el[i, 0].min() >= 10 - 13.4


def test_scan3d_options_change_the_filter(tmp_path) -> None:
    depth = _corridor(40, 121, fov_el_deg=60.0, fov_az_deg=180.0)
    path = tmp_path / "c.npy"
    np.save(path, depth)
    proc = _run("scan3d", str(path), "--fov-az", "180", "--fov-el", "60", "--r0", "0.29",
                "--r", "0.7", "--range", "5")
    assert proc.returncode == 0, proc.stderr
    mask = np.array(json.loads(proc.stdout)["safe_mask"])
    bank = DiscFilterBank(SphericalGrid(40, 121, math.radians(60), math.radians(180)),
                          geometry=RobotGeometry(r0_m=0.29, r_m=0.7), range_m=5.0)
    np.testing.assert_array_equal(mask, bank.safe_mask(depth).astype(int))
    assert mask.any() and mask[20, 60] == 1 and mask[20, 0] == mask[20, 120] == 0


@pytest.mark.parametrize(
    ("content", "args", "match"),
    [
        (np.ones(5), (), r"FILE must hold a 2D \(rows, cols\) depth image, got shape=\(5,\)"),
        (np.ones((2, 3, 4)), (), r"got shape=\(2, 3, 4\)"),
        (np.array([["a", "b"], ["c", "d"]]), (), r"FILE must hold real numbers, got dtype=<U1"),
        (np.ones((90, 360)), ("--fov-el", "200"), r"--fov-el must be in \(0, 180\] degrees"),
        (np.ones((90, 360)), ("--fov-az", "0"), r"--fov-az must be in \(0, 360\] degrees"),
        (np.ones((90, 360)), ("--r", "0.1"), r"r_m must be finite and > r0_m=0.15, got r_m=0.1"),
        (np.ones((90, 360)), ("--range", "2"), r"range_m must be finite and > l_th_m=2.817"),
        (np.ones((90, 360)), ("--range", "x"), r"invalid float value: 'x'"),
        (np.ones((1, 360)), (), r"rows must be an integer >= 2, got rows=1"),
        # a narrow image is answered (below), but not with a bad option
        (np.ones((5, 360)), ("--fov-el", "10", "--range", "2"),
         r"range_m must be finite and > l_th_m=2.817"),
        (np.ones((5, 360)), ("--fov-el", "10", "--r", "0.1"), r"r_m must be finite and > r0_m"),
    ],
)
def test_scan3d_bad_input_is_one_line_exit_2(tmp_path, content, args, match) -> None:
    path = tmp_path / "bad.npy"
    np.save(path, content)
    proc = _run("scan3d", str(path), *args)
    assert proc.returncode == 2 and proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert re.search(match, lines[0]), lines[0]


#: A grid of 1 degree steps (27 x 27 pixels over 26 x 26 degrees) and the paper's drone: alpha / 2 =
#: asin(0.15 / 0.65) = 13.34 deg, so the horizon's disc reaches 13 rows and 13 columns from its
#: centre and spans 27 x 27 pixels; every row's disc (|elevation| <= 13 deg) reaches 13 columns
#: along its own row (14 needs an elevation of 17.6 deg or more), so the image has room for the
#: disc of its centre pixel only. One pixel narrower, in either direction, it has none.
NARROW = ("image narrower than the disc filter: {have}, its footprint for alpha=26.7 deg spans "
          "{need}")


def _open_image(rows: int, cols: int) -> np.ndarray:
    return np.full((rows, cols), np.inf)  # no return anywhere: open


@pytest.mark.parametrize(("rows", "cols", "have", "need"), [
    (26, 27, "26 rows", "27 rows"),
    (27, 26, "26 columns", "27 columns"),
    (26, 26, "26 rows and 26 columns", "27 rows and 27 columns"),
])
def test_an_image_one_pixel_narrower_than_the_disc_is_all_unsafe_with_a_reason(
        tmp_path, rows, cols, have, need) -> None:
    path = tmp_path / "narrow.npy"
    np.save(path, _open_image(rows, cols))
    proc = _run("scan3d", str(path), "--fov-el", str(rows - 1), "--fov-az", str(cols - 1))
    assert proc.returncode == 0 and proc.stderr == ""
    out = json.loads(proc.stdout)
    assert out["reason"] == NARROW.format(have=have, need=need)
    assert np.array(out["safe_mask"]).shape == (rows, cols)
    assert not np.array(out["safe_mask"]).any() and out["safe_fraction"] == 0.0
    assert out["bands"] == [] and (out["rows"], out["cols"]) == (rows, cols)


def test_an_image_just_wide_enough_gets_the_sliding_window_result(tmp_path) -> None:
    """27 x 27 pixels: the centre pixel's disc is the whole image (open: safe); every other
    pixel's reaches past an edge, where the zero padding blocks it (the paper's Tc < i < M - Tc)."""
    path = tmp_path / "fits.npy"
    np.save(path, _open_image(27, 27))
    proc = _run("scan3d", str(path), "--fov-el", "26", "--fov-az", "26")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    expected = np.zeros((27, 27), int)
    expected[13, 13] = 1
    assert "reason" not in out and len(out["bands"]) == 1
    np.testing.assert_array_equal(out["safe_mask"], expected)


def test_a_full_turn_just_tall_enough_blocks_the_disc_around_an_obstacle(tmp_path) -> None:
    """27 rows over 26 degrees, 360 columns over a full turn: only the horizon row can be safe,
    and there every pixel but the 13 columns on each side of an obstacle (1 m away, inside l_th;
    wrapping around the seam) is; 26 rows over 25 degrees: nothing, with the reason."""
    depth = _open_image(27, 360)
    depth[13, 5] = 1.0  # azimuth -175 deg: its disc wraps past -180
    np.save(tmp_path / "tall.npy", depth)
    np.save(tmp_path / "short.npy", depth[1:])
    proc = _run("scan3d", str(tmp_path / "tall.npy"), "--fov-el", "26")
    assert proc.returncode == 0, proc.stderr
    mask = np.array(json.loads(proc.stdout)["safe_mask"])
    cols = np.arange(360)
    gap = np.minimum(np.abs(cols - 5), 360 - np.abs(cols - 5))  # columns from the obstacle
    np.testing.assert_array_equal(mask[13], (gap > 13).astype(int))
    assert not np.delete(mask, 13, axis=0).any()
    proc = _run("scan3d", str(tmp_path / "short.npy"), "--fov-el", "25")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["reason"] == NARROW.format(have="26 rows", need="27 rows")
    assert not np.array(out["safe_mask"]).any()


def test_an_image_whose_widened_band_footprints_do_not_fit_is_all_unsafe_with_a_reason(
        tmp_path) -> None:
    """90 rows over 89 degrees, 27 columns over 26: the horizon's disc (27 x 27) fits, but the
    bank widens each band's footprint to its widest row's (29 columns at the horizon band), so
    an image open everywhere has no safe pixel; the bank itself says so."""
    grid = SphericalGrid(90, 27, math.radians(89), math.radians(26))
    bank = DiscFilterBank(grid)
    assert min(band.footprint.shape[1] for band in bank.bands) == 29
    assert not bank.safe_mask(_open_image(90, 27)).any()
    np.save(tmp_path / "tall.npy", _open_image(90, 27))
    proc = _run("scan3d", str(tmp_path / "tall.npy"), "--fov-el", "89", "--fov-az", "26")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["reason"] == ("image narrower than the disc filter: 27 columns, its widened "
                             "footprints for alpha=26.7 deg span 29 columns or more")
    assert not np.array(out["safe_mask"]).any() and out["bands"] == []


def test_narrow_reason_agrees_with_the_bank_it_stands_for() -> None:
    """The library: None where DiscFilterBank can be made, the reason where it refuses the
    grid; the paper's 90 x 360 image fits."""
    from fftnav.observe.spherical import narrow_reason

    assert narrow_reason(SphericalGrid(90, 360)) is None
    for rows, cols in ((27, 27), (26, 27), (27, 26)):
        grid = SphericalGrid(rows, cols, math.radians(rows - 1), math.radians(cols - 1))
        reason = narrow_reason(grid)
        if reason is None:
            DiscFilterBank(grid)
        else:
            with pytest.raises(ValueError, match=r"(rows|cols) must be >= the disc footprint's "
                                                 r"27 for alpha=26\.7 deg, got \1=26"):
                DiscFilterBank(grid)
    with pytest.raises(ValueError, match=r"range_m must be finite and > l_th_m=2\.817, got "
                                         r"range_m=2"):
        narrow_reason(SphericalGrid(5, 360, math.radians(10)), range_m=2)


def test_scan3d_refuses_an_npz_archive(tmp_path) -> None:
    path = tmp_path / "two.npz"
    np.savez(path, depth=np.ones((90, 360)), other=np.zeros(3))
    proc = _run("scan3d", str(path))
    assert proc.returncode == 2 and proc.stdout == "" and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1
    assert re.search(r"two\.npz: is a \.npz archive, not one \.npy array", lines[0]), lines[0]


def test_depth3d_image_extent_is_the_pixel_edges() -> None:
    from fftnav.report.depth3d import _extent_deg

    for grid in (SphericalGrid(90, 360), SphericalGrid(30, 61, math.radians(60), math.pi)):
        left, right, bottom, top = _extent_deg(grid)
        # imshow puts pixel (i, j)'s centre at these coordinates (row 0 at the top)
        x = left + (np.arange(grid.cols) + 0.5) * (right - left) / grid.cols
        y = top - (np.arange(grid.rows) + 0.5) * (top - bottom) / grid.rows
        np.testing.assert_allclose(x, np.degrees(grid.azimuths_rad()), atol=1e-9)
        np.testing.assert_allclose(y, np.degrees(grid.elevations_rad()), atol=1e-9)


def test_scan3d_unreadable_files(tmp_path) -> None:
    junk = tmp_path / "junk.npy"
    junk.write_text("not an array")
    for path, match in ((junk, "junk.npy: not a .npy array"), (tmp_path / "missing.npy", "No such file")):
        proc = _run("scan3d", str(path))
        assert proc.returncode == 2 and match in proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1


def test_figure_depth3d_draws_two_pngs(tmp_path) -> None:
    proc = _run("figure", "depth3d", "--out", str(tmp_path), "--seed", "2")
    assert proc.returncode == 0, proc.stderr
    paths = proc.stdout.split()
    assert [p.rsplit("/", 1)[-1] for p in paths] == ["fig4_depth.png", "fig4_safe.png"]
    assert all((tmp_path / p.rsplit("/", 1)[-1]).stat().st_size > 20_000 for p in paths)
