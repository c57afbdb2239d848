"""Localization without external positioning: odometry with noise, relative measurements.

Pure numpy, like :mod:`fftnav.observe`:

- :mod:`fftnav.localization.odometry`: the sampled odometry motion model (Probabilistic
  Robotics, Table 5.6) with a gyro bias, the drift presets and how drift is measured;
- :mod:`fftnav.localization.relative`: what a robot measures of a neighbour (range, bearing,
  relative heading, with noise) and the rigid transforms between robots' frames.
"""

from fftnav.localization.odometry import (
    DRIFT_PRESETS,
    OdometryNoise,
    compose,
    drift_percent,
    odometry_motion,
    reference_path,
    sample_motion_model_odometry,
)

__all__ = [
    "DRIFT_PRESETS",
    "OdometryNoise",
    "compose",
    "drift_percent",
    "odometry_motion",
    "reference_path",
    "sample_motion_model_odometry",
]
