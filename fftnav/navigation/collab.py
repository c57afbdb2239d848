"""What ``collab`` robots share: the walls they see, as a few line segments.

Every second each robot fits line segments to the readings of its current lidar scan
(:func:`scan_segments`: chains of neighbouring readings simplified by Douglas-Peucker, the ones at
least :data:`MIN_SEGMENT_M` long: walls and long obstacle sides, not trunks or robots) and
broadcasts the :data:`MAX_SEGMENTS_PER_MESSAGE` longest through the episode's lossy, delayed,
range-limited :class:`~fftnav.episode.comms.Channel`, in at most :data:`MAX_MESSAGE_BYTES` bytes
(:func:`encode_segments`: a count byte, then the end points in centimetres as int16). A receiver
draws them into its own map (:meth:`fftnav.navigation.ownmap.OwnMaps.add_segments`): a robot at a
wall then knows where its neighbours saw the wall go on, and where they saw it end.

A receiver reads its neighbours' segments only once one of its own scans has shown a wall longer
than the sensing range R (:func:`long_wall`): only there can the wall's far side lie beyond what
the robot sees, so only there can its neighbours tell it something it cannot see. Until then it
holds what arrives and decides as ``own-only`` does; the held segments are drawn at their
arrival ticks when the gate opens. From then on its map also knows where its neighbours stood
when they sent (every message carries its sender's pose): its own scans of them are not walls
(:meth:`fftnav.navigation.ownmap.OwnMaps.set_robots`), so two robots meeting in a corridor pass
each other instead of each planning the way round the other.

At a decision ``collab`` compares the two sides by the length of the way to the goal through
that map (:meth:`fftnav.navigation.ownmap.OwnMaps.side_costs`) and takes the clearly shorter one
(docs/planner.md, "collab"). Pure numpy; nothing but the robot's own scan and pose and its
neighbours' messages.
"""

from __future__ import annotations

import math
import struct

import numpy as np

__all__ = [
    "MAX_MESSAGE_BYTES",
    "MAX_SEGMENTS_PER_MESSAGE",
    "NEIGHBOUR_AGE_TICKS",
    "PERIOD_TICKS",
    "decode_segments",
    "encode_segments",
    "long_wall",
    "scan_segments",
]

#: Upper bound of a message (bytes).
MAX_MESSAGE_BYTES = 64
#: Segments per message: 1 count byte + 8 bytes each (two end points, x and y in cm) = 57 bytes.
MAX_SEGMENTS_PER_MESSAGE = 7
#: Only segments at least this long (m) are shared (a trunk or a robot is shorter).
MIN_SEGMENT_M = 0.6
#: Two neighbouring readings farther apart than this (m) belong to different obstacles.
CHAIN_GAP_M = 0.35
#: Douglas-Peucker tolerance (m): no reading lies farther than this from its segment.
FIT_TOLERANCE_M = 0.08
#: A robot broadcasts its segments every this many control ticks (once a second at 10 Hz).
PERIOD_TICKS = 10
#: A receiver takes a neighbour to stand where its last message was sent from for this many
#: control ticks after that message arrived (one period and a half).
NEIGHBOUR_AGE_TICKS = 15


def encode_segments(segments: np.ndarray) -> bytes:
    """``segments`` ``(n, 2, 2)`` (m, at most :data:`MAX_SEGMENTS_PER_MESSAGE`, inside +-327 m)
    as bytes: a count byte, then x0, y0, x1, y1 in centimetres as little-endian int16.

    >>> encode_segments(np.array([[[1.0, 2.5], [0.0, -1.0]]])).hex()
    '016400fa0000009cff'
    """
    seg = np.asarray(segments, dtype=float).reshape(-1, 2, 2)
    if len(seg) > MAX_SEGMENTS_PER_MESSAGE:
        raise ValueError(f"segments must hold at most {MAX_SEGMENTS_PER_MESSAGE} segments, "
                         f"got segments with {len(seg)}")
    cm = np.round(seg * 100.0)
    if np.any(np.abs(cm) > 32767):
        raise ValueError(f"segments must lie within +-327.67 m, got segments={seg.tolist()}")
    return struct.pack(f"<B{4 * len(seg)}h", len(seg), *cm.astype(int).ravel().tolist())


