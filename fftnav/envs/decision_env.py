"""The decision-level environment: each Bug decision of one robot is one step (Gymnasium).

:class:`DecisionEnv` runs the real episode (:class:`~fftnav.episode.core.EpisodeCore` with the
Bug planner, :class:`~fftnav.navigation.bugcontrol.BugController`) in which every robot decides
its sides through the environment: one shared learner makes all the swarm's decisions, in the
order the planner asks for them (tick by tick, robots in index order within a tick).

Spaces
    observation: the ``decision-v1`` features of the pending decision
    (:mod:`fftnav.navigation.decision_features`, 53 float32 values); action: ``Discrete(2)``,
    0 = RIGHT, 1 = LEFT (the planner's :data:`~fftnav.navigation.policies.RIGHT` and
    :data:`~fftnav.navigation.policies.LEFT`).

Steps
    :meth:`DecisionEnv.reset` starts an episode and runs it until some robot must decide;
    :meth:`DecisionEnv.step` gives that decision its side and runs the episode on until the next
    decision of any robot (or the episode's end: ``terminated``; the last observation is zeros).
    ``truncated`` is always False: the episode's own time limit ends its robots.

Reward and credit assignment (metres)
    A robot's decision *owns* the path that robot drives from that decision to its next
    decision, or to its end (arrived, collided, timed out or lost): its reward is minus that
    length, plus ``arrival_bonus_m`` if the robot then arrived, or minus ``failure_penalty_m``
    if it then failed. The path a robot drives before its first decision belongs to no
    decision. A decision's reward is known when the segment closes: at the same robot's next
    decision or at its end. Each step's reward is the sum of the rewards that became known
    since the previous step (during the simulation the step ran), whichever robots' they are;
    ``info["closed"]`` lists them one by one as ``(decision, robot, reward)``, ``decision``
    being the step index (0 for the decision :meth:`reset` returned) of the decision it rewards,
    so that a learner can assign each reward to its own decision exactly.

Inside, the episode runs on a worker thread that the environment drives step by step: the
planner's call for a side blocks until :meth:`step` supplies the action, and the environment
waits until the worker needs the next one, so exactly one of them runs at any time and the
episode is the same, bit for bit, as :func:`~fftnav.episode.run_episode` with a policy making
the same choices. :meth:`close` ends the worker; :meth:`reset` in the middle of an episode
abandons it first (its simulator closed, its thread joined).

>>> from fftnav.envs import DecisionEnv
>>> env = DecisionEnv("forest", map_seeds=(100, 200), robots=3)
>>> env.observation_space.shape, int(env.action_space.n)
((53,), 2)
"""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass, field
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from fftnav import metrics
from fftnav.config import SwarmConfig
from fftnav.episode.core import EpisodeCore
from fftnav.episode.loop import episode_rows
from fftnav.episode.record import EpisodeRow
from fftnav.errors import FftnavError
from fftnav.navigation.bugcontrol import BugController
from fftnav.navigation.controllers import ControllerSetup
from fftnav.navigation.decision_features import EXTREMA, N_FEATURES, NEIGHBOURS, decision_features
from fftnav.navigation.policies import LEFT, RIGHT, DecisionContext, Policy
from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.states import Status
from fftnav.validate import check_choice, check_integer, check_number
from fftnav.world import World, generate_world

__all__ = ["ACTION_SIDES", "DecisionEnv"]

#: The side of each action: 0 -> RIGHT, 1 -> LEFT.
ACTION_SIDES = (RIGHT, LEFT)
#: The name the underlying episode's rows carry.
POLICY_NAME = "decision-env"
#: Most episodes :meth:`DecisionEnv.reset` starts to find one in which some robot decides.
MAX_TRIES = 10


class _Abandoned(Exception):
    """Raised inside the worker's episode to end it early (reset or close)."""


_ABANDON = object()


@dataclass
class _Open:
    """A robot's latest decision whose segment is still open: its step index and the robot's
    path length (m) when it decided."""

    decision: int
    length_m: float


