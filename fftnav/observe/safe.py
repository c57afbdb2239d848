"""Safe directions from the filtered scan (paper Sec. III-C, eqs. (y1 for safe) and (h1)).

Beam i is safe iff ``y1(i) >= l_th / R``. Because the clipped scan never exceeds ``l_th / R``,
this is equivalent to: every beam in the centred window of ``window_beams`` beams reads at least
``l_th`` (a sliding-window minimum, :func:`sliding_min_safe_mask`). Pure numpy / scipy.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe import kernels
from fftnav.observe.scan import angle_increment_rad, beam_angles_rad, is_full_circle

__all__ = [
    "SAFE_TOL",
    "SAFE_RTOL",
    "safe_mask",
    "safe_tolerance",
    "sliding_min_safe_mask",
    "safe_sectors_rad",
    "beam_index",
    "is_safe_direction",
    "nearest_safe_headings",
]

#: Largest tolerance (normalised units) of the test ``y1 >= l_th/R - tol``. FFT round-off is
#: ~1e-16 of the signal (whose values are at most ``l_th/R``); the smallest real deficit of a scan
#: quantised to 1 mm is ~1e-3 / R / window (5e-6 for R = 3 m and a 61-beam window).
SAFE_TOL = 1e-9
#: Tolerance relative to the threshold ``l_th/R``: an absolute 1e-9 would exceed the threshold
#: itself once R > 1e9 l_th (every beam safe); relative to ``l_th/R`` it stays 1e7 times above the
#: round-off and 1e5 times below the deficit of any blocked beam, whatever R.
SAFE_RTOL = 1e-8


def safe_tolerance(threshold: float) -> float:
    """Tolerance of the safety test for a threshold ``l_th/R``: ``min(SAFE_TOL, SAFE_RTOL *
    threshold)`` (``SAFE_TOL`` for the paper's robots and ranges, relative for huge R).

    >>> safe_tolerance(0.2), safe_tolerance(0.5e-9)
    (1e-09, 5e-18)
    """
    return min(SAFE_TOL, SAFE_RTOL * float(threshold))


def safe_mask(y1: np.ndarray, *, threshold: float) -> np.ndarray:
    """Safe beams ``y1 >= threshold - safe_tolerance(threshold)`` (eq. (y1 for safe)), boolean,
    same shape."""
    return np.asarray(y1) >= threshold - safe_tolerance(threshold)


def sliding_min_safe_mask(
    s: np.ndarray, *, window_beams: int, threshold: float, circular: bool = False
) -> np.ndarray:
    """Same mask as the FFT test, by a sliding-window minimum (eq. (necessary and sufficient ...)).

    Parameters
    ----------
    s : ndarray, shape (K, M)
        Normalised sanitised scans ``d / R``.
    window_beams : int
        Odd window width (beams), centred on each beam.
    threshold : float
        ``l_th / R``.
    circular : bool
        Wrap around (full circle) instead of zero padding.
    """
    from scipy.ndimage import minimum_filter1d  # only this oracle / benchmark path needs it

    mode = "wrap" if circular else "constant"
    low = minimum_filter1d(s, window_beams, axis=-1, mode=mode, cval=0.0)
    return low >= threshold


def _beam_params(mask: np.ndarray, fov_rad: float) -> tuple[int, float, bool]:
    beams = mask.shape[-1]
    return beams, angle_increment_rad(beams, fov_rad), is_full_circle(fov_rad)


def safe_sectors_rad(mask: np.ndarray, *, fov_rad: float) -> list[tuple[float, float]]:
    """Merge one scan's safe beams into sectors ``(start, end)`` of beam angles (rad).

    Each sector runs counter-clockwise from ``start`` to ``end`` (both safe beams). For a full
    circle a sector crossing the back is merged across the wrap and then has ``start > end``;
    if every beam is safe the single sector is ``(angles[0], angles[-1])``.
    """
    m = np.asarray(mask, dtype=bool)
    if m.ndim != 1:
        raise FftnavError(f"mask must be 1-D (one scan), got shape={m.shape}")
    beams, _, full = _beam_params(m, fov_rad)
    angles = beam_angles_rad(beams, fov_rad)
    edges = np.diff(np.concatenate([[False], m, [False]]).astype(np.int8))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    if full and len(starts) > 1 and m[0] and m[-1]:  # merge the run through the back
        starts, ends = starts[1:], np.concatenate([ends[1:-1], ends[:1]])
    return [(float(angles[a]), float(angles[b])) for a, b in zip(starts, ends, strict=True)]


def beam_index(angle_rad: np.ndarray | float, *, beams: int, fov_rad: float) -> np.ndarray:
    """Index of the beam nearest to each angle (rad); clipped to the field of view."""
    inc = angle_increment_rad(beams, fov_rad)
    a = np.asarray(angle_rad, dtype=np.float64)
    if is_full_circle(fov_rad):
        return np.rint((a + math.pi) / inc).astype(np.int64) % beams
    return np.clip(np.rint((a + fov_rad / 2.0) / inc).astype(np.int64), 0, beams - 1)


def is_safe_direction(
    mask: np.ndarray, angle_rad: np.ndarray | float, *, fov_rad: float
) -> np.ndarray:
    """Whether the beam nearest to ``angle_rad`` is safe.

    ``mask`` is ``(M,)`` with a scalar angle, or ``(K, M)`` with ``K`` angles (one per robot);
    returns a bool (array of shape ``(K,)``).
    """
    m = np.asarray(mask, dtype=bool)
    idx = beam_index(angle_rad, beams=m.shape[-1], fov_rad=fov_rad)
    if m.ndim == 1:
        return m[idx]
    return m[np.arange(m.shape[0]), np.broadcast_to(idx, m.shape[:1])]


@functools.lru_cache(maxsize=16)
def _angles(beams: int, fov_rad: float) -> np.ndarray:
    angles = beam_angles_rad(beams, fov_rad)
    angles.flags.writeable = False
    return angles


def _nearest_safe_one(mask: np.ndarray, target_rad: float,
                      fov_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`nearest_safe_headings` of one scan ``(M,)`` and one target: the same beams, from
    the safe beams' offsets to the target beam (a handful of numpy calls instead of (K, M)
    arrays; faster than the compiled walk's set-up for one scan)."""
    beams, _, full = _beam_params(mask, fov_rad)
    safe = np.flatnonzero(mask)
    if safe.size == 0:
        return np.float64(np.nan), np.float64(np.nan)
    j = int(beam_index(target_rad, beams=beams, fov_rad=fov_rad))
    angles = _angles(beams, fov_rad)
    out = []
    for offset in (safe - j, j - safe):  # CCW offsets, CW offsets
        if full:
            offset %= beams
            out.append(angles[safe[np.argmin(offset)]])
        else:
            ahead = offset >= 0
            out.append(angles[safe[ahead][np.argmin(offset[ahead])]] if ahead.any()
                       else np.float64(np.nan))
    return out[0], out[1]


def nearest_safe_headings(
    mask: np.ndarray, target_rad: np.ndarray | float, *, fov_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest safe heading on the left (CCW) and on the right (CW) of a target angle.

    Starting from the beam nearest to the target (included), the left heading is the first safe
    beam met turning counter-clockwise, the right one turning clockwise (wrapping through the
    back for a full circle). Batched: ``mask`` ``(K, M)`` with ``K`` targets.

    Returns
    -------
    left_rad, right_rad : ndarray
        Beam angles in radians; NaN where no safe beam exists on that side.
    """
    m = np.asarray(mask, dtype=bool)
    single = m.ndim == 1
    if single and np.ndim(target_rad) == 0:  # one scan, one target
        return _nearest_safe_one(m, target_rad, fov_rad)
    m2 = np.atleast_2d(m)
    beams, _, full = _beam_params(m2, fov_rad)
    j = np.broadcast_to(beam_index(target_rad, beams=beams, fov_rad=fov_rad), m2.shape[:1])
    if kernels.AVAILABLE:  # the same beams by a compiled walk from the target beam
        found = np.empty((2, len(j)), dtype=np.int64)
        kernels.nearest_safe_beams(np.ascontiguousarray(m2), np.ascontiguousarray(j), full,
                                   found[0], found[1])
        left, right = np.where(found >= 0, _angles(beams, fov_rad)[found], np.nan)
        return (left[0], right[0]) if single else (left, right)
    off = np.arange(beams) - j[:, None]  # (K, M) signed beam offsets
    angles = beam_angles_rad(beams, fov_rad)
    out = []
    for o in (off, -off):  # CCW offsets, CW offsets
        if full:
            o = o % beams
        o = np.where(m2 & (o >= 0), o, beams + 1)
        best = np.argmin(o, axis=1)
        found = o[np.arange(len(best)), best] <= beams
        out.append(np.where(found, angles[best], np.nan))
    left, right = out
    return (left[0], right[0]) if single else (left, right)
