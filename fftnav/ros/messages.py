"""ROS messages built from plain values, for any rosbags typestore (ROS 1 or any ROS 2 release).

:func:`make` fills every field not given with its zero (numbers 0, strings empty, sequences
empty, nested messages made the same way), so one call works whatever fields a release adds
(``visualization_msgs/Marker`` gained texture fields in Iron; ROS 1 headers have ``seq``).
The typestore comes from rosbags (:func:`typestore`); this module never imports it itself.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.ros import require_rosbags

__all__ = ["make", "stamp", "typestore", "yaw_quaternion"]

#: Marker types and actions used here (visualization_msgs/Marker constants).
ARROW, SPHERE, CYLINDER, LINE_LIST, SPHERE_LIST, TEXT, TRIANGLE_LIST = 0, 2, 3, 5, 7, 9, 11
ADD, DELETE = 0, 2


def typestore(ros1: bool) -> Any:
    """The rosbags typestore messages are written with: ROS 1 Noetic (with ``tf2_msgs/TFMessage``,
    which rosbags' Noetic store lacks) or ROS 2 Humble."""
    require_rosbags()
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    if not ros1:
        return get_typestore(Stores.ROS2_HUMBLE)
    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                      "tf2_msgs/msg/TFMessage"))
    return store


@functools.cache
def _nodetype() -> Any:
    require_rosbags()
    from rosbags.typesys.base import Nodetype

    return Nodetype


def _zero(store: Any, node: tuple) -> Any:
    Nodetype = _nodetype()  # noqa: N806 (rosbags' enum)
    kind, spec = node
    if kind == Nodetype.NAME:
        return make(store, spec)
    if kind == Nodetype.BASE:
        name = spec[0]
        return ("" if name == "string" else False if name == "bool"
                else 0.0 if name.startswith("float") else 0)
    sub, length = spec
    if sub[0] == Nodetype.BASE and sub[1][0] not in ("string", "bool"):
        return np.zeros(length if kind == Nodetype.ARRAY else 0, dtype=sub[1][0])
    return [_zero(store, sub) for _ in range(length if kind == Nodetype.ARRAY else 0)]


def make(store: Any, msgtype: str, **values: Any) -> Any:
    """A message of ``msgtype`` (e.g. ``"sensor_msgs/msg/LaserScan"``) with ``values``; the
    other fields zero. An unknown field name raises ValueError."""
    fields = store.fielddefs[msgtype][1]
    unknown = set(values) - {name for name, _ in fields}
    if unknown:
        raise FftnavError(f"{msgtype} has no field {sorted(unknown)}")
    args = [values[name] if name in values else _zero(store, node) for name, node in fields]
    return store.types[msgtype](*args)


def stamp(store: Any, time_s: float) -> Any:
    """A ``builtin_interfaces/Time`` of ``time_s`` seconds (rounded to the nanosecond)."""
    ns = round(time_s * 1e9)
    return make(store, "builtin_interfaces/msg/Time", sec=ns // 1_000_000_000,
                nanosec=ns % 1_000_000_000)


def yaw_quaternion(store: Any, yaw_rad: float) -> Any:
    """A ``geometry_msgs/Quaternion`` of a rotation by ``yaw_rad`` about z."""
    return make(store, "geometry_msgs/msg/Quaternion", z=math.sin(yaw_rad / 2.0),
                w=math.cos(yaw_rad / 2.0))


def header(store: Any, time_s: float | Any, frame_id: str) -> Any:
    """A ``std_msgs/Header`` at ``time_s`` (seconds, or a Time message) in ``frame_id``."""
    when = stamp(store, time_s) if isinstance(time_s, (int, float)) else time_s
    return make(store, "std_msgs/msg/Header", stamp=when, frame_id=frame_id)


def point(store: Any, x: float, y: float, z: float = 0.0) -> Any:
    """A ``geometry_msgs/Point``."""
    return store.types["geometry_msgs/msg/Point"](float(x), float(y), float(z))


def color(store: Any, r: float, g: float, b: float, a: float) -> Any:
    """A ``std_msgs/ColorRGBA``."""
    return store.types["std_msgs/msg/ColorRGBA"](float(r), float(g), float(b), float(a))


def pose(store: Any, x: float = 0.0, y: float = 0.0, z: float = 0.0, yaw_rad: float = 0.0
         ) -> Any:
    """A ``geometry_msgs/Pose`` at ``(x, y, z)`` turned by ``yaw_rad`` about z."""
    return make(store, "geometry_msgs/msg/Pose", position=point(store, x, y, z),
                orientation=yaw_quaternion(store, yaw_rad))


def vector(store: Any, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Any:
    """A ``geometry_msgs/Vector3``."""
    return make(store, "geometry_msgs/msg/Vector3", x=float(x), y=float(y), z=float(z))


def serialize(store: Any, msg: Any, msgtype: str, ros1: bool) -> bytes:
    """The message's bytes: ROS 1 serialisation or little-endian CDR."""
    if ros1:
        return bytes(store.serialize_ros1(msg, msgtype))
    return bytes(store.serialize_cdr(msg, msgtype))
