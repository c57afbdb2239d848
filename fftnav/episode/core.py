"""One swarm episode advanced one control tick at a time: the core both drivers share.

:class:`EpisodeCore` holds an episode's simulator (:class:`~fftnav.sim.swarm.SwarmSim`), the
robots' FFT pipeline, the message channel (:class:`~fftnav.episode.comms.Channel`), the
controller's hooks and the rule of the episode: when a robot departs, arrives, collides or runs
out of time, and what then happens to it. :func:`fftnav.episode.loop.run_episode` drives it with
the episode's controller (:meth:`EpisodeCore.run`); :class:`fftnav.envs.SwarmNavEnv` drives it
with the agents' actions. A control tick is

1. :meth:`~EpisodeCore.begin_tick`: robots whose departure tick it is depart
   (:meth:`Controller.release <fftnav.navigation.controllers.Controller.release>`), robots whose
   time is up leave the world;
2. :meth:`~EpisodeCore.observe`: the moving robots' scans go through the pipeline, the channel
   delivers the packets due, and the swarm is a :class:`~fftnav.navigation.controllers.SwarmStep`;
3. commands and messages are chosen from it (the controller's
   :meth:`~fftnav.navigation.controllers.Controller.step`, or the agents' actions);
4. :meth:`~EpisodeCore.advance`: the messages are broadcast, the tick goes on the recording's
   tape and to ``on_tick``, the simulator drives the robots one control period, and the rule
   takes out the robots that arrived or touched an obstacle.

Every robot has a :class:`fftnav.states.Status` at every tick: waiting at its start until its
departure tick (``episode.departure``), moving, then arrived (within ``success_radius_m`` of its
goal), collided (touched an obstacle; a collision outranks an arrival in the same period),
timed out (``episode.time_limit_s`` after its departure) or lost (with ``localization.mode =
"odometry"``: it stopped where its estimate said its goal was, within
``localization.stop_radius_m``, and its goal was not within ``success_radius_m``). The rule judges
the true poses; the controller sees only the poses the robots know
(:class:`~fftnav.episode.localize.Localizer`: the true ones, or their odometry's estimates), and
each packet places its sender where its receiver measures it. A robot that leaves is parked
(taken out of the world) and the controller's ``finish(robot)`` is called, once for every
robot.
"""

from __future__ import annotations

import inspect
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.episode.comms import Channel
from fftnav.episode.localize import Localizer, localization_rng
from fftnav.episode.recording import Tape
from fftnav.errors import FftnavError
from fftnav.navigation.controllers import Controller, ControllerSetup, Packet, SwarmStep
from fftnav.sim.swarm import Observation, SwarmSim
from fftnav.states import Status
from fftnav.validate import check_integer
from fftnav.world.model import World

__all__ = ["EpisodeCore", "OnTick", "Robots", "Sensed", "episode_seeds"]

#: ``on_tick(step, scans, commands, outgoing, truth)``: the swarm at a control tick (its poses
#: those the robots know), every robot's raw lidar ranges ``(N, M)`` (m; rows of robots not in
#: ``step.active`` are stale), the commands ``(N, 2)`` (v m/s, omega rad/s), the messages sent,
#: by robot, and the true poses ``(N, 3)`` (the same as ``step.poses`` with exact
#: localization; a hook of four arguments is called without them). A hook observes the episode
#: for the benchmark (a bag, a log): unlike a controller, it may see the truth.
OnTick = Callable[..., None]


def _takes_truth(hook: Callable[..., None]) -> bool:
    """Whether an ``on_tick`` hook takes the true poses (a fifth argument, or ``*args``); a
    hook of four arguments is called without them."""
    try:
        params = inspect.signature(hook).parameters.values()
    except (TypeError, ValueError):  # a builtin without a signature: the full call
        return True
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 5 or any(p.kind is p.VAR_POSITIONAL for p in params)


def episode_seeds(seed: int) -> tuple[int, np.random.Generator]:
    """The simulator's sensor-noise seed and the episode's generator (decision policies, packet
    loss, pose noise), both derived from the episode's ``seed``.

    >>> sim_seed, rng = episode_seeds(7)
    >>> sim_seed == episode_seeds(7)[0], rng.random() == episode_seeds(7)[1].random()
    (True, True)
    """
    seed = check_integer("seed", seed, low=0)
    sim_ss, ep_ss = np.random.SeedSequence(seed).spawn(2)
    return int(sim_ss.generate_state(1)[0]), np.random.default_rng(ep_ss)


