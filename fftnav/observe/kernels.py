"""Compiled per-scan steps of the single-scan pipeline (optional: needs numba, extra ``fast``).

One scan through :meth:`fftnav.observe.pipeline.Pipeline.process` costs about 45 numpy calls on
360-element arrays, each with its fixed dispatch cost; the arithmetic itself is a few
microseconds. The single-scan path keeps the paper's FFT formulation and numpy's FFT (the
reference filtering, bit for bit) and replaces everything before and after it by two compiled
loops:

- :func:`prepare`: sanitise and normalise the ranges and write the clipped row (for h1) and the
  raw row (for h2) into the zero-padded FFT input, exactly as
  :meth:`fftnav.observe.filters.FilterBank.filter_ranges` does;
- :func:`finish`: the safe mask ``y1 >= limit`` (``limit = l_th/R - tolerance``, computed by the
  caller, :func:`fftnav.observe.safe.safe_mask`'s test), the extrema of y2 exactly as
  :func:`fftnav.observe.compress.find_extrema_flat` (same slopes, same plateau rule, same
  clipping of distances) and the compact message words.

Every operation is the same IEEE double operation as in the numpy path, in the same order, so
masks, y1, y2, extrema and messages are bit-identical (``tests/observe/test_kernels.py`` checks it
on random scans and on every scan of the four Radish logs). Without numba, :data:`AVAILABLE` is
False and the pipeline uses its numpy path.
"""

from __future__ import annotations

import numpy as np

__all__ = ["AVAILABLE", "finish", "prepare"]

try:  # optional dependency: pip install fftnav[fast]
    from numba import njit
except ImportError:  # pragma: no cover - exercised where numba is missing
    AVAILABLE = False

    def njit(*args, **kwargs):  # type: ignore[no-redef]
        """Stand-in decorator: the functions stay plain Python (correct, slow, unused)."""
        return args[0] if args and callable(args[0]) else (lambda fn: fn)
else:
    AVAILABLE = True


@njit(cache=True, nogil=True)
def prepare(ranges: np.ndarray, range_m: float, threshold: float, work: np.ndarray) -> None:
    """Write one scan into ``work`` ``(2, L)``: row 0 ``min(s, l_th/R)``, row 1 ``s = d / R``,
    with ``d = max(min(r, R), 0)`` and NaN read as 0 (columns ``M..L-1`` stay as they are, 0).

    The same operations as ``np.minimum``, ``np.fmax``, ``np.divide`` and ``np.minimum`` of
    :meth:`~fftnav.observe.filters.FilterBank.filter_ranges`.
    """
    for i in range(ranges.shape[0]):
        r = ranges[i]
        if r != r:  # NaN: invalid beam, blocked
            d = 0.0
        else:
            d = r if r <= range_m else range_m  # np.minimum (+inf -> R)
            d = d if d >= 0.0 else 0.0  # np.fmax(d, 0)
        s = d / range_m
        work[1, i] = s
        work[0, i] = s if s <= threshold else threshold


@njit(cache=True, nogil=True)
def finish(out: np.ndarray, tau: int, limit: float, valid: np.ndarray, circular: bool,
           eps: float, angles: np.ndarray, range_m: float, angle_scale: float,
           dist_scale: float, mask: np.ndarray, sigma: np.ndarray, is_min: np.ndarray,
           payload: np.ndarray) -> int:
    """Safe mask, extrema and compact message words of one filtered scan.

    Parameters
    ----------
    out : ndarray, shape (2, L)
        Inverse FFT output: row 0 is y1, row 1 is y2, both aligned at column ``tau``.
    tau : int
        Group delay (0 in circular mode).
    limit : float
        Beam i is safe iff ``y1[i] >= limit``.
    valid : ndarray of bool, shape (W,)
        Columns of the (wrapped, if ``circular``) row that may hold an extremum.
    circular : bool
        The row wraps: one beam of each end is copied beyond the other, as in
        :func:`~fftnav.observe.compress.find_extrema_flat`.
    eps : float
        Flat-slope threshold (``EXTREMUM_EPS``).
    angles : ndarray, shape (M,)
        Beam angles (rad).
    range_m : float
        R (m).
    angle_scale, dist_scale : float
        Quantisation factors of the compact layout (``4096 / 2 pi`` and ``2047 / R``).
    mask, sigma, is_min, payload : ndarray
        Outputs: ``(M,)`` bool, ``(M, 2)`` float, ``(M,)`` bool and ``(3 M,)`` uint8, the
        compact payload (3 big-endian bytes per extremum); the first n rows (3 n bytes) are
        filled.

    Returns
    -------
    int
        The number n of extrema.
    """
    m = angles.shape[0]
    for i in range(m):
        mask[i] = out[0, tau + i] >= limit
    # the row as find_extrema_flat sees it
    width = m + 2 if circular else m
    y = np.empty(width)
    if circular:
        y[0] = out[1, tau + m - 1]
        y[width - 1] = out[1, tau]
        for i in range(m):
            y[i + 1] = out[1, tau + i]
    else:
        for i in range(m):
            y[i] = out[1, tau + i]
    # consecutive non-flat slopes of opposite sign enclose one extremum, at the middle of the
    # plateau between them (rounded down); with no flat slope, where the slope changes sign
    n = 0
    last = -1  # index of the last non-flat slope
    last_sign = 0
    for j in range(width - 1):
        d = y[j + 1] - y[j]
        sign = 1 if d > eps else (-1 if d < -eps else 0)
        if sign == 0:
            continue
        if last >= 0 and sign != last_sign:
            col = (last + 1 + j) // 2
            if valid[col]:
                beam = col - 1 if circular else col
                value = y[col] * range_m
                value = value if value >= 0.0 else 0.0
                value = value if value <= range_m else range_m
                angle = angles[beam]
                sigma[n, 0] = angle
                sigma[n, 1] = value
                minimum = last_sign < 0
                is_min[n] = minimum
                qa = np.int64(np.rint(angle * angle_scale))
                qd = np.int64(np.rint(value * dist_scale))
                word = ((qa << 12) & 0xFFF000) | qd | (np.int64(minimum) << 11)
                payload[3 * n] = (word >> 16) & 0xFF
                payload[3 * n + 1] = (word >> 8) & 0xFF
                payload[3 * n + 2] = word & 0xFF
                n += 1
        last, last_sign = j, sign
    return n
