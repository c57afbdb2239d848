"""One swarm episode: the robots' message channel, the episode's tick, its loop and its record;
3D quadrotor flights.

Modules: :mod:`~fftnav.episode.comms` (the lossy, delayed, range-limited channel),
:mod:`~fftnav.episode.record` (``EpisodeRow``, the CSV columns),
:mod:`~fftnav.episode.recording` (per-tick recordings: ``read_recording``),
:mod:`~fftnav.episode.core` (``EpisodeCore``: one tick of the swarm, the rule of departures,
arrivals, collisions and time-outs, shared by ``run_episode`` and the environment
:class:`fftnav.envs.SwarmNavEnv`), :mod:`~fftnav.episode.loop` (``run_episode``: the core
driven to the end, then the rows), :mod:`~fftnav.episode.flight3d` (the 3D flight
controller and experiment).
The robots' controllers are in :mod:`fftnav.navigation`.
"""

from fftnav.config import CommsConfig, EpisodeConfig, RobotConfig, SensorConfig, SwarmConfig
from fftnav.episode.loop import run_episode
from fftnav.episode.record import EPISODE_COLUMNS, EpisodeResult, EpisodeRow, episode_csv
from fftnav.episode.recording import Recording, RecordingError, read_recording

__all__ = ["EPISODE_COLUMNS", "CommsConfig", "EpisodeConfig", "EpisodeResult", "EpisodeRow",
           "Recording", "RecordingError", "RobotConfig", "SensorConfig", "SwarmConfig",
           "episode_csv", "read_recording", "run_episode"]
