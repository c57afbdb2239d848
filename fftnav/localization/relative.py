"""What a robot measures of a neighbour, and the transforms between robots' frames.

Without external positioning a robot knows its neighbours only relative to itself: a ranging
sensor (UWB, a camera reading a fiducial on the neighbour) gives the neighbour's range and
bearing in the robot's body frame and the neighbour's heading relative to its own, each with
Gaussian noise (:func:`measure_relative`). Put at the robot's own estimated pose, the
measurement places the neighbour in the robot's frame (:func:`place`); what the neighbour sent
in its body frame is then moved into the robot's frame with :func:`to_frame`.

Pure numpy.
"""

from __future__ import annotations

import numpy as np

from fftnav.errors import FftnavError
from fftnav.validate import check_number

__all__ = ["from_frame", "measure_relative", "place", "to_frame"]


def _pose(name: str, pose: np.ndarray) -> np.ndarray:
    arr = np.asarray(pose, dtype=float)
    if arr.shape[-1:] != (3,) or not np.isfinite(arr).all():
        raise FftnavError(f"{name} must be finite poses (x_m, y_m, yaw_rad) in its last axis, "
                          f"got {name} of shape {arr.shape}")
    return arr


def _points(points: np.ndarray) -> np.ndarray:
    arr = np.asarray(points, dtype=float)
    if arr.shape[-1:] != (2,) or not np.isfinite(arr).all():
        raise FftnavError(f"points must be finite (x_m, y_m) in their last axis, got points of "
                          f"shape {arr.shape}")
    return arr


def measure_relative(observers: np.ndarray, target: np.ndarray, *, range_sigma_m: float,
                     bearing_sigma_rad: float, heading_sigma_rad: float,
                     rng: np.random.Generator | None) -> np.ndarray:
    """``(range_m, bearing_rad, heading_rad)`` of the robot at true pose ``target`` ``(3,)`` as
    each robot at true pose ``observers`` ``(K, 3)`` measures it: its distance, its direction
    in the observer's body frame (CCW from the heading) and its heading relative to the
    observer's, each plus zero-mean Gaussian noise of the given standard deviation (three
    draws per observer from ``rng`` when any sigma is non-zero; ``rng`` may be None
    otherwise). The range stays >= 0.

    >>> z = measure_relative(np.array([[0.0, 0.0, np.pi / 2]]), np.array([1.0, 0.0, 0.0]),
    ...                      range_sigma_m=0, bearing_sigma_rad=0, heading_sigma_rad=0, rng=None)
    >>> np.round(z, 6).tolist()
    [[1.0, -1.570796, -1.570796]]
    """
    obs = _pose("observers", observers).reshape(-1, 3)
    tgt = _pose("target", target).reshape(3)
    sig = np.array([check_number("range_sigma_m", range_sigma_m, low=0),
                    check_number("bearing_sigma_rad", bearing_sigma_rad, low=0),
                    check_number("heading_sigma_rad", heading_sigma_rad, low=0)])
    d = tgt[:2] - obs[:, :2]
    z = np.stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - obs[:, 2],
                  tgt[2] - obs[:, 2]], axis=1)
    if sig.any():
        if rng is None:
            raise FftnavError("rng must be a numpy Generator when a sigma is non-zero, got None")
        z = z + rng.standard_normal(z.shape) * sig
        z[:, 0] = np.abs(z[:, 0])
    z[:, 1:] = (z[:, 1:] + np.pi) % (2.0 * np.pi) - np.pi
    return z


def place(poses: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The measured robot's pose in each observer's frame: ``z`` ``(K, 3)`` (range, bearing,
    relative heading, :func:`measure_relative`) put at the observers' poses ``(K, 3)`` (their
    estimates, in their own frames).

    >>> place(np.array([[1.0, 1.0, np.pi / 2]]), np.array([[2.0, 0.0, 0.0]])).round(6).tolist()
    [[1.0, 3.0, 1.570796]]
    """
    p = _pose("poses", poses).reshape(-1, 3)
    m = np.asarray(z, dtype=float).reshape(-1, 3)
    if len(m) != len(p):
        raise FftnavError(f"z must have one row per pose ({len(p)}), got z of shape {m.shape}")
    ang = p[:, 2] + m[:, 1]
    yaw = (p[:, 2] + m[:, 2] + np.pi) % (2.0 * np.pi) - np.pi
    return np.stack([p[:, 0] + m[:, 0] * np.cos(ang), p[:, 1] + m[:, 0] * np.sin(ang), yaw],
                    axis=1)


def to_frame(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Points ``(..., 2)`` given in the body frame of a robot at ``pose`` ``(3,)`` (x along its
    heading), in the frame ``pose`` is written in.

    >>> to_frame(np.array([[1.0, 0.0], [0.0, 2.0]]), np.array([1.0, 1.0, np.pi / 2])).round(6)
    array([[ 1.,  2.],
           [-1.,  1.]])
    """
    p = _pose("pose", pose).reshape(3)
    pts = _points(points)
    c, s = np.cos(p[2]), np.sin(p[2])
    x, y = pts[..., 0], pts[..., 1]
    return np.stack([p[0] + c * x - s * y, p[1] + s * x + c * y], axis=-1)


def from_frame(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Points ``(..., 2)`` given in the frame ``pose`` ``(3,)`` is written in, in the body
    frame of a robot at ``pose``: the inverse of :func:`to_frame`.

    >>> p = np.array([0.5, -1.0, 2.0])
    >>> from_frame(to_frame(np.array([[3.0, 4.0]]), p), p).round(9).tolist()
    [[3.0, 4.0]]
    """
    p = _pose("pose", pose).reshape(3)
    pts = _points(points)
    c, s = np.cos(p[2]), np.sin(p[2])
    x, y = pts[..., 0] - p[0], pts[..., 1] - p[1]
    return np.stack([c * x + s * y, -s * x + c * y], axis=-1)
