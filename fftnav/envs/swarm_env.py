"""``SwarmNavEnv``: the fftnav swarm as a PettingZoo ``ParallelEnv`` for multi-agent learning.

The environment drives the same episode core as the benchmark's episodes
(:class:`fftnav.episode.core.EpisodeCore`: simulator, FFT pipeline, message channel, and the rule
of departures, arrivals, collisions and the time limit), with the agents' actions as commands.

Agents ``robot_0 .. robot_{K-1}``, one per start of the world; ``agents`` are the robots in the
world (waiting at their start or moving). Every step each agent sends ``(v_mps, w_radps)`` (a
``Box`` within the robot's limits) and receives a ``Dict`` observation. ``step(actions)`` takes a
dict mapping agents to finite arrays of shape ``(2,)`` (an agent without an action stands still;
an agent waiting to depart, ``episode.departure``, stands still whatever its action); anything
else, NaN or inf included, is a ``ValueError`` naming the agent. Finite values outside the
``Box`` are clipped to the robot's speed limits by the simulator (as Gymnasium's
``ClipAction``). The observation:

``scan``
    its lidar ranges (m, ``float32``, ``(M,)``; no return reads R, blind beams 0);
``goal``
    its goal in its own frame, ``(x_m, y_m)`` (x ahead, y to the left), from the pose it
    knows (with ``localization.mode = "odometry"``, its odometry's estimate);
``safe_mask`` (``Observations(safe_mask=True)``)
    the FFT pipeline's safe beams (``MultiBinary(M)``);
``messages``, ``neighbours`` (``Observations(max_neighbours > 0)``)
    the latest compressed observations received from up to ``max_neighbours`` neighbours (raw
    bytes, zero-padded to ``MESSAGE_BYTES``, ``uint8``) and the senders' poses relative to the
    receiver ``(x_m, y_m, yaw_rad)`` (zeros where there is no message; with odometry, as the
    receiver measured them). Every moving robot
    broadcasts its compact message as ``comms.broadcast`` says (``on_obstacle``: when the goal
    direction is not safe; ``every_tick``) through the same lossy, delayed, range-limited
    channel as the benchmark's ``fusion``.

Rewards (:class:`Rewards`, configurable; judged on the true poses, like the benchmark, with
odometry too): ``progress`` times the decrease of the distance to the goal over the step (m),
plus ``arrival`` once on arrival (within ``success_radius_m``), plus ``collision`` (negative)
once on touching an obstacle, plus ``step`` every step. An agent terminates on arrival,
collision or, with odometry, when it stops where its estimate says its goal is and it is not
(lost; it is then parked out of the world;
``terminate_on_collision=False`` keeps it driving, with the collision reward on every step in
contact) and is truncated at the time limit (``episode.time_limit_s`` after its departure).
``infos`` give each agent's ``arrived``, ``collided``, ``goal_distance_m`` and true ``pose``
``(x_m, y_m, yaw_rad)`` after the step: the benchmark's judgement, not an observation (with
odometry a policy that read them would know more than its robot). ``render_mode="rgb_array"``
returns a top-down frame drawn like ``fftnav replay``'s, with the clock, a legend and the scan
of the robot ``render_robot`` (:meth:`SwarmNavEnv.render`).

``reset(seed=..., options=...)``: ``seed`` seeds the episode (sensor noise, packet loss);
``options`` may set ``world_kind``, ``map_seed``, ``robots``, ``controller`` and any config key
(``"packet_loss"``, ``"sensor.range_m"``, ...; :meth:`fftnav.config.SwarmConfig.replace`); a bad
value raises ``ValueError``, a key that is none of these is ignored with a warning (PettingZoo's
API test passes arbitrary options). A new world is generated (and the simulator rebuilt) only
when the kind, map seed, robots or a config key of the simulator changes.

A scripted controller drives the environment as it drives an episode: ``options={"controller":
NAME}`` (a decision policy or controller, :func:`fftnav.navigation.resolve.resolve`) makes it
from the episode's :class:`~fftnav.navigation.controllers.ControllerSetup`, as
:func:`~fftnav.episode.loop.run_episode` does, and the episode calls its ``hold``, ``release``
and ``finish``; each step, its commands and messages come from the swarm the environment
exposes (:attr:`SwarmNavEnv.controller`, :attr:`SwarmNavEnv.core`):

>>> from fftnav.envs import SwarmNavEnv
>>> env = SwarmNavEnv("forest", map_seed=3, robots=2)
>>> _ = env.reset(seed=0, options={"controller": "bug-left", "time_limit_s": 0.5})
>>> while env.agents:
...     commands, outgoing = env.controller.step(env.core.swarm)
...     _ = env.step({a: commands[env.index(a)] for a in env.agents},
...                  messages={env.possible_agents[i]: m for i, m in outgoing.items()})
>>> env.core.tick, [s.label for s in env.statuses()]
(5, ['timed_out', 'timed_out'])
>>> env.close()
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from fftnav.config import SwarmConfig
from fftnav.episode.core import EpisodeCore
from fftnav.errors import FftnavError
from fftnav.navigation.resolve import Resolved, resolve
from fftnav.observe.safe import beam_index
from fftnav.observe.scan import wrap_angle
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.states import Status
from fftnav.validate import Checked, check_choice, check_integer, integer_field, number_field
from fftnav.world import World, generate_world

__all__ = ["MESSAGE_BYTES", "Observations", "Rewards", "SwarmNavEnv"]

#: Size of a message slot in the observation (the compact message of up to 31 extrema).
MESSAGE_BYTES = 128

@dataclass(frozen=True)
class Rewards(Checked):
    """Reward terms: ``progress`` per metre of progress to the goal, ``arrival`` once on arrival,
    ``collision`` once on touching an obstacle, ``step`` every step."""

    progress: float = number_field(1.0)
    arrival: float = number_field(10.0)
    collision: float = number_field(-10.0)
    step: float = number_field(0.0)


@dataclass(frozen=True)
class Observations(Checked):
    """What an agent observes beside its scan and goal: ``safe_mask``, the FFT pipeline's safe
    beams; ``max_neighbours``, message slots (0: no messages, nothing is broadcast).

    >>> Observations(safe_mask=True, max_neighbours=4).pipeline
    True
    """

    safe_mask: bool = False
    max_neighbours: int = integer_field(0, low=0)

    @property
    def pipeline(self) -> bool:
        """Whether they need the FFT pipeline."""
        return bool(self.safe_mask or self.max_neighbours)


def _real(values: Any) -> np.ndarray | None:
    """``values`` as float64 if they are real numbers (integers or floats), else None (complex,
    boolean, text and objects are not actions; numpy would cast complex with a warning)."""
    raw = np.asarray(values)
    if raw.dtype.kind not in "iuf":
        return None
    return raw.astype(np.float64)


def _is_config_key(key: Any) -> bool:
    try:
        SwarmConfig.locate(key)
    except (ValueError, TypeError, AttributeError):
        return False
    return True


@functools.lru_cache(maxsize=4)
def _world(kind: str, map_seed: int, robots: int, r0_m: float) -> World:
    return generate_world(kind, map_seed, robots=robots, robot_radius_m=r0_m)


class SwarmNavEnv(ParallelEnv):
    """The swarm navigation task as a PettingZoo parallel environment.

    Parameters
    ----------
    world : str or World
        A registered world kind (``forest``, ``rocky``, ...), generated from ``map_seed`` and
        ``robots``; or a fixed world (e.g. an imported ROS map).
    map_seed : int
        Seed of the generated world.
    robots : int
        Robots (agents) of a generated world.
    config : SwarmConfig, optional
        Robot, sensor, comms and episode parameters (default: the paper's).
    rewards : Rewards, optional
    observations : Observations, optional
        The safe mask and the message slots in the observations (default: neither).
    terminate_on_collision : bool
        End an agent when it touches an obstacle (default, as in the benchmark); with False it
        keeps driving and gets the collision reward on every step in contact.
    render_mode : {None, "rgb_array"}

    Attributes
    ----------
    render_robot : int or None
        The robot whose scan, safe sectors and state :meth:`render` draws, ringed (robot 0 at
        first; None: none); set it to pick another.
    """

    metadata = {"render_modes": ["rgb_array"], "name": "fftnav_swarm_v1",
                "is_parallelizable": True, "render_fps": 10}

    def __init__(self, world: str | World = "forest", *, map_seed: int = 0, robots: int = 15,
                 config: SwarmConfig | None = None, rewards: Rewards | None = None,
                 observations: Observations | None = None,
                 terminate_on_collision: bool = True,
                 render_mode: str | None = None) -> None:
        self.render_mode = check_choice("render_mode", render_mode, (None, "rgb_array"))
        self.render_robot = 0
        self.rewards = rewards or Rewards()
        self.observations = observations or Observations()
        self.terminate_on_collision = bool(terminate_on_collision)
        if not isinstance(world, (str, World)):
            raise FftnavError(f"world must be a world kind (str) or a World, got "
                              f"world={world!r:.80}")
        self._fixed_world = world if isinstance(world, World) else None
        self._kind = "forest" if self._fixed_world is not None else world
        self._map_seed = check_integer("map_seed", map_seed, low=0)
        self._robots = check_integer("robots", robots, low=1)
        self._base_config = config or SwarmConfig()
        self.config = self._base_config
        self.world = self._fixed_world or _world(self._kind, self._map_seed, self._robots,
                                                 self.config.robot.r0_m)
        self._sim: SwarmSim | None = None
        self._sim_key: tuple[Any, ...] | None = None
        self._core: EpisodeCore | None = None
        self._method: Resolved | None = None
        self._own_messages: dict[int, bytes] = {}
        self._renderer: Any = None
        self._renderer_key: tuple[Any, ...] | None = None
        #: The failure causes of the robots that failed in this episode (render), by robot.
        self._causes: dict[int, str] = {}
        self._set_agents()
        self.agents: list[str] = []

    @property
    def render_robot(self) -> int | None:
        """The robot whose scan, safe sectors and state :meth:`render` draws (None: none); a
        robot the world does not have draws none."""
        return self._render_robot

    @render_robot.setter
    def render_robot(self, robot: int | None) -> None:
        self._render_robot = None if robot is None else check_integer("render_robot", robot,
                                                                       low=0)

    # -- spaces ------------------------------------------------------------------------------

    def _set_agents(self) -> None:
        self.possible_agents = [f"robot_{i}" for i in range(len(self.world.starts))]
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self._obs_space = self._make_observation_space()
        self._act_space = self._make_action_space()

    def _make_observation_space(self) -> spaces.Dict:
        cfg = self.config
        m, r = cfg.sensor.beams, cfg.sensor.range_m
        w, h = self.world.size_m
        reach = float(math.hypot(w, h))
        items: dict[str, spaces.Space] = {
            "scan": spaces.Box(0.0, r, (m,), np.float32),
            "goal": spaces.Box(-reach, reach, (2,), np.float32),
        }
        if self.observations.safe_mask:
            items["safe_mask"] = spaces.MultiBinary(m)
        if self.observations.max_neighbours:
            n = self.observations.max_neighbours
            items["messages"] = spaces.Box(0, 255, (n, MESSAGE_BYTES), np.uint8)
            items["neighbours"] = spaces.Box(
                np.array([[-reach, -reach, -math.pi]] * n, np.float32),
                np.array([[reach, reach, math.pi]] * n, np.float32), dtype=np.float32)
        return spaces.Dict(items)

    def _make_action_space(self) -> spaces.Box:
        v, w = self.config.robot.v_max_mps, self.config.robot.w_max_radps
        return spaces.Box(np.array([-v, -w], np.float32), np.array([v, w], np.float32),
                          dtype=np.float32)

    def observation_space(self, agent: str) -> spaces.Dict:
        return self._obs_space

    def action_space(self, agent: str) -> spaces.Box:
        return self._act_space

    def index(self, agent: str) -> int:
        """The robot index of ``agent`` (its start in the world)."""
        try:
            return self._index[agent]
        except (KeyError, TypeError):  # not an agent: the error naming the choices
            return self._index[check_choice("agent", agent, self.possible_agents)]

    # -- what a scripted controller sees -----------------------------------------------------

    @property
    def core(self) -> EpisodeCore | None:
        """The episode being run (None before :meth:`reset`): its ``swarm`` is the
        :class:`~fftnav.navigation.controllers.SwarmStep` of the current tick, what a
        controller's ``step`` takes."""
        return self._core

    @property
    def controller(self) -> Any:
        """The controller named by ``reset(options={"controller": ...})``, or None."""
        return None if self._method is None or self._core is None else self._core.controller

    def statuses(self) -> list[Status]:
        """Every robot's :class:`~fftnav.states.Status` at the current tick."""
        if self._core is None:
            raise FftnavError("statuses() needs an episode: call reset() first")
        return [Status(int(s)) for s in self._core.status()]

    # -- episode -----------------------------------------------------------------------------

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, Any]]]:
        method = self._configure(dict(options or {}))
        if seed is None:
            seed = int(np.random.SeedSequence().generate_state(1)[0])
        seed = check_integer("seed", seed, low=0)
        sim_config = SimConfig.for_swarm(self.config)
        key = (self.world.to_json(), sim_config)
        if self._sim is None or key != self._sim_key:
            if self._sim is not None:
                self._sim.close()
            self._sim, self._sim_key = SwarmSim(self.world, config=sim_config), key
            self._set_agents()
        self._method = method
        core = self._core = EpisodeCore(
            self.world, self.config, self._sim, seed=seed,
            controller=None if method is None else method.make,
            collisions_end=self.terminate_on_collision)
        self._causes = {}
        core.begin_tick()
        core.observe(pipeline=self._pipeline())
        self._dist = self._goal_distance()
        self.agents = [a for a in self.possible_agents if core.robots.active[self._index[a]]]
        return self._observe(self.agents), {a: {} for a in self.agents}

    def _configure(self, options: dict[str, Any]) -> Resolved | None:
        """Apply ``reset``'s options: the world, the config; the controller they name."""
        kind = options.pop("world_kind", self._kind)
        map_seed = check_integer("map_seed", options.pop("map_seed", self._map_seed), low=0)
        robots = check_integer("robots", options.pop("robots", self._robots), low=1)
        controller = options.pop("controller", None)
        method = None if controller is None else resolve(controller)
        known = {k: v for k, v in options.items() if _is_config_key(k)}
        for key in options.keys() - known.keys():  # PettingZoo's API test passes arbitrary keys
            warnings.warn(f"SwarmNavEnv.reset ignores the unknown option {key!r}", stacklevel=3)
        self.config = self._base_config.replace(known) if known else self._base_config
        if self._fixed_world is None:
            self.world = _world(kind, map_seed, robots, self.config.robot.r0_m)
        return method

    def _pipeline(self) -> bool:
        """Whether the episode runs the FFT pipeline: for the observations or the controller."""
        assert self._core is not None
        return self.observations.pipeline or (self._method is not None
                                         and bool(self._core.controller.uses_pipeline))

    def _goal_distance(self) -> np.ndarray:
        assert self._core is not None
        return np.hypot(*(self._core.obs.poses[:, :2] - self._core.goals).T)

    def _commands(self, actions: Mapping[str, Any]) -> np.ndarray:
        """The agents' actions as commands ``(K, 2)`` (zero for an agent without one or not
        moving); a value that is not a dict of agents to finite ``(2,)`` arrays is a ValueError
        naming it."""
        if not isinstance(actions, Mapping):
            raise FftnavError(f"actions must be a dict mapping each agent to an array "
                              f"(v_mps, w_radps) of shape (2,), got {type(actions).__name__}")
        assert self._core is not None
        moving = self._core.robots.moving(self._core.tick)
        commands = np.zeros((len(self.possible_agents), 2))
        # every action checked at once; anything wrong is found and named agent by agent below
        try:
            idx = np.array([self._index[agent] for agent in actions], dtype=np.intp)
            values = _real(list(actions.values()))
        except (KeyError, TypeError, ValueError):
            values = None
        if values is not None and values.shape == (len(idx), 2) and np.isfinite(values).all():
            keep = moving[idx]
            commands[idx[keep]] = values[keep]
            return commands
        for agent, action in actions.items():
            i = self.index(agent)
            try:
                value = _real(action)
            except (TypeError, ValueError):
                value = None
            if value is None and np.iscomplexobj(action):
                raise FftnavError(f"actions[{agent!r}] must be real numbers (v_mps, w_radps), "
                                  f"got complex values: {action!r:.80}")
            if value is None or value.shape != (2,):
                shape = "no number array" if value is None else f"shape {value.shape}"
                raise FftnavError(f"actions[{agent!r}] must be an array (v_mps, w_radps) of "
                                  f"shape (2,), got {shape}: {action!r:.80}")
            if not np.isfinite(value).all():
                raise FftnavError(f"actions[{agent!r}] must be finite, got {value.tolist()}")
            if moving[i]:
                commands[i] = value
        return commands

    def _outgoing(self, messages: Mapping[str, Any] | None) -> dict[int, bytes]:
        """The messages broadcast this tick, by robot: ``messages`` (agent -> bytes) if given,
        else the environment's own (``Observations.max_neighbours``)."""
        if messages is None:
            return self._own_messages
        if not isinstance(messages, Mapping):
            raise FftnavError(f"messages must be a dict mapping agents to bytes, got "
                              f"{type(messages).__name__}")
        outgoing = {}
        for agent, payload in messages.items():
            if not isinstance(payload, (bytes, bytearray)):
                raise FftnavError(f"messages[{agent!r}] must be bytes, got "
                                  f"{type(payload).__name__}")
            outgoing[self.index(agent)] = bytes(payload)
        return outgoing

    def step(self, actions: dict[str, Any], messages: Mapping[str, bytes] | None = None
             ) -> tuple[dict, dict, dict, dict, dict]:
        """One control tick: every agent's action (``actions``, agent -> ``(v_mps, w_radps)``)
        and, optionally, the messages the robots broadcast (``messages``, agent -> bytes, e.g.
        a scripted controller's; default: the environment's own, ``Observations``)."""
        core = self._core
        if self._sim is None or core is None or not self.agents:
            raise FftnavError("step() needs a live episode: call reset() first")
        commands = self._commands(actions)
        outgoing = self._outgoing(messages)
        agents = list(self.agents)
        moving = core.robots.moving(core.tick)
        core.advance(commands, outgoing)
        if core.begin_tick():
            core.observe(pipeline=self._pipeline())
        dist = self._goal_distance()
        status = core.status()
        collided = core.obs.obstacle_contact & moving
        arrived = moving & (status == int(Status.ARRIVED))
        reward = (self.rewards.progress * (self._dist - dist) + self.rewards.step
                  + self.rewards.arrival * arrived + self.rewards.collision * collided)
        self._dist = dist
        ended = (arrived | (status == int(Status.COLLIDED))
                 | (status == int(Status.LOST))).tolist()
        timed_out = (status == int(Status.TIMED_OUT)).tolist()
        values = reward.tolist()
        arrivals, collisions, distances = arrived.tolist(), collided.tolist(), dist.tolist()
        rewards, terminations, truncations, infos = {}, {}, {}, {}
        for agent in agents:
            i = self._index[agent]
            rewards[agent] = values[i]
            terminations[agent] = ended[i]
            truncations[agent] = timed_out[i]
            infos[agent] = {"arrived": arrivals[i], "collided": collisions[i],
                            "goal_distance_m": distances[i], "pose": core.obs.poses[i].copy()}
        observations = self._observe(agents)
        self.agents = [a for a in agents if core.robots.active[self._index[a]]]
        return observations, rewards, terminations, truncations, infos

    # -- observations ------------------------------------------------------------------------

    def _observe(self, agents: list[str]) -> dict[str, dict[str, np.ndarray]]:
        """The observations of ``agents`` at the current tick: the moving robots' from the
        core's swarm, the others' (waiting, or left at this step) from their latest scans."""
        core = self._core
        assert core is not None
        self._own_messages = {}
        if not agents:
            return {}
        swarm = core.swarm if core.swarm is not None and core.swarm.tick == core.tick else None
        idx = np.array([self._index[a] for a in agents])
        seen = np.zeros(len(core.goals), bool)
        if swarm is not None:
            seen[swarm.active] = True
        seen = seen[idx]
        sensed = None
        if not seen.all():
            sensed = core.sense(idx[~seen], pipeline=self.observations.pipeline)
        if swarm is not None and self.observations.max_neighbours:
            self._own_messages = self._broadcasts(swarm)
        known = core.localizer.poses(core.obs.poses).tolist()
        goals = core.goals.tolist()
        out = {}
        for agent, i, own in zip(agents, idx.tolist(), seen.tolist(), strict=True):
            view = swarm if own else sensed
            assert view is not None
            out[agent] = self._agent_obs(i, view, known[i], goals[i])
        return out

    def _agent_obs(self, i: int, view: Any, pose: list[float],
                   goal: list[float]) -> dict[str, np.ndarray]:
        """Robot ``i``'s observation from ``view`` (the swarm or a :class:`Sensed`), at the pose
        it knows ``pose`` ``(x_m, y_m, yaw_rad)`` (its estimate with ``localization.mode =
        "odometry"``), with its goal ``goal`` ``(x_m, y_m)``."""
        x, y, yaw = pose
        dx, dy = goal[0] - x, goal[1] - y
        c, s = math.cos(yaw), math.sin(yaw)
        obs = {"scan": view.ranges_m[i].astype(np.float32),
               "goal": np.array([c * dx + s * dy, -s * dx + c * dy], np.float32)}
        if self.observations.safe_mask:
            obs["safe_mask"] = view.safe[i].astype(np.int8)
        if self.observations.max_neighbours:
            obs["messages"], obs["neighbours"] = self._inbox(i, pose)
        return obs

    def _inbox(self, i: int, pose: list[float]) -> tuple[np.ndarray, np.ndarray]:
        core = self._core
        assert core is not None
        n = self.observations.max_neighbours
        messages = np.zeros((n, MESSAGE_BYTES), np.uint8)
        rel = np.zeros((n, 3), np.float32)
        packets = core.channel.inbox(i, tick=core.tick, max_age_ticks=core.max_age_ticks)
        x, y, yaw = pose
        c, s = math.cos(yaw), math.sin(yaw)
        packets = sorted(packets, key=lambda p: math.hypot(p.sender_pose[0] - x,
                                                           p.sender_pose[1] - y))[:n]
        for slot, pkt in enumerate(packets):
            payload = np.frombuffer(pkt.payload[:MESSAGE_BYTES], np.uint8)
            messages[slot, :len(payload)] = payload
            dx, dy = pkt.sender_pose[0] - x, pkt.sender_pose[1] - y
            rel[slot] = (c * dx + s * dy, -s * dx + c * dy, wrap_angle(pkt.sender_pose[2] - yaw))
        return messages, rel

    def _broadcasts(self, swarm: Any) -> dict[int, bytes]:
        """The moving robots' compact messages, sent with their commands: every tick, or when
        the goal direction is not safe (``comms.broadcast``)."""
        idx, poses, sensor = swarm.active, swarm.poses, self.config.sensor
        every_tick = self.config.comms.broadcast == "every_tick"
        beta = np.arctan2(*(swarm.goals[idx] - poses[idx, :2]).T[::-1]) - poses[idx, 2]
        beams = beam_index(np.asarray(wrap_angle(beta)), beams=sensor.beams,
                           fov_rad=sensor.fov_rad)
        goal_safe = swarm.safe[idx, beams]
        return {i: swarm.messages[j] for j, i in enumerate(idx.tolist())
                if every_tick or not goal_safe[j]}

    # -- rendering ---------------------------------------------------------------------------

    def render(self) -> np.ndarray | None:
        """A top-down RGB frame ``(H, W, 3)`` uint8 (``render_mode="rgb_array"``), else None.

        Drawn like a replay's frames (:class:`fftnav.report.frames.RasterRenderer`): the map at
        5 cm per pixel in the first rows (the first row the top of the world, the world's border
        on its edge pixels), every robot in the colour of its status and, with a scripted
        controller, of its planner's state (waiting, moving, following, ..., arrived, failed),
        with its heading and trail, a line to its goal while it drives, a red cross where it
        failed with its failure cause (the ``failure`` of ``episodes.csv``:
        :func:`fftnav.metrics.classify_failure`), and the scan returns and safe sectors (to
        l_th) of the robot ``render_robot``, ringed, while it moves. Below the map, the key:
        the clock over the episode's time limit, that robot's state in words, a scale bar and
        the legend. The frame's size is fixed for a world, robot radius and l_th."""
        if self.render_mode != "rgb_array" or self._sim is None or self._core is None:
            return None
        # report is the layer above envs: imported here, when a frame is asked for
        from fftnav.report.frames import RasterRenderer, SwarmFrame, describe_robot, kinds_of

        core, cfg = self._core, self.config
        safe_m = min(cfg.geometry.l_th_m, cfg.sensor.range_m)
        key = (self.world.to_json(), cfg.robot.r0_m, safe_m)
        if self._renderer is None or key != self._renderer_key:
            self._renderer = RasterRenderer(self.world, r0_m=cfg.robot.r0_m, resolution_m=0.05,
                                            safe_m=safe_m)
            self._renderer_key = key
        trajectories = core.trajectories()
        status = core.status()
        states = self._render_states(status)
        causes = self._failure_causes(status, trajectories)
        picked = self.render_robot if (self.render_robot is not None
                                       and self.render_robot < len(status)) else None
        scan, label = None, ""
        if picked is not None:
            scan = self._render_scan(picked, safe_m)
            label = describe_robot(picked, int(status[picked]), **states.get(picked, {}),
                                   cause=causes.get(picked, ""))
        mode = np.array([states.get(i, {}).get("mode", np.nan) for i in range(len(status))])
        n = len(status)
        return self._renderer(SwarmFrame(
            poses=np.array([t[-1] for t in trajectories]), kinds=kinds_of(status, mode),
            trails=[t[:, :2] for t in trajectories], time_s=float(core.obs.time_s),
            picked=picked, scan=scan, causes=[causes.get(i, "") for i in range(n)],
            end_s=cfg.episode.time_limit_s + cfg.episode.last_departure_s(n),
            picked_label=label))

    def _render_states(self, status: np.ndarray) -> dict[int, dict[str, float]]:
        """The planner's ``mode`` and ``side`` of each moving robot, by robot (a scripted
        controller's; none for the agents')."""
        core = self._core
        assert core is not None
        if self._method is None:
            return {}
        states = {}
        for i in np.flatnonzero(status == int(Status.MOVING)).tolist():
            values = core.controller.state(i)
            states[i] = {k: float(values[k]) for k in ("mode", "side") if k in values}
        return states

    def _render_scan(self, robot: int, safe_m: float) -> Any:
        """Robot ``robot``'s scan of the current tick (a :class:`fftnav.report.frames.ScanView`;
        its safe sectors when the pipeline runs), or None when it does not move."""
        from fftnav.report.frames import ScanView

        core = self._core
        assert core is not None
        swarm = core.swarm
        if swarm is None or swarm.tick != core.tick or robot not in swarm.active:
            return None
        safe = (np.zeros(len(swarm.angles_rad), bool) if swarm.safe is None
                else swarm.safe[robot])
        return ScanView(np.asarray(swarm.angles_rad), swarm.ranges_m[robot], safe,
                        self.config.sensor.range_m, safe_m)

    def _failure_causes(self, status: np.ndarray,
                        trajectories: list[np.ndarray]) -> dict[int, str]:
        """The failure cause of every robot that left without arriving, by robot, as
        :func:`fftnav.episode.loop.run_episode` gives it in the ``failure`` column (computed
        once for each, when it has left)."""
        from fftnav.episode.loop import failure_cause, positions_by_tick

        core = self._core
        assert core is not None
        failed = [i for i, s in enumerate(status.tolist())
                  if Status(s).gone and s != Status.ARRIVED and i not in self._causes]
        if failed:
            by_tick = positions_by_tick(trajectories, core.robots.departure)
            for i in failed:
                self._causes[i] = failure_cause(core, i, trajectories[i], by_tick)
        return self._causes

    def close(self) -> None:
        if self._sim is not None:
            self._sim.close()
            self._sim = None
