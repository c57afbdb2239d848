"""Dimension reduction and reconstruction (paper Sec. III-D, eqs. (extrema), (x_i)).

Sigma is the set of local extrema of the low-passed scan y2: an array of shape ``(n, 2)`` of
(angle in rad, CCW from the heading; distance in metres), sorted by angle, plus a boolean array
telling which are minima. Pure numpy.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "EXTREMUM_EPS",
    "find_extrema",
    "find_extrema_flat",
    "quadrant_areas_batch",
    "reconstruct",
    "quadrant_areas",
]

#: Slopes ``|y2(i+1) - y2(i)| <= EXTREMUM_EPS`` (normalised units) count as flat, so that FFT
#: round-off (~1e-16) on an open, constant stretch does not create spurious extrema.
EXTREMUM_EPS = 1e-12


def find_extrema_flat(
    y2: np.ndarray,
    *,
    angles_rad: np.ndarray,
    range_m: float,
    blind_rad: float = 0.0,
    circular: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Extrema of all K scans at once, as flat arrays (see :func:`find_extrema`).

    Returns
    -------
    sigma : ndarray, shape (N, 2)
        (angle rad, distance m) of every extremum, scan by scan, by increasing beam index.
    is_min : ndarray of bool, shape (N,)
    offsets : ndarray of int, shape (K + 1,)
        Scan k owns rows ``offsets[k]:offsets[k + 1]``.
    """
    k, m = y2.shape
    # one contiguous (K, W) array: the scans, with a wrapped beam at each end if circular
    y = np.concatenate([y2[:, -1:], y2, y2[:, :1]], axis=1) if circular else y2.copy()
    width = y.shape[1]
    valid = np.zeros(width, bool)  # columns that may hold an extremum: not the ends, not blind
    inner = angles_rad if circular else angles_rad[1:-1]
    np.less_equal(np.abs(inner), math.pi - blind_rad / 2.0, out=valid[1:-1])
    run = y.reshape(-1)  # all rows end to end
    slope = run[1:] - run[:-1]  # y[i + 1] - y[i], also across the junctions between rows
    if slope.size and np.minimum.reduce(np.abs(slope), axis=None) > EXTREMUM_EPS:
        # no flat slope (the usual case; a flat junction only sends the batch to the general
        # path below): an extremum wherever the slope changes sign
        down = slope < 0.0
        turn = np.zeros(run.size, bool)
        np.not_equal(down[1:], down[:-1], out=turn[1:-1])
        rows_turn = turn.reshape(k, width)
        rows_turn &= valid  # also drops the junctions, which fall on end columns
        at = np.flatnonzero(turn)
        rows, col = np.divmod(at, width)
        minima = down[at - 1]
        values = run[at]
    else:  # consecutive non-flat slopes of opposite sign in one row enclose one extremum:
        # the beams after the first slope up to the second one form its plateau
        d = y[:, 1:] - y[:, :-1]
        nslopes = width - 1
        sgn = (d > EXTREMUM_EPS).view(np.int8) - (d < -EXTREMUM_EPS).view(np.int8)
        nz = np.flatnonzero(sgn)
        sign = sgn.ravel()[nz]
        row = nz // nslopes
        turn = (sign[:-1] != sign[1:]) & (row[:-1] == row[1:])
        rows = row[:-1][turn]
        start = nz[:-1][turn] - rows * nslopes + 1  # first plateau column
        col = (start + nz[1:][turn] - rows * nslopes) // 2
        ok = valid[col]
        rows, col, minima = rows[ok], col[ok], sign[:-1][turn][ok] < 0
        values = y[rows, col]
    beam = col - 1 if circular else col
    sigma = np.empty((len(beam), 2))
    sigma[:, 0] = angles_rad[beam]
    dist = sigma[:, 1]
    np.multiply(values, range_m, out=dist)
    np.maximum(dist, 0.0, out=dist)  # Gibbs ringing may leave [0, R]
    np.minimum(dist, range_m, out=dist)
    return sigma, minima, np.searchsorted(rows, np.arange(k + 1))


