"""What a robot knows when it picks a side: its own P_s and the fused P (paper Sec. III-E).

The :class:`Decider` holds the swarm's latest observations (extrema Sigma per robot, poses, goal
bearings) and the message channel, and computes, for one robot on demand, P_s from its own Sigma
and the fused P from its own and its neighbours' messages. Both are taken in the goal frame: the
robot frame rotated by the goal bearing beta, so that the quadrants of Fig. 2b and the
neighbours' target sector are centred on the goal (docs/planner.md).
"""

from __future__ import annotations

import collections

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.episode.comms import Channel, Packet
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
    channel : Channel
        The episode's message channel (the inboxes).
    rng : numpy.random.Generator
        The episode's generator (pose noise of received messages).
    full_circle : bool
        Whether the scans cover 360 degrees.
    """

    def __init__(self, config: SwarmConfig, channel: Channel, rng: np.random.Generator, *,
                 full_circle: bool) -> None:
        self.config, self.channel, self.rng = config, channel, rng
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
        self.present: np.ndarray = np.zeros(0, dtype=bool)

    def observe(self, tick: int, poses: np.ndarray, goals: np.ndarray, robots: np.ndarray,
                sigma: list[np.ndarray], present: np.ndarray | None = None) -> None:
        """The swarm at ``tick``: poses ``(K, 3)``, goals ``(K, 2)`` and the Sigma of each robot
        in ``robots`` (robot frame); ``present`` marks the robots in the world (moving or
        waiting to depart; default: ``robots``), the candidates of the neighbour accounting."""
        delta = goals - poses[:, :2]
        self.tick, self.poses = tick, poses
        self.beta = np.arctan2(delta[:, 1], delta[:, 0]) - poses[:, 2]
        self.sigma = dict(zip(robots.tolist(), sigma, strict=True))
        if present is None:
            present = np.zeros(len(poses), dtype=bool)
            present[robots] = True
        self.present = present

    def _own_sigma(self, i: int) -> np.ndarray:
        return rotate_sigma(self.sigma[i], -float(self.beta[i]))

    def own_probability(self, i: int) -> float:
        """P_s of robot ``i`` (eq. (P_s)) from the quadrant areas of its Sigma."""
        x0 = quadrant_areas(self._own_sigma(i), alpha_rad=self.geometry.alpha_rad,
                            range_m=self.config.sensor.range_m, full_circle=self.full_circle)
        return float(own_probability(x0))

    def _packets(self, i: int) -> list[Packet]:
        """The fresh packets of robot ``i``'s inbox (sent in the last second)."""
        return self.channel.inbox(i, tick=self.tick, max_age_ticks=self._max_age_ticks)

    @property
    def _max_age_ticks(self) -> int:
        return int(self.config.episode.control_hz)

    def _neighbours(self, i: int) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray]:
        """Decoded messages in robot ``i``'s inbox and the senders' poses relative to its goal
        frame ``(n, 3)`` (with pose noise)."""
        cfg = self.config
        packets = self._packets(i)
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
        return decision.p

    def _account(self, i: int, rel: np.ndarray, sides: np.ndarray) -> None:
        """Count, for robot ``i``'s decision, why each other robot in the world was fused or
        not (:data:`fftnav.metrics.NEIGHBOUR_REASONS`); ``rel`` and ``sides`` are those of the
        fresh packets of its inbox, in order."""
        counts = self.neighbour_reasons[i]
        heard = set()
        for pkt, (x, y, _), side in zip(self._packets(i), rel, sides, strict=True):
            heard.add(pkt.sender)
            dist = float(np.hypot(x, y))
            if side:
                counts["fused"] += 1
            elif dist < 2.0 * self.geometry.r_m:
                counts["too_close"] += 1
            elif dist > self.config.comms.comm_range_m:
                counts["out_of_range"] += 1
            else:
                counts["behind"] += 1
        ch, oldest = self.channel, self.tick - self._max_age_ticks
        for j in np.flatnonzero(self.present):
            if j == i or j in heard:
                continue
            if ch.last_sent[j] < oldest:
                counts["no_message"] += 1
            elif ch.last_lost[j, i] >= oldest:
                counts["lost"] += 1
            elif ch.last_out_of_range[j, i] >= oldest:
                counts["out_of_range"] += 1
            else:  # sent, reached, still in flight (delay_ticks)
                counts["no_message"] += 1
