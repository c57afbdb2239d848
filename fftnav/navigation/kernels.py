"""Compiled loops of the Bug planner (optional: needs numba, extra ``fast``), bit for bit.

Two per-tick costs of the planner are loops over a scan's beams that numpy can only do by
building large temporary arrays; here they are plain loops compiled by numba:

- :func:`corridor_free_compiled` (kernel ``_corridor``): which headings a short straight move
  can take without touching a scan point (:func:`fftnav.navigation.bug.corridor_free`): ``M``
  headings against the ``P`` scan points within reach. The numpy version builds ``(M, P)``
  arrays per robot; this loop does the same arithmetic per heading and point and stops at the
  first point in the corridor. The trigonometry stays in numpy (its vectorised ``cos`` and
  ``sin`` need not round as the C library's do), passed in as arrays; every other operation
  is the same IEEE double operation in the same order (``x = cos h * px + sin h * py``,
  ``y = cos h * py - sin h * px``, no fused multiply-add), so the mask is identical
  (``tests/navigation/test_corridor.py``).
- :func:`mark_scan`: one scan into one robot's own map
  (:meth:`fftnav.navigation.ownmap.OwnMaps.update`, whose numpy version is the fallback): the
  same IEEE operations in the same order, so the same cells
  (``tests/navigation/test_ownmap.py``).

Without numba :data:`AVAILABLE` is False and the callers use their numpy versions. Every kernel
caches its machine code on disk (``cache=True``), as :mod:`fftnav.observe.kernels` does.
"""

from __future__ import annotations

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe.kernels import AVAILABLE, njit

__all__ = ["AVAILABLE", "corridor_free_compiled", "mark_scan"]


def corridor_free_compiled(ranges_m: np.ndarray, angles_rad: np.ndarray, *,
                           half_width_m: float, lookahead_m: float, reach_m: float) -> np.ndarray:
    """:func:`fftnav.navigation.bug.corridor_free` by the compiled loop (needs numba): the
    points within ``reach_m`` (``0 < d < reach``) of each scan, in the frame of each heading."""
    if np.ndim(ranges_m) != 2 or np.shape(angles_rad) != (np.shape(ranges_m)[1],):
        raise FftnavError("ranges_m must be (K, M) and angles_rad (M,), got "
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


@njit(cache=True, nogil=True)
def mark_scan(ux: np.ndarray, uy: np.ndarray, rr: np.ndarray, x: float, y: float,
              samples: np.ndarray, lo: np.ndarray, res: float, range_m: float, clear_m: float,
              corner_row: int, corner_col: int, size: int, tick: int, last_free: np.ndarray,
              last_hit: np.ndarray) -> None:
    """:meth:`~fftnav.navigation.ownmap.OwnMaps.update` of one scan (beams of directions
    ``(ux, uy)`` and readings ``rr``) into one robot's ``last_free`` / ``last_hit``: the same
    IEEE operations in the same order as the numpy version (the points ``x + u * s``, the cells
    ``floor((p - lo) / res)``, the 3 x 3 dilation of the hit cells in the window at
    ``corner``), so the same cells."""
    rows, cols = last_free.shape
    near = np.zeros((size, size), dtype=np.bool_)
    limit = range_m * (1.0 - 1e-6)
    for b in range(rr.shape[0]):
        if rr[b] < limit:
            col = np.int64(np.floor((x + ux[b] * rr[b] - lo[0]) / res))
            row = np.int64(np.floor((y + uy[b] * rr[b] - lo[1]) / res))
            if 0 <= row < rows and 0 <= col < cols:
                last_hit[row, col] = tick
                if 0 <= row - corner_row < size and 0 <= col - corner_col < size:
                    near[row - corner_row, col - corner_col] = True
    ring = np.zeros((size, size), dtype=np.bool_)  # binary_dilation by a 3 x 3 square
    for a in range(size):
        for c in range(size):
            if near[a, c]:
                for da in range(max(a - 1, 0), min(a + 2, size)):
                    for dc in range(max(c - 1, 0), min(c + 2, size)):
                        ring[da, dc] = True
    for b in range(rr.shape[0]):
        reach = rr[b] - clear_m
        for s in range(samples.shape[0]):
            if not samples[s] <= reach:
                continue
            col = np.int64(np.floor((x + ux[b] * samples[s] - lo[0]) / res))
            row = np.int64(np.floor((y + uy[b] * samples[s] - lo[1]) / res))
            if not (0 <= row < rows and 0 <= col < cols):
                continue
            a, c = row - corner_row, col - corner_col
            if not (0 <= a < size and 0 <= c < size and ring[a, c]):
                last_free[row, col] = tick
