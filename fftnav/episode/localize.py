"""What the robots of an episode know of where they are: exact poses, or their own odometry.

A :class:`Localizer` holds every robot's pose as the robot knows it (``[localization]``,
:class:`fftnav.config.LocalizationConfig`):

- ``mode = "exact"``: the true poses, read from the simulator at every tick;
- ``mode = "odometry"``: each robot's estimate, which starts at its start pose (the robot knows
  where it starts and where its goal is, nothing else) and after every control period moves by
  the robot's odometry reading of its true motion, noisy
  (:func:`fftnav.localization.sample_motion_model_odometry`).

It also says where a receiver places a message's sender (:meth:`Localizer.locate`): at the
sender's true pose (exact), or at the receiver's estimate moved by its measurement of the sender
(range, bearing, relative heading with noise: :func:`fftnav.localization.relative.
measure_relative`), which puts the sender in the receiver's own frame.

The noise comes from the episode's localization generator (:func:`localization_rng`): one
seeded generator per episode, apart from the decision policies' and the channel's, so two
policies on the same map draw the same noise sequence.
"""

from __future__ import annotations

import math

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.localization.odometry import sample_motion_model_odometry
from fftnav.localization.relative import measure_relative, place
from fftnav.validate import check_integer

__all__ = ["Localizer", "localization_rng"]


def localization_rng(seed: int) -> np.random.Generator:
    """The episode's localization generator: the third child of the episode seed's
    ``SeedSequence`` (the first two: :func:`fftnav.episode.core.episode_seeds`).

    >>> localization_rng(7).random() == localization_rng(7).random()
    True
    """
    seed = check_integer("seed", seed, low=0)
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(3)[2])


class Localizer:
    """Every robot's pose as it knows it (module docstring).

    Parameters
    ----------
    config : SwarmConfig
        ``localization`` (mode, drift, measurement noise) and ``episode.control_hz``.
    start : ndarray, shape (N, 3)
        The robots' true start poses.
    rng : numpy.random.Generator
        The source of the odometry and measurement noise (:func:`localization_rng`).

    Examples
    --------
    >>> from fftnav.config import SwarmConfig
    >>> cfg = SwarmConfig().replace({"mode": "odometry", "drift": "none"})
    >>> loc = Localizer(cfg, np.zeros((2, 3)), np.random.default_rng(0))
    >>> loc.moved(np.zeros((2, 3)), np.array([[0.05, 0.0, 0.0], [0.0, 0.0, 0.0]]), np.array([0]))
    >>> loc.poses(np.zeros((2, 3))).round(9).tolist()
    [[0.05, 0.0, 0.0], [0.0, 0.0, 0.0]]
    """

    def __init__(self, config: SwarmConfig, start: np.ndarray, rng: np.random.Generator) -> None:
        loc = config.localization
        self.odometry = loc.odometry
        self.noise = loc.noise
        self.dt_s = 1.0 / config.episode.control_hz
        self.rng = rng
        self.sigmas = (loc.range_noise_m, math.radians(loc.bearing_noise_deg),
                       math.radians(loc.heading_noise_deg))
        #: The robots' estimates (odometry mode; None in exact mode).
        self.estimates: np.ndarray | None = (np.array(start, dtype=float, copy=True)
                                             if self.odometry else None)

    def poses(self, truth: np.ndarray) -> np.ndarray:
        """The poses the robots know ``(N, 3)``: ``truth`` itself in exact mode, else the
        estimates."""
        return truth if self.estimates is None else self.estimates

    def moved(self, before: np.ndarray, after: np.ndarray, robots: np.ndarray) -> None:
        """Robots ``robots`` drove from true poses ``before`` to ``after`` in one control
        period: their estimates move by their odometry's reading of it."""
        if self.estimates is None or not len(robots):
            return
        self.estimates[robots] = sample_motion_model_odometry(
            self.estimates[robots], before[robots], after[robots], noise=self.noise,
            dt_s=self.dt_s, rng=self.rng)

    def locate(self, sender: int, receivers: np.ndarray, truth: np.ndarray) -> np.ndarray:
        """Where each of ``receivers`` places ``sender`` ``(k, 3)``, in its own frame: at its
        estimate moved by its measurement of the sender (range, bearing, relative heading)."""
        if self.estimates is None:
            return np.repeat(truth[sender][None, :], len(receivers), axis=0)
        z = measure_relative(truth[receivers], truth[sender], range_sigma_m=self.sigmas[0],
                             bearing_sigma_rad=self.sigmas[1], heading_sigma_rad=self.sigmas[2],
                             rng=self.rng)
        return place(self.estimates[receivers], z)
