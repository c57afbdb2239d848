"""3D observations: spherical depth images and the 2D FFT disc filter (paper Sec. III-B, IV-A).

A spherical depth image ``D`` (metres) is sampled on an elevation x azimuth grid; the paper
normalises it as ``s(u, v) = D / R`` (eq. (3D sensor data)) and extends the safe-direction filter
h1 (eq. (h1)) to 2D "by circular rotation": a disc of angular diameter alpha, applied by 2D FFT.

Layout (:class:`SphericalGrid`): row 0 is the top elevation ``+fov_el/2`` and the last row the
bottom ``-fov_el/2`` (endpoints included); columns run in azimuth from ``-fov_az/2`` (-180 deg for a
full circle, with step ``2 pi / cols`` and no duplicated seam) to ``+fov_az/2`` (endpoints included
for a partial field of view). Azimuth is CCW from the heading, elevation up from the horizon.

The disc of a pixel is the set of grid pixels whose direction lies within the great-circle angle
alpha / 2 of the pixel's direction (:func:`disc_footprint`). At elevation ``e`` it spans about
``1 / cos(e)`` times more columns than at the horizon, so one footprint cannot serve every row.
The rows are grouped into *elevation bands* (:attr:`DiscFilterBank.bands`): rows whose
``1 / cos(e)`` differ by at most the factor ``band_widening``, and, as one last band, the rows whose
disc reaches a pole. Each band is filtered with the union of its rows' discs, so the test is
conservative everywhere (it never skips a pixel of a row's own disc) and tests at most a little
more than the disc. One forward 2D FFT is shared; each band costs one product and one inverse FFT.
Filtering is zero-padded in elevation (so rows closer than the disc radius to the top or bottom
edge are never safe, as the paper's ``Tc < i < M - Tc``) and circular in azimuth when the azimuth
covers 360 degrees (zero-padded otherwise).

Pure numpy / scipy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import fft as sfft

from fftnav.errors import FftnavError
from fftnav.limits import MAX_DEPTH_PIXELS, check_limit
from fftnav.observe.geometry import DRONE, RobotGeometry
from fftnav.observe.safe import safe_tolerance
from fftnav.observe.scan import sanitize_ranges
from fftnav.validate import Checked, check_number, integer_field, number_field

__all__ = ["SphericalGrid", "Band", "DiscFilterBank", "disc_footprint", "narrow_reason",
           "sanitize_depth"]



@dataclass(frozen=True)
class SphericalGrid(Checked):
    """Elevation x azimuth sampling grid of a spherical depth image.

    Parameters
    ----------
    rows, cols : int
        Number of elevation rows and azimuth columns, each ``>= 2``.
    fov_el_rad : float
        Vertical field of view in radians, ``0 < fov_el_rad <= pi``, centred on the horizon.
    fov_az_rad : float
        Horizontal field of view in radians, ``0 < fov_az_rad <= 2 pi``, centred on the heading.
    """

    rows: int = integer_field(low=2)
    cols: int = integer_field(low=2)
    # the upper bounds admit a full circle computed with rounding (np.deg2rad(360))
    fov_el_rad: float = number_field(math.pi / 2, low=0, low_open=True, high=math.pi + 1e-12)
    fov_az_rad: float = number_field(2 * math.pi, low=0, low_open=True,
                                     high=2 * math.pi + 1e-12)

    @property
    def full_azimuth(self) -> bool:
        """True when the azimuth covers the whole circle (filtering wraps around)."""
        return self.fov_az_rad >= 2 * math.pi - 1e-9

    @property
    def el_step_rad(self) -> float:
        """Elevation step between rows, radians (endpoints included)."""
        return self.fov_el_rad / (self.rows - 1)

    @property
    def az_step_rad(self) -> float:
        """Azimuth step between columns, radians (``2 pi / cols`` for a full circle)."""
        return self.fov_az_rad / (self.cols if self.full_azimuth else self.cols - 1)

    def elevations_rad(self) -> np.ndarray:
        """Row elevations, radians, from ``+fov_el/2`` (row 0) down to ``-fov_el/2``."""
        return self.fov_el_rad / 2 - self.el_step_rad * np.arange(self.rows)

    def azimuths_rad(self) -> np.ndarray:
        """Column azimuths, radians, from ``-fov_az/2`` (column 0) increasing CCW."""
        return -self.fov_az_rad / 2 + self.az_step_rad * np.arange(self.cols)

    def directions(self) -> np.ndarray:
        """Unit ray directions, sensor frame (x forward, y left, z up), shape (rows, cols, 3)."""
        el = self.elevations_rad()[:, None]
        az = self.azimuths_rad()[None, :]
        return np.stack(np.broadcast_arrays(
            np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)), axis=-1)


def sanitize_depth(depth_m: np.ndarray, *, range_m: float) -> np.ndarray:
    """Normalised depth ``s = D / R`` (eq. (3D sensor data)) with the project's input rules.

    :func:`fftnav.observe.scan.sanitize_ranges` divided by R: ``+inf`` and readings ``>= R`` are "no
    return" and read 1 (open, R); NaN and negative readings are invalid and read 0 (blocked).
    The input is not modified.

    Parameters
    ----------
    depth_m : numpy.ndarray
        Depth readings in metres, any shape.
    range_m : float
        Maximum range R in metres, finite and ``> 0``.

    Returns
    -------
    numpy.ndarray
        Float array in ``[0, 1]``, same shape.
    """
    return sanitize_ranges(depth_m, range_m=range_m) / range_m


def disc_footprint(grid: SphericalGrid, elevation_rad: float, *, half_angle_rad: float
                   ) -> np.ndarray:
    """Grid offsets within a great-circle angle of a pixel at ``elevation_rad`` (any azimuth).

    Offset ``(di, dj)`` (rows down, columns CCW) belongs iff the directions at
    ``(e, 0)`` and ``(e - di el_step, dj az_step)`` are at most ``half_angle_rad`` apart:
    ``sin e sin e' + cos e cos e' cos(dj az_step) >= cos(half_angle)``. Columns reach at most
    half the circle for a full azimuth (farther offsets wrap around) and ``cols - 1`` otherwise.

    Parameters
    ----------
    grid : SphericalGrid
        Image grid.
    elevation_rad : float
        Elevation of the centre pixel, radians.
    half_angle_rad : float
        Disc radius, radians (alpha / 2 for the safe-direction filter).

    Returns
    -------
    numpy.ndarray
        Boolean ``(2a + 1, 2b + 1)``, centre ``(a, b)``; ``a = floor(half_angle / el_step)`` and
        ``b`` the largest column offset in the disc.
    """
    rows = half_angle_rad // grid.el_step_rad
    b_max = grid.cols // 2 if grid.full_azimuth else grid.cols - 1
    check_limit("disc footprint cells (the image's elevation step is tiny against alpha)",
                (2 * rows + 1) * (2 * b_max + 1), MAX_DEPTH_PIXELS,
                hint="use a larger fov_el or fewer columns")
    a = int(rows)
    e2 = elevation_rad - np.arange(-a, a + 1)[:, None] * grid.el_step_rad
    dj = np.arange(-b_max, b_max + 1)[None, :] * grid.az_step_rad
    cos_d = (math.sin(elevation_rad) * np.sin(e2)
             + math.cos(elevation_rad) * np.cos(e2) * np.cos(dj))
    fp = cos_d >= math.cos(half_angle_rad) - 1e-12
    b = int(np.abs(np.nonzero(fp)[1] - b_max).max())
    return fp[:, b_max - b: b_max + b + 1]


def _check_range(range_m: float, geometry: RobotGeometry) -> None:
    """Refuse a range that is not finite or not above the robot's l_th."""
    l_th = geometry.l_th_m
    if not (isinstance(range_m, (int, float)) and math.isfinite(range_m) and range_m > l_th):
        raise FftnavError(
            f"range_m must be finite and > l_th_m={l_th:.4g}, got range_m={range_m!r}")


