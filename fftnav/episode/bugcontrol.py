"""The Bug planner with a decision policy, as a controller (the default of every episode).

:class:`BugController` is what ran before controllers existed, unchanged: the FFT pipeline's safe
masks feed the :class:`~fftnav.planning.bug.BugPlanner`, which asks the decision policy for a side
when a goal direction is blocked; with a policy whose messages are ``"observation"``
(``fusion``) a robot whose goal direction is blocked broadcasts its compressed observation (or
every tick, with ``comms.broadcast = "every_tick"``); with ``"passages"`` (``collab``) robots
share the passages they found (:mod:`fftnav.episode.collab`). Its rows carry the policy's name,
its decision counters, the planner's diagnostics and the neighbour accounting.
"""

from __future__ import annotations

import numpy as np

from fftnav import metrics
from fftnav.episode.collab import PERIOD_TICKS, PassageBoard
from fftnav.episode.comms import Channel
from fftnav.episode.decider import Decider
from fftnav.planning.bug import BugPlanner
from fftnav.planning.controllers import Controller, ControllerSetup, SwarmStep
from fftnav.planning.policies import DecisionContext, Policy

__all__ = ["BugController"]


class BugController(Controller):
    """The Bug planner (docs/planner.md) deciding sides with ``policy``.

    Parameters
    ----------
    setup : ControllerSetup
        Swarm size, configuration, the episode's generator.
    policy : Policy
        The decision policy.
    channel : Channel
        The episode's message channel (the decider reads the inboxes from it).
    full_circle : bool
        Whether the scans cover 360 degrees.
    area_m : (float, float), optional
        Width and height (m) of the mission area (the world's map, corner at the origin): the
        robots' own maps cover it (:class:`~fftnav.planning.bug.BugPlanner`).
    """

    uses_pipeline = True

    def __init__(self, setup: ControllerSetup, policy: Policy, channel: Channel, *,
                 full_circle: bool, area_m: tuple[float, float] | None = None) -> None:
        super().__init__(setup)
        n = setup.n_robots
        self.policy, self.rng, self.channel = policy, setup.rng, channel
        self.name = policy.name  # type: ignore[misc]  # its rows carry the policy's name
        self.decider = Decider(setup.config, channel, setup.rng, full_circle=full_circle)
        self.board = PassageBoard(n)  # collab's passages (empty for the other policies)
        self._seen = np.zeros(n, dtype=np.int64)  # board version at the last (re)decision
        self.poses = np.zeros((n, 3))
        self.goals = np.zeros((n, 2))
        self.planner = BugPlanner.for_swarm(
            n, setup.config, self._decide, self._reconsider if policy.reconsiders else None,
            area_m=area_m)

    def _decide(self, i: int) -> int:
        ctx = DecisionContext(i, lambda: self.decider.own_probability(i),
                              lambda: self.decider.fused_probability(i), self.rng,
                              lambda: self._shared_side(i))
        return self.policy.decide(ctx)

    def _shared_side(self, i: int) -> int | None:
        self._seen[i] = self.board.version[i]
        return self.board.side(i, self.poses[i, :2], self.goals[i])

    def _reconsider(self, i: int, side: int) -> int:
        """A robot following on ``side`` takes the side of the best shared passage when its
        board changed since it last decided (news arrived); otherwise it keeps its side."""
        if self.board.version[i] == self._seen[i]:
            return side
        shared = self._shared_side(i)
        return side if shared is None else shared

    def _read_passages(self, tick: int, present: np.ndarray) -> None:
        for r in np.flatnonzero(present):
            for pkt in self.channel.inbox(int(r), tick=tick, max_age_ticks=PERIOD_TICKS):
                self.board.receive(int(r), pkt.sender, pkt.tick, pkt.payload)

    def _passages(self, tick: int, idx: np.ndarray) -> dict[int, bytes]:
        """``collab``: robots that just got past an obstacle learn a passage and tell it at
        once; every robot that knows passages repeats them every PERIOD_TICKS ticks."""
        fresh = {int(i) for i in idx if self.planner.left_boundary[i]
                 and self.board.add(int(i), self.poses[i, :2])}
        outgoing: dict[int, bytes] = {}
        for i in idx.tolist():
            if i in fresh or (tick + i) % PERIOD_TICKS == 0:
                payload = self.board.message(i)
                if payload is not None:
                    outgoing[i] = payload
        return outgoing

    def step(self, swarm: SwarmStep) -> tuple[np.ndarray, dict[int, bytes]]:
        """Observe, decide, plan; the messages of the robots that broadcast this tick."""
        idx, sigma = swarm.active, swarm.sigma
        present = swarm.present
        if present is None:
            present = np.zeros(len(swarm.poses), dtype=bool)
            present[idx] = True
        self.poses, self.goals = swarm.poses, swarm.goals
        self.decider.observe(swarm.tick, swarm.poses, swarm.goals, idx, sigma, present=present)
        if self.policy.messages == "passages":
            self._read_passages(swarm.tick, present)
        commands, blocked = self.planner.step(swarm.time_s, swarm.poses, swarm.goals,
                                              swarm.safe, swarm.ranges_m, swarm.y1)
        outgoing: dict[int, bytes] = {}
        if self.policy.messages == "passages":
            outgoing = self._passages(swarm.tick, idx)
        elif self.policy.messages == "observation":
            every_tick = self.config.comms.broadcast == "every_tick"
            for j, i in enumerate(idx.tolist()):
                if every_tick or blocked[i]:
                    outgoing[i] = swarm.messages[j]
        return commands, outgoing

    def finish(self, robot: int) -> None:
        self.planner.finish(robot)

    def hold(self, robot: int) -> None:
        self.planner.hold(robot)

    def release(self, robot: int) -> None:
        self.planner.release(robot)

    def counters(self, robot: int) -> dict[str, int | float]:
        planner, dt = self.planner, 1.0 / self.config.episode.control_hz
        return {
            "decisions_left": int(planner.decisions[robot, 0]),
            "decisions_right": int(planner.decisions[robot, 1]),
            "decisions_with_neighbours": self.decider.with_neighbours[robot],
            "decisions_flipped_by_neighbours": self.decider.flipped[robot],
            "follow_time_s": float(planner.follow_ticks[robot] * dt),
            "stall_time_s": float(planner.stall_ticks[robot] * dt),
            "loop_flips": int(planner.loop_flips[robot]),
            "escape_time_s": float(planner.escape_ticks[robot] * dt),
            "sides_remembered": int(planner.sides_remembered[robot]),
            "sides_reconsidered": int(planner.reconsidered[robot]),
            **{f"neighbours_{reason}": self.decider.neighbour_reasons[robot][reason]
               for reason in metrics.NEIGHBOUR_REASONS},
        }
