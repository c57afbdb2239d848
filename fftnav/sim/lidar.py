"""Simulated 2D lidar for a whole swarm: one batched PyBullet ray test per tick.

Beams lie in the robot's yaw-only frame at the lidar height, ordered from -Theta/2 to +Theta/2
relative to the heading (``fftnav.scan.beam_angles_rad``, paper Sec. IV-B: M = 360, R = 3 m,
Theta = 360 deg, a 15 deg blind sector at the back reading 0).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pybullet as p

from fftnav.scan import beam_angles_rad

__all__ = ["MAX_BATCH_RAYS", "Lidar"]

#: Rays per ``rayTestBatch`` call; Bullet's limit is 16,384 (MAX_RAY_INTERSECTION_BATCH_SIZE).
MAX_BATCH_RAYS = 16_000


class Lidar:
    """Ray pattern of one lidar model, cast for K robots at once.

    Parameters
    ----------
    client : int
        PyBullet physics client id.
    beams : int
        Number of beams M.
    range_m : float
        Maximum range R in metres; a ray that hits nothing reads R.
    fov_deg : float
        Field of view Theta in degrees (360 for a full circle).
    blind_deg : float
        Width of the blind sector centred on the back (degrees); its beams read 0.
    height_m : float
        Height of the beams above the ground, metres.
    start_m : float
        Rays start this far from the robot centre (just outside the robot's own body), so a
        robot never sees itself; the reported range is still measured from the centre:
        ``start + hitFraction * (R - start)``.
    mask : int
        Bullet collision-filter mask of the rays (which body groups they can hit).
    """

    def __init__(self, client: int, *, beams: int, range_m: float, fov_deg: float,
                 blind_deg: float, height_m: float, start_m: float, mask: int) -> None:
        self._client = client
        self.range_m = float(range_m)
        self.angles_rad = beam_angles_rad(beams, math.radians(fov_deg))
        #: Beams outside the blind sector (the only ones cast).
        self.live = np.abs(self.angles_rad) < math.pi - math.radians(blind_deg) / 2.0 - 1e-12
        self._start_m = float(start_m)
        self._height_m = float(height_m)
        self._mask = int(mask)
        #: Wall-clock seconds spent in ``scan`` so far (read by the speed bench).
        self.seconds_spent = 0.0

    def scan(self, poses: np.ndarray) -> np.ndarray:
        """Ranges ``(K, M)`` in metres for robots at ``poses`` ``(K, 3)`` (x m, y m, yaw rad).

        All live beams of all robots go in one ``rayTestBatch`` call (split only above
        ``MAX_BATCH_RAYS``); blind-sector beams read 0.
        """
        tic = time.perf_counter()
        poses = np.asarray(poses, dtype=float)
        k = len(poses)
        out = np.zeros((k, self.angles_rad.size))
        if k == 0:
            return out
        theta = poses[:, 2:3] + self.angles_rad[self.live]
        direction = np.stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)], axis=-1)
        centre = np.c_[poses[:, :2], np.full(k, self._height_m)][:, None, :]
        starts = (centre + self._start_m * direction).reshape(-1, 3)
        ends = (centre + self.range_m * direction).reshape(-1, 3)
        fractions = np.empty(len(starts))
        for s in range(0, len(starts), MAX_BATCH_RAYS):
            hits = p.rayTestBatch(starts[s:s + MAX_BATCH_RAYS], ends[s:s + MAX_BATCH_RAYS],
                                  collisionFilterMask=self._mask, physicsClientId=self._client)
            fractions[s:s + len(hits)] = [h[2] for h in hits]
        out[:, self.live] = (self._start_m
                             + fractions * (self.range_m - self._start_m)).reshape(k, -1)
        self.seconds_spent += time.perf_counter() - tic
        return out
