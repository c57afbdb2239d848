"""The robots of one :class:`~fftnav.envs.SwarmNavEnv` as a fixed batch of learner slots.

A learned controller sees, at run time, ``OBSERVATIONS[name].build(obs, config)`` of each active
robot (:class:`fftnav.navigation.learned.LearnedController`); :class:`SwarmBatch` gives the
learner exactly those vectors, built by the same function from the same
:class:`~fftnav.navigation.controllers.SwarmStep`, so that what is trained is what runs.

Slot ``i`` is robot ``i``. An episode runs until every robot has ended, or until fewer than
``min_live`` are still driving (the others are then truncated: cut short, not failed); a robot
that has ended (arrived, collided, timed out) sees zeros and gets 0 until then, and its slot is
done at its own last step and again at the episode's end ("black death", as PettingZoo's vector
wrappers do). Each new episode draws its world kind and map seed from the training schedule with the
batch's generator, so the same seed gives the same sequence of episodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.envs.swarm_env import Observations, Rewards, SwarmNavEnv
from fftnav.learn.config import MapRange
from fftnav.navigation.controllers import robot_observations
from fftnav.navigation.learned import OBSERVATIONS, action_commands
from fftnav.states import Status

__all__ = ["EpisodeTally", "SwarmBatch"]


@dataclass
class EpisodeTally:
    """Robot outcomes of the finished training episodes (the progress bar's running AR)."""

    robots: int = 0
    arrived: int = 0
    episodes: int = 0


class SwarmBatch:
    """One :class:`SwarmNavEnv` whose robots are ``n`` fixed learner slots.

    Parameters
    ----------
    observation : str
        A registered observation (:data:`fftnav.navigation.learned.OBSERVATIONS`).
    schedule : MapRange
        World kinds of the training episodes and ``[first, end)`` of their map seeds.
    robots : int
    config : SwarmConfig
    rewards : Rewards
    rng : numpy.random.Generator
        Draws each episode's world kind, map seed and episode seed.
    speeds : (float, float), optional
        ``v_range`` of the actions (default: ``v = a_v v_max``).
    min_live : int
        The episode is cut short when fewer robots than this are still driving (1: it runs
        until every robot has ended); the robots still driving are then truncated.

    Attributes
    ----------
    n : int
        Slots (robots).
    size : int
        Observation length.
    live_steps : int
        Steps of moving robots so far (the environment's work; the learner's samples are
        ``n`` per step).
    tally : EpisodeTally
    """

    def __init__(self, observation: str, *, schedule: MapRange, robots: int, config: SwarmConfig,
                 rewards: Rewards, rng: np.random.Generator,
                 speeds: tuple[float, float] | None = None, min_live: int = 1) -> None:
        self.spec = OBSERVATIONS[observation]
        self.worlds = schedule.worlds
        self.map_seeds = (schedule.first, schedule.end)
        self.rng = rng
        self.config = config
        self.env = SwarmNavEnv(self.worlds[0], map_seed=schedule.first, robots=robots,
                               config=config, rewards=rewards,
                               observations=Observations(safe_mask=self.spec.uses_pipeline))
        self.n = robots
        self.size = self.spec.size(config)
        self.live_steps = 0
        self.tally = EpisodeTally()
        self.episode: tuple[str, int, int] | None = None
        self.speeds = speeds
        self.min_live = min_live

    def reset(self) -> np.ndarray:
        """Start the next episode of the schedule; the observations ``(n, size)``."""
        kind = self.worlds[int(self.rng.integers(len(self.worlds)))]
        map_seed = int(self.rng.integers(*self.map_seeds))
        seed = int(self.rng.integers(2**31))
        self.episode = (kind, map_seed, seed)
        self.env.reset(seed=seed, options={"world_kind": kind, "map_seed": map_seed,
                                           "robots": self.n})
        return self.observe()

    def observe(self) -> np.ndarray:
        """Every slot's observation at the current tick, float64, as the learned controller
        builds it (zeros for a robot not moving)."""
        out = np.zeros((self.n, self.size))
        core = self.env.core
        swarm = None if core is None else core.swarm
        if swarm is None or swarm.tick != core.tick or not len(swarm.active):
            return out
        for i, obs in robot_observations(swarm, inbox=self.spec.messages):
            out[i] = self.spec.build(obs, self.config)
        return out

    def step(self, actions: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
        """Apply the network outputs ``actions`` ``(n, 2)`` as the learned controller does
        (:func:`~fftnav.navigation.learned.action_commands`).

        Returns
        -------
        obs : ndarray ``(n, size)``
            The next observations (at the episode's end, the last ones; :meth:`reset` starts
            the next).
        rewards : ndarray ``(n,)``
        dones : ndarray ``(n,)`` of bool
            A robot's last step, and every slot at the episode's end.
        truncated : ndarray ``(n,)`` of bool
            Robots still driving when the episode was cut short (``min_live``): their return
            goes on beyond it (a learner bootstraps it from ``obs``).
        ended : bool
            Whether the episode ended.
        """
        env = self.env
        commands = action_commands(np.asarray(actions).reshape(self.n, 2),
                                   v_max_mps=self.config.robot.v_max_mps,
                                   w_max_radps=self.config.robot.w_max_radps, speeds=self.speeds)
        core = env.core
        assert core is not None
        self.live_steps += int(core.robots.moving(core.tick).sum())
        act = {a: commands[env.index(a)] for a in env.agents}
        _, rew, term, trunc, _ = env.step(act)
        rewards = np.zeros(self.n, np.float32)
        dones = np.zeros(self.n, bool)
        for agent, r in rew.items():
            i = env.index(agent)
            rewards[i] = r
            dones[i] = term[agent] or trunc[agent]
        obs = self.observe()
        truncated = np.zeros(self.n, bool)
        live = [env.index(a) for a in env.agents]
        if live and len(live) >= self.min_live:
            return obs, rewards, dones, truncated, False
        truncated[live] = True
        self.tally.robots += self.n
        self.tally.arrived += int((core.status() == int(Status.ARRIVED)).sum())
        self.tally.episodes += 1
        dones[:] = True
        return obs, rewards, dones, truncated, True

    def close(self) -> None:
        self.env.close()
