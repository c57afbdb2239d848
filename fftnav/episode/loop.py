"""One swarm episode: a world, a decision policy and a seed -> one row per robot.

Each control tick ties the stages together (:class:`~fftnav.episode.core.EpisodeCore`): the
PyBullet swarm's lidar scans (:mod:`fftnav.sim`) -> the FFT pipeline (:mod:`fftnav.observe`) ->
the controller (:mod:`fftnav.navigation`): by default the Bug planner, which asks the decision
policy for a side when a goal direction is blocked
(:class:`~fftnav.navigation.bugcontrol.BugController`), or any controller
(:mod:`fftnav.navigation.controllers`) -> swarm messages (:mod:`fftnav.episode.comms`) -> the
simulator advances one control period. The metrics of the rows come from :mod:`fftnav.metrics`
applied to the trajectories.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from fftnav import metrics
from fftnav.config import SwarmConfig
from fftnav.episode.core import EpisodeCore, OnTick
from fftnav.episode.record import EpisodeResult, EpisodeRow
from fftnav.episode.recording import Tape
from fftnav.navigation.resolve import resolve
from fftnav.optimal.reference import optimal_lengths
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.states import Status
from fftnav.validate import check_integer
from fftnav.world.model import World

__all__ = ["OnTick", "episode_rows", "failure_cause", "positions_by_tick", "run_episode"]


@functools.lru_cache(maxsize=8)
def _reference_lengths(world_json: str, r0_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid A* and geodesic lengths of a world's robots, cached: every policy run on the same map
    in this process reuses them (they take about a second or two per 20 m x 20 m map)."""
    return optimal_lengths(World.from_json(world_json), r0_m=r0_m)


def run_episode(
    world: World,
    policy: str,
    *,
    seed: int = 0,
    config: SwarmConfig | None = None,
    gui: bool = False,
    reference: tuple[np.ndarray, np.ndarray] | None = None,
    record: bool = False,
    on_tick: OnTick | None = None,
) -> EpisodeResult:
    """Run every robot of ``world`` to its goal under decision ``policy``.

    Parameters
    ----------
    world : fftnav.world.World
        Obstacles, starts and goals (one robot per start).
    policy : str
        A decision policy (run by the Bug planner) or a controller: a registered name
        (``fusion``, ``vfh``, ...), ``module:attr``, ``path/to/file.py:attr`` or an entry point
        of group ``fftnav.policies`` (:func:`fftnav.navigation.resolve.resolve`). The rows carry
        its name.
    seed : int
        Episode seed: sensor noise, packet loss, pose noise and the ``random`` policy all derive
        from it. The world has its own seed.
    config : SwarmConfig, optional
        Robot, sensor, communication and episode parameters (default: the paper's setting).
    gui : bool
        Open the PyBullet GUI.
    reference : (ndarray, ndarray), optional
        The robots' grid A* and geodesic lengths (m) if already known (an experiment computes
        them once per map); default: computed here
        (:func:`fftnav.optimal.reference.optimal_lengths`, cached per process).
    record : bool
        Keep the episode's recording (:mod:`fftnav.episode.recording`) in the result's
        ``tape``; the rows do not change.
    on_tick : callable, optional
        Called at every control tick, after the controller decided and before the simulator
        advances (:data:`OnTick`); ``fftnav episode --bag`` writes the bag from it. The rows do
        not change.

    Returns
    -------
    EpisodeResult
        One :class:`~fftnav.episode.record.EpisodeRow` per robot (``robot`` is the index in the
        world's starts), the trajectories sampled at the control rate and, with ``record``,
        the tape (:meth:`EpisodeResult.recording` gives the file's bytes).

    Notes
    -----
    The episode is an :class:`~fftnav.episode.core.EpisodeCore` driven by its controller,
    made from the episode's :class:`~fftnav.navigation.controllers.ControllerSetup`
    (:meth:`fftnav.navigation.resolve.Resolved.make`). Each control tick: the lidar scans of the
    moving robots go through the FFT pipeline in one batched call (unless a controller does
    without it); the controller turns them into commands (by default the Bug planner,
    ``docs/planner.md``, which asks the decision policy for a side when a goal direction is
    blocked) and messages, broadcast through the channel (robots that met an obstacle send
    their compact message with ``fusion``); the simulator advances one control period. A robot
    within ``success_radius_m`` of its goal has arrived, one touching an obstacle has failed;
    either is parked (taken out of the world). With ``episode.departure`` other than
    ``together`` a robot waits at its start until its departure tick; its trajectory and time
    limit start then, and it is parked when its time is up. The controller's ``finish(robot)``
    is called once for every robot when it leaves: arrived, failed or out of time (including
    the robots still driving when the last tick ends).
    """
    cfg = config or SwarmConfig()
    cfg.episode.check_departures(len(world.starts))
    method = resolve(policy)
    seed = check_integer("seed", seed, low=0)
    tape = Tape(world, cfg, method.name, seed, cfg.pipeline().angles_rad) if record else None
    optimal, geodesic = (_reference_lengths(world.to_json(), cfg.robot.r0_m)  # unreachable: fail
                         if reference is None else reference)
    with SwarmSim(world, config=SimConfig.for_swarm(cfg), gui=gui) as sim:
        core = EpisodeCore(world, cfg, sim, seed=seed, controller=method.make, tape=tape,
                           on_tick=on_tick)
        core.run()
    trajectories = core.trajectories()
    rows = episode_rows(core, method.name, (optimal, geodesic))
    return EpisodeResult(rows=rows, trajectories=trajectories, tape=tape,
                         compute_s=core.compute_s, robot_ticks=core.robot_ticks,
                         left=core.robots.left.copy())


