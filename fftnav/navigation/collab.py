"""What ``collab`` robots share: the walls they see, as a few line segments.

Every second each robot fits line segments to the readings of its current lidar scan
(:func:`scan_segments`: chains of neighbouring readings simplified by Douglas-Peucker, the ones at
least :data:`MIN_SEGMENT_M` long: walls and long obstacle sides, not trunks or robots) and
broadcasts the :data:`MAX_SEGMENTS_PER_MESSAGE` longest through the episode's lossy, delayed,
range-limited :class:`~fftnav.episode.comms.Channel`, in at most :data:`MAX_MESSAGE_BYTES` bytes
(:func:`encode_message`: a count byte, the sender's distance to its goal, then the end points
in centimetres as int16). A receiver draws them into its own map
(:meth:`fftnav.navigation.ownmap.OwnMaps.add_segments`): a robot at a wall then knows where its
neighbours saw the wall go on, and where they saw it end. With ``[localization] mode =
"odometry"`` the segments travel in the sender's body frame and the receiver places them through
its measurement of the sender, refusing a message that crosses what its own lidar sees free
(:class:`fftnav.navigation.messages.Walls`, docs/localization.md).

A receiver reads its neighbours' segments only once one of its own scans has shown a wall longer
than the sensing range R (:func:`long_wall`): only there can the wall's far side lie beyond what
the robot sees, so only there can its neighbours tell it something it cannot see. Until then it
holds what arrives and decides as ``own-only`` does; the held segments are drawn at their
arrival ticks when the gate opens. From then on its map also knows where its neighbours stood
when they sent (every message carries its sender's pose): its own scans of them are not walls
(:meth:`fftnav.navigation.ownmap.OwnMaps.set_robots`), so two robots meeting in a corridor pass
each other instead of each planning the way round the other. And where two robots stand in
each other's way too close to pass, they agree on who goes first (:func:`waits_for`: the one
that announced the shorter distance to its goal): it waits while the other gives way.

At a decision ``collab`` compares the two sides by the length of the way to the goal through
that map (:meth:`fftnav.navigation.ownmap.OwnMaps.side_costs`) and takes the clearly shorter one
(docs/planner.md, "collab"). Heading for its goal, a robot whose walls (its own segments and
its neighbours', :meth:`fftnav.navigation.ownmap.OwnMaps.add_walls`) block the straight line
(its way through them more than ``PlannerParams.guide_margin_m`` longer) steers along that way
instead, as an escaping robot does (the planner's ``guide``): it goes round a trap, or to a gap
its neighbours saw, before it meets the wall. Pure numpy; nothing but the robot's own scan and
pose and its neighbours' messages.
"""

from __future__ import annotations

import math
import struct

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe.scan import wrap_angle

__all__ = [
    "MAX_MESSAGE_BYTES",
    "MAX_SEGMENTS_PER_MESSAGE",
    "NEIGHBOUR_AGE_TICKS",
    "BLOCK_BEARING_RAD",
    "BLOCK_RADIUS_M",
    "PERIOD_TICKS",
    "decode_message",
    "encode_message",
    "long_wall",
    "scan_segments",
    "waits_for",
]

#: Upper bound of a message (bytes).
MAX_MESSAGE_BYTES = 64
#: Segments per message: 1 count byte, 2 bytes of goal distance, 8 bytes per segment (two end
#: points, x and y in cm): 59 bytes.
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
#: A neighbour stands in a robot's way when it stands within this distance (m: the planning
#: distance l_th, a robot's diameter, and 0.3 m for the age of its position) ...
BLOCK_RADIUS_M = 1.2
#: ... and within this angle (rad) of the robot's goal bearing.
BLOCK_BEARING_RAD = math.radians(60.0)