def decode_segments(data: bytes) -> np.ndarray:
    """The segments ``(n, 2, 2)`` (m) of a message written by :func:`encode_segments`."""
    if len(data) < 1 or len(data) != 1 + 8 * data[0]:
        raise ValueError(f"data must be a segment message (1 + 8 n bytes), got {len(data)} bytes")
    values = struct.unpack(f"<{4 * data[0]}h", data[1:])
    return np.asarray(values, dtype=float).reshape(-1, 2, 2) / 100.0


def _simplify(points: np.ndarray, out: list[tuple[np.ndarray, np.ndarray]]) -> None:
    """Douglas-Peucker: split the chain at its reading farthest from the end-to-end line."""
    a, b = points[0], points[-1]
    ab = b - a
    length = float(np.hypot(*ab))
    if len(points) > 2:
        rel = points - a
        if length > 0:
            off = np.abs(ab[0] * rel[:, 1] - ab[1] * rel[:, 0]) / length
        else:
            off = np.hypot(rel[:, 0], rel[:, 1])
        k = int(np.argmax(off))
        if off[k] > FIT_TOLERANCE_M:
            _simplify(points[:k + 1], out)
            _simplify(points[k:], out)
            return
    out.append((a, b))


def scan_segments(pose: np.ndarray, ranges_m: np.ndarray, angles_rad: np.ndarray, *,
                  range_m: float) -> np.ndarray:
    """Line segments ``(n, 2, 2)`` (world frame, m, longest first) fitted to a scan's readings.

    Readings below ``range_m`` (zero: no reading) taken in beam order form chains while
    neighbours lie within CHAIN_GAP_M; each chain is simplified to segments no reading of
    which lies farther than FIT_TOLERANCE_M from it; segments shorter than MIN_SEGMENT_M are
    dropped.
    """
    r = np.asarray(ranges_m, dtype=float)
    hit = (r > 0) & (r < range_m * (1.0 - 1e-6))
    x, y, yaw = (float(v) for v in pose)
    pts = np.stack([x + r * np.cos(angles_rad + yaw), y + r * np.sin(angles_rad + yaw)], axis=1)
    idx = np.flatnonzero(hit)
    if len(idx) < 2:
        return np.zeros((0, 2, 2))
    jump = np.hypot(*(pts[idx[1:]] - pts[idx[:-1]]).T) > CHAIN_GAP_M
    breaks = np.flatnonzero(jump | (np.diff(idx) > 1)) + 1
    segments: list[tuple[np.ndarray, np.ndarray]] = []
    for chain in np.split(idx, breaks):
        if len(chain) >= 2:
            _simplify(pts[chain], segments)
    kept = [(a, b) for a, b in segments if math.hypot(*(b - a)) >= MIN_SEGMENT_M]
    kept.sort(key=lambda s: -math.hypot(*(s[1] - s[0])))
    return np.array(kept, dtype=float).reshape(-1, 2, 2)


def long_wall(segments: np.ndarray, *, range_m: float) -> bool:
    """Whether any segment ``(n, 2, 2)`` (m) is longer than the sensing range ``range_m``.

    >>> long_wall(np.array([[[0.0, 0.0], [3.5, 0.0]]]), range_m=3.0)
    True
    >>> long_wall(np.array([[[0.0, 0.0], [2.0, 2.0]]]), range_m=3.0)
    False
    """
    seg = np.asarray(segments, dtype=float).reshape(-1, 2, 2)
    return bool(np.any(np.hypot(*(seg[:, 1] - seg[:, 0]).T) > range_m))