def narrow_reason(grid: SphericalGrid, *, geometry: RobotGeometry = DRONE,
                  range_m: float = 10.0) -> str | None:
    """Why an image on ``grid`` has no safe pixel whatever it holds, because it has fewer rows or
    columns than the disc filter (the 2D pipeline's segment narrower than the safety window);
    None when a pixel can be safe.

    The horizon's disc must fit (else :class:`DiscFilterBank` cannot be made); and the bank's
    footprints, widened per band of rows, must leave a safe pixel in an image open everywhere
    (depth ``range_m``), which is then the test. ``range_m`` is checked as the bank checks it
    (ValueError).

    >>> import math
    >>> narrow_reason(SphericalGrid(5, 360, math.radians(10), 2 * math.pi))
    'image narrower than the disc filter: 5 rows, its footprint for alpha=26.7 deg spans 11 rows'
    >>> print(narrow_reason(SphericalGrid(90, 27, math.radians(89), math.radians(26)))
    ...       .replace(", ", ",\\n"))
    image narrower than the disc filter: 27 columns,
    its widened footprints for alpha=26.7 deg span 29 columns or more
    """
    _check_range(range_m, geometry)
    need = disc_footprint(grid, 0.0, half_angle_rad=geometry.alpha_rad / 2).shape
    short = [(name, have, n) for name, have, n in zip(("rows", "columns"),
                                                       (grid.rows, grid.cols), need, strict=True)
             if have < n]
    if short:
        have = " and ".join(f"{h} {name}" for name, h, _ in short)
        spans = " and ".join(f"{n} {name}" for name, _, n in short)
        return (f"image narrower than the disc filter: {have}, its footprint for "
                f"alpha={geometry.alpha_deg:.1f} deg spans {spans}")
    bank = DiscFilterBank(grid, geometry=geometry, range_m=range_m)
    if bank.safe_mask(np.full((grid.rows, grid.cols), float(range_m))).any():
        return None
    cols = min(band.footprint.shape[1] for band in bank.bands)
    if cols > grid.cols:
        return (f"image narrower than the disc filter: {grid.cols} columns, its widened "
                f"footprints for alpha={geometry.alpha_deg:.1f} deg span {cols} columns or more")
    return (f"image narrower than the disc filter: {grid.rows} rows and {grid.cols} columns "
            f"leave no pixel whose footprint for alpha={geometry.alpha_deg:.1f} deg fits")