def episode_rows(core: EpisodeCore, policy: str,
                 reference: tuple[np.ndarray, np.ndarray] | None = None) -> list[EpisodeRow]:
    """The rows of an ended episode's core, one per robot, named ``policy``; ``reference``:
    the robots' grid A* and geodesic lengths (m), default computed (cached per process)."""
    optimal, geodesic = (_reference_lengths(core.world.to_json(), core.config.robot.r0_m)
                         if reference is None else reference)
    trajectories = core.trajectories()
    by_tick = positions_by_tick(trajectories, core.robots.departure)
    return [_row(core, i, trajectories[i], policy=policy,
                 lengths_m=(float(optimal[i]), float(geodesic[i])), by_tick=by_tick)
            for i in range(len(trajectories))]


def positions_by_tick(trajectories: list[np.ndarray], departure: np.ndarray) -> np.ndarray:
    """Every robot's position at every tick of the episode, ``(G, N, 2)``: robot j's
    trajectory sample k is tick ``departure[j] + k``; before its departure it waits at its
    start (in the world), after its last sample it is parked (out of the world): NaN.

    >>> trajectories = [np.array([[0.0, 0, 0], [0, 1, 0]]), np.array([[5.0, 0, 0]])]
    >>> positions_by_tick(trajectories, np.array([0, 1]))[:, 1]
    array([[5., 0.],
           [5., 0.]])
    >>> positions_by_tick(trajectories, np.array([1, 0]))[:, 0]
    array([[0., 0.],
           [0., 0.],
           [0., 1.]])
    """
    ends = [int(d) + len(t) for d, t in zip(departure, trajectories, strict=True)]
    out = np.full((max(ends), len(trajectories), 2), np.nan)
    for j, (d, t) in enumerate(zip(departure, trajectories, strict=True)):
        out[:d, j] = t[0, :2]
        out[d:d + len(t), j] = t[:, :2]
    return out


def failure_cause(core: EpisodeCore, i: int, trajectory: np.ndarray,
                  by_tick: np.ndarray) -> str:
    """Robot ``i``'s cause of failure (empty if it arrived), the other robots aligned by tick."""
    departure = int(core.robots.departure[i])
    others = np.delete(by_tick[departure:departure + len(trajectory)], i, axis=1)
    config = core.config
    ep = config.episode
    thresholds = metrics.FailureThresholds.for_robot(r0_m=config.robot.r0_m,
                                                     v_max_mps=config.robot.v_max_mps)
    features = metrics.failure_features(
        trajectory, core.goals[i], collided=bool(core.robots.collided[i]), others=others,
        dt_s=1.0 / ep.control_hz, time_limit_s=ep.time_limit_s,
        success_radius_m=ep.success_radius_m, thresholds=thresholds)
    lost = bool(core.robots.left[i] == Status.LOST)
    return metrics.classify_failure(dataclasses.replace(features, lost=lost))


def _row(core: EpisodeCore, i: int, trajectory: np.ndarray, *, policy: str,
         lengths_m: tuple[float, float], by_tick: np.ndarray) -> EpisodeRow:
    """Robot ``i``'s row: metrics of its trajectory, counts of the episode and its cause of
    failure (``lengths_m``: its grid A* and geodesic lengths; ``by_tick``:
    :func:`positions_by_tick`)."""
    ep, goal = core.config.episode, core.goals[i]
    dt = 1.0 / ep.control_hz
    collided = bool(core.robots.collided[i])
    ok = metrics.arrived(trajectory[:, :2], goal, dt_s=dt, collided=collided,
                         success_radius_m=ep.success_radius_m, time_limit_s=ep.time_limit_s)
    length = metrics.path_length_m(trajectory[:, :2])
    optimal_m, geodesic_m = lengths_m
    return EpisodeRow(
        robot=i,
        policy=policy,
        arrived=ok,
        collided=collided,
        path_length_m=length,
        optimal_length_m=optimal_m,
        geodesic_length_m=geodesic_m,
        spl=float(metrics.spl_terms([ok], [length], [optimal_m])[0]),
        time_s=metrics.time_to_goal_s(trajectory[:, :2], goal, dt_s=dt,
                                      success_radius_m=ep.success_radius_m)
        if ok else float("nan"),
        bytes_sent=int(core.channel.bytes_sent[i]),
        messages_sent=int(core.channel.messages_sent[i]),
        **core.controller.counters(i),
        robot_contacts=int(core.robots.robot_contacts[i]),
        failure=failure_cause(core, i, trajectory, by_tick),
    )
