"""What ``collab`` robots share: passages, the places where a robot got past an obstacle.

A robot that was blocked, followed the obstacle's boundary and left it with progress (the Bug
planner's leave rule) has found a *passage*: its position at that moment lies beyond an obstacle,
on a way that works. Each robot keeps a board of the passages it found and those it heard of, and
broadcasts the newest ones once a second through the episode's lossy, delayed, range-limited
:class:`~fftnav.episode.comms.Channel` (receivers store them, so a passage travels from robot to
robot: relaying what robots ahead have seen). A passage message is at most
:data:`MAX_MESSAGE_BYTES` bytes.

When a robot is blocked, :meth:`PassageBoard.side` looks for the known passage ahead of it
(toward its goal, within ``PASSAGE_RANGE_M``) that minimises the straight-line estimate of the
way through it, ``|p - x| + |g - p|``, and returns the side it lies on (left +1 or right -1
of the goal direction), or None when no passage lies clearly to one side. The ``collab`` policy
(:mod:`fftnav.planning.policies`) takes that side when its own view is not decisive, and the
planner reconsiders a side being followed when news arrives (docs/planner.md, "collab").
Pure numpy; no ground truth beyond the robot's own pose and its neighbours' messages.
"""

from __future__ import annotations

import math
import struct

import numpy as np

__all__ = ["MAX_MESSAGE_BYTES", "PassageBoard", "decode_passages", "encode_passages"]

#: Upper bound of a passage message (issue 10: at most 64 bytes per message).
MAX_MESSAGE_BYTES = 64
#: Passages per message: 1 count byte + 4 bytes each (x and y in cm, int16) = 49 bytes.
MAX_PASSAGES_PER_MESSAGE = 12
#: Two passages closer than this (m) are one.
MERGE_RADIUS_M = 0.5
#: Only passages within this distance (m) of a robot are considered (3 R for R = 3 m).
PASSAGE_RANGE_M = 9.0
#: A passage less than this (m) to either side of the goal line says nothing about the side.
MIN_LATERAL_M = 0.5
#: A robot broadcasts its passages every this many control ticks (once a second at 10 Hz).
PERIOD_TICKS = 10


def encode_passages(points: np.ndarray) -> bytes:
    """``points`` ``(n, 2)`` (m, at most :data:`MAX_PASSAGES_PER_MESSAGE`, inside +-327 m) as
    bytes: a count byte, then x and y in centimetres as little-endian int16.

    >>> encode_passages(np.array([[1.0, 2.5]])).hex()
    '016400fa00'
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(pts) > MAX_PASSAGES_PER_MESSAGE:
        raise ValueError(f"points must hold at most {MAX_PASSAGES_PER_MESSAGE} passages, "
                         f"got points with {len(pts)}")
    cm = np.round(pts * 100.0)
    if np.any(np.abs(cm) > 32767):
        raise ValueError(f"points must lie within +-327.67 m, got points={pts.tolist()}")
    return struct.pack(f"<B{2 * len(pts)}h", len(pts), *cm.astype(int).ravel().tolist())


def decode_passages(data: bytes) -> np.ndarray:
    """The passages ``(n, 2)`` (m) of a message written by :func:`encode_passages`."""
    if len(data) < 1 or len(data) != 1 + 4 * data[0]:
        raise ValueError(f"data must be a passage message (1 + 4 n bytes), got {len(data)} bytes")
    values = struct.unpack(f"<{2 * data[0]}h", data[1:])
    return np.asarray(values, dtype=float).reshape(-1, 2) / 100.0


class PassageBoard:
    """The passages each of ``n_robots`` robots knows, newest last.

    Parameters
    ----------
    n_robots : int
        Robots of the episode.
    """

    def __init__(self, n_robots: int) -> None:
        self.known: list[list[tuple[float, float]]] = [[] for _ in range(n_robots)]
        #: Per robot: how many times its board changed (a new passage was learned).
        self.version = np.zeros(n_robots, dtype=np.int64)
        self._heard: dict[tuple[int, int], int] = {}  # (receiver, sender) -> tick last read

    def add(self, robot: int, point: np.ndarray) -> bool:
        """Learn a passage (own or heard); False if a known one lies within MERGE_RADIUS_M."""
        x, y = (float(v) for v in point)
        for px, py in self.known[robot]:
            if math.hypot(px - x, py - y) < MERGE_RADIUS_M:
                return False
        self.known[robot].append((x, y))
        self.version[robot] += 1
        return True

    def message(self, robot: int) -> bytes | None:
        """The message robot ``robot`` broadcasts: its newest passages (None: it knows none)."""
        if not self.known[robot]:
            return None
        return encode_passages(np.array(self.known[robot][-MAX_PASSAGES_PER_MESSAGE:]))

    def receive(self, robot: int, sender: int, tick: int, payload: bytes) -> None:
        """Read a packet from ``sender`` sent at ``tick`` (a packet read before is skipped)."""
        if self._heard.get((robot, sender)) == tick:
            return
        self._heard[(robot, sender)] = tick
        for point in decode_passages(payload):
            self.add(robot, point)

    def side(self, robot: int, position: np.ndarray, goal: np.ndarray) -> int | None:
        """The side (+1 left, -1 right of the goal direction) of the best known passage ahead
        of a robot at ``position`` driving to ``goal``; None if there is none, or if it lies
        less than MIN_LATERAL_M off the goal line."""
        if not self.known[robot]:
            return None
        pts = np.array(self.known[robot])
        to_goal = np.asarray(goal, float) - np.asarray(position, float)
        dist = float(np.hypot(*to_goal))
        if dist == 0.0:
            return None
        ahead = to_goal / dist
        rel = pts - np.asarray(position, float)
        along = rel @ ahead
        lateral = ahead[0] * rel[:, 1] - ahead[1] * rel[:, 0]  # left positive
        reach = np.hypot(rel[:, 0], rel[:, 1])
        ok = (along > 0.0) & (along < dist) & (reach <= PASSAGE_RANGE_M)
        if not ok.any():
            return None
        cost = np.where(ok, reach + np.hypot(*(np.asarray(goal, float) - pts).T), np.inf)
        best = int(np.argmin(cost))
        if abs(lateral[best]) < MIN_LATERAL_M:
            return None
        return 1 if lateral[best] > 0 else -1
