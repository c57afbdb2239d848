"""What a robot knows when it picks a side: its own P_s and the fused P (paper Sec. III-E).

The :class:`Decider` holds the swarm's latest observations (extrema Sigma per robot, poses, goal
bearings, the robots' inboxes) and computes, for one robot on demand, P_s from its own Sigma
and the fused P from its own and its neighbours' messages. Both are taken in the goal frame: the
robot frame rotated by the goal bearing beta, so that the quadrants of Fig. 2b and the
neighbours' target sector are centred on the goal (docs/planner.md).
"""

from __future__ import annotations

import collections
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.navigation.controllers import Packet, SwarmStep
from fftnav.observe.codec import decode_message
from fftnav.observe.compress import quadrant_areas
from fftnav.observe.fusion import decide_turn, own_probability, rotate_sigma

__all__ = ["Decider"]


class Decider:
    """P_s and the fused P of the robots of one episode.

    Parameters
    ----------
    config : SwarmConfig
        Robot geometry (alpha), sensor range R, communication range and pose noise.
    rng : numpy.random.Generator
        The episode's generator (pose noise of received messages).
    full_circle : bool
        Whether the scans cover 360 degrees.
    """

    def __init__(self, config: SwarmConfig, rng: np.random.Generator, *,
                 full_circle: bool) -> None:
        self.config, self.rng = config, rng
        self.geometry = config.geometry
        self.full_circle = full_circle
        self.tick = 0
        self.poses: np.ndarray = np.zeros((0, 3))
        self.beta: np.ndarray = np.zeros(0)
        self.sigma: dict[int, np.ndarray] = {}
        #: Per robot: fused decisions that used at least one neighbour, and those among them
        #: whose side differs from the robot's own (P_s) side.
        self.with_neighbours: dict[int, int] = collections.Counter()
        self.flipped: dict[int, int] = collections.Counter()
        #: Per robot and reason of :data:`fftnav.metrics.NEIGHBOUR_REASONS`: how many times,
        #: over its fused decisions, another robot in the world was fused or not, and why.
        self.neighbour_reasons: dict[int, collections.Counter[str]] = collections.defaultdict(
            collections.Counter)
        #: Per robot: the last P_s and fused P computed for it (its state, for recordings).
        self.last_p_own: dict[int, float] = {}
        self.last_p_fused: dict[int, float] = {}
        self.inbox: Callable[[int], Sequence[Packet]] = lambda i: ()
        self.unheard: Callable[[int], Mapping[int, str]] = lambda i: {}

    def observe(self, swarm: SwarmStep) -> None:
        """The swarm at one tick: poses, goals and the Sigma of each active robot (robot frame),
        the robots' inboxes, and why a robot in the world was not heard (``swarm.unheard``,
        for the neighbour accounting)."""
        assert swarm.sigma is not None  # the Bug controller runs the pipeline
        delta = swarm.goals - swarm.poses[:, :2]
        self.tick, self.poses = swarm.tick, swarm.poses
        self.beta = np.arctan2(delta[:, 1], delta[:, 0]) - swarm.poses[:, 2]
        self.sigma = dict(zip(swarm.active.tolist(), swarm.sigma, strict=True))
        self.inbox, self.unheard = swarm.inbox, swarm.unheard

    def _own_sigma(self, i: int) -> np.ndarray:
        return rotate_sigma(self.sigma[i], -float(self.beta[i]))

    def own_probability(self, i: int) -> float:
        """P_s of robot ``i`` (eq. (P_s)) from the quadrant areas of its Sigma."""
        x0 = quadrant_areas(self._own_sigma(i), alpha_rad=self.geometry.alpha_rad,
                            range_m=self.config.sensor.range_m, full_circle=self.full_circle)
        p = self.last_p_own[i] = float(own_probability(x0))
        return p

    def _neighbours(self, i: int) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray]:
        """Decoded messages in robot ``i``'s inbox and the senders' poses relative to its goal
        frame ``(n, 3)`` (with pose noise)."""
        cfg = self.config
        packets = self.inbox(i)
        frame = float(self.poses[i, 2] + self.beta[i])  # goal-frame heading in the world
        c, s = np.cos(frame), np.sin(frame)
        neighbours, rel = [], []
        for pkt in packets:
            sig, is_min = decode_message(pkt.payload, range_m=cfg.sensor.range_m)
            d = np.asarray(pkt.sender_pose[:2]) - self.poses[i, :2]
            if cfg.comms.pose_noise_m > 0:
                d = d + self.rng.normal(0.0, cfg.comms.pose_noise_m, 2)
            rel.append((c * d[0] + s * d[1], -s * d[0] + c * d[1], pkt.sender_pose[2] - frame))
            neighbours.append((sig, is_min))
        return neighbours, np.array(rel).reshape(-1, 3)

    def fused_probability(self, i: int) -> float:
        """The fused P of robot ``i`` (eq. (P)): its P_s and its neighbours' P_i."""
        neighbours, rel = self._neighbours(i)
        decision = decide_turn(
            self._own_sigma(i), neighbours=neighbours, rel_poses=rel, target_rad=0.0,
            geometry=self.geometry, range_m=self.config.sensor.range_m,
            max_range_m=self.config.comms.comm_range_m, full_circle=self.full_circle,
        )
        if (decision.sides != 0).any():
            self.with_neighbours[i] += 1
            self.flipped[i] += decision.turn_left != (decision.p_s > 0.5)
        self._account(i, rel, decision.sides)
        self.last_p_own[i], self.last_p_fused[i] = float(decision.p_s), float(decision.p)
        return decision.p

    def _account(self, i: int, rel: np.ndarray, sides: np.ndarray) -> None:
        """Count, for robot ``i``'s decision, why each other robot in the world was fused or
        not (:data:`fftnav.metrics.NEIGHBOUR_REASONS`): ``rel`` and ``sides`` are those of the
        packets of its inbox, in order; the robots it has no packet from come with their
        reason from ``unheard``."""
        counts = self.neighbour_reasons[i]
        for (x, y, _), side in zip(rel, sides, strict=True):
            dist = float(np.hypot(x, y))
            if side:
                counts["fused"] += 1
            elif dist < 2.0 * self.geometry.r_m:
                counts["too_close"] += 1
            elif dist > self.config.comms.comm_range_m:
                counts["out_of_range"] += 1
            else:
                counts["behind"] += 1
        for reason in self.unheard(i).values():
            counts[reason] += 1