def find_extrema(
    y2: np.ndarray,
    *,
    angles_rad: np.ndarray,
    range_m: float,
    blind_rad: float = 0.0,
    circular: bool = False,
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Local maxima and minima of each filtered scan (eq. (extrema)), batched.

    A beam is a maximum when the last non-flat slope before it rises and the slope after it
    falls (a minimum: the reverse); slopes of at most :data:`EXTREMUM_EPS` are flat, and a
    plateau yields one extremum at its middle beam (rounded down). The end beams of a linear
    scan are never extrema; in circular mode the scan wraps (a plateau through beam 0 is not
    merged across the wrap). Extrema inside the rear blind sector, ``|angle| > pi -
    blind_rad / 2``, are dropped.

    Parameters
    ----------
    y2 : ndarray, shape (K, M)
        Normalised filter output ``h2 * s``.
    angles_rad : ndarray, shape (M,)
        Beam angles (rad).
    range_m : float
        Maximum range R (m), to convert distances to metres.
    blind_rad : float
        Rear blind-sector width (rad).
    circular : bool
        Treat each scan as periodic.

    Returns
    -------
    sigmas : list of ndarray, each (n_k, 2)
        (angle rad, distance m) of the extrema of scan k, by increasing beam index. Distances
        are ``clip(y2, 0, 1) * R``: the windowed sinc rings slightly outside ``[0, 1]`` next to
        steps (e.g. the zero padding of an open scan).
    is_min : list of ndarray of bool, each (n_k,)
        True for minima.
    """
    sig, mins, off = find_extrema_flat(
        y2, angles_rad=angles_rad, range_m=range_m, blind_rad=blind_rad, circular=circular
    )
    return np.split(sig, off[1:-1]), np.split(mins, off[1:-1])


def reconstruct(sigma: np.ndarray, angles_rad: np.ndarray, *, full_circle: bool) -> np.ndarray:
    """Reconstruct distances (m) at ``angles_rad`` by linear interpolation of d against phi
    between the extrema (Sec. III-D), periodic for a full circle, constant beyond the outer
    extrema otherwise. An empty Sigma carries no free space and reconstructs to 0 (blocked).
    """
    sigma = np.asarray(sigma, dtype=np.float64).reshape(-1, 2)
    if len(sigma) == 0:
        return np.zeros(np.shape(angles_rad))
    order = np.argsort(sigma[:, 0], kind="stable")
    phi, d = sigma[order, 0], sigma[order, 1]
    return np.interp(angles_rad, phi, d, period=2.0 * math.pi if full_circle else None)


def quadrant_areas(
    sigma: np.ndarray, *, alpha_rad: float, range_m: float, full_circle: bool
) -> np.ndarray:
    """Polygon areas x0 = [I, II, III, IV] of the reconstruction, eq. (x_i), normalised units.

    For each quadrant of Fig. 2b (I ``[0, a/2]``, II ``[a/2, pi/2]``, III ``[-pi/2, -a/2]``,
    IV ``[-a/2, 0]``), sums ``1/2 d_j d_(j+1) sin(phi_(j+1) - phi_j)`` over the extrema inside
    it, with the quadrant's two boundary angles (distances interpolated as in
    :func:`reconstruct`) as first and last vertices. Distances are normalised by R, so a fully
    open quadrant of angle w has area about ``sin(w) / 2``.
    """
    sigma = np.asarray(sigma, dtype=np.float64).reshape(-1, 2)
    sigma = sigma[np.argsort(sigma[:, 0], kind="stable")]
    return quadrant_areas_batch(
        sigma,
        np.array([0, len(sigma)]),
        alpha_rad=alpha_rad,
        range_m=range_m,
        full_circle=full_circle,
    )[0]


def quadrant_areas_batch(
    sigma: np.ndarray,
    offsets: np.ndarray,
    *,
    alpha_rad: float,
    range_m: float,
    full_circle: bool,
) -> np.ndarray:
    """:func:`quadrant_areas` of K scans at once, shape ``(K, 4)``.

    ``sigma[offsets[k]:offsets[k + 1]]`` is scan k's Sigma sorted by angle (as returned by
    :func:`find_extrema_flat`). The scans are laid side by side on one angle axis (scan k
    shifted by ``8 pi k``), so one interpolation and one sort serve the whole batch.
    """
    span = 8.0 * math.pi  # > the 6 pi a scan's knots (with wrapped copies) can cover
    offsets = np.asarray(offsets)
    k = len(offsets) - 1
    counts = np.diff(offsets)
    row = np.repeat(np.arange(k), counts)
    phi, d = sigma[:, 0], sigma[:, 1] / range_m
    key = phi + span * row
    full = counts > 0
    first, last, rk = offsets[:-1][full], offsets[1:][full] - 1, np.arange(k)[full] * span
    if full_circle:  # periodic: wrapped copies of the last and first extrema
        lo, lo_d, hi, hi_d = phi[last] - 2 * math.pi, d[last], phi[first] + 2 * math.pi, d[first]
    else:  # constant beyond the outer extrema
        lo, lo_d, hi, hi_d = -2 * math.pi, d[first], 2 * math.pi, d[last]
    knots = np.concatenate([lo + rk, key, hi + rk])
    order = np.argsort(knots, kind="stable")
    h, q = alpha_rad / 2.0, math.pi / 2.0
    bounds = np.array([-q, -h, 0.0, h, q])
    bkey = (bounds + span * np.arange(k)[:, None]).ravel()
    if len(knots):
        bd = np.interp(bkey, knots[order], np.concatenate([lo_d, d, hi_d])[order])
    else:  # no scan has an extremum
        bd = np.zeros(len(bkey))
    bd[np.repeat(~full, 5)] = 0.0  # an empty Sigma reconstructs to 0
    inside = (phi > -q) & (phi < q)
    vkey = np.concatenate([bkey, key[inside]])
    order = np.argsort(vkey, kind="stable")
    vkey = vkey[order]
    vd = np.concatenate([bd, d[inside]])[order]
    vrow = np.concatenate([np.repeat(np.arange(k), 5), row[inside]])[order]
    same = vrow[:-1] == vrow[1:]
    tri = 0.5 * vd[:-1] * vd[1:] * np.sin(np.diff(vkey))
    mid = 0.5 * (vkey[:-1] + vkey[1:]) - span * vrow[:-1]
    # 0: III, 1: IV, 2: I, 3: II (a degenerate edge at a bound, from an extremum within
    # rounding of +-pi/2, falls in the neighbouring quadrant with its zero area)
    quadrant = np.searchsorted(bounds[1:-1], mid)
    x = np.bincount((4 * vrow[:-1] + quadrant)[same], weights=tri[same], minlength=4 * k)
    return x.reshape(k, 4)[:, [2, 3, 0, 1]]
