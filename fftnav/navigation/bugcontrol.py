"""The Bug planner with a decision policy, as a controller (the default of every episode).

:class:`BugController`: the FFT pipeline's safe masks feed the
:class:`~fftnav.navigation.bug.BugPlanner`, which asks the decision policy for a side when a goal
direction is blocked. What its robots broadcast and how they read it is the policy's message
kind (:mod:`fftnav.navigation.messages`), of which it makes one instance per episode: with
``"observation"`` (``fusion``) a robot whose goal direction is blocked broadcasts its compressed
observation (or every tick, with ``comms.broadcast = "every_tick"``); with ``"walls"``
(``collab``) robots share the wall segments they see (:mod:`fftnav.navigation.collab`), drawn
into the receivers' own maps, and the policy may ask which side the way through that map passes
(:meth:`~fftnav.navigation.ownmap.OwnMaps.side_costs`). Like every controller it is built from
its :class:`~fftnav.navigation.controllers.ControllerSetup` alone and sees the swarm only
through :class:`~fftnav.navigation.controllers.SwarmStep`. Its state (:meth:`BugController.state`)
is the planner's :class:`~fftnav.states.State` of each robot; its rows carry the policy's name,
its decision counters, the planner's diagnostics and the neighbour accounting.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from fftnav import metrics
from fftnav.navigation.bug import BugPlanner
from fftnav.navigation.controllers import Controller, ControllerSetup, SwarmStep
from fftnav.navigation.decider import Decider
from fftnav.navigation.messages import MessageKind
from fftnav.navigation.policies import DecisionContext, DecisionObservation, Policy
from fftnav.observe.fusion import neighbour_input, neighbour_probability, rotate_sigma

__all__ = ["SIDE_MARGIN_M", "SIDE_RADIUS_M", "UNKNOWN_COST", "BugController"]

#: ``collab``'s map says which side only when one side's way is this much shorter (m).
SIDE_MARGIN_M = 1.0
#: ... counting a step through a cell the robot has never seen (neither hit nor passed by its
#: beams) as this many steps: the way round a wall end nobody has seen is dearer than the way
#: through a gap the robot saw open.
UNKNOWN_COST = 3.0
#: The two sides' ways are compared through the cells this far (m) from the robot.
SIDE_RADIUS_M = 1.0


class BugController(Controller):
    """The Bug planner (docs/planner.md) deciding sides with ``policy``.

    Parameters
    ----------
    setup : ControllerSetup
        Swarm size, configuration, the episode's generator and the world's facts: whether the
        scans cover 360 degrees, the mission area (the robots' own maps cover it,
        :class:`~fftnav.navigation.bug.BugPlanner`) and whether walls enclose it.
    policy : Policy
        The decision policy.
    """

    uses_pipeline = True

    def __init__(self, setup: ControllerSetup, policy: Policy) -> None:
        super().__init__(setup)
        n = setup.n_robots
        self.policy, self.rng = policy, setup.rng
        self.name = policy.name  # type: ignore[misc]  # its rows carry the policy's name
        self.decider = Decider(setup.config, setup.rng, full_circle=setup.full_circle)
        #: The policy's message kind in this episode (None: its robots send nothing).
        self.messages: MessageKind | None = (None if policy.messages is None
                                             else policy.messages(setup))
        self._read = np.zeros(n, dtype=np.int64)  # messages read at the last (re)decision
        self.poses = np.zeros((n, 3))
        self.goals = np.zeros((n, 2))
        self._swarm: SwarmStep | None = None
        self.planner = BugPlanner.for_swarm(
            n, setup.config, self._decide, self._reconsider if policy.reconsiders else None,
            area_m=setup.area_m, wait=self._asks("waits"), guide=self._asks("guides"),
            walled=setup.walled)

    def _decide(self, i: int) -> int:
        seen: list[DecisionObservation] = []

        def observation() -> DecisionObservation:
            if not seen:
                seen.append(self._observation(i))
            return seen[0]

        ctx = DecisionContext(i, lambda: self.decider.own_probability(i),
                              lambda: self.decider.fused_probability(i), self.rng,
                              lambda: self._shared_side(i), observation)
        return self.policy.decide(ctx)

    def _observation(self, i: int) -> DecisionObservation:
        """What fusion uses at robot ``i``'s decision (:class:`DecisionObservation`): its P_s and
        extrema, and each received message's P_i and sender pose in the goal frame (the
        senders placed as :meth:`Decider.fused_probability
        <fftnav.navigation.decider.Decider.fused_probability>` places them)."""
        decider, cfg = self.decider, self.config
        geometry, range_m = decider.geometry, cfg.sensor.range_m
        p_s = decider.own_probability(i)
        sigma = rotate_sigma(decider.sigma[i], -float(decider.beta[i]))
        neighbours, rel = decider._neighbours(i)  # the senders as fusion places them
        p_n = np.array([float(neighbour_probability(
            neighbour_input(rotate_sigma(sig, float(pose[2])), is_min, target_rad=0.0,
                            alpha_rad=geometry.alpha_rad, range_m=range_m),
            geometry=geometry, range_m=range_m))
            for (sig, is_min), pose in zip(neighbours, rel, strict=True)])
        return DecisionObservation(p_s, sigma, p_n.reshape(-1), rel, range_m,
                                   cfg.comms.comm_range_m)

    def _shared_side(self, i: int) -> int | None:
        """The side (+1 left, -1 right of the goal) whose way to the goal through robot ``i``'s
        map (its own scans and the walls its neighbours shared) is shorter by at least
        SIDE_MARGIN_M; None if neither is."""
        self._read[i] = self._messages_read(i)
        maps = self.planner.maps
        if maps is None:
            return None
        left, right = maps.side_costs(i, self.poses[i, :2], self.goals[i], radius_m=SIDE_RADIUS_M,
                                      shared_only=True, unknown_cost=UNKNOWN_COST)
        if min(left, right) == np.inf or abs(left - right) < SIDE_MARGIN_M:
            return None
        return 1 if left < right else -1

    def _messages_read(self, i: int) -> int:
        """How many messages robot ``i`` has read (its message kind counts them)."""
        return 0 if self.messages is None else self.messages.read(i)

    def _reconsider(self, i: int, side: int) -> int:
        """A following robot asks its policy again when news arrived since it last decided."""
        if self._messages_read(i) == self._read[i]:
            return side
        return self._decide(i)

    def _asks(self, question: str) -> Callable[[int], bool] | None:
        """The planner's hook ``robot -> bool`` that asks the message kind ``question``
        (``"waits"``: the right of way; ``"guides"``: the guided way) at the current tick;
        None for a policy without messages (never)."""
        if self.messages is None:
            return None
        ask = getattr(self.messages, question)

        def answer(i: int) -> bool:
            assert self._swarm is not None
            return bool(ask(self._swarm, i))

        return answer

    def step(self, swarm: SwarmStep) -> tuple[np.ndarray, dict[int, bytes]]:
        """Observe, read the messages that arrived, decide, plan; the messages of the robots
        that broadcast this tick."""
        self.poses, self.goals, self._swarm = swarm.poses, swarm.goals, swarm
        self.decider.observe(swarm)
        kind = self.messages
        if kind is not None:
            kind.receive(swarm, self.planner.maps)
        commands, blocked = self.planner.step(swarm.time_s, swarm.poses, swarm.goals,
                                              safe=swarm.safe, ranges_m=swarm.ranges_m,
                                              y1=swarm.y1)
        outgoing = kind.send(swarm, blocked, self.planner.maps) if kind is not None else {}
        return commands, outgoing

    def finish(self, robot: int) -> None:
        self.planner.finish(robot)

    def hold(self, robot: int) -> None:
        self.planner.hold(robot)

    def release(self, robot: int) -> None:
        self.planner.release(robot)

    def state(self, robot: int) -> dict[str, float]:
        """``mode``: the planner's :class:`~fftnav.states.State` code (0 goal, 1 follow, 2
        escape, 3 done, 4 wait, 5 guided); ``side`` (+1 left, -1 right while it follows or
        escapes, else 0); ``decisions`` taken; and the last ``p_own`` (P_s) and ``p_fused``
        (fused P) computed for its decisions (NaN before; ``fusion`` computes both,
        ``own-only`` only P_s, the baselines neither)."""
        memory = self.planner.memory[robot]
        nan = math.nan
        return {"mode": int(memory.state), "side": memory.side,
                "decisions": self.planner.stats.decided(robot),
                "p_own": self.decider.last_p_own.get(robot, nan),
                "p_fused": self.decider.last_p_fused.get(robot, nan)}

    def counters(self, robot: int) -> dict[str, int | float]:
        """The planner's counters (:meth:`~fftnav.navigation.memory.PlannerStats.row`) and the
        decider's: decisions that fused neighbours or were flipped by them, and why each other
        robot was fused or not."""
        return {
            **self.planner.stats.row(robot, control_hz=self.config.episode.control_hz),
            "decisions_with_neighbours": self.decider.with_neighbours[robot],
            "decisions_flipped_by_neighbours": self.decider.flipped[robot],
            **{f"neighbours_{reason}": self.decider.neighbour_reasons[robot][reason]
               for reason in metrics.NEIGHBOUR_REASONS},
        }
