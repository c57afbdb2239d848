"""One swarm episode: a world, a decision policy and a seed -> one row per robot.

Each control tick ties the stages together: the PyBullet swarm's lidar scans (:mod:`fftnav.sim`)
-> the FFT pipeline (:mod:`fftnav.observe`) -> the controller (:mod:`fftnav.navigation`): by
default the Bug planner, which asks the decision policy for a side when a goal direction is
blocked (:class:`~fftnav.navigation.bugcontrol.BugController`), or any controller
(:mod:`fftnav.navigation.controllers`) -> swarm messages (:mod:`fftnav.episode.comms`) -> the
simulator advances one control period. The metrics of the rows come from :mod:`fftnav.metrics`
applied to the trajectories.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fftnav import metrics
from fftnav.config import SwarmConfig
from fftnav.episode.comms import Channel
from fftnav.episode.record import EpisodeResult, EpisodeRow
from fftnav.episode.recording import STATUS, Tape
from fftnav.navigation.bugcontrol import BugController
from fftnav.navigation.controllers import Controller, ControllerSetup, Packet, SwarmStep
from fftnav.navigation.policies import Policy
from fftnav.navigation.resolve import Resolved, registered_names, resolve
from fftnav.optimal.reference import optimal_lengths
from fftnav.plugins import PluginProxy, plugin_call, source_file
from fftnav.sim.swarm import Observation, SimConfig, SwarmSim
from fftnav.validate import check_integer
from fftnav.world.model import World

__all__ = ["OnTick", "positions_by_tick", "run_episode"]

#: ``on_tick(step, scans, commands, outgoing)`` of :func:`run_episode`: the swarm at a control
#: tick, every robot's raw lidar ranges ``(N, M)`` (m; rows of robots not in ``step.active``
#: are stale), the commands ``(N, 2)`` (v m/s, omega rad/s) and the messages sent, by robot.
OnTick = Callable[[SwarmStep, np.ndarray, np.ndarray, dict[int, bytes]], None]


def _seeds(seed: int) -> tuple[int, np.random.Generator]:
    """Everything random in an episode derives from ``seed``: the simulator's sensor-noise seed
    and the episode's generator (random policy, packet loss, pose noise)."""
    seed = check_integer("seed", seed, low=0)
    sim_ss, ep_ss = np.random.SeedSequence(seed).spawn(2)
    return int(sim_ss.generate_state(1)[0]), np.random.default_rng(ep_ss)