class Band(NamedTuple):
    """Rows filtered together and their common footprint (see :class:`DiscFilterBank`)."""

    rows: np.ndarray
    footprint: np.ndarray


class DiscFilterBank:
    """2D safe-direction filter h1 (a disc of angular diameter alpha) for one sensor and robot.

    Designed once per (grid, robot, range): the rows are grouped into elevation bands and the
    padded spectrum of each band's footprint is kept, so filtering an image is one real 2D FFT
    and, per band, a product and one inverse FFT (the paper's "stored in ROM").

    Parameters
    ----------
    grid : SphericalGrid
        Sampling grid of the images to filter.
    geometry : RobotGeometry, optional
        Robot protective-distance model (l_th, alpha; eqs. (1)-(2)); default the paper's drone
        (r0 = 0.15 m, r = 0.65 m: l_th = 2.82 m, alpha = 26.7 deg).
    range_m : float, optional
        Maximum sensor range R in metres, ``> l_th`` (default 10).
    band_widening : float, optional
        Rows share a band while ``1 / cos(elevation)`` varies by at most this factor inside it
        (default 1.1): a row's test then covers its own disc and at most about 10 % more
        columns. Rows whose disc reaches a pole form one more band.

    Raises
    ------
    ValueError
        If ``range_m`` is not above l_th, ``band_widening`` is not above 1 or the horizon's
        disc footprint does not fit in the grid (:func:`narrow_reason` tells that case apart).
    """

    def __init__(
        self, grid: SphericalGrid, *, geometry: RobotGeometry = DRONE, range_m: float = 10.0,
        band_widening: float = 1.1,
    ) -> None:
        _check_range(range_m, geometry)
        l_th = geometry.l_th_m
        check_number("band_widening", band_widening, low=1, low_open=True)
        self.grid, self.geometry, self.range_m = grid, geometry, float(range_m)
        self.threshold = l_th / self.range_m
        half = geometry.alpha_rad / 2
        horizon = disc_footprint(grid, 0.0, half_angle_rad=half)
        for name, need, have in zip(("rows", "cols"), horizon.shape, (grid.rows, grid.cols),
                                    strict=True):
            if have < need:
                raise FftnavError(
                    f"{name} must be >= the disc footprint's {need} for "
                    f"alpha={geometry.alpha_deg:.1f} deg, got {name}={have}")
        self.bands = self._bands(half, band_widening)
        a = horizon.shape[0] // 2  # every footprint spans the same rows, +-a
        b = max(band.footprint.shape[1] for band in self.bands) // 2
        # Zero padding: N >= rows + a (cols + b) keeps the wrapped-around kernel in the padding.
        self.fft_shape = (sfft.next_fast_len(grid.rows + a, real=True),
                          grid.cols if grid.full_azimuth
                          else sfft.next_fast_len(grid.cols + b, real=True))
        self._spectra = [self._spectrum(band.footprint) for band in self.bands]

    def _bands(self, half: float, widening: float) -> list[Band]:
        el = self.grid.elevations_rad()
        cos_el = np.cos(np.minimum(np.abs(el), math.pi / 2))
        polar = np.abs(el) + half >= math.pi / 2  # the disc reaches a pole
        with np.errstate(divide="ignore"):
            key = np.floor(-np.log(cos_el) / math.log(widening))
        key[polar] = np.inf
        bands = []
        for k in np.unique(key):
            rows = np.flatnonzero(key == k)
            fps = [disc_footprint(self.grid, el[i], half_angle_rad=half) for i in rows]
            b = max(fp.shape[1] for fp in fps) // 2
            union = np.logical_or.reduce(
                [np.pad(fp, ((0, 0), (b - fp.shape[1] // 2,) * 2)) for fp in fps])
            bands.append(Band(rows, union))
        return bands

    def _spectrum(self, footprint: np.ndarray) -> np.ndarray:
        """rfft2 of the footprint's mean kernel, centred on index (0, 0): y1(i, j) is the mean of
        s(i + di, j + dj) over the footprint's offsets (a correlation; no group delay)."""
        kernel = np.zeros(self.fft_shape)
        ii, jj = np.nonzero(footprint)
        a, b = footprint.shape[0] // 2, footprint.shape[1] // 2
        kernel[(a - ii) % self.fft_shape[0], (b - jj) % self.fft_shape[1]] = 1.0
        return sfft.rfft2(kernel / kernel.sum())

    def _check(self, depth_m: np.ndarray) -> np.ndarray:
        d = np.asarray(depth_m)
        if d.dtype.kind not in "biuf":
            raise FftnavError(f"depth_m must be a real numeric array, got dtype={d.dtype}")
        shape = (self.grid.rows, self.grid.cols)
        if d.shape != shape:
            raise FftnavError(f"depth_m must have shape (rows, cols)={shape}, got shape={d.shape}")
        return d

    def filter(self, depth_m: np.ndarray) -> np.ndarray:
        """Filtered image y1: the disc mean of ``min(s, l_th / R)`` by 2D FFT (eqs. (h1), (3D)).

        Each row takes the mean over its band's footprint (:attr:`bands`).

        Parameters
        ----------
        depth_m : numpy.ndarray
            Depth image in metres, shape ``(rows, cols)``, real numbers; input rules of
            :func:`sanitize_depth`.

        Returns
        -------
        numpy.ndarray
            y1, normalised (dimensionless, ``<= l_th / R``), shape ``(rows, cols)``.
        """
        d = self._check(depth_m)
        s = np.minimum(sanitize_depth(d, range_m=self.range_m), self.threshold)
        spectrum = sfft.rfft2(s, self.fft_shape)
        y = np.empty(d.shape)
        for band, h in zip(self.bands, self._spectra, strict=True):
            # inverse 2D FFT, the azimuth half only for the band's rows
            rows = sfft.ifft(spectrum * h, axis=0)[band.rows]
            y[band.rows] = sfft.irfft(rows, self.fft_shape[1], axis=1)[:, : self.grid.cols]
        return y

    def safe_mask(self, depth_m: np.ndarray) -> np.ndarray:
        """Safe-direction domain: ``y1 >= l_th / R`` (eq. (y1 for safe), extended to 2D).

        Because ``min(s, l_th/R)`` never exceeds ``l_th/R``, a pixel is safe exactly when every
        reading in its band's footprint reaches l_th (a sliding minimum over the footprint).

        Returns
        -------
        numpy.ndarray
            Boolean mask, shape ``(rows, cols)``, in the image's own layout.
        """
        return self.filter(depth_m) >= self.threshold - safe_tolerance(self.threshold)

    def nearest_direction(
        self, mask: np.ndarray, target_el_rad: float, target_az_rad: float
    ) -> tuple[float, float] | None:
        """The True pixel of ``mask`` closest (great-circle) to a target direction.

        Parameters
        ----------
        mask : numpy.ndarray
            Boolean mask, shape ``(rows, cols)`` (e.g. :meth:`safe_mask`).
        target_el_rad, target_az_rad : float
            Target elevation and azimuth in the sensor frame, radians.

        Returns
        -------
        tuple of float or None
            ``(elevation_rad, azimuth_rad)`` of the nearest True pixel, None if there is none.
        """
        m = np.asarray(mask, dtype=bool)
        if m.shape != (self.grid.rows, self.grid.cols):
            raise FftnavError(
                f"mask must have shape {(self.grid.rows, self.grid.cols)}, got shape={m.shape}")
        if not m.any():
            return None
        el = self.grid.elevations_rad()[:, None]
        az = self.grid.azimuths_rad()[None, :]
        cos_d = (np.sin(el) * math.sin(target_el_rad)
                 + np.cos(el) * math.cos(target_el_rad) * np.cos(az - target_az_rad))
        i, j = np.unravel_index(np.argmax(np.where(m, cos_d, -np.inf)), m.shape)
        return float(el[i, 0]), float(az[0, j])
