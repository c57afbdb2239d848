"""Compiled :func:`fftnav.navigation.bug.corridor_free` (optional numba), bit for bit.

The planner asks, every tick and for every robot, which headings a short straight move can
take without touching a scan point: ``M`` headings against the ``P`` scan points within reach.
The numpy version builds ``(M, P)`` arrays per robot; this loop does the same arithmetic per
heading and point and stops at the first point in the corridor. The trigonometry stays in
numpy (its vectorised ``cos`` and ``sin`` need not round as the C library's do), passed in
as arrays; every other operation is the same IEEE double operation in the same order
(``x = cos h * px + sin h * py``, ``y = cos h * py - sin h * px``, no fused multiply-add), so
the mask is identical (``tests/navigation/test_corridor.py``).
"""

from __future__ import annotations

import numpy as np

from fftnav.observe.kernels import AVAILABLE, njit

__all__ = ["AVAILABLE", "corridor_free_compiled"]


def corridor_free_compiled(ranges_m: np.ndarray, angles_rad: np.ndarray, *,
                           half_width_m: float, lookahead_m: float, reach_m: float) -> np.ndarray:
    """:func:`fftnav.navigation.bug.corridor_free` by the compiled loop (needs numba): the
    points within ``reach_m`` (``0 < d < reach``) of each scan, in the frame of each heading."""
    if np.ndim(ranges_m) != 2 or np.shape(angles_rad) != (np.shape(ranges_m)[1],):
        raise ValueError("ranges_m must be (K, M) and angles_rad (M,), got "
                         f"ranges_m.shape={np.shape(ranges_m)}, "
                         f"angles_rad.shape={np.shape(angles_rad)}")
    cos_h, sin_h = np.cos(angles_rad), np.sin(angles_rad)
    free = np.ones(ranges_m.shape, dtype=bool)
    _corridor(np.ascontiguousarray(ranges_m, dtype=float), cos_h, sin_h, float(half_width_m),
              float(lookahead_m), float(reach_m), free)
    return free


@njit(cache=True, nogil=True)
def _corridor(ranges: np.ndarray, cos_h: np.ndarray, sin_h: np.ndarray, half_width: float,
              lookahead: float, reach: float, free: np.ndarray) -> None:
    k_count, m = ranges.shape
    px, py = np.empty(m), np.empty(m)
    for k in range(k_count):
        n = 0
        for i in range(m):  # the scan points within reach, as the numpy version selects them
            d = ranges[k, i]
            if d > 0.0 and d < reach:
                px[n] = d * cos_h[i]
                py[n] = d * sin_h[i]
                n += 1
        for h in range(m):
            c, s = cos_h[h], sin_h[h]
            for p in range(n):
                x = c * px[p] + s * py[p]
                if x > 0.0 and x <= lookahead:
                    y = c * py[p] - s * px[p]
                    if abs(y) < half_width:
                        free[k, h] = False
                        break