@functools.lru_cache(maxsize=8)
def _reference_lengths(world_json: str, r0_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid A* and geodesic lengths of a world's robots, cached: every policy run on the same map
    in this process reuses them (they take about a second or two per 20 m x 20 m map)."""
    return optimal_lengths(World.from_json(world_json), r0_m=r0_m)


@dataclass
class _Robots:
    """Per-robot state of a running episode: ``active`` robots are in the world (waiting at
    their start until their departure tick, or moving); the others arrived or failed."""

    active: np.ndarray
    collided: np.ndarray
    robot_contacts: np.ndarray
    in_contact: np.ndarray
    departure: np.ndarray
    trajectories: list[list[np.ndarray]] = field(default_factory=list)
    #: How each robot left (a code of :data:`fftnav.episode.recording.STATUS`; 0 while in it).
    left: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.uint8))

    @classmethod
    def start(cls, obs: Observation, departure: list[int]) -> _Robots:
        n = len(obs.poses)
        return cls(np.ones(n, dtype=bool), np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64),
                   np.zeros(n, dtype=bool), np.asarray(departure, dtype=np.int64),
                   [[obs.poses[i].copy()] for i in range(n)], np.zeros(n, dtype=np.uint8))

    def moving(self, tick: int) -> np.ndarray:
        """Active robots that have departed by ``tick``."""
        return self.active & (self.departure <= tick)

    def leave(self, i: int, how: str) -> None:
        """Robot ``i`` leaves the world: ``arrived``, ``collided`` or ``timed_out``."""
        self.active[i] = False
        self.left[i] = STATUS.index(how)

    def status(self, tick: int) -> np.ndarray:
        """Every robot's :data:`~fftnav.episode.recording.STATUS` code at ``tick``."""
        waiting = self.active & (self.departure > tick)
        return np.where(self.active, np.where(waiting, STATUS.index("waiting"),
                                              STATUS.index("moving")), self.left)


class _Onboard:
    """The robots' software: FFT pipeline, message channel and the controller."""

    def __init__(self, world: World, method: Resolved, config: SwarmConfig,
                 rng: np.random.Generator, tape: Tape | None = None,
                 on_tick: OnTick | None = None) -> None:
        self.config, self.rng, self.tape, self.on_tick = config, rng, tape, on_tick
        self.pipe = config.pipeline()
        n = len(world.starts)
        self.goals = np.asarray(world.goals, dtype=np.float64)
        self.channel = Channel(n, range_m=config.comms.comm_range_m,
                               loss=config.comms.packet_loss,
                               delay_ticks=config.comms.delay_ticks, rng=rng)
        setup = ControllerSetup.for_world(world, config, rng)
        plugin = method.reference not in registered_names()
        if method.policy is not None:
            policy = _guarded_policy(method) if plugin else method.policy
            self.controller: Controller = BugController(setup, policy)
        elif plugin:
            self.controller = _guarded_controller(method, setup)
        else:
            assert method.controller is not None
            self.controller = method.controller(setup)
        self.max_age_ticks = int(config.episode.control_hz)

    def _inbox(self, tick: int) -> Callable[[int], list[Packet]]:
        return lambda i: self.channel.inbox(i, tick=tick, max_age_ticks=self.max_age_ticks)

    def _unheard(self, tick: int, present: np.ndarray) -> Callable[[int], dict[int, str]]:
        return lambda i: self.channel.unheard(i, tick=tick, max_age_ticks=self.max_age_ticks,
                                              present=present)

    def commands(self, tick: int, obs: Observation, moving: np.ndarray,
                 active: np.ndarray) -> np.ndarray:
        """One control tick of every moving robot: observe, control, broadcast (to the active
        robots in range, moving or waiting)."""
        n, beams, range_m = len(moving), self.config.sensor.beams, self.config.sensor.range_m
        idx = np.flatnonzero(moving)
        ranges = np.zeros((n, beams))
        ranges[idx] = self.pipe.normalise(obs.scans[idx]) * range_m
        safe = y1 = messages = sigma = None
        if self.controller.uses_pipeline:
            res = self.pipe.process(obs.scans[idx], with_p_s=False)
            safe = np.zeros((n, beams), dtype=bool)
            y1 = np.zeros((n, beams))
            safe[idx], y1[idx] = res.safe_mask, res.y1
            messages, sigma = res.messages, res.sigma
        self.channel.deliver(tick)
        step = SwarmStep(tick=tick, time_s=obs.time_s, poses=obs.poses, goals=self.goals,
                         active=idx, ranges_m=ranges, angles_rad=self.pipe.angles_rad, safe=safe,
                         y1=y1, messages=messages, inbox=self._inbox(tick), sigma=sigma,
                         present=active, arrived=self.channel.arrived,
                         unheard=self._unheard(tick, active))
        commands, outgoing = self.controller.step(step)
        for i in sorted(outgoing):
            self.channel.broadcast(int(i), outgoing[i], tick=tick, poses=obs.poses,
                                   active=active)
        if self.tape is not None:
            self._record(step, commands, outgoing)
        if self.on_tick is not None:
            self.on_tick(step, obs.scans, commands, outgoing)
        return commands

    def _record(self, step: SwarmStep, commands: np.ndarray, outgoing: dict[int, bytes]
                ) -> None:
        """Put one tick on the tape: what the robots saw, decided, sent and received."""
        assert self.tape is not None
        status = self.robots.status(step.tick)
        self.tape.tick(step.time_s, step.poses, status, commands=commands,
                       ranges_m=step.ranges_m, safe=step.safe,
                       state={int(i): self.controller.state(int(i)) for i in step.active})
        for i in sorted(outgoing):
            self.tape.message(step.tick, int(i), outgoing[i])
        for sender, receiver, sent_tick in self.channel.delivered():
            self.tape.delivery(step.tick, sender, receiver, sent_tick)

    def advance(self, sim: SwarmSim, commands: np.ndarray, robots: _Robots,
                tick: int) -> Observation:
        """Drive the swarm one control period; count robot contacts; park robots that arrived
        or touched an obstacle."""
        idx = np.flatnonzero(robots.moving(tick))
        obs = sim.step(commands)
        robots.robot_contacts += obs.robot_contact & robots.active & ~robots.in_contact  # onsets
        robots.in_contact = obs.robot_contact & robots.active
        if self.tape is not None:
            self.tape.contacts(obs.obstacle_contact, obs.robot_contact)
        for i in idx:
            robots.trajectories[i].append(obs.poses[i].copy())
            hit = bool(obs.obstacle_contact[i])
            home = (np.hypot(*(obs.poses[i, :2] - self.goals[i]))
                    <= self.config.episode.success_radius_m)
            if hit or home:
                robots.collided[i] = hit
                robots.leave(int(i), "collided" if hit else "arrived")
                self.controller.finish(int(i))
                sim.park(int(i))
        return obs


def _guarded_policy(method: Resolved) -> Policy:
    """A plugin's decision policy whose errors are one-line PluginErrors naming it."""
    assert method.policy is not None
    decide = method.policy.decide
    name = getattr(decide, "__name__", "decide")
    return dataclasses.replace(method.policy, decide=functools.partial(
        plugin_call, method.reference, name, source_file(decide), decide))


def _guarded_controller(method: Resolved, setup: ControllerSetup) -> Controller:
    """A plugin's controller, made and then called through :class:`~fftnav.plugins.PluginProxy`
    (what it raises, in ``__init__``, ``act`` or any other call, is a one-line PluginError
    naming it, the call and its file and line)."""
    cls = method.controller
    assert cls is not None
    source = source_file(cls)
    controller = plugin_call(method.reference, f"{cls.__name__}.__init__", source, cls, setup,
                             defined=cls.__init__)
    calls = ({} if cls.step is not Controller.step  # the base's step calls act per robot
             else {"step": (f"{cls.__name__}.act", controller.act)})
    return PluginProxy(controller, method.reference, source, calls)  # type: ignore[return-value]


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
    Each control tick: the lidar scans of the active robots go through the FFT pipeline in one
    batched call (unless a controller does without it); the controller turns them into commands
    (by default the Bug planner, ``docs/planner.md``, which asks the decision policy for a side
    when a goal direction is blocked) and messages, broadcast through the channel (robots that
    met an obstacle send their compact message with ``fusion``); the simulator advances one
    control period. A robot
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
    sim_seed, rng = _seeds(seed)
    tape = Tape(world, cfg, method.name, seed, cfg.pipeline().angles_rad) if record else None
    onboard = _Onboard(world, method, cfg, rng, tape, on_tick)
    optimal, geodesic = (_reference_lengths(world.to_json(), cfg.robot.r0_m)  # unreachable: fail
                         if reference is None else reference)
    with SwarmSim(world, config=SimConfig.for_swarm(cfg), gui=gui) as sim:
        obs = sim.reset(seed=sim_seed)
        robots = onboard.robots = _Robots.start(obs, cfg.episode.departure_ticks(
            len(world.starts)))
        for i in np.flatnonzero(robots.departure > 0):
            onboard.controller.hold(int(i))
        for tick in range(cfg.episode.max_ticks + int(robots.departure.max())):
            for i in np.flatnonzero(robots.active & (robots.departure == tick) & (tick > 0)):
                onboard.controller.release(int(i))
            out_of_time = tick - robots.departure >= cfg.episode.max_ticks  # waves, staggered
            for i in np.flatnonzero(robots.active & out_of_time):
                robots.leave(int(i), "timed_out")
                onboard.controller.finish(int(i))
                sim.park(int(i))
            if not robots.active.any():
                break
            commands = onboard.commands(tick, obs, robots.moving(tick), robots.active)
            obs = onboard.advance(sim, commands, robots, tick)
        for i in np.flatnonzero(robots.active):  # out of ticks: time is up for everyone left
            robots.leave(int(i), "timed_out")
            onboard.controller.finish(int(i))
        if tape is not None:
            tape.end(obs.time_s, obs.poses, robots.status(tick + 1))
    trajectories = [np.array(t) for t in robots.trajectories]
    by_tick = positions_by_tick(trajectories, robots.departure)
    rows = [_row(i, method.name, trajectories[i], onboard, robots, float(optimal[i]),
                 float(geodesic[i]), by_tick) for i in range(len(trajectories))]
    return EpisodeResult(rows=rows, trajectories=trajectories, tape=tape)


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


def _failure(i: int, trajectory: np.ndarray, collided: bool, config: SwarmConfig,
             goal: np.ndarray, departure: int, by_tick: np.ndarray) -> str:
    """Robot ``i``'s cause of failure (empty if it arrived), the other robots aligned by tick."""
    others = np.delete(by_tick[departure:departure + len(trajectory)], i, axis=1)
    ep = config.episode
    thresholds = metrics.FailureThresholds.for_robot(r0_m=config.robot.r0_m,
                                                     v_max_mps=config.robot.v_max_mps)
    return metrics.classify_failure(metrics.failure_features(
        trajectory, goal, collided=collided, others=others, dt_s=1.0 / ep.control_hz,
        time_limit_s=ep.time_limit_s, success_radius_m=ep.success_radius_m,
        thresholds=thresholds))


def _row(i: int, policy: str, trajectory: np.ndarray, onboard: _Onboard, robots: _Robots,
         optimal_m: float, geodesic_m: float, by_tick: np.ndarray) -> EpisodeRow:
    """Robot ``i``'s row: metrics of its trajectory, counts of the episode and its cause of
    failure (``by_tick``: :func:`positions_by_tick`)."""
    ep, goal = onboard.config.episode, onboard.goals[i]
    dt = 1.0 / ep.control_hz
    collided = bool(robots.collided[i])
    ok = metrics.arrived(trajectory[:, :2], goal, dt_s=dt, collided=collided,
                         success_radius_m=ep.success_radius_m, time_limit_s=ep.time_limit_s)
    length = metrics.path_length_m(trajectory[:, :2])
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
        bytes_sent=int(onboard.channel.bytes_sent[i]),
        messages_sent=int(onboard.channel.messages_sent[i]),
        **onboard.controller.counters(i),
        robot_contacts=int(robots.robot_contacts[i]),
        failure=_failure(i, trajectory, collided, onboard.config, goal,
                         int(robots.departure[i]), by_tick),
    )