def encode_message(segments: np.ndarray, *, goal_m: float) -> bytes:
    """A ``walls`` message: the sender's distance to its goal ``goal_m`` (m; its right of way,
    :func:`waits_for`) and ``segments`` ``(n, 2, 2)`` (m, at most
    :data:`MAX_SEGMENTS_PER_MESSAGE`, inside +-327 m), as bytes: a count byte, the goal distance
    in centimetres as a little-endian uint16 (at most 655.35 m), then x0, y0, x1, y1 of each
    segment in centimetres as little-endian int16 (``3 + 8 n`` bytes).

    >>> encode_message(np.array([[[1.0, 2.5], [0.0, -1.0]]]), goal_m=7.5).hex()
    '01ee026400fa0000009cff'
    """
    seg = np.asarray(segments, dtype=float).reshape(-1, 2, 2)
    if len(seg) > MAX_SEGMENTS_PER_MESSAGE:
        raise FftnavError(f"segments must hold at most {MAX_SEGMENTS_PER_MESSAGE} segments, "
                          f"got segments with {len(seg)}")
    cm = np.round(seg * 100.0)
    if np.any(np.abs(cm) > 32767):
        raise FftnavError(f"segments must lie within +-327.67 m, got segments={seg.tolist()}")
    if not goal_m >= 0:
        raise FftnavError(f"goal_m must be >= 0, got goal_m={goal_m!r}")
    goal_cm = round(min(goal_m, 655.35) * 100.0)
    return struct.pack(f"<BH{4 * len(seg)}h", len(seg), goal_cm, *cm.astype(int).ravel().tolist())


def decode_message(data: bytes) -> tuple[float, np.ndarray]:
    """The goal distance (m) and segments ``(n, 2, 2)`` (m) of a message written by
    :func:`encode_message`."""
    if len(data) < 3 or len(data) != 3 + 8 * data[0]:
        raise FftnavError(f"data must be a walls message (3 + 8 n bytes), got {len(data)} bytes")
    values = struct.unpack(f"<H{4 * data[0]}h", data[1:])
    return values[0] / 100.0, np.asarray(values[1:], dtype=float).reshape(-1, 2, 2) / 100.0


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
    """Line segments ``(n, 2, 2)`` (m, longest first, in the frame of ``pose``: the world's,
    or the robot's estimated frame with odometry) fitted to a scan's readings.

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


def waits_for(xy: np.ndarray, goal: np.ndarray, *, index: int, goal_m: float,
              neighbours: np.ndarray) -> bool:
    """Whether the robot ``index`` at ``xy`` (m), whose goal direction is blocked, waits for
    its neighbours to clear the way: the right of way.

    The neighbours in its way are those within :data:`BLOCK_RADIUS_M` of ``xy`` whose bearing
    lies within :data:`BLOCK_BEARING_RAD` of the goal's. A robot goes first when its pair
    (goal distance, index) is below every such neighbour's: the one nearer its goal has the
    right of way, the lower index at a tie. It waits when it goes first; otherwise (or with
    nobody in its way) it gives way: it does what it would do alone.

    Both robots of a pair compare the same two numbers when ``goal_m`` is the distance the
    robot last sent, and each neighbour's is the distance it last sent (:func:`encode_message`).

    Parameters
    ----------
    xy, goal : array_like, shape (2,)
        The robot's position and goal (m).
    index : int
        The robot's index.
    goal_m : float
        The goal distance the robot last announced (m; inf: none yet, it goes last).
    neighbours : ndarray, shape (n, 4)
        ``x_m, y_m, goal_m, index`` of each neighbour, as its last message said.

    Returns
    -------
    bool

    Examples
    --------
    Two robots face each other 1 m apart, each having announced 5 m to its goal; robot 0 (the
    lower index) goes first:

    >>> waits_for(np.array([0.0, 0.0]), np.array([6.0, 0.0]), index=0, goal_m=5.0,
    ...           neighbours=np.array([[1.0, 0.0, 5.0, 1.0]]))
    True
    >>> waits_for(np.array([1.0, 0.0]), np.array([-5.0, 0.0]), index=1, goal_m=5.0,
    ...           neighbours=np.array([[0.0, 0.0, 5.0, 0.0]]))
    False
    """
    nb = np.asarray(neighbours, dtype=float).reshape(-1, 4)
    x, y = float(xy[0]), float(xy[1])
    dx, dy = nb[:, 0] - x, nb[:, 1] - y
    ahead = math.atan2(float(goal[1]) - y, float(goal[0]) - x)
    off = np.abs(wrap_angle(np.arctan2(dy, dx) - ahead))
    in_way = (np.hypot(dx, dy) <= BLOCK_RADIUS_M) & (off <= BLOCK_BEARING_RAD)
    if not in_way.any():
        return False
    mine = (goal_m, index)
    return all(mine < (float(g), int(j)) for g, j in nb[in_way, 2:4])
