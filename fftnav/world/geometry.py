"""Exact 2D geometry of a world: analytic ray casts (the lidar's oracle) and obstacle distances.

Each obstacle class casts rays against all of its obstacles at once
(:meth:`fftnav.world.obstacles.Obstacle.ray_distances`); this module groups a world's obstacles
by class. Pure numpy.
"""

from __future__ import annotations

from itertools import groupby

import numpy as np

from fftnav.errors import FftnavError
from fftnav.validate import check_number
from fftnav.world.model import World

__all__ = ["raycast_world"]


def raycast_world(world: World, origins: np.ndarray, angles: np.ndarray, range_m: float,
                  *, chunk: int = 2048) -> np.ndarray:
    """Exact 2D ray casts against the world's obstacles (numpy oracle of the lidar).

    Parameters
    ----------
    world : World
        Obstacles to cast against (robots are not included).
    origins : array_like, shape (K, 2)
        Ray origins (x, y) in metres, world frame.
    angles : array_like, shape (K, M)
        Ray directions in radians, world frame (CCW from +x).
    range_m : float
        Maximum range R in metres, > 0.
    chunk : int, optional
        Rays processed per vectorised block (memory bound).

    Returns
    -------
    numpy.ndarray, shape (K, M)
        Distance from the origin to the first obstacle boundary along each ray, ``range_m``
        for a miss (as the lidar reports), 0 for an origin inside an obstacle.

    Examples
    --------
    >>> from fftnav.world.obstacles import Circle
    >>> w = World("demo", 0, (4.0, 4.0), (Circle((3.0, 1.0), 0.5, 1.0),),
    ...           np.array([[1.0, 1.0, 0.0]]), np.array([[1.0, 3.0]]))
    >>> raycast_world(w, [[1.0, 1.0]], [[0.0, np.pi / 2]], 3.0)
    array([[1.5, 3. ]])
    """
    origins = np.asarray(origins, dtype=float)
    angles = np.asarray(angles, dtype=float)
    if origins.ndim != 2 or origins.shape[1] != 2:
        raise FftnavError(f"origins must have shape (K, 2), got shape={origins.shape}")
    if angles.ndim != 2 or angles.shape[0] != origins.shape[0]:
        raise FftnavError(f"angles must have shape (K={origins.shape[0]}, M), got "
                          f"shape={angles.shape}")
    check_number("range_m", range_m, low=0, low_open=True)
    p = np.repeat(origins, angles.shape[1], axis=0)
    d = np.c_[np.cos(angles.ravel()), np.sin(angles.ravel())]
    by_class = [(cls, list(group)) for cls, group in groupby(
        sorted(world.solids, key=lambda o: o.shape), key=type)]
    out = np.full(len(p), float(range_m))
    for s in range(0, len(p), chunk):
        best = out[s:s + chunk]
        for cls, group in by_class:
            best = np.minimum(best, cls.ray_distances(group, p[s:s + chunk], d[s:s + chunk]))
        out[s:s + chunk] = best
    return out.reshape(angles.shape)
