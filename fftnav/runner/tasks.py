"""Episode tasks: one task = (env, map, policy); ``run_task`` turns one into per-robot rows.

Seeds: map ``i`` of an experiment is generated with ``map_seed + i``; the episode seed (sensor
noise, packet loss, random decisions) is derived from ``(map_seed + i, env)`` with
``numpy.random.SeedSequence``, so every policy sees the same map *and* the same episode seed
(paired comparisons), and a task's result depends only on the task and the config.
"""

from __future__ import annotations

import json
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from fftnav.episode import EpisodeRow, run_episode
from fftnav.optimal.reference import optimal_lengths
from fftnav.runner.config import ExperimentConfig
from fftnav.world import World, generate_world, load_world

__all__ = ["Task", "TaskResult", "episode_seed", "iter_tasks", "make_tasks", "map_reference",
           "run_task", "task_count", "task_id", "task_world"]


@dataclass(frozen=True, order=True)
class Task:
    """One episode to run. Ordering (env, map_seed, policy) is the order of rows in the CSVs;
    ``policy`` is the name the rows carry (:attr:`ExperimentConfig.policy_names`)."""

    env: str
    map_seed: int
    policy: str
    episode_seed: int
    keep_trajectories: bool
    #: The map's reference lengths (grid A*, geodesic; metres, one per robot), computed once per
    #: map by the runner (:func:`map_reference`); None: the episode computes them.
    reference: tuple[tuple[float, ...], tuple[float, ...]] | None = field(default=None,
                                                                            compare=False)

    @property
    def task_id(self) -> str:
        """File-name-safe identifier, e.g. ``forest-1000-fusion``."""
        return task_id(self.env, self.map_seed, self.policy)


def task_id(env: str, map_seed: int, policy: str) -> str:
    """The identifier of a task (its result files' name), e.g. ``forest-1000-fusion``."""
    return f"{env}-{map_seed}-{policy}"


@dataclass
class TaskResult:
    """Per-robot rows, if kept, trajectories ``(T_i, 3)``, and the recording's bytes if the
    config keeps it (``[record] episodes``)."""

    rows: list[EpisodeRow]
    trajectories: list[np.ndarray] | None
    recording: bytes | None = None
    #: The method's compute: wall-clock seconds and robot-ticks
    #: (:attr:`fftnav.episode.EpisodeResult.compute_ms`); None: not measured.
    compute: tuple[float, int] | None = None


def episode_seed(env: str, map_seed: int) -> int:
    """Episode seed of a map: ``SeedSequence((map_seed, crc32(env)))``, a 32-bit integer."""
    seq = np.random.SeedSequence((map_seed, zlib.crc32(env.encode())))
    return int(seq.generate_state(1)[0])


def iter_tasks(config: ExperimentConfig, *,
               where: Callable[[str], bool] | None = None) -> Iterator[Task]:
    """The tasks of an experiment one by one, sorted (env, map_seed, policy), never all in
    memory: ``len(envs) * maps * len(policies)`` (:func:`task_count`) tasks; the first
    ``trajectory_maps`` maps of each env keep their trajectories. With ``where``, only the
    tasks whose :func:`task_id` it accepts (the episode seed, the costly part, is derived for
    those only)."""
    for env in sorted(config.envs):
        for i in range(config.maps):
            map_seed, seed = config.map_seed + i, None
            for policy in sorted(config.policy_names):
                if where is not None and not where(task_id(env, map_seed, policy)):
                    continue
                if seed is None:
                    seed = episode_seed(env, map_seed)
                yield Task(env, map_seed, policy, seed, i < config.trajectory_maps)


def task_count(config: ExperimentConfig) -> int:
    """Number of tasks of an experiment."""
    return len(config.envs) * config.maps * len(config.policies)


def make_tasks(config: ExperimentConfig) -> list[Task]:
    """All tasks of an experiment as a list, sorted (env, map_seed, policy) (see
    :func:`iter_tasks`, which the runner uses)."""
    return list(iter_tasks(config))


def run_task(config: ExperimentConfig, task: Task) -> TaskResult:
    """Generate the task's world (cached per process) and run its episode, recorded as
    ``[record] episodes`` says (the recording's bytes are made in the worker).

    Parameters
    ----------
    config : ExperimentConfig
    task : Task

    Returns
    -------
    TaskResult
    """
    world = task_world(config, task.env, task.map_seed)
    policy = config.resolved[task.policy].reference
    lengths = None if task.reference is None else tuple(np.array(r) for r in task.reference)
    result = run_episode(world, policy, seed=task.episode_seed, config=config.swarm,
                         reference=lengths, record=config.record != "none")
    kept = config.record == "all" or (config.record == "failures" and result.failed)
    return TaskResult(result.rows, result.trajectories if task.keep_trajectories else None,
                      result.recording() if kept else None,
                      compute=(result.compute_s, result.robot_ticks))


def map_reference(config: ExperimentConfig, task: Task) -> np.ndarray:
    """The reference lengths of the task's map, ``(2, N)``: grid A* and geodesic (m) of every
    robot (:func:`fftnav.optimal.reference.optimal_lengths`), the same for all its policies."""
    world = task_world(config, task.env, task.map_seed)
    return np.array(optimal_lengths(world, r0_m=config.swarm.robot.r0_m))


def task_world(config: ExperimentConfig, env: str, map_seed: int) -> World:
    """The world of a map: ``generate_world(env, map_seed, robots=..., **overrides)``, or the
    world file of an env of ``[world_files]`` (the same for every map), cached."""
    if env in config.world_files:
        return _file_world(config.world_files[env])
    return _cached_world(env, map_seed, config.robots,
                         json.dumps(config.world_overrides(env), sort_keys=True))


@lru_cache(maxsize=8)
def _file_world(path: str) -> World:
    return load_world(path)


@lru_cache(maxsize=8)
def _cached_world(env: str, map_seed: int, robots: int, overrides_json: str) -> World:
    """Per-process cache of generated worlds (the policies of a map share its world)."""
    return generate_world(env, map_seed, robots=robots, **json.loads(overrides_json))
