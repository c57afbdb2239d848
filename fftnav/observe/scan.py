"""Scan validation, sanitising and beam angles (paper Sec. III-B, eq. "sensor data").

A scan is M range readings in metres over a field of view Theta, ordered from -Theta/2 to
+Theta/2 (counter-clockwise from the heading, see ``docs/architecture.md``). Pure numpy.
"""

from __future__ import annotations

import math

import numpy as np

from fftnav.errors import FftnavError
from fftnav.validate import check_integer, check_number

__all__ = [
    "FULL_CIRCLE_RAD",
    "is_full_circle",
    "angle_increment_rad",
    "beam_angles_rad",
    "as_scan_batch",
    "sanitize_ranges",
    "wrap_angle",
]

FULL_CIRCLE_RAD = 2.0 * math.pi


def is_full_circle(fov_rad: float) -> bool:
    """True when the field of view is a full circle (``2 pi`` within 1e-9 rad)."""
    return abs(fov_rad - FULL_CIRCLE_RAD) < 1e-9


def wrap_angle(angle_rad: np.ndarray | float) -> np.ndarray:
    """Angles wrapped to ``[-pi, pi)`` (radians), as a new array."""
    return (np.asarray(angle_rad, dtype=np.float64) + math.pi) % FULL_CIRCLE_RAD - math.pi


def _check_fov_beams(beams: int, fov_rad: float) -> None:
    check_integer("beams", beams, low=2)
    if not 0.0 < check_number("fov_rad", fov_rad) <= FULL_CIRCLE_RAD + 1e-9:
        raise FftnavError(f"fov_rad must be in (0, 2*pi], got fov_rad={fov_rad!r}")


def angle_increment_rad(beams: int, fov_rad: float) -> float:
    """Angle between neighbouring beams, radians.

    ``fov / M`` for a full circle (no duplicated beam), ``fov / (M - 1)`` for a partial field
    of view (both endpoints are beams, as in ROS ``LaserScan`` and CARMEN logs).
    """
    _check_fov_beams(beams, fov_rad)
    return fov_rad / beams if is_full_circle(fov_rad) else fov_rad / (beams - 1)


def beam_angles_rad(beams: int, fov_rad: float) -> np.ndarray:
    """Beam angles theta_n in radians, CCW from the heading, shape ``(beams,)``.

    Full circle: ``-pi + n 2pi/M`` (beam M/2 is the heading, beam 0 the back).
    Partial field of view: ``-fov/2 + n fov/(M-1)``.
    """
    inc = angle_increment_rad(beams, fov_rad)
    start = -math.pi if is_full_circle(fov_rad) else -fov_rad / 2.0
    return start + inc * np.arange(beams)


def as_scan_batch(ranges: np.ndarray, *, beams: int | None = None) -> tuple[np.ndarray, bool]:
    """Validate a scan ``(M,)`` or a batch ``(K, M)``; return a float ``(K, M)`` view and
    whether the input was a single scan.

    Parameters
    ----------
    ranges : array_like
        Range readings in metres.
    beams : int, optional
        Required number of beams M (last axis).

    Raises
    ------
    ValueError
        If the array is not 1-D or 2-D, is empty, is not numeric, or has the wrong M.
    """
    arr = np.asarray(ranges)
    if arr.dtype.kind not in "biuf":
        raise FftnavError(f"ranges must be a numeric array, got dtype={arr.dtype}")
    if arr.ndim not in (1, 2) or arr.size == 0:
        raise FftnavError(
            f"ranges must have shape (M,) or (K, M) with K, M > 0, got shape={arr.shape}"
        )
    if beams is not None and arr.shape[-1] != beams:
        raise FftnavError(f"ranges must have beams={beams} readings per scan, "
                          f"got shape={arr.shape}")
    single = arr.ndim == 1
    return np.atleast_2d(arr).astype(np.float64, copy=False), single


def sanitize_ranges(ranges: np.ndarray, *, range_m: float) -> np.ndarray:
    """Map real sensor values to ``[0, R]`` (a new array; the input is never modified).

    ``+inf`` and readings ``>= R`` mean "no return": open space, read as ``R``.
    NaN and negative readings are invalid beams and count as blocked: ``0``.

    Parameters
    ----------
    ranges : ndarray
        Range readings in metres, any shape.
    range_m : float
        Maximum range R in metres, ``> 0``.
    """
    check_number("range_m", range_m, low=0, low_open=True)
    d = np.asarray(ranges, dtype=np.float64)
    out = np.minimum(d, range_m)  # +inf -> R; NaN stays NaN
    out[~(out >= 0.0)] = 0.0  # NaN and negative -> blocked
    return out