@dataclass
class _Worker:
    """One episode run on a thread, handing each decision to the environment."""

    world: World
    config: SwarmConfig
    seed: int
    messages: str | None
    arrival_bonus_m: float
    failure_penalty_m: float
    to_env: queue.Queue[tuple[Any, ...]] = field(default_factory=queue.Queue)
    to_worker: queue.Queue[Any] = field(default_factory=queue.Queue)
    core: EpisodeCore | None = None
    decisions: int = 0
    open: dict[int, _Open] = field(default_factory=dict)
    closed: list[tuple[int, int, float]] = field(default_factory=list)
    thread: threading.Thread | None = None

    def start(self) -> None:
        self.thread = threading.Thread(target=self._run, name="fftnav-decision-env",
                                       daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            with SwarmSim(self.world, config=SimConfig.for_swarm(self.config)) as sim:
                self.core = EpisodeCore(self.world, self.config, sim, seed=self.seed,
                                        controller=self._controller)
                self.core.run()
            self.to_env.put(("done", self._take_closed()))
        except _Abandoned:
            pass
        except BaseException as exc:  # handed to the environment's thread, raised there
            self.to_env.put(("error", exc))

    def _controller(self, setup: ControllerSetup) -> BugController:
        policy = Policy(POLICY_NAME, self._decide, self.messages,
                        "the decisions of DecisionEnv's actions")
        worker = self

        class _Controller(BugController):
            def finish(self, robot: int) -> None:
                worker._end(robot)
                super().finish(robot)

        return _Controller(setup, policy)

    def _length(self, robot: int) -> float:
        assert self.core is not None
        return metrics.path_length_m(np.array(self.core.robots.trajectories[robot])[:, :2])

    def _take_closed(self) -> list[tuple[int, int, float]]:
        closed, self.closed = self.closed, []
        return closed

    def _decide(self, ctx: DecisionContext) -> int:
        obs = ctx.observation()
        assert obs is not None and self.core is not None
        robot, length = ctx.robot, self._length(ctx.robot)
        previous = self.open.get(robot)
        if previous is not None:
            self.closed.append((previous.decision, robot, -(length - previous.length_m)))
        self.open[robot] = _Open(self.decisions, length)
        info = {"robot": robot, "decision": self.decisions, "tick": self.core.tick,
                "p_s": obs.p_s}
        self.decisions += 1
        self.to_env.put(("decide", decision_features(obs), info, self._take_closed()))
        action = self.to_worker.get()
        if action is _ABANDON:
            raise _Abandoned
        return ACTION_SIDES[action]

    def _end(self, robot: int) -> None:
        """Robot ``robot`` left the episode: close its open decision's segment."""
        previous = self.open.pop(robot, None)
        if previous is None:
            return
        assert self.core is not None
        arrived = self.core.robots.left[robot] == Status.ARRIVED
        bonus = self.arrival_bonus_m if arrived else -self.failure_penalty_m
        reward = -(self._length(robot) - previous.length_m) + bonus
        self.closed.append((previous.decision, robot, reward))

    def next(self) -> tuple[Any, ...]:
        """Wait for the worker's next message: a decision, the end, or its error (raised)."""
        message = self.to_env.get()
        if message[0] == "error":
            self.join()
            raise message[1]
        if message[0] == "done":
            self.join()
        return message

    def abandon(self) -> None:
        """End the episode wherever it is waiting; the thread is joined."""
        if self.thread is not None and self.thread.is_alive():
            self.to_worker.put(_ABANDON)
        self.join()

    def join(self) -> None:
        if self.thread is not None:
            self.thread.join()
            self.thread = None


def _observation_space() -> spaces.Box:
    low = np.full(N_FEATURES, -1.0, np.float32)
    high = np.full(N_FEATURES, 1.0, np.float32)
    low[0] = 0.0
    for k in range(NEIGHBOURS):
        low[1 + 5 * k: 4 + 5 * k] = 0.0  # present, P_i, distance
        high[3 + 5 * k] = 2.0  # distance / comm range (pose noise may place it beyond)
    for e in range(EXTREMA):
        low[21 + 4 * e: 23 + 4 * e] = 0.0  # present, distance / R
    return spaces.Box(low, high, dtype=np.float32)


class DecisionEnv(gymnasium.Env):
    """The Bug planner's side decisions of a swarm as a Gymnasium environment (module
    docstring: spaces, steps, reward and credit assignment).

    Parameters
    ----------
    world : str or World
        A registered world kind (``forest``, ``rocky``, ...), generated anew at each reset from
        a map seed drawn from ``map_seeds``; or a fixed world.
    map_seeds : (int, int)
        The range ``[first, end)`` of map seeds a reset draws from (generated worlds).
    robots : int
        Robots of a generated world.
    config : SwarmConfig, optional
        Robot, sensor, comms and episode parameters (default: the paper's).
    messages : {"observation", None}
        What the robots broadcast: their compressed observation as ``fusion``'s do (the
        neighbours' P_i then fill the features), or nothing (the neighbour slots stay empty).
    arrival_bonus_m, failure_penalty_m : float
        Added to, and subtracted from, the reward of a robot's last decision when it arrives,
        or fails (collides, times out or is lost); metres of path, ``>= 0``.

    Notes
    -----
    ``reset(seed=, options=)``: ``seed`` seeds the environment's generator, from which each
    reset draws the map seed and the episode's seed; ``options`` may fix ``map_seed``,
    ``episode_seed``, ``world_kind`` and ``robots``. When no robot decides in an episode, the
    reset starts another one with new draws (at most 10; with both seeds fixed, one), and
    raises FftnavError if none has a decision.
    """

    metadata = {"render_modes": []}

    def __init__(self, world: str | World = "forest", *, map_seeds: tuple[int, int] = (0, 100),
                 robots: int = 15, config: SwarmConfig | None = None,
                 messages: str | None = "observation", arrival_bonus_m: float = 5.0,
                 failure_penalty_m: float = 20.0) -> None:
        if not isinstance(world, (str, World)):
            raise FftnavError(f"world must be a world kind (str) or a World, got "
                              f"world={world!r:.80}")
        self._fixed_world = world if isinstance(world, World) else None
        self._kind = world if isinstance(world, str) else "forest"
        if (not isinstance(map_seeds, (tuple, list)) or len(map_seeds) != 2):
            raise FftnavError(f"map_seeds must be a pair (first, end), got map_seeds={map_seeds!r}")
        first = check_integer("map_seeds[0]", map_seeds[0], low=0)
        end = check_integer("map_seeds[1]", map_seeds[1], low=first + 1)
        self.map_seeds = (first, end)
        self.robots = check_integer("robots", robots, low=1)
        self.config = config or SwarmConfig()
        self.messages = check_choice("messages", messages, ("observation", None))
        self.arrival_bonus_m = check_number("arrival_bonus_m", arrival_bonus_m, low=0)
        self.failure_penalty_m = check_number("failure_penalty_m", failure_penalty_m, low=0)
        self.observation_space = _observation_space()
        self.action_space = spaces.Discrete(2)
        self._worker: _Worker | None = None
        self._done_worker: _Worker | None = None
        self._step = 0
        #: The world of the current episode (None before reset).
        self.world: World | None = None

    # -- episode -----------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self._abandon()
        options = dict(options or {})
        unknown = options.keys() - {"map_seed", "episode_seed", "world_kind", "robots"}
        if unknown:
            raise FftnavError(f"options must be among map_seed, episode_seed, world_kind, "
                              f"robots, got {sorted(unknown)}")
        fixed = "episode_seed" in options and ("map_seed" in options or self._fixed_world)
        for _ in range(1 if fixed else MAX_TRIES):
            world, episode_seed = self._draw(options)
            worker = _Worker(world, self.config, episode_seed, self.messages,
                             self.arrival_bonus_m, self.failure_penalty_m)
            self.world, self._step = world, 0
            worker.start()
            message = worker.next()
            if message[0] == "decide":
                self._worker = worker
                self._done_worker = None
                obs, _, info = self._answer(message)
                return obs, info
        raise FftnavError(f"no robot decided in {1 if fixed else MAX_TRIES} episode(s) of "
                          f"reset(options={options!r}): choose a world with obstacles in the "
                          f"robots' way")

    def _draw(self, options: dict[str, Any]) -> tuple[World, int]:
        """The world and the episode seed of one episode (drawn unless ``options`` fix them)."""
        rng = self.np_random
        map_seed = int(rng.integers(*self.map_seeds))
        episode_seed = int(rng.integers(2 ** 31))
        map_seed = check_integer("map_seed", options.get("map_seed", map_seed), low=0)
        episode_seed = check_integer("episode_seed", options.get("episode_seed", episode_seed),
                                     low=0)
        if self._fixed_world is not None:
            return self._fixed_world, episode_seed
        kind = options.get("world_kind", self._kind)
        robots = check_integer("robots", options.get("robots", self.robots), low=1)
        world = generate_world(kind, map_seed, robots=robots,
                               robot_radius_m=self.config.robot.r0_m)
        return world, episode_seed

    def _answer(self, message: tuple[Any, ...]) -> tuple[np.ndarray, float, dict[str, Any]]:
        """The observation, reward and info of a worker's message."""
        closed = message[-1]
        reward = float(sum(r for _, _, r in closed))
        if message[0] == "decide":
            obs = np.asarray(message[1], dtype=np.float32)
            info = {**message[2], "closed": closed}
        else:
            obs = np.zeros(N_FEATURES, np.float32)
            info = {"closed": closed}
        return obs, reward, info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        worker = self._worker
        if worker is None:
            raise FftnavError("step() needs a pending decision: call reset() first (or again, "
                              "after the episode terminated)")
        if isinstance(action, np.ndarray) and action.shape in ((), (1,)):
            action = action.reshape(()).item()
        if (isinstance(action, bool) or not isinstance(action, (int, np.integer))
                or int(action) not in (0, 1)):
            raise FftnavError(f"action must be 0 (right) or 1 (left), got action={action!r}")
        worker.to_worker.put(int(action))
        message = worker.next()
        self._step += 1
        obs, reward, info = self._answer(message)
        terminated = message[0] == "done"
        if terminated:
            self._worker, self._done_worker = None, worker
        return obs, reward, terminated, False, info

    @property
    def core(self) -> EpisodeCore | None:
        """The episode being run, or the one that just terminated (None before reset)."""
        worker = self._worker or self._done_worker
        return None if worker is None else worker.core

    def episode_rows(self) -> list[EpisodeRow]:
        """The rows of the episode that terminated (as :func:`~fftnav.episode.run_episode`
        gives them; the ``policy`` column says ``decision-env``)."""
        worker = self._done_worker
        if worker is None or worker.core is None:
            raise FftnavError("episode_rows() needs a terminated episode: step until "
                              "terminated first")
        return episode_rows(worker.core, POLICY_NAME)

    def _abandon(self) -> None:
        if self._worker is not None:
            self._worker.abandon()
        self._worker = self._done_worker = None

    def close(self) -> None:
        """End the running episode (its simulator closed, its thread joined)."""
        self._abandon()
