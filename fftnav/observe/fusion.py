"""Probabilistic fusion and the left/right decision (paper Sec. III-E, eqs. (P_s) to (P)).

All distances entering the sigmoids are normalised by R (the paper's ``w_n`` is normalised, and
so are the areas x0). Pure numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe.compress import quadrant_areas, reconstruct
from fftnav.observe.geometry import RobotGeometry
from fftnav.observe.scan import wrap_angle
from fftnav.validate import check_number

__all__ = [
    "NEIGHBOUR_WEIGHT_RATIO",
    "sigmoid",
    "own_probability",
    "rotate_sigma",
    "neighbour_input",
    "neighbour_probability",
    "neighbour_sides",
    "fuse",
    "Decision",
    "decide_turn",
]

#: w_i / w_0 used in the paper's simulations (Sec. III-E).
NEIGHBOUR_WEIGHT_RATIO = 1.0 / 3.0


def sigmoid(x: np.ndarray | float) -> np.ndarray:
    """Logistic function ``1 / (1 + exp(-x))``."""
    return 1.0 / (1.0 + np.exp(-np.asarray(x, dtype=np.float64)))


def own_probability(x0: np.ndarray, *, ws: float = 1.0, b0: float = 0.0) -> np.ndarray:
    """P_s = sigmoid(W0 . x0 + b0), W0 = [ws, 1, -1, -ws] / (1 + ws), eqs. (P_s), (W_0).

    Parameters
    ----------
    x0 : ndarray, shape (..., 4)
        Normalised quadrant areas [I, II, III, IV] (:func:`fftnav.observe.compress.quadrant_areas`).
    ws : float
        Weight of the safety sector (quadrants I, IV) relative to the sides, ``> 0``.
    b0 : float
        Bias (0 without prior knowledge).
    """
    check_number("ws", ws, low=0, low_open=True)
    x0 = np.asarray(x0, dtype=np.float64)
    if x0.shape[-1:] != (4,):
        raise FftnavError(f"x0 must have shape (..., 4), got shape={x0.shape}")
    w0 = np.array([ws, 1.0, -1.0, -ws]) / (1.0 + ws)
    return sigmoid(x0 @ w0 + b0)


def rotate_sigma(sigma: np.ndarray, yaw_rad: float) -> np.ndarray:
    """Express a neighbour's Sigma in the receiver frame: add the neighbour's yaw relative to
    the receiver to every angle (wrapped to ``[-pi, pi)``); distances unchanged. New array."""
    out = np.array(sigma, dtype=np.float64).reshape(-1, 2)
    out[:, 0] = wrap_angle(out[:, 0] + yaw_rad)
    return out


def neighbour_input(
    sigma: np.ndarray,
    is_min: np.ndarray,
    *,
    target_rad: float,
    alpha_rad: float,
    range_m: float,
) -> float:
    """x_ni of eq. (x_1): a neighbour's passability towards the target, normalised by R.

    Looks at the sector of width alpha centred on ``target_rad`` (Sigma already in the receiver
    frame). Without a minimum inside the sector, x_ni is the largest of the extrema inside it and
    the two boundary values (interpolated, periodic); with a minimum inside, it is the mean of
    that largest value and the smallest minimum.
    """
    sig = np.asarray(sigma, dtype=np.float64).reshape(-1, 2)
    mins = np.asarray(is_min, dtype=bool)
    rel = np.abs(wrap_angle(sig[:, 0] - target_rad))
    inside = rel <= alpha_rad / 2.0
    edges = target_rad + np.array([-alpha_rad, alpha_rad]) / 2.0
    candidates = np.concatenate([sig[inside, 1], reconstruct(sig, edges, full_circle=True)])
    high = candidates.max()
    inside_min = inside & mins
    x = 0.5 * (high + sig[inside_min, 1].min()) if inside_min.any() else high
    return float(x / range_m)


def neighbour_probability(
    x_ni: np.ndarray | float, *, geometry: RobotGeometry, range_m: float
) -> np.ndarray:
    """P_i = sigmoid(x_ni + w_n), w_n = -(2 (l_th + r) + r0) / R, eq. (P_ni)."""
    w_n = -(2.0 * (geometry.l_th_m + geometry.r_m) + geometry.r0_m) / range_m
    return sigmoid(np.asarray(x_ni, dtype=np.float64) + w_n)


def neighbour_sides(rel_xy: np.ndarray, *, r_m: float, max_range_m: float) -> np.ndarray:
    """Which side each neighbour is fused on: +1 left, -1 right, 0 not fused.

    ``rel_xy`` ``(n, 2)``: neighbour positions in the receiver frame (x ahead, y left), metres.
    Excluded: protective circles overlapping (distance < 2r), farther than ``max_range_m``, or
    behind or straight ahead (bearing outside ``(0, pi/2]`` left and ``[-pi/2, 0)`` right).
    """
    xy = np.asarray(rel_xy, dtype=np.float64).reshape(-1, 2)
    dist = np.hypot(xy[:, 0], xy[:, 1])
    bearing = np.arctan2(xy[:, 1], xy[:, 0])
    ok = (dist >= 2.0 * r_m) & (dist <= max_range_m) & (np.abs(bearing) <= math.pi / 2.0)
    return np.where(ok, np.sign(bearing), 0.0).astype(np.int64)


def fuse(p_s: float, p_left: np.ndarray, p_right: np.ndarray) -> float:
    """Fused probability of turning left, eq. (P): ``w0 P_s + sum_l w_i P_i + sum_r w_i (1 - P_i)``
    with ``w_i = w0 / 3`` and all weights summing to 1."""
    p_left, p_right = np.asarray(p_left, float), np.asarray(p_right, float)
    n = p_left.size + p_right.size
    w0 = 1.0 / (1.0 + NEIGHBOUR_WEIGHT_RATIO * n)
    wi = NEIGHBOUR_WEIGHT_RATIO * w0
    return float(w0 * p_s + wi * (p_left.sum() + (1.0 - p_right).sum()))


@dataclass(frozen=True)
class Decision:
    """Outcome of :func:`decide_turn`.

    Attributes
    ----------
    p : float
        Fused probability of turning left.
    p_s : float
        The robot's own probability.
    p_neighbours : ndarray
        P_i of each neighbour (NaN for those not fused).
    sides : ndarray
        +1 left, -1 right, 0 not fused, per neighbour.
    turn_left : bool
        ``p > 0.5``.
    """

    p: float
    p_s: float
    p_neighbours: np.ndarray
    sides: np.ndarray
    turn_left: bool


def decide_turn(
    own_sigma: np.ndarray,
    *,
    neighbours: list[tuple[np.ndarray, np.ndarray]],
    rel_poses: np.ndarray,
    target_rad: float,
    geometry: RobotGeometry,
    range_m: float,
    max_range_m: float,
    full_circle: bool = True,
) -> Decision:
    """Whole left/right decision of Sec. III-E in one call.

    Parameters
    ----------
    own_sigma : ndarray, shape (n, 2)
        The robot's own extrema (angle rad, distance m).
    neighbours : list of (sigma, is_min)
        Decoded neighbour messages, each Sigma in the neighbour's own frame.
    rel_poses : ndarray, shape (len(neighbours), 3)
        Each neighbour's (x m, y m, yaw rad) in the receiver frame.
    target_rad : float
        Bearing of the target in the receiver frame (rad).
    geometry : RobotGeometry
        Robot model (l_th, alpha, r, r0).
    range_m : float
        Maximum range R (m).
    max_range_m : float
        Neighbours farther than this are not fused (m).
    full_circle : bool
        Whether the own scan covers 360 degrees (periodic interpolation).
    """
    poses = np.asarray(rel_poses, dtype=np.float64).reshape(-1, 3)
    if len(poses) != len(neighbours):
        raise FftnavError(
            f"rel_poses must have one row per neighbour ({len(neighbours)}), "
            f"got shape={np.shape(rel_poses)}"
        )
    x0 = quadrant_areas(
        own_sigma, alpha_rad=geometry.alpha_rad, range_m=range_m, full_circle=full_circle
    )
    p_s = float(own_probability(x0))
    sides = neighbour_sides(poses[:, :2], r_m=geometry.r_m, max_range_m=max_range_m)
    p_n = np.full(len(neighbours), np.nan)
    for i, ((sig, mins), pose) in enumerate(zip(neighbours, poses, strict=True)):
        if sides[i]:
            x = neighbour_input(
                rotate_sigma(sig, pose[2]),
                mins,
                target_rad=target_rad,
                alpha_rad=geometry.alpha_rad,
                range_m=range_m,
            )
            p_n[i] = neighbour_probability(x, geometry=geometry, range_m=range_m)
    p = fuse(p_s, p_n[sides > 0], p_n[sides < 0])
    return Decision(p=p, p_s=p_s, p_neighbours=p_n, sides=sides, turn_left=p > 0.5)
