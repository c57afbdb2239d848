"""Bags for the tests, written with rosbags' own writers (independent of fftnav.ros.bags)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from fftnav.ros import messages as rosmsg

LASERSCAN = "sensor_msgs/msg/LaserScan"


#: The LaserScan fields of a test scan that a test does not give: a 180 degree scan, 10 m.
SCAN_FIELDS = {"angle_min": -math.pi / 2, "angle_max": math.pi / 2, "range_min": 0.0,
               "range_max": 10.0}


def scan_msg(store, ranges, *, i=0, frame_id="laser", stamp_ns=None, **fields):
    """LaserScan ``i`` (stamped 1 s + 0.1 s i unless ``stamp_ns``) of ``ranges`` (float32);
    ``fields``: angle_min, angle_max, angle_increment (default: the span over len - 1),
    range_min, range_max (default :data:`SCAN_FIELDS`)."""
    ranges = np.asarray(ranges, dtype=np.float32)
    fields = {**SCAN_FIELDS, **fields}
    fields.setdefault("angle_increment",
                      (fields["angle_max"] - fields["angle_min"]) / (len(ranges) - 1))
    ns = 1_000_000_000 + i * 100_000_000 if stamp_ns is None else stamp_ns
    stamp = rosmsg.make(store, "builtin_interfaces/msg/Time", sec=ns // 10**9,
                        nanosec=ns % 10**9)
    return rosmsg.make(store, LASERSCAN, header=rosmsg.header(store, stamp, frame_id),
                       ranges=ranges, intensities=np.full(len(ranges), 7.0, dtype=np.float32),
                       **fields)


def write_bag(path: Path, topics: dict[str, Sequence], *, kind: str | None = None) -> Path:
    """Write ``{topic: [(msgtype, msg_or_callable(store)), ...]}`` (one connection per topic
    and message type) to a bag of ``kind``
    (``bag``, ``db3``, ``mcap``, ``db3-folder``, ``mcap-folder``; default: from the suffix);
    messages are interleaved by index, 0.1 s apart. Returns the bag path (a file for single
    files)."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    kind = kind or path.suffix.lower().lstrip(".")
    ros1 = kind == "bag"
    store = rosmsg.typestore(ros1=ros1)
    if ros1:
        writer = Writer1(path)
        target = path
    else:
        plugin = StoragePlugin.MCAP if kind.startswith("mcap") else StoragePlugin.SQLITE3
        folder = path if kind.endswith("folder") else path.with_name(path.name + ".dir")
        writer = Writer2(folder, version=8, storage_plugin=plugin)
        target = path
    with writer:
        conns = {}  # a connection per topic and type: the first type's made first
        for topic, items in topics.items():
            msgtype = items[0][0] if items else LASERSCAN
            conns[topic, msgtype] = writer.add_connection(topic, msgtype, typestore=store)
        longest = max((len(v) for v in topics.values()), default=0)
        for i in range(longest):
            for topic, items in topics.items():
                if i < len(items):
                    msgtype, msg = items[i]
                    msg = msg(store) if callable(msg) else msg
                    data = (store.serialize_ros1(msg, msgtype) if ros1
                            else store.serialize_cdr(msg, msgtype))
                    if (topic, msgtype) not in conns:
                        conns[topic, msgtype] = writer.add_connection(topic, msgtype,
                                                                      typestore=store)
                    writer.write(conns[topic, msgtype], 1_000_000_000 + i * 100_000_000, data)
    if not ros1 and not kind.endswith("folder"):
        inner = folder / f"{folder.name}.{'mcap' if kind.startswith('mcap') else 'db3'}"
        inner.rename(target)
        for f in folder.iterdir():
            f.unlink()
        folder.rmdir()
    return target


def scans_bag(path: Path, scans: Iterable, *, topic="/scan", kind=None, **fields) -> Path:
    """A bag of one LaserScan topic, a message per row of ``scans``."""
    items = [(LASERSCAN, (lambda s, r=r, i=i: scan_msg(s, r, i=i, **fields)))
             for i, r in enumerate(scans)]
    return write_bag(path, {topic: items}, kind=kind)
