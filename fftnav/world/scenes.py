"""Analytic 2D scenes for figures, tests and benchmarks: a robot among circular trunks.

Ranges come from exact ray-circle intersections (numpy), in the scan convention of
:mod:`fftnav.observe.scan`; no simulator involved. Pure numpy.
"""

from __future__ import annotations

import numpy as np

from fftnav.observe.filters import DEFAULT_BLIND_RAD
from fftnav.observe.scan import beam_angles_rad

__all__ = ["random_trunks", "ray_cast_circles", "trunk_scans"]


def random_trunks(
    rng: np.random.Generator,
    *,
    n_trunks: int = 14,
    extent_m: float = 3.2,
    radius_m: tuple[float, float] = (0.08, 0.3),
    clearance_m: float = 0.5,
) -> tuple[np.ndarray, np.ndarray]:
    """Random trunk centres ``(n, 2)`` (m, robot frame: x ahead, y left) and radii ``(n,)`` (m)
    in the square ``[-extent, extent]^2``, each at least ``clearance_m`` from the robot."""
    centres = np.empty((0, 2))
    radii = np.empty(0)
    while len(centres) < n_trunks:
        c = rng.uniform(-extent_m, extent_m, 2)
        rad = rng.uniform(*radius_m)
        if np.hypot(*c) - rad >= clearance_m:
            centres, radii = np.vstack([centres, c]), np.append(radii, rad)
    return centres, radii


def ray_cast_circles(
    centres: np.ndarray,
    radii: np.ndarray,
    *,
    angles_rad: np.ndarray,
    range_m: float,
    blind_rad: float = 0.0,
) -> np.ndarray:
    """Range (m) along each ray from the origin to the nearest circle; ``+inf`` beyond
    ``range_m`` (no return), ``0`` inside the rear blind sector ``|angle| > pi - blind/2``.

    Solves ``|t u - c|^2 = rad^2`` for the smallest ``t > 0`` with ``u`` the ray direction.
    """
    u = np.stack([np.cos(angles_rad), np.sin(angles_rad)], axis=1)  # (M, 2)
    b = u @ np.asarray(centres, float).T  # (M, n): u . c
    c2 = np.sum(np.square(centres), axis=1) - np.square(radii)  # |c|^2 - rad^2
    disc = b**2 - c2
    t = b - np.sqrt(np.where(disc >= 0, disc, np.nan))
    t = np.where((disc >= 0) & (t > 0), t, np.inf)
    d = t.min(axis=1, initial=np.inf)
    d[d > range_m] = np.inf
    d[np.abs(angles_rad) > np.pi - blind_rad / 2.0] = 0.0
    return d


def trunk_scans(
    rng: np.random.Generator,
    k: int,
    *,
    beams: int = 360,
    range_m: float = 3.0,
    blind_rad: float = DEFAULT_BLIND_RAD,
) -> np.ndarray:
    """``k`` full-circle scans ``(k, beams)`` (m) of independent random trunk scenes,
    quantised to millimetres (like a real sensor), paper's simulated lidar by default."""
    angles = beam_angles_rad(beams, 2.0 * np.pi)
    rows = [
        ray_cast_circles(
            *random_trunks(rng), angles_rad=angles, range_m=range_m, blind_rad=blind_rad
        )
        for _ in range(k)
    ]
    return np.round(np.array(rows), 3)
