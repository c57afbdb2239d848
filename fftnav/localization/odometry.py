"""Wheel odometry with noise: the sampled odometry motion model, and drift presets.

A robot without external positioning integrates its own odometry: between two control ticks it
reads the motion of its wheels as the relative motion ``(delta_rot1, delta_trans, delta_rot2)``
(turn toward the direction of travel, drive, turn to the final heading) and adds it to its
estimate. :func:`sample_motion_model_odometry` is Thrun, Burgard and Fox, *Probabilistic
Robotics* (2005), Table 5.6: the read motion is perturbed by zero-mean Gaussian noise of variance

.. math::

    \\sigma^2_{rot1} = \\alpha_1 \\delta_{rot1}^2 + \\alpha_2 \\delta_{trans}^2, \\quad
    \\sigma^2_{trans} = \\alpha_3 \\delta_{trans}^2 + \\alpha_4 (\\delta_{rot1}^2 +
    \\delta_{rot2}^2), \\quad
    \\sigma^2_{rot2} = \\alpha_1 \\delta_{rot2}^2 + \\alpha_2 \\delta_{trans}^2

and applied to the estimate. A constant gyro bias ``b`` (rad/s) adds ``b dt`` to every heading
change (half to each turn). The model is applied once per control tick (``dt`` = 1 /
``control_hz``), so the drift it gives depends on the rate it is applied at: the presets
(:data:`DRIFT_PRESETS`) are calibrated at the benchmark's 10 Hz on :func:`reference_path`
(docs/localization.md), and :func:`drift_percent` measures any setting the same way.

Pure numpy; all randomness comes from the caller's ``numpy.random.Generator``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fftnav.errors import FftnavError
from fftnav.validate import check_integer, check_number

__all__ = [
    "DRIFT_PRESETS",
    "OdometryNoise",
    "compose",
    "drift_percent",
    "odometry_motion",
    "reference_path",
    "sample_motion_model_odometry",
]


@dataclass(frozen=True)
class OdometryNoise:
    """The noise of a robot's odometry (:func:`sample_motion_model_odometry`).

    Attributes
    ----------
    alpha1 : float
        Rotation noise from rotation (variance per rad^2 of turn), >= 0.
    alpha2 : float
        Rotation noise from translation (rad^2 per m^2 driven), >= 0.
    alpha3 : float
        Translation noise from translation (variance per m^2 driven), >= 0.
    alpha4 : float
        Translation noise from rotation (m^2 per rad^2 of turn), >= 0.
    gyro_bias_radps : float
        Constant error of the heading rate (rad/s; positive: the estimate turns left of the
        truth).

    >>> OdometryNoise(0.01, 0.001, 0.01, 0.001).is_exact, OdometryNoise().is_exact
    (False, True)
    """

    alpha1: float = 0.0
    alpha2: float = 0.0
    alpha3: float = 0.0
    alpha4: float = 0.0
    gyro_bias_radps: float = 0.0

    def __post_init__(self) -> None:
        for name in ("alpha1", "alpha2", "alpha3", "alpha4"):
            check_number(name, getattr(self, name), low=0, high=1e6)
        check_number("gyro_bias_radps", self.gyro_bias_radps, low=-10.0, high=10.0)

    @property
    def alphas(self) -> tuple[float, float, float, float]:
        """``(alpha1, alpha2, alpha3, alpha4)``."""
        return (self.alpha1, self.alpha2, self.alpha3, self.alpha4)

    @property
    def is_exact(self) -> bool:
        """Whether the odometry is noise-free and unbiased."""
        return not any(self.alphas) and self.gyro_bias_radps == 0.0

    def scaled(self, factor: float) -> OdometryNoise:
        """The alphas times ``factor`` (the bias unchanged)."""
        f = check_number("factor", factor, low=0)
        return OdometryNoise(*(a * f for a in self.alphas), gyro_bias_radps=self.gyro_bias_radps)


#: The shape of the presets' noise: their alphas are these times a factor. A reading's
#: standard deviations are sqrt(alpha) times the motion (Table 5.6), so at the ``typical``
#: factor (0.4392) a 5 cm step (0.5 m/s, 10 Hz) has a rotation error of 1.4 mrad and a
#: translation error of 3.3 mm, and a 0.1 rad turn a rotation error of 6.6 mrad.
_SHAPE = OdometryNoise(alpha1=0.01, alpha2=0.0017, alpha3=0.01, alpha4=0.001)

#: Drift presets by name: the :class:`OdometryNoise` whose mean position error at the end of
#: :func:`reference_path` (20 m at 0.5 m/s, 10 Hz) is about 0.5 % (``low``), 2 % (``typical``)
#: and 5 % (``high``) of the distance driven (:func:`drift_percent`; calibrated by
#: ``fftnav bench drift``, docs/localization.md); ``none`` is noise-free odometry.
DRIFT_PRESETS: dict[str, OdometryNoise] = {
    "none": OdometryNoise(),
    "low": _SHAPE.scaled(0.0274),
    "typical": _SHAPE.scaled(0.4392),
    "high": _SHAPE.scaled(2.7489),
}


def _poses(name: str, poses: np.ndarray) -> np.ndarray:
    arr = np.asarray(poses, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3 or not np.isfinite(arr).all():
        raise FftnavError(f"{name} must be an (N, 3) array of finite poses (x_m, y_m, yaw_rad), "
                          f"got {name} of shape {arr.shape}")
    return arr


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def odometry_motion(before: np.ndarray, after: np.ndarray, *, min_trans_m: float = 1e-6
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The relative motion ``(delta_rot1, delta_trans, delta_rot2)`` (rad, m, rad) between
    poses ``before`` and ``after`` ``(N, 3)``: turn, drive, turn.

    A motion shorter than ``min_trans_m`` is a turn on the spot (``delta_rot1 = 0``); a motion
    backward (more than 90 degrees off the heading) is a negative ``delta_trans``, so the turns
    stay small.

    >>> rot1, trans, rot2 = odometry_motion(np.array([[0.0, 0.0, 0.0]]),
    ...                                     np.array([[1.0, 1.0, np.pi / 2]]))
    >>> round(float(rot1[0]), 6), round(float(trans[0]), 6), round(float(rot2[0]), 6)
    (0.785398, 1.414214, 0.785398)
    """
    a, b = _poses("before", before), _poses("after", after)
    d = b[:, :2] - a[:, :2]
    trans = np.hypot(d[:, 0], d[:, 1])
    moved = trans >= min_trans_m
    rot1 = np.where(moved, _wrap(np.arctan2(d[:, 1], d[:, 0]) - a[:, 2]), 0.0)
    back = np.abs(rot1) > np.pi / 2
    rot1 = np.where(back, _wrap(rot1 - np.pi), rot1)
    trans = np.where(back, -trans, trans)
    rot2 = _wrap(b[:, 2] - a[:, 2] - rot1)
    return rot1, trans, rot2


