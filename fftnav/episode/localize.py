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

The noise comes from the episode's seed, apart from the decision policies' and the channel's
draws (:func:`localization_rng`): each robot's odometry noise is drawn ahead, one row per
control tick, from a generator of its own, so a robot's odometry errors at a given tick are
the same whatever the policy and whatever the other robots do (two policies on one map are
compared on the same noise); the measurements draw from one more generator.
"""

from __future__ import annotations

import math

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.localization.odometry import sample_motion_model_odometry
from fftnav.localization.relative import measure_relative, place
from fftnav.validate import check_integer

__all__ = ["Localizer", "localization_rng"]


def localization_rng(seed: int) -> np.random.SeedSequence:
    """The episode's localization seed: the third child of the episode seed's ``SeedSequence``
    (the first two: :func:`fftnav.episode.core.episode_seeds`); :class:`Localizer` spawns the
    robots' odometry generators and the measurements' from it.

    >>> localization_rng(7).generate_state(1) == localization_rng(7).generate_state(1)
    array([ True])
    """
    seed = check_integer("seed", seed, low=0)
    return np.random.SeedSequence(seed).spawn(3)[2]


class Localizer:
    """Every robot's pose as it knows it (module docstring).

    Parameters
    ----------
    config : SwarmConfig
        ``localization`` (mode, drift, measurement noise) and ``episode.control_hz``.
    start : ndarray, shape (N, 3)
        The robots' true start poses.
    seed : numpy.random.SeedSequence
        The episode's localization seed (:func:`localization_rng`): robot i's odometry noise
        comes from its child i, the measurements' from child N.
    ticks : int
        Control ticks of the episode (the odometry noise drawn ahead).

    Examples
    --------
    >>> from fftnav.config import SwarmConfig
    >>> cfg = SwarmConfig().replace({"mode": "odometry", "drift": "none"})
    >>> loc = Localizer(cfg, np.zeros((2, 3)), localization_rng(0), ticks=10)
    >>> loc.moved(np.zeros((2, 3)), np.array([[0.05, 0.0, 0.0], [0.0, 0.0, 0.0]]), np.array([0]))
    >>> loc.poses(np.zeros((2, 3))).round(9).tolist()
    [[0.05, 0.0, 0.0], [0.0, 0.0, 0.0]]
    """

    def __init__(self, config: SwarmConfig, start: np.ndarray, seed: np.random.SeedSequence,
                 *, ticks: int) -> None:
        loc = config.localization
        self.odometry = loc.odometry
        self.noise = loc.noise
        self.dt_s = 1.0 / config.episode.control_hz
        self.sigmas = (loc.range_noise_m, math.radians(loc.bearing_noise_deg),
                       math.radians(loc.heading_noise_deg))
        n = len(start)
        self.tick = 0
        #: The robots' estimates (odometry mode; None in exact mode).
        self.estimates: np.ndarray | None = None
        #: Each robot's odometry noise, drawn ahead: ``(ticks, 3, N)`` standard normals.
        self.normals = np.zeros((0, 3, n))
        self.rng: np.random.Generator | None = None
        if self.odometry:
            children = seed.spawn(n + 1)
            self.estimates = np.array(start, dtype=float, copy=True)
            if any(self.noise.alphas):
                self.normals = np.stack([np.random.default_rng(c).standard_normal(
                    (max(int(ticks), 1), 3)) for c in children[:n]], axis=2)
            self.rng = np.random.default_rng(children[n])

    def poses(self, truth: np.ndarray) -> np.ndarray:
        """The poses the robots know ``(N, 3)``: ``truth`` itself in exact mode, else the
        estimates."""
        return truth if self.estimates is None else self.estimates

    def moved(self, before: np.ndarray, after: np.ndarray, robots: np.ndarray) -> None:
        """End of a control period: robots ``robots`` drove from true poses ``before`` to
        ``after``, and their estimates move by their odometry's reading of it (with the noise
        of this tick's row). The estimates are a new array: poses handed out before stay as
        they were."""
        tick, self.tick = self.tick, self.tick + 1
        if self.estimates is None or not len(robots):
            return
        normals = None
        if len(self.normals):
            normals = self.normals[min(tick, len(self.normals) - 1)][:, robots]
        estimates = self.estimates.copy()
        estimates[robots] = sample_motion_model_odometry(
            self.estimates[robots], before[robots], after[robots], noise=self.noise,
            dt_s=self.dt_s, normals=normals)
        self.estimates = estimates

    def locate(self, sender: int, receivers: np.ndarray, truth: np.ndarray) -> np.ndarray:
        """Where each of ``receivers`` places ``sender`` ``(k, 3)``, in its own frame: at its
        estimate moved by its measurement of the sender (range, bearing, relative heading)."""
        if self.estimates is None:
            return np.repeat(truth[sender][None, :], len(receivers), axis=0)
        z = measure_relative(truth[receivers], truth[sender], range_sigma_m=self.sigmas[0],
                             bearing_sigma_rad=self.sigmas[1], heading_sigma_rad=self.sigmas[2],
                             rng=self.rng)
        return place(self.estimates[receivers], z)