@dataclass
class Robots:
    """Every robot's place in a running episode: ``active`` robots are in the world (waiting at
    their start until their departure tick, or moving); the others left it, as ``left`` says.

    >>> from fftnav.states import Status
    >>> robots = Robots(np.ones(2, bool), np.zeros(2, bool), np.zeros(2, np.int64),
    ...                 np.zeros(2, bool), np.array([0, 5]), left=np.zeros(2, np.uint8))
    >>> robots.leave(0, Status.ARRIVED)
    >>> [Status(s).label for s in robots.status(3)]
    ['arrived', 'waiting']
    """

    active: np.ndarray
    collided: np.ndarray
    robot_contacts: np.ndarray
    in_contact: np.ndarray
    departure: np.ndarray
    #: Each robot's poses, from its departure on, one per control tick.
    trajectories: list[list[np.ndarray]] = field(default_factory=list)
    #: The :class:`~fftnav.states.Status` with which each robot left (0 while it is in the world).
    left: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.uint8))

    @classmethod
    def start(cls, obs: Observation, departure: list[int]) -> Robots:
        """Every robot at its start, in the world, departing at its tick of ``departure``."""
        n = len(obs.poses)
        return cls(np.ones(n, dtype=bool), np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64),
                   np.zeros(n, dtype=bool), np.asarray(departure, dtype=np.int64),
                   [[obs.poses[i].copy()] for i in range(n)], np.zeros(n, dtype=np.uint8))

    def moving(self, tick: int) -> np.ndarray:
        """Active robots that have departed by ``tick``."""
        return self.active & (self.departure <= tick)

    def leave(self, i: int, how: Status) -> None:
        """Robot ``i`` leaves the world: ``ARRIVED``, ``COLLIDED``, ``TIMED_OUT`` or ``LOST``."""
        self.active[i] = False
        self.left[i] = int(how)

    def status(self, tick: int) -> np.ndarray:
        """Every robot's :class:`~fftnav.states.Status` code at ``tick``."""
        waiting = self.active & (self.departure > tick)
        return np.where(self.active, np.where(waiting, int(Status.WAITING), int(Status.MOVING)),
                        self.left)


@dataclass(frozen=True)
class Sensed:
    """What some robots' scans give at one tick: rows of all N robots, zero for the others.

    Attributes
    ----------
    ranges_m : ndarray, (N, M)
        Sanitised ranges (m; no return reads R, blind and invalid beams 0).
    safe, y1 : ndarray (N, M) or None
        The FFT pipeline's safe mask and filtered scan (None without the pipeline).
    messages, sigma : list or None
        Each robot's compact message and extrema, in the order of the robots asked for.
    """

    ranges_m: np.ndarray
    safe: np.ndarray | None = None
    y1: np.ndarray | None = None
    messages: list[bytes] | None = None
    sigma: list[np.ndarray] | None = None