def compose(poses: np.ndarray, rot1: np.ndarray, trans: np.ndarray, rot2: np.ndarray
            ) -> np.ndarray:
    """``poses`` ``(N, 3)`` moved by the relative motions (turn ``rot1``, drive ``trans``,
    turn ``rot2``): the inverse of :func:`odometry_motion`.

    >>> p = compose(np.array([[0.0, 0.0, 0.0]]), *odometry_motion(
    ...     np.array([[0.0, 0.0, 0.0]]), np.array([[1.0, -2.0, 0.5]])))
    >>> np.round(p, 9).tolist()
    [[1.0, -2.0, 0.5]]
    """
    p = _poses("poses", poses)
    heading = p[:, 2] + rot1
    return np.stack([p[:, 0] + trans * np.cos(heading), p[:, 1] + trans * np.sin(heading),
                     _wrap(heading + rot2)], axis=1)


def sample_motion_model_odometry(estimate: np.ndarray, before: np.ndarray, after: np.ndarray,
                                 *, noise: OdometryNoise, dt_s: float,
                                 rng: np.random.Generator | None = None,
                                 normals: np.ndarray | None = None) -> np.ndarray:
    """The estimates ``(N, 3)`` after the robots moved from ``before`` to ``after`` (true
    poses, ``(N, 3)``), read through noisy odometry (Probabilistic Robotics, Table 5.6).

    Parameters
    ----------
    estimate : ndarray, shape (N, 3)
        The estimated poses at ``before`` (x_m, y_m, yaw_rad).
    before, after : ndarray, shape (N, 3)
        True poses at two consecutive control ticks.
    noise : OdometryNoise
        The alphas and the gyro bias.
    dt_s : float
        Time between the two ticks (s; the bias's heading error is ``gyro_bias_radps dt_s``).
    rng : numpy.random.Generator, optional
        The source of the noise: three standard normal draws per robot when any alpha is
        non-zero, none otherwise.
    normals : ndarray, shape (3, N), optional
        The standard normal draws to use instead of ``rng``'s (rows: rot1, trans, rot2), e.g.
        drawn ahead from one generator per robot.

    Returns
    -------
    ndarray, shape (N, 3)
        The new estimates: ``estimate`` moved by the noisy motion.

    Examples
    --------
    Noise-free odometry moves the estimate exactly as the truth moved:

    >>> est = sample_motion_model_odometry(
    ...     np.array([[5.0, 5.0, 0.0]]), np.array([[0.0, 0.0, 0.0]]),
    ...     np.array([[0.05, 0.0, 0.01]]), noise=OdometryNoise(), dt_s=0.1,
    ...     rng=np.random.default_rng(0))
    >>> np.round(est, 9).tolist()
    [[5.05, 5.0, 0.01]]
    """
    est = _poses("estimate", estimate)
    dt = check_number("dt_s", dt_s, low=0)
    rot1, trans, rot2 = odometry_motion(before, after)
    if len(est) != len(rot1):
        raise FftnavError(f"estimate must have one row per robot ({len(rot1)}), "
                          f"got estimate of shape {est.shape}")
    a1, a2, a3, a4 = noise.alphas
    if any(noise.alphas):
        e = _normals(rng, normals, len(est))
        sd = np.sqrt([a1 * rot1**2 + a2 * trans**2, a3 * trans**2 + a4 * (rot1**2 + rot2**2),
                      a1 * rot2**2 + a2 * trans**2])
        rot1, trans, rot2 = rot1 - e[0] * sd[0], trans - e[1] * sd[1], rot2 - e[2] * sd[2]
    half = 0.5 * noise.gyro_bias_radps * dt
    return compose(est, rot1 + half, trans, rot2 + half)


