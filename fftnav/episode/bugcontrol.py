"""The Bug planner with a decision policy, as a controller (the default of every episode).

:class:`BugController` is what ran before controllers existed, unchanged: the FFT pipeline's safe
masks feed the :class:`~fftnav.planning.bug.BugPlanner`, which asks the decision policy for a side
when a goal direction is blocked; with a policy that ``uses_messages`` (``fusion``) a robot whose
goal direction is blocked broadcasts its compressed observation (or every tick, with
``comms.broadcast = "every_tick"``). Its rows carry the policy's name and decision counters.
"""

from __future__ import annotations

import numpy as np

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
    """

    uses_pipeline = True

    def __init__(self, setup: ControllerSetup, policy: Policy, channel: Channel, *,
                 full_circle: bool) -> None:
        super().__init__(setup)
        self.policy, self.rng = policy, setup.rng
        self.name = policy.name  # type: ignore[misc]  # its rows carry the policy's name
        self.decider = Decider(setup.config, channel, setup.rng, full_circle=full_circle)
        self.planner = BugPlanner.for_swarm(setup.n_robots, setup.config, self._decide)

    def _decide(self, i: int) -> int:
        ctx = DecisionContext(i, lambda: self.decider.own_probability(i),
                              lambda: self.decider.fused_probability(i), self.rng)
        return self.policy.decide(ctx)

    def step(self, swarm: SwarmStep) -> tuple[np.ndarray, dict[int, bytes]]:
        """Observe, decide, plan; the messages of the robots that broadcast this tick."""
        idx, sigma = swarm.active, swarm.sigma
        self.decider.observe(swarm.tick, swarm.poses, swarm.goals, idx, sigma)
        commands, blocked = self.planner.step(swarm.time_s, swarm.poses, swarm.goals,
                                              swarm.safe, swarm.ranges_m, swarm.y1)
        outgoing: dict[int, bytes] = {}
        if self.policy.uses_messages:
            every_tick = self.config.comms.broadcast == "every_tick"
            for j, i in enumerate(idx.tolist()):
                if every_tick or blocked[i]:
                    outgoing[i] = swarm.messages[j]
        return commands, outgoing

    def finish(self, robot: int) -> None:
        self.planner.finish(robot)

    def counters(self, robot: int) -> dict[str, int]:
        return {
            "decisions_left": int(self.planner.decisions[robot, 0]),
            "decisions_right": int(self.planner.decisions[robot, 1]),
            "decisions_with_neighbours": self.decider.with_neighbours[robot],
            "decisions_flipped_by_neighbours": self.decider.flipped[robot],
        }
