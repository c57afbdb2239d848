"""``SwarmNavEnv``: the fftnav swarm as a PettingZoo ``ParallelEnv`` for multi-agent learning.

Agents ``robot_0 .. robot_{K-1}``, one per start of the world. Every step each live agent sends
``(v_mps, w_radps)`` (a ``Box`` within the robot's limits) and receives a ``Dict`` observation.
``step(actions)`` takes a dict mapping agents to finite arrays of shape ``(2,)`` (an agent
without an action stands still); anything else, NaN or inf included, is a ``ValueError`` naming
the agent. Finite values outside the ``Box`` are clipped to it, as the simulator clips commands
to the robot's speed limits (Gymnasium's ``ClipAction``). The observation:

``scan``
    its lidar ranges (m, ``float32``, ``(M,)``; no return reads R, blind beams 0);
``goal``
    its goal in its own frame, ``(x_m, y_m)`` (x ahead, y to the left);
``safe_mask`` (``observe_safe_mask=True``)
    the FFT pipeline's safe beams (``MultiBinary(M)``);
``messages``, ``neighbours`` (``max_neighbours > 0``)
    the latest compressed observations received from up to ``max_neighbours`` neighbours (raw
    bytes, zero-padded to ``MESSAGE_BYTES``, ``uint8``) and the senders' poses relative to the
    receiver ``(x_m, y_m, yaw_rad)`` (zeros where there is no message). Every live robot
    broadcasts its compact message as ``comms.broadcast`` says (``on_obstacle``: when the goal
    direction is not safe; ``every_tick``) through the same lossy, delayed, range-limited
    channel as the benchmark's ``fusion``.

Rewards (:class:`Rewards`, configurable): ``progress`` times the decrease of the distance to the
goal over the step (m), plus ``arrival`` once on arrival (within ``success_radius_m``), plus
``collision`` (negative) once on touching an obstacle, plus ``step`` every step. An agent
terminates on arrival or collision (it is then parked out of the world;
``terminate_on_collision=False`` keeps it driving, with the collision reward on every step in
contact); all live agents are
truncated at the time limit (``episode.time_limit_s``). ``render_mode="rgb_array"`` returns a
top-down frame drawn like ``fftnav replay``'s (:meth:`SwarmNavEnv.render`).

``reset(seed=..., options=...)``: ``seed`` seeds the episode (sensor noise, packet loss);
``options`` may set ``world_kind``, ``map_seed``, ``robots`` and any config key
(``"packet_loss"``, ``"sensor.range_m"``, ...; :meth:`fftnav.config.SwarmConfig.replace`); a bad
value raises ``ValueError``, a key that is none of these is ignored with a warning (PettingZoo's
API test passes arbitrary options). A new
world is generated (and the simulator rebuilt) only when the kind, map seed, robots or a config
key of the simulator changes.
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
from fftnav.episode.comms import Channel
from fftnav.observe.safe import beam_index
from fftnav.observe.scan import wrap_angle
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.validate import Checked, check_choice, check_integer, number_field
from fftnav.world import World, generate_world

__all__ = ["MESSAGE_BYTES", "Rewards", "SwarmNavEnv"]

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
    world_kind : str
        A registered world kind (``forest``, ``rocky``); ignored when ``world`` is given.
    map_seed : int
        Seed of the generated world.
    robots : int
        Robots (agents) of a generated world.
    world : World, optional
        A fixed world (e.g. an imported ROS map) instead of a generated one.
    config : SwarmConfig, optional
        Robot, sensor, comms and episode parameters (default: the paper's).
    rewards : Rewards, optional
    observe_safe_mask : bool
        Add the FFT safe mask to the observations.
    max_neighbours : int
        Message slots per observation (0: no messages, nothing is broadcast).
    terminate_on_collision : bool
        End an agent when it touches an obstacle (default, as in the benchmark); with False it
        keeps driving and gets the collision reward on every step in contact.
    render_mode : {None, "rgb_array"}
    """

    metadata = {"render_modes": ["rgb_array"], "name": "fftnav_swarm_v0",
                "is_parallelizable": True, "render_fps": 10}

    def __init__(self, *, world_kind: str = "forest", map_seed: int = 0, robots: int = 15,
                 world: World | None = None, config: SwarmConfig | None = None,
                 rewards: Rewards | None = None, observe_safe_mask: bool = False,
                 max_neighbours: int = 0, terminate_on_collision: bool = True,
                 render_mode: str | None = None) -> None:
        self.render_mode = check_choice("render_mode", render_mode, (None, "rgb_array"))
        self.rewards = rewards or Rewards()
        self.observe_safe_mask = bool(observe_safe_mask)
        self.max_neighbours = check_integer("max_neighbours", max_neighbours, low=0)
        self.terminate_on_collision = bool(terminate_on_collision)
        self._fixed_world = world
        self._kind, self._map_seed = world_kind, check_integer("map_seed", map_seed, low=0)
        self._robots = check_integer("robots", robots, low=1)
        self._base_config = config or SwarmConfig()
        self.config = self._base_config
        self.world = world if world is not None else _world(world_kind, self._map_seed,
                                                            self._robots,
                                                            self.config.robot.r0_m)
        self._sim: SwarmSim | None = None
        self._sim_key: tuple[Any, ...] | None = None
        self._set_agents()
        self.agents: list[str] = []

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
        if self.observe_safe_mask:
            items["safe_mask"] = spaces.MultiBinary(m)
        if self.max_neighbours:
            n = self.max_neighbours
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

    # -- episode -----------------------------------------------------------------------------

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, Any]]]:
        options = dict(options or {})
        kind = options.pop("world_kind", self._kind)
        map_seed = check_integer("map_seed", options.pop("map_seed", self._map_seed), low=0)
        robots = check_integer("robots", options.pop("robots", self._robots), low=1)
        known = {k: v for k, v in options.items() if _is_config_key(k)}
        for key in options.keys() - known.keys():  # PettingZoo's API test passes arbitrary keys
            warnings.warn(f"SwarmNavEnv.reset ignores the unknown option {key!r}", stacklevel=2)
        self.config = self._base_config.replace(known) if known else self._base_config
        if self._fixed_world is None:
            self.world = _world(kind, map_seed, robots, self.config.robot.r0_m)
        if seed is None:
            seed = int(np.random.SeedSequence().generate_state(1)[0])
        seed = check_integer("seed", seed, low=0)
        sim_ss, ep_ss = np.random.SeedSequence(seed).spawn(2)
        self._rng = np.random.default_rng(ep_ss)
        sim_config = SimConfig.for_swarm(self.config)
        key = (self.world.to_json(), sim_config)
        if self._sim is None or key != self._sim_key:
            if self._sim is not None:
                self._sim.close()
            self._sim, self._sim_key = SwarmSim(self.world, config=sim_config), key
            self._set_agents()
        self._pipe = self.config.pipeline()
        k = len(self.world.starts)
        self._channel = Channel(k, range_m=self.config.comms.comm_range_m,
                                loss=self.config.comms.packet_loss,
                                delay_ticks=self.config.comms.delay_ticks, rng=self._rng)
        self._obs = self._sim.reset(seed=int(sim_ss.generate_state(1)[0]))
        self._tick = 0
        self._live = np.ones(k, dtype=bool)
        self._trail = [self._obs.poses.copy()]  # drawn by render()
        self._outcome = np.zeros(k, np.int8)  # 0 live, 1 arrived, 2 failed
        self._goals = np.asarray(self.world.goals, dtype=np.float64)
        self._dist = self._goal_distance()
        self.agents = list(self.possible_agents)
        observations = self._observe()
        return observations, {a: {} for a in self.agents}

    def _goal_distance(self) -> np.ndarray:
        return np.hypot(*(self._obs.poses[:, :2] - self._goals).T)

    def _commands(self, actions: Mapping[str, Any]) -> np.ndarray:
        """The agents' actions as commands ``(K, 2)`` (zero for an agent without one); a value
        that is not a dict of agents to finite ``(2,)`` arrays is a ValueError naming it."""
        if not isinstance(actions, Mapping):
            raise ValueError(f"actions must be a dict mapping each agent to an array "
                             f"(v_mps, w_radps) of shape (2,), got {type(actions).__name__}")
        commands = np.zeros((len(self.possible_agents), 2))
        for agent, action in actions.items():
            check_choice("agent", agent, self.possible_agents)
            try:
                value = np.asarray(action, dtype=np.float64)
            except (TypeError, ValueError):
                value = None
            if value is None or value.shape != (2,):
                shape = "no number array" if value is None else f"shape {value.shape}"
                raise ValueError(f"actions[{agent!r}] must be an array (v_mps, w_radps) of "
                                 f"shape (2,), got {shape}: {action!r:.80}")
            if not np.isfinite(value).all():
                raise ValueError(f"actions[{agent!r}] must be finite, got {value.tolist()}")
            commands[self._index[agent]] = value
        return commands

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        if self._sim is None or not self.agents:
            raise ValueError("step() needs a live episode: call reset() first")
        commands = np.clip(self._commands(actions), self._act_space.low, self._act_space.high)
        live = self._live.copy()
        self._obs = self._sim.step(commands)
        self._tick += 1
        dist = self._goal_distance()
        ep = self.config.episode
        collided = self._obs.obstacle_contact & live
        arrived = (dist <= ep.success_radius_m) & live & ~collided
        reward = (self.rewards.progress * (self._dist - dist) + self.rewards.step
                  + self.rewards.arrival * arrived + self.rewards.collision * collided)
        self._dist = dist
        truncated = self._tick >= ep.max_ticks
        agents = list(self.agents)
        rewards, terminations, truncations, infos = {}, {}, {}, {}
        for agent in agents:
            i = self._index[agent]
            rewards[agent] = float(reward[i])
            terminations[agent] = bool(arrived[i]
                                       or (collided[i] and self.terminate_on_collision))
            truncations[agent] = bool(truncated and not terminations[agent])
            infos[agent] = {"arrived": bool(arrived[i]), "collided": bool(collided[i]),
                            "goal_distance_m": float(dist[i])}
        observations = self._observe(agents)
        self._trail.append(np.where(live[:, None], self._obs.poses, np.nan))
        for agent in agents:
            i = self._index[agent]
            if terminations[agent] or truncations[agent]:
                self._outcome[i] = 1 if arrived[i] else 2
                self._live[i] = False
                self._sim.park(i)
        self.agents = [a for a in agents if self._live[self._index[a]]]
        return observations, rewards, terminations, truncations, infos

    def _observe(self, agents: list[str] | None = None) -> dict[str, dict[str, np.ndarray]]:
        agents = self.agents if agents is None else agents
        if not agents:
            return {}
        idx = np.array([self._index[a] for a in agents])
        scans = self._obs.scans[idx]
        ranges = self._pipe.normalise(scans) * self.config.sensor.range_m
        poses = self._obs.poses
        need_pipeline = self.observe_safe_mask or self.max_neighbours
        if need_pipeline:
            res = self._pipe.process(scans, with_p_s=False)
        if self.max_neighbours:
            self._channel.deliver(self._tick)
        out = {}
        for j, (agent, i) in enumerate(zip(agents, idx.tolist(), strict=True)):
            x, y, yaw = poses[i]
            d = self._goals[i] - (x, y)
            c, s = math.cos(yaw), math.sin(yaw)
            obs = {"scan": ranges[j].astype(np.float32),
                   "goal": np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]], np.float32)}
            if self.observe_safe_mask:
                obs["safe_mask"] = res.safe_mask[j].astype(np.int8)
            if self.max_neighbours:
                obs["messages"], obs["neighbours"] = self._inbox(i)
            out[agent] = obs
        if self.max_neighbours:
            self._broadcast(idx, res)
        return out

    def _inbox(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        n = self.max_neighbours
        messages = np.zeros((n, MESSAGE_BYTES), np.uint8)
        rel = np.zeros((n, 3), np.float32)
        packets = self._channel.inbox(i, tick=self._tick,
                                      max_age_ticks=int(self.config.episode.control_hz))
        x, y, yaw = self._obs.poses[i]
        c, s = math.cos(yaw), math.sin(yaw)
        packets = sorted(packets, key=lambda p: math.hypot(p.sender_pose[0] - x,
                                                           p.sender_pose[1] - y))[:n]
        for slot, pkt in enumerate(packets):
            payload = np.frombuffer(pkt.payload[:MESSAGE_BYTES], np.uint8)
            messages[slot, :len(payload)] = payload
            dx, dy = pkt.sender_pose[0] - x, pkt.sender_pose[1] - y
            rel[slot] = (c * dx + s * dy, -s * dx + c * dy, wrap_angle(pkt.sender_pose[2] - yaw))
        return messages, rel

    def _broadcast(self, idx: np.ndarray, res: Any) -> None:
        every_tick = self.config.comms.broadcast == "every_tick"
        poses = self._obs.poses
        beta = np.arctan2(*(self._goals[idx] - poses[idx, :2]).T[::-1]) - poses[idx, 2]
        goal_safe = res.safe_mask[np.arange(len(idx)),
                                  self._pipe_beam(np.asarray(wrap_angle(beta)))]
        for j, i in enumerate(idx.tolist()):
            if every_tick or not goal_safe[j]:
                self._channel.broadcast(i, res.messages[j], tick=self._tick, poses=poses,
                                        active=self._live)

    def _pipe_beam(self, angle: np.ndarray) -> np.ndarray:
        sensor = self.config.sensor
        return beam_index(angle, beams=sensor.beams, fov_rad=sensor.fov_rad)

    # -- rendering ---------------------------------------------------------------------------

    def render(self) -> np.ndarray | None:
        """A top-down RGB frame ``(H, W, 3)`` uint8 at 5 cm per pixel, the first row the top of
        the world (``render_mode="rgb_array"``), else None. It is drawn like a replay's frames
        (:class:`fftnav.report.frames.RasterRenderer`): every robot in the colour of its state
        (moving, arrived, failed) with its heading and trail, a line to its goal while it
        drives, a cross where it failed (collided, or truncated before its goal)."""
        if self.render_mode != "rgb_array" or self._sim is None:
            return None
        # report is the layer above envs: imported here, when a frame is asked for
        from fftnav.report.frames import KINDS, RasterRenderer, SwarmFrame

        renderer = getattr(self, "_renderer", None)
        if (renderer is None or renderer.world is not self.world
                or renderer.r0_m != self.config.robot.r0_m):
            renderer = self._renderer = RasterRenderer(self.world, r0_m=self.config.robot.r0_m,
                                                       resolution_m=0.05)
        trail = np.array(self._trail)  # (T, K, 3), NaN once a robot left
        last = np.max(np.where(np.isfinite(trail[..., 0]), np.arange(len(trail))[:, None], 0),
                      axis=0)
        poses = trail[last, np.arange(trail.shape[1])]
        kinds = np.array([KINDS.index(("moving", "arrived", "failed")[o])
                          for o in self._outcome])
        trails = [t[np.isfinite(t[:, 0]), :2] for t in trail.transpose(1, 0, 2)]
        return renderer(SwarmFrame(poses=poses, kinds=kinds, trails=trails))

    def close(self) -> None:
        if self._sim is not None:
            self._sim.close()
            self._sim = None