def _normals(rng: np.random.Generator | None, normals: np.ndarray | None, n: int
             ) -> np.ndarray:
    if normals is not None:
        e = np.asarray(normals, dtype=float)
        if e.shape != (3, n) or not np.isfinite(e).all():
            raise FftnavError(f"normals must be a finite (3, {n}) array, got normals of shape "
                              f"{e.shape}")
        return e
    if rng is None:
        raise FftnavError("rng must be a numpy Generator when normals are not given, got None")
    return rng.standard_normal((3, n))


def reference_path(*, length_m: float = 20.0, speed_mps: float = 0.5, control_hz: float = 10.0,
                   turn_radps: float = 0.4, period_s: float = 10.0) -> np.ndarray:
    """The true poses ``(T + 1, 3)`` of the path on which drift is measured: ``length_m`` at
    ``speed_mps``, one pose per control tick, the heading rate swinging as
    ``turn_radps * sin(2 pi t / period_s)`` (a robot weaving between obstacles).

    >>> path = reference_path()
    >>> path.shape, round(float(np.hypot(*np.diff(path[:, :2], axis=0).T).sum()), 3)
    ((401, 3), 20.0)
    """
    length = check_number("length_m", length_m, low=0, low_open=True, high=1e5)
    v = check_number("speed_mps", speed_mps, low=0, low_open=True)
    hz = check_number("control_hz", control_hz, low=0, low_open=True)
    ticks = int(round(length / v * hz))
    t = np.arange(ticks + 1) / hz
    w = check_number("turn_radps", turn_radps, low=0) * np.sin(
        2.0 * np.pi * t / check_number("period_s", period_s, low=0, low_open=True))
    yaw = np.concatenate([[0.0], np.cumsum(w[:-1]) / hz])
    mid = yaw[:-1] + 0.5 * np.diff(yaw)
    step = v / hz
    xy = np.concatenate([[[0.0, 0.0]], np.cumsum(np.stack([step * np.cos(mid), step * np.sin(mid)],
                                                          axis=1), axis=0)])
    return np.column_stack([xy, yaw])


def drift_percent(noise: OdometryNoise, *, runs: int = 2000, seed: int = 0,
                  path: np.ndarray | None = None, control_hz: float = 10.0) -> float:
    """Mean position error of the estimate at the end of ``path`` (default
    :func:`reference_path`), in percent of the distance driven, over ``runs`` robots.

    >>> drift_percent(OdometryNoise())
    0.0
    """
    n = check_integer("runs", runs, low=1, high=1_000_000)
    truth = reference_path(control_hz=control_hz) if path is None else np.asarray(path, float)
    if truth.ndim != 2 or truth.shape[1] != 3 or len(truth) < 2:
        raise FftnavError(f"path must be a (T, 3) array of poses with T >= 2, got path of shape "
                          f"{truth.shape}")
    rng = np.random.default_rng(check_integer("seed", seed, low=0))
    est = np.repeat(truth[:1], n, axis=0)
    for k in range(1, len(truth)):
        est = sample_motion_model_odometry(est, np.repeat(truth[k - 1:k], n, axis=0),
                                           np.repeat(truth[k:k + 1], n, axis=0), noise=noise,
                                           dt_s=1.0 / control_hz, rng=rng)
    driven = float(np.hypot(*np.diff(truth[:, :2], axis=0).T).sum())
    err = np.hypot(*(est[:, :2] - truth[-1, :2]).T)
    return round(float(100.0 * err.mean() / driven), 12)
