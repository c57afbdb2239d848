"""3D observations: spherical depth images and the 2D FFT disc filter (paper Sec. III-B, IV-A).

A spherical depth image ``D`` (metres) is sampled on an elevation x azimuth grid; the paper
normalises it as ``s(u, v) = D / R`` (eq. (3D sensor data)) and extends the safe-direction filter
h1 (eq. (h1)) to 2D "by circular rotation": a disc of angular diameter alpha, applied by 2D FFT.

Layout (:class:`SphericalGrid`): row 0 is the top elevation ``+fov_el/2`` and the last row the
bottom ``-fov_el/2`` (endpoints included); columns run in azimuth from ``-fov_az/2`` (-180 deg for a
full circle, with step ``2 pi / cols`` and no duplicated seam) to ``+fov_az/2`` (endpoints included
for a partial field of view). Azimuth is CCW from the heading, elevation up from the horizon.

The disc footprint is the set of grid offsets ``(di, dj)`` whose great-circle angular distance from
the centre, *measured at the equator*, is ``<= alpha / 2``. A 2D FFT is shift invariant, so the same
footprint is used at every row. At elevation ``e`` the true disc spans ``1 / cos(e)`` times more
columns, so the footprint tests only a part of it there (about ``cos(e)`` of its azimuthal width):
the test is exact at the horizon and increasingly non-conservative towards the poles
(``docs/3d.md`` quantifies it). Filtering is zero-padded in elevation (so rows closer than the disc
radius to the top or bottom edge are never safe, as the paper's ``Tc < i < M - Tc``) and circular
in azimuth when the azimuth covers 360 degrees (zero-padded otherwise).

Pure numpy / scipy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import fft as sfft

from fftnav.geometry import DRONE, RobotGeometry

__all__ = ["SphericalGrid", "DiscFilterBank", "sanitize_depth"]

#: Absolute tolerance of the test ``y1 >= l_th / R`` on normalised values (FFT round-off is ~1e-15).
SAFE_TOL = 1e-9


def _check_count(name: str, value: object, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {name}={value!r}")
    return int(value)


@dataclass(frozen=True)
class SphericalGrid:
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

    rows: int
    cols: int
    fov_el_rad: float = math.pi / 2
    fov_az_rad: float = 2 * math.pi

    def __post_init__(self) -> None:
        _check_count("rows", self.rows, 2)
        _check_count("cols", self.cols, 2)
        for name, top in (("fov_el_rad", math.pi), ("fov_az_rad", 2 * math.pi)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0 < v <= top + 1e-12):
                raise ValueError(f"{name} must be in (0, {top:.6g}], got {name}={v!r}")

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


def sanitize_depth(depth_m: np.ndarray, range_m: float) -> np.ndarray:
    """Normalised depth ``s = D / R`` (eq. (3D sensor data)) with the project's input rules.

    ``+inf`` and readings ``>= R`` are "no return" and read 1 (open, R); NaN and negative readings
    are invalid and read 0 (blocked). The input is not modified.

    Parameters
    ----------
    depth_m : numpy.ndarray
        Depth readings in metres, any shape.
    range_m : float
        Maximum range R in metres.

    Returns
    -------
    numpy.ndarray
        Float array in ``[0, 1]``, same shape.
    """
    d = np.array(depth_m, dtype=float)
    d[np.isnan(d) | (d < 0)] = 0.0
    return np.minimum(d, range_m) / range_m


class DiscFilterBank:
    """2D safe-direction filter h1 (a disc of angular diameter alpha) for one sensor and robot.

    Designed once per (grid, robot, range); the padded spectrum of h1 is kept, so filtering an
    image is one real 2D FFT, a product and one inverse FFT (the paper's "stored in ROM").

    Parameters
    ----------
    grid : SphericalGrid
        Sampling grid of the images to filter.
    geometry : RobotGeometry, optional
        Robot protective-distance model (l_th, alpha; eqs. (1)-(2)); default the paper's drone
        (r0 = 0.15 m, r = 0.65 m: l_th = 2.82 m, alpha = 26.7 deg).
    range_m : float, optional
        Maximum sensor range R in metres, ``> l_th`` (default 10).

    Raises
    ------
    ValueError
        If ``range_m`` is not above l_th or the disc footprint does not fit in the grid.
    """

    def __init__(
        self, grid: SphericalGrid, *, geometry: RobotGeometry = DRONE, range_m: float = 10.0
    ) -> None:
        l_th = geometry.l_th_m
        if not (isinstance(range_m, (int, float)) and math.isfinite(range_m) and range_m > l_th):
            raise ValueError(
                f"range_m must be finite and > l_th_m={l_th:.4g}, got range_m={range_m!r}")
        self.grid, self.geometry, self.range_m = grid, geometry, float(range_m)
        self.threshold = l_th / self.range_m
        fp = self.footprint
        sizes = (grid.rows, grid.cols)
        for name, need, have in zip(("rows", "cols"), fp.shape, sizes, strict=True):
            if have < need:
                raise ValueError(
                    f"{name} must be >= the disc footprint's {need} for "
                    f"alpha={geometry.alpha_deg:.1f} deg, got {name}={have}")
        a, b = fp.shape[0] // 2, fp.shape[1] // 2
        # Zero padding: N >= rows + a keeps the wrapped-around kernel half in the padding.
        self.fft_shape = (sfft.next_fast_len(grid.rows + a, real=True),
                          grid.cols if grid.full_azimuth
                          else sfft.next_fast_len(grid.cols + b, real=True))
        kernel = np.zeros(self.fft_shape)
        ii, jj = np.nonzero(fp)
        kernel[ii - a, jj - b] = 1.0 / ii.size  # centred on index (0, 0): no group delay
        self.spectrum = sfft.rfft2(kernel)

    @cached_property
    def footprint(self) -> np.ndarray:
        """Boolean disc footprint, shape ``(2a+1, 2b+1)``: offsets within alpha/2 at the equator.

        Offset ``(di, dj)`` belongs iff the great-circle distance between ``(0, 0)`` and
        ``(di * el_step, dj * az_step)`` is ``<= alpha / 2``, i.e.
        ``cos(di el_step) cos(dj az_step) >= cos(alpha / 2)``.
        """
        half = self.geometry.alpha_rad / 2
        a = int(half // self.grid.el_step_rad)
        b = int(half // self.grid.az_step_rad)
        di = np.arange(-a, a + 1)[:, None] * self.grid.el_step_rad
        dj = np.arange(-b, b + 1)[None, :] * self.grid.az_step_rad
        return np.cos(di) * np.cos(dj) >= math.cos(half) - 1e-12

    def _check(self, depth_m: np.ndarray) -> np.ndarray:
        try:
            d = np.asarray(depth_m, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"depth_m must be an array of numbers, got {type(depth_m).__name__}") from exc
        shape = (self.grid.rows, self.grid.cols)
        if d.shape != shape:
            raise ValueError(f"depth_m must have shape (rows, cols)={shape}, got shape={d.shape}")
        return d

    def filter(self, depth_m: np.ndarray) -> np.ndarray:
        """Filtered image y1: the disc mean of ``min(s, l_th / R)`` by 2D FFT (eqs. (h1), (3D)).

        Parameters
        ----------
        depth_m : numpy.ndarray
            Depth image in metres, shape ``(rows, cols)``; input rules of :func:`sanitize_depth`.

        Returns
        -------
        numpy.ndarray
            y1, normalised (dimensionless, ``<= l_th / R``), shape ``(rows, cols)``.
        """
        s = np.minimum(sanitize_depth(self._check(depth_m), self.range_m), self.threshold)
        y = sfft.irfft2(sfft.rfft2(s, self.fft_shape) * self.spectrum, self.fft_shape)
        return y[: self.grid.rows, : self.grid.cols]

    def safe_mask(self, depth_m: np.ndarray) -> np.ndarray:
        """Safe-direction domain: ``y1 >= l_th / R`` (eq. (y1 for safe), extended to 2D).

        Because ``min(s, l_th/R)`` never exceeds ``l_th/R``, a pixel is safe exactly when every
        reading in its disc footprint reaches l_th (a sliding minimum over the footprint).

        Returns
        -------
        numpy.ndarray
            Boolean mask, shape ``(rows, cols)``, in the image's own layout.
        """
        return self.filter(depth_m) >= self.threshold - SAFE_TOL

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
            raise ValueError(
                f"mask must have shape {(self.grid.rows, self.grid.cols)}, got shape={m.shape}")
        if not m.any():
            return None
        el = self.grid.elevations_rad()[:, None]
        az = self.grid.azimuths_rad()[None, :]
        cos_d = (np.sin(el) * math.sin(target_el_rad)
                 + np.cos(el) * math.cos(target_el_rad) * np.cos(az - target_az_rad))
        i, j = np.unravel_index(np.argmax(np.where(m, cos_d, -np.inf)), m.shape)
        return float(el[i, 0]), float(az[0, j])
