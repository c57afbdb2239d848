"""2D disc filter on spherical depth images: oracle, corridor, input rules, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.observe.geometry import DRONE, RobotGeometry
from fftnav.observe.spherical import DiscFilterBank, SphericalGrid, disc_footprint, sanitize_depth


def _sliding_min_oracle(bank: DiscFilterBank, depth: np.ndarray) -> np.ndarray:
    """Safe iff min(D/R) over the row's band footprint reaches l_th/R: a brute-force minimum
    over the offsets (di, dj), outside rows (and columns of a partial azimuth) reading 0."""
    s = np.minimum(np.nan_to_num(depth, nan=-1.0).clip(min=0), bank.range_m) / bank.range_m
    rows, cols = s.shape
    safe = np.zeros(s.shape, bool)
    for band in bank.bands:
        a, b = (n // 2 for n in band.footprint.shape)
        p = np.pad(s, ((0, 0), (b, b)), mode="wrap" if bank.grid.full_azimuth else "constant")
        p = np.pad(p, ((a, a), (0, 0)))
        m = np.full(s.shape, np.inf)
        for ii, jj in zip(*np.nonzero(band.footprint), strict=True):
            m = np.minimum(m, p[ii: ii + rows, jj: jj + cols])  # s(i + ii - a, j + jj - b)
        safe[band.rows] = m[band.rows] >= bank.threshold
    return safe


def _blob_image(rng: np.random.Generator, rows: int, cols: int) -> np.ndarray:
    """Open image (inf) with random obstacle blobs at mm-quantised depths, some above l_th."""
    depth = np.full((rows, cols), np.inf)
    for _ in range(rng.integers(3, 12)):
        i, j = rng.integers(rows), rng.integers(cols)
        h, w = rng.integers(1, 8, size=2)
        depth[i:i + h, j:j + w] = np.round(rng.uniform(0.5, 12.0), 3)
    return depth


@pytest.mark.parametrize("fov_az_deg", [360.0, 120.0])
def test_mask_equals_sliding_minimum_oracle(fov_az_deg: float) -> None:
    rng = np.random.default_rng(7)
    grid = SphericalGrid(45, 180 if fov_az_deg == 360 else 61, math.radians(90),
                         math.radians(fov_az_deg))
    bank = DiscFilterBank(grid)
    for _ in range(20):
        depth = _blob_image(rng, grid.rows, grid.cols)
        mask = bank.safe_mask(depth)
        np.testing.assert_array_equal(mask, _sliding_min_oracle(bank, depth))
        assert 0 < mask.sum() < mask.size


def test_full_resolution_oracle_and_wraparound() -> None:
    bank = DiscFilterBank(SphericalGrid(90, 360))
    depth = np.full((90, 360), np.inf)
    depth[40:50, 0] = 1.0  # an obstacle on the seam at azimuth -180 deg
    depth[44, 200] = DRONE.l_th_m - 1e-3  # just inside l_th: blocks its disc
    depth[30, 100] = DRONE.l_th_m  # exactly l_th: harmless
    mask = bank.safe_mask(depth)
    np.testing.assert_array_equal(mask, _sliding_min_oracle(bank, depth))
    assert not mask[45, -1] and not mask[45, 1]  # blocked on both sides of the seam
    assert mask[30, 100] and not mask[44, 200]


def _unit(el: np.ndarray, az: np.ndarray) -> np.ndarray:
    return np.stack(np.broadcast_arrays(np.cos(el) * np.cos(az), np.cos(el) * np.sin(az),
                                        np.sin(el)), axis=-1)


@pytest.mark.parametrize("el_deg", [0.0, 40.0, -70.0])
def test_footprint_is_the_great_circle_disc(el_deg: float) -> None:
    grid = SphericalGrid(90, 360)
    half = DRONE.alpha_rad / 2
    e = math.radians(el_deg)
    fp = disc_footprint(grid, e, half_angle_rad=half)
    a, b = fp.shape[0] // 2, fp.shape[1] // 2
    # independent oracle: angle between the unit vectors at (e, 0) and (e - di*del, dj*daz)
    vec = _unit(e - np.arange(-a, a + 1)[:, None] * grid.el_step_rad,
                np.arange(-b, b + 1)[None, :] * grid.az_step_rad)
    angle = np.arccos(np.clip(vec @ _unit(np.array(e), np.array(0.0)), -1, 1))
    np.testing.assert_array_equal(fp, angle <= half + 1e-12)
    assert fp[:, 0].any() and fp[:, -1].any()  # cropped to the disc's columns
    if el_deg == 0.0:
        assert fp.shape == (27, 27) and fp[a].sum() == 27 and fp[:, b].sum() == 27
        assert fp.sum() == pytest.approx(math.pi * (13.34 ** 2), rel=0.05)
    else:  # wider than at the horizon by about 1 / cos(e) (the true disc's azimuth half-width)
        assert b * grid.az_step_rad == pytest.approx(
            math.asin(math.sin(half) / math.cos(e)), abs=grid.az_step_rad)


def test_bands_cover_each_rows_disc_and_little_more() -> None:
    grid = SphericalGrid(60, 120, math.pi)  # the full sphere: 3.05 x 3 deg pixels
    bank = DiscFilterBank(grid)
    half = DRONE.alpha_rad / 2
    el = grid.elevations_rad()
    assert sorted(np.concatenate([band.rows for band in bank.bands])) == list(range(60))
    for band in bank.bands:
        B = band.footprint.shape[1] // 2
        widest = max(np.cos(el[band.rows])) / max(min(np.cos(el[band.rows])), 1e-12)
        assert widest <= 1.1 or np.all(np.abs(el[band.rows]) + half >= math.pi / 2)
        for i in band.rows:
            own = disc_footprint(grid, el[i], half_angle_rad=half)
            b = own.shape[1] // 2
            assert not (own & ~band.footprint[:, B - b: B + b + 1]).any()  # conservative
            if abs(el[i]) + half < math.pi / 2:  # away from the poles: at most 25 % more
                assert band.footprint.sum() <= 1.25 * own.sum()
    # one band per factor 1.1 of 1 / cos(e) up to the polar rows (|e| >= 90 deg - alpha/2), + 1
    assert len(bank.bands) <= math.floor(-math.log(math.sin(half)) / math.log(1.1)) + 2
    horizon = DiscFilterBank(SphericalGrid(90, 360))  # rows within 45 deg: 1 / cos <= 1.1^3.6
    assert len(horizon.bands) == math.floor(-math.log(math.cos(math.pi / 4)) / math.log(1.1)) + 1


def test_no_pixel_of_an_obstacles_disc_is_safe_near_the_poles() -> None:
    grid = SphericalGrid(60, 120, math.pi)
    bank = DiscFilterBank(grid)
    dirs = grid.directions()
    for i0, j0 in ((30, 0), (15, 40), (10, 100), (48, 7), (51, 60)):  # 1.5 .. 59.5 deg
        depth = np.full((60, 120), np.inf)
        depth[i0, j0] = 1.0
        mask = bank.safe_mask(depth)
        angle = np.arccos(np.clip(dirs @ dirs[i0, j0], -1, 1))
        assert not mask[angle <= DRONE.alpha_rad / 2].any()
        assert mask[(angle > 1.5 * DRONE.alpha_rad) & (np.abs(grid.elevations_rad())
                                                       < math.radians(60))[:, None]].all()
        np.testing.assert_array_equal(mask, _sliding_min_oracle(bank, depth))


def test_edges_and_poles_are_never_safe() -> None:
    grid = SphericalGrid(90, 361, math.radians(90), math.radians(180))
    bank = DiscFilterBank(grid)
    mask = bank.safe_mask(np.full((90, 361), np.inf))
    # zero padding: safe iff every grid sample of the band's footprint lies inside the image:
    # a = 13 rows (1.01 deg) from the top and bottom, b(row) columns (0.5 deg) from each side
    half = DRONE.alpha_rad / 2
    a = math.floor(math.degrees(half) / (90 / 89))
    b = np.zeros(90, int)
    for band in bank.bands:
        b[band.rows] = band.footprint.shape[1] // 2
    i, j = np.arange(90)[:, None], np.arange(361)[None, :]
    np.testing.assert_array_equal(mask, (i >= a) & (i <= 89 - a) & (j >= b[:, None])
                                  & (j <= 360 - b[:, None]))
    # b(row) reaches at least the row's own disc: along the row, acos((cos h - sin^2 e) / cos^2 e)
    e = grid.elevations_rad()
    along = np.arccos((math.cos(half) - np.sin(e) ** 2) / np.cos(e) ** 2)
    assert a == 13 and np.all(b >= np.floor(along / math.radians(0.5) + 1e-9))
    assert b[45] <= 1.1 * 26 + 1  # the horizon band is at most 10 % (+ a pixel) wider
    assert b[0] > 30  # 45 deg: the disc is 1 / cos(45 deg) wider than at the horizon
    el = np.degrees(grid.elevations_rad())
    assert np.abs(el[mask.any(axis=1)]).max() < 45 - DRONE.alpha_deg / 2 + 1.02


def _corridor_depth(grid: SphericalGrid, half_w: float, half_h: float) -> np.ndarray:
    """Ray distance from the centre of an infinite corridor along x (walls y=+-w, z=+-h)."""
    d = grid.directions()
    with np.errstate(divide="ignore"):
        return np.minimum(half_w / np.abs(d[..., 1]), half_h / np.abs(d[..., 2]))


def test_corridor_gives_safe_directions_only_along_the_corridor() -> None:
    grid = SphericalGrid(90, 360)
    bank = DiscFilterBank(grid)
    depth = _corridor_depth(grid, 1.2, 1.0)
    mask = bank.safe_mask(depth)
    d = grid.directions()
    # a direction is safe only if every ray within alpha/2 of it reaches l_th inside the corridor
    lat = np.abs(d[..., 1]) * DRONE.l_th_m
    assert mask.any() and not mask[lat > 1.2].any()
    angle_to_axis = np.degrees(np.arccos(np.abs(d[..., 0])))
    assert angle_to_axis[mask].max() < 90 - math.degrees(math.acos(1.0 / DRONE.l_th_m))
    eq = np.argmin(np.abs(grid.elevations_rad()))
    assert mask[eq, 180] and mask[eq, 0]  # straight ahead (az 0) and straight back (az -180)
    assert not mask[eq, 90] and not mask[eq, 270]  # the walls at -90 and +90 deg
    np.testing.assert_array_equal(mask, _sliding_min_oracle(bank, depth))


def test_input_rules_inf_beyond_range_nan_negative() -> None:
    raw = np.array([[np.inf, 12.0, 10.0, 5.0], [np.nan, -1.0, 0.0, 2.0]])
    before = raw.copy()
    np.testing.assert_array_equal(sanitize_depth(raw, range_m=10.0),
                                  [[1.0, 1.0, 1.0, 0.5], [0.0, 0.0, 0.0, 0.2]])
    np.testing.assert_array_equal(raw, before)
    bank = DiscFilterBank(SphericalGrid(45, 180))
    open_img = np.full((45, 180), np.inf)
    for bad in (np.nan, -2.0):
        img = open_img.copy()
        img[22, 90] = bad
        mask = bank.safe_mask(img)
        zeroed = np.where(np.isnan(img) | (img < 0), 0.0, img)
        np.testing.assert_array_equal(mask, bank.safe_mask(zeroed))
        assert not mask[22, 90] and mask[22, 10]
    np.testing.assert_array_equal(bank.safe_mask(np.full((45, 180), 50.0)),
                                  bank.safe_mask(open_img))


def test_nearest_direction_matches_brute_force() -> None:
    rng = np.random.default_rng(3)
    grid = SphericalGrid(30, 72)
    bank = DiscFilterBank(grid)
    dirs = grid.directions()
    for _ in range(30):
        mask = rng.random((30, 72)) < 0.05
        t_el, t_az = rng.uniform(-1.2, 1.2), rng.uniform(-math.pi, math.pi)
        target = np.array([math.cos(t_el) * math.cos(t_az), math.cos(t_el) * math.sin(t_az),
                           math.sin(t_el)])
        el, az = bank.nearest_direction(mask, t_el, t_az)
        got = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        best = np.max((dirs @ target)[mask])
        assert got @ target == pytest.approx(best, abs=1e-12)
    assert bank.nearest_direction(np.zeros((30, 72), bool), 0.0, 0.0) is None


def test_grid_layout() -> None:
    g = SphericalGrid(90, 360)
    assert math.degrees(g.elevations_rad()[0]) == pytest.approx(45)
    assert math.degrees(g.elevations_rad()[-1]) == pytest.approx(-45)
    assert math.degrees(g.azimuths_rad()[0]) == pytest.approx(-180)
    assert math.degrees(g.azimuths_rad()[180]) == pytest.approx(0)
    assert math.degrees(g.az_step_rad) == pytest.approx(1.0)
    np.testing.assert_allclose(g.directions()[0, 180], [math.sqrt(0.5), 0, math.sqrt(0.5)],
                               atol=1e-12)
    part = SphericalGrid(10, 11, 0.5, 1.0)
    assert part.azimuths_rad()[-1] == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"rows": 1, "cols": 360}, r"rows must be an integer >= 2, got rows=1"),
        ({"rows": 90.0, "cols": 360}, r"rows must be an integer >= 2, got rows=90.0"),
        ({"rows": 90, "cols": True}, r"cols must be an integer >= 2, got cols=True"),
        ({"rows": 90, "cols": 360, "fov_el_rad": 0.0}, r"fov_el_rad must be a finite number in \(0, 3.14159\]"),
        ({"rows": 90, "cols": 360, "fov_az_rad": 7.0}, r"fov_az_rad must be .* got fov_az_rad=7.0"),
        ({"rows": 90, "cols": 360, "fov_el_rad": float("nan")}, r"got fov_el_rad=nan"),
    ],
)
def test_grid_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SphericalGrid(**kwargs)


def test_bank_and_image_errors() -> None:
    grid = SphericalGrid(90, 360)
    with pytest.raises(ValueError, match=r"range_m must be finite and > l_th_m=2.817, got range_m=2"):
        DiscFilterBank(grid, range_m=2)
    with pytest.raises(ValueError, match=r"range_m must be .* got range_m=inf"):
        DiscFilterBank(grid, range_m=math.inf)
    with pytest.raises(ValueError, match=r"rows must be >= the disc footprint's 5 .* got rows=4"):
        DiscFilterBank(SphericalGrid(4, 360, math.radians(15)))
    with pytest.raises(ValueError, match=r"cols must be >= the disc footprint's 27 .* got cols=20"):
        DiscFilterBank(SphericalGrid(90, 20, fov_az_rad=math.radians(19)))
    bank = DiscFilterBank(grid, geometry=RobotGeometry(r0_m=0.15, r_m=0.65))
    for bad, match in [
        (np.ones(360), r"depth_m must have shape \(rows, cols\)=\(90, 360\), got shape=\(360,\)"),
        (np.ones((360, 90)), r"got shape=\(360, 90\)"),
        (np.ones((1, 90, 360)), r"got shape=\(1, 90, 360\)"),
        ([["a"] * 360] * 90, r"depth_m must be a real numeric array, got dtype=<U1"),
        (np.full((90, 360), "5.0"), r"depth_m must be a real numeric array, got dtype=<U3"),
        (np.ones((90, 360), complex), r"depth_m must be a real numeric array, got dtype=complex"),
        (np.ones((90, 360), object), r"depth_m must be a real numeric array, got dtype=object"),
    ]:
        with pytest.raises(ValueError, match=match):
            bank.safe_mask(bad)
    with pytest.raises(ValueError, match=r"band_widening must be a finite number > 1, got "
                                         r"band_widening=1.0"):
        DiscFilterBank(grid, band_widening=1.0)
    with pytest.raises(ValueError, match=r"range_m must be a finite number > 0, got range_m=0"):
        sanitize_depth(np.ones(3), range_m=0)
    with pytest.raises(ValueError, match=r"mask must have shape \(90, 360\), got shape=\(3,\)"):
        bank.nearest_direction(np.ones(3, bool), 0.0, 0.0)
