"""Batched PyBullet ray casts: the one ``rayTestBatch`` wrapper of the simulators.

Bullet refuses batches of more than ``MAX_RAY_INTERSECTION_BATCH_SIZE - 1`` rays (16,383: a
batch of 16,384 returns no results, a larger one raises), so :func:`cast_rays` splits longer
batches into chunks of at most ``MAX_RAYS`` rays.
"""

from __future__ import annotations

import numpy as np
import pybullet as p

from fftnav.errors import FftnavError

__all__ = ["MAX_RAYS", "cast_rays"]

#: Most rays Bullet answers in one ``rayTestBatch`` call.
MAX_RAYS: int = p.MAX_RAY_INTERSECTION_BATCH_SIZE - 1


def cast_rays(client: int, starts: np.ndarray, ends: np.ndarray, *, mask: int = -1) -> np.ndarray:
    """Hit fractions of the rays ``starts[i] -> ends[i]`` in one physics client.

    Parameters
    ----------
    client : int
        PyBullet physics client id.
    starts, ends : array_like, shape (N, 3)
        Ray start and end points (m, world frame).
    mask : int, optional
        Bullet collision-filter mask of the rays (which body groups they can hit); -1 (default)
        hits every body.

    Returns
    -------
    numpy.ndarray, shape (N,)
        Fraction in [0, 1] of each ray's length at its first hit, 1 for a miss: the hit lies
        at ``start + fraction * (end - start)``.
    """
    starts = np.asarray(starts, dtype=float)
    ends = np.asarray(ends, dtype=float)
    if starts.ndim != 2 or starts.shape[1] != 3 or ends.shape != starts.shape:
        raise FftnavError(f"starts and ends must both have shape (N, 3), got "
                          f"starts.shape={starts.shape}, ends.shape={ends.shape}")
    fractions = np.ones(len(starts))
    for s in range(0, len(starts), MAX_RAYS):
        hits = p.rayTestBatch(starts[s:s + MAX_RAYS], ends[s:s + MAX_RAYS], numThreads=1,
                              collisionFilterMask=mask, physicsClientId=client)
        fractions[s:s + MAX_RAYS] = [h[2] for h in hits]
    return fractions