class EpisodeCore:
    """One episode of ``world``'s swarm, advanced a control tick at a time (module docstring).

    The episode starts when the core is made: the simulator is reset (robots at their starts)
    and the robots departing later are held (``controller.hold``).

    Parameters
    ----------
    world : World
        Obstacles, starts and goals (one robot per start).
    config : SwarmConfig
        Robot, sensor, communication and episode parameters.
    sim : SwarmSim
        The simulator of ``world`` (made for ``config``: :meth:`SimConfig.for_swarm
        <fftnav.sim.swarm.SimConfig.for_swarm>`); the core resets it, its owner closes it.
    seed : int
        The episode's seed (:func:`episode_seeds`).
    controller : callable, optional
        ``ControllerSetup -> Controller``, e.g. :meth:`fftnav.navigation.resolve.Resolved.make`:
        the controller whose hooks (``hold``, ``release``, ``finish``, ``state``) the episode
        calls and that :meth:`run` drives; default: the base :class:`Controller`, whose hooks do
        nothing (the commands then come from elsewhere, e.g. an environment's agents).
    tape : Tape, optional
        Keeps every tick (``run_episode(record=True)``).
    on_tick : OnTick, optional
        Called at every tick after the commands are chosen, before the simulator advances.
    collisions_end : bool
        Whether touching an obstacle ends a robot (default); otherwise it keeps driving.
    """

    def __init__(self, world: World, config: SwarmConfig, sim: SwarmSim, *, seed: int,
                 controller: Callable[[ControllerSetup], Controller] | None = None,
                 tape: Tape | None = None, on_tick: OnTick | None = None,
                 collisions_end: bool = True) -> None:
        n = len(world.starts)
        config.episode.check_departures(n)
        sim_seed, self.rng = episode_seeds(seed)
        self.world, self.config, self.sim = world, config, sim
        self.tape, self.on_tick, self.collisions_end = tape, on_tick, bool(collisions_end)
        self._tick_truth = on_tick is not None and _takes_truth(on_tick)
        self.pipe = config.pipeline()
        self.goals = np.asarray(world.goals, dtype=np.float64)
        self.channel = Channel(n, range_m=config.comms.comm_range_m,
                               loss=config.comms.packet_loss,
                               delay_ticks=config.comms.delay_ticks, rng=self.rng)
        #: What the controller was made from: the world's facts and the episode's generator.
        self.setup = ControllerSetup.for_world(world, config, self.rng)
        self.controller: Controller = (Controller if controller is None else controller)(
            self.setup)
        self.max_age_ticks = int(config.episode.control_hz)
        #: The simulator's latest observation (true poses) and the current control tick.
        self.obs = sim.reset(seed=sim_seed)
        self.tick = 0
        self.robots = Robots.start(self.obs, config.episode.departure_ticks(n))
        #: What the robots know of their poses (exact, or their odometry's estimates).
        last_tick = config.episode.max_ticks + int(self.robots.departure.max())
        self.localizer = Localizer(config, self.obs.poses, localization_rng(seed),
                                   ticks=last_tick)
        #: The swarm as :meth:`observe` saw it at the current tick (None before).
        self.swarm: SwarmStep | None = None
        #: Seconds of the method's own compute (the FFT pipeline, when the controller uses it,
        #: and the controller's ``step``), and robot-ticks observed: what
        #: :attr:`EpisodeResult.compute_ms` divides (wall clock, so it varies run to run).
        self.compute_s = 0.0
        self.robot_ticks = 0
        for i in np.flatnonzero(self.robots.departure > 0):
            self.controller.hold(int(i))

    # -- the tick ----------------------------------------------------------------------------

    def begin_tick(self) -> bool:
        """Start the current tick: robots whose departure tick it is depart, robots whose time
        is up (``max_ticks`` after their departure) leave; whether any robot is still in the
        world."""
        robots, tick = self.robots, self.tick
        for i in np.flatnonzero(robots.active & (robots.departure == tick) & (tick > 0)):
            self.controller.release(int(i))
        out_of_time = tick - robots.departure >= self.config.episode.max_ticks
        for i in np.flatnonzero(robots.active & out_of_time):
            self._leave(int(i), Status.TIMED_OUT)
        return bool(robots.active.any())

    def observe(self, *, pipeline: bool | None = None) -> SwarmStep:
        """The swarm at the current tick (kept as :attr:`swarm`): the moving robots' scans
        through the pipeline (``pipeline``: default, the controller's ``uses_pipeline``), the
        packets due delivered."""
        robots, tick, obs = self.robots, self.tick, self.obs
        idx = np.flatnonzero(robots.moving(tick))
        self.robot_ticks += len(idx)
        sensed = self.sense(idx, pipeline=(self.controller.uses_pipeline if pipeline is None
                                           else pipeline))
        self.channel.deliver(tick)
        self.swarm = SwarmStep(
            tick=tick, time_s=obs.time_s, poses=self.localizer.poses(obs.poses),
            goals=self.goals, active=idx,
            ranges_m=sensed.ranges_m, angles_rad=self.pipe.angles_rad, safe=sensed.safe,
            y1=sensed.y1, messages=sensed.messages, inbox=self._inbox(tick), sigma=sensed.sigma,
            present=robots.active, arrived=self.channel.arrived,
            unheard=self._unheard(tick, robots.active))
        return self.swarm

    def sense(self, idx: np.ndarray, *, pipeline: bool) -> Sensed:
        """What the latest scans of robots ``idx`` give (the others' rows are zero)."""
        n, beams = len(self.goals), self.config.sensor.beams
        scans = self.obs.scans
        ranges = np.zeros((n, beams))
        ranges[idx] = self.pipe.normalise(scans[idx]) * self.config.sensor.range_m
        if not pipeline:
            return Sensed(ranges)
        begin = time.perf_counter()
        res = self.pipe.process(scans[idx], with_p_s=False)
        self.compute_s += time.perf_counter() - begin
        safe = np.zeros((n, beams), dtype=bool)
        y1 = np.zeros((n, beams))
        safe[idx], y1[idx] = res.safe_mask, res.y1
        return Sensed(ranges, safe, y1, res.messages, res.sigma)

    def advance(self, commands: np.ndarray, outgoing: Mapping[int, bytes]) -> Observation:
        """End the current tick with ``commands`` ``(N, 2)`` (v m/s, w rad/s) and the messages
        ``outgoing`` (robot -> bytes): broadcast them (to the robots in the world within range),
        record the tick, call ``on_tick``, drive the swarm one control period, then take out
        the robots that arrived or touched an obstacle. The next tick is then current."""
        if self.swarm is None or self.swarm.tick != self.tick:
            raise FftnavError(f"advance() needs the swarm of tick {self.tick}: call observe() "
                              f"first, got the swarm of tick "
                              f"{None if self.swarm is None else self.swarm.tick}")
        step, robots, localizer = self.swarm, self.robots, self.localizer
        outgoing = dict(outgoing)
        locate = localizer.locate if localizer.odometry else None
        for i in sorted(outgoing):
            self.channel.broadcast(int(i), outgoing[i], tick=self.tick, poses=self.obs.poses,
                                   active=robots.active, locate=locate)
        if self.tape is not None:
            self._record(step, commands, outgoing)
        if self.on_tick is not None:
            self.on_tick(step, self.obs.scans, commands, outgoing,
                         *((self.obs.poses,) if self._tick_truth else ()))
        idx = np.flatnonzero(robots.moving(self.tick))
        before = self.obs.poses
        obs = self.obs = self.sim.step(commands)
        localizer.moved(before, obs.poses, idx)
        robots.robot_contacts += obs.robot_contact & robots.active & ~robots.in_contact  # onsets
        robots.in_contact = obs.robot_contact & robots.active
        if self.tape is not None:
            self.tape.contacts(obs.obstacle_contact, obs.robot_contact)
        for i in idx:
            robots.trajectories[i].append(obs.poses[i].copy())
            self._judge(int(i))
        self.tick += 1
        return obs

    def _judge(self, i: int) -> None:
        """The rule after a control period, on the true poses: robot ``i`` collided if it
        touched an obstacle (``collisions_end``), else arrived if it is within
        ``success_radius_m`` of its goal, else is lost if it stops believing it is there
        (odometry mode: its estimate within ``localization.stop_radius_m`` of its goal)."""
        obs, radius = self.obs, self.config.episode.success_radius_m
        hit = bool(obs.obstacle_contact[i])
        home = np.hypot(*(obs.poses[i, :2] - self.goals[i])) <= radius
        if hit and self.collisions_end:
            self.robots.collided[i] = True
            self._leave(i, Status.COLLIDED)
        elif home and not hit:
            self._leave(i, Status.ARRIVED)
        elif (self.localizer.odometry and not hit
              and np.hypot(*(self.localizer.poses(obs.poses)[i, :2] - self.goals[i]))
              <= self.config.localization.stop_radius_m):
            self._leave(i, Status.LOST)

    def _leave(self, i: int, how: Status) -> None:
        self.robots.leave(i, how)
        self.controller.finish(i)
        self.sim.park(i)

    def end(self) -> None:
        """End the episode: the time is up for every robot still in the world; the tape's last
        tick."""
        for i in np.flatnonzero(self.robots.active):
            self._leave(int(i), Status.TIMED_OUT)
        if self.tape is not None:
            self.tape.end(self.obs.time_s, self.obs.poses, self.status(),
                          estimates=self.localizer.estimates)

    def run(self) -> None:
        """Run the episode to its end with its controller's commands and messages."""
        while self.begin_tick():
            step = self.observe()
            begin = time.perf_counter()
            commands, outgoing = self.controller.step(step)
            self.compute_s += time.perf_counter() - begin
            self.advance(commands, outgoing)
        self.end()

    # -- what the episode shows --------------------------------------------------------------

    def status(self) -> np.ndarray:
        """Every robot's :class:`~fftnav.states.Status` code at the current tick."""
        return self.robots.status(self.tick)

    def trajectories(self) -> list[np.ndarray]:
        """Each robot's poses ``(T_i, 3)`` from its departure on, one per control tick."""
        return [np.array(t) for t in self.robots.trajectories]

    def _inbox(self, tick: int) -> Callable[[int], list[Packet]]:
        return lambda i: self.channel.inbox(i, tick=tick, max_age_ticks=self.max_age_ticks)

    def _unheard(self, tick: int, present: np.ndarray) -> Callable[[int], dict[int, str]]:
        return lambda i: self.channel.unheard(i, tick=tick, max_age_ticks=self.max_age_ticks,
                                              present=present)

    def _record(self, step: SwarmStep, commands: np.ndarray, outgoing: dict[int, bytes]
                ) -> None:
        """Put one tick on the tape: what the robots saw, decided, sent and received."""
        assert self.tape is not None
        self.tape.tick(step.time_s, self.obs.poses, self.robots.status(step.tick),
                       estimates=self.localizer.estimates, commands=commands,
                       ranges_m=step.ranges_m, safe=step.safe,
                       state={int(i): self.controller.state(int(i)) for i in step.active})
        for i in sorted(outgoing):
            self.tape.message(step.tick, int(i), outgoing[i])
        for sender, receiver, sent_tick in self.channel.delivered():
            self.tape.delivery(step.tick, sender, receiver, sent_tick)
