"""Bags in and out: a topic's LaserScans streamed through the pipeline, the annotated bag.

:func:`scan_bag` reads a ROS 1 ``.bag``, a ROS 2 bag folder, or a single ``.db3`` or ``.mcap``
file with rosbags, message by message: the scans are processed a batch at a time (at most
:data:`BATCH_READINGS` readings; each distinct beam count, field of view and range of the topic
gets a :class:`~fftnav.observe.pipeline.Pipeline` of its own,
:class:`~fftnav.ros.laserscan.LayoutPipelines`), so memory stays bounded whatever the bag's
size. Every message is answered: a scan narrower than the safety window gets a line with no
safe beam and a ``reason``. With ``out_bag`` it writes every input topic again plus
``/fftnav/safe_scan`` and ``/fftnav/safe_directions`` (:class:`AnnotatedBag`).
"""

from __future__ import annotations

import contextlib
import errno
import io
import json
import math
import os
import shutil
import sqlite3
import struct
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.files import cannot_write, remove_stale_temporaries_of, track_temporary
from fftnav.limits import MAX_BEAMS, check_limit
from fftnav.observe.geometry import RobotGeometry
from fftnav.ros import check_not_special, require_rosbags
from fftnav.ros import messages as rosmsg
from fftnav.ros.laserscan import Layout, LayoutPipelines, ScanResult, layout_of, rep117_ranges

__all__ = ["BATCH_READINGS", "LASERSCAN", "AnnotatedBag", "BagFile", "BagWriter", "check_bag",
           "check_out_bag", "deserialize", "messages", "open_bag", "scan_bag"]

LASERSCAN = "sensor_msgs/msg/LaserScan"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
SAFE_SCAN, SAFE_DIRECTIONS = "/fftnav/safe_scan", "/fftnav/safe_directions"
#: Readings of the scans processed at once (as many as 4,096 scans of 360 beams).
BATCH_READINGS = 4096 * 360
#: Bytes of the other topics' messages held until a batch is written (annotated bag).
BATCH_BYTES = 64 << 20
_SQLITE_MAGIC = b"SQLite format 3\x00"


def _is_ros1(path: Path) -> bool:
    return path.name.lower().endswith(".bag") and not path.is_dir()


def _check_sqlite_size(path: Path) -> None:
    """Refuse a ``.db3`` shorter than the size its SQLite header states (rosbags reads the
    pages that are there and silently drops the rest)."""
    with open(path, "rb") as fh:
        head = fh.read(100)
    if len(head) < 100 or not head.startswith(_SQLITE_MAGIC):
        raise FftnavError(f"{path}: damaged bag: not an SQLite database")
    page = int.from_bytes(head[16:18], "big")
    page = 65536 if page == 1 else page
    pages = int.from_bytes(head[28:32], "big")
    if head[92:96] == head[24:28] and pages and path.stat().st_size < page * pages:
        raise FftnavError(f"{path}: damaged bag: truncated ({path.stat().st_size} bytes, its "
                          f"SQLite header states {page * pages})")


def check_bag(path: str | Path) -> Path:
    """Refuse, without opening them, what is not a bag file or folder (a FIFO, a device); check
    every ``.db3`` against its SQLite header. Returns the path."""
    path = Path(path)
    check_not_special(path)
    files = sorted(path.iterdir()) if path.is_dir() else [path]
    for f in files:
        if f.name.lower().endswith(".db3"):
            check_not_special(f)
            _check_sqlite_size(f)
    return path


def check_out_bag(bag: str | Path, out: str | Path) -> Path:
    """Refuse an output bag that would overwrite the input: the input itself, a path inside
    the input's folder or a folder holding the input; or a pipe, device or existing folder."""
    src, dst = Path(bag).resolve(), Path(out).resolve()
    if dst == src or src in dst.parents or dst in src.parents:
        raise FftnavError(f"--out-bag must not be the input bag, a path inside it or a folder "
                          f"holding it, got --out-bag={str(out)!r} for the bag {str(bag)!r}")
    if dst.exists():
        if dst.is_dir():
            raise FftnavError(f"--out-bag names an existing folder, got --out-bag={str(out)!r}")
        check_not_special(dst, "--out-bag")
    return Path(out)


def _reader_errors() -> tuple[type[BaseException], ...]:
    """What rosbags and the storages under it raise on a damaged bag."""
    require_rosbags()
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error
    from rosbags.serde import SerdeError
    from rosbags.typesys import TypesysError

    return (AnyReaderError, Reader1Error, Reader2Error, SerdeError, TypesysError,
            sqlite3.DatabaseError, struct.error, EOFError, zlib.error, UnicodeDecodeError,
            KeyError, IndexError, AssertionError, ValueError)


class _AnyCase(dict):
    """rosbags' storage plugins by file suffix, looked up in any case (``.MCAP``)."""

    def get(self, key: Any, default: Any = None) -> Any:
        return super().get(key.lower() if isinstance(key, str) else key, default)


def _reader(path: Path) -> Any:
    """rosbags' AnyReader of one bag, its kind told by the name in any case (``.BAG``)."""
    require_rosbags()
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag1 import Reader as Reader1
    from rosbags.rosbag2 import Reader as Reader2

    class _Reader2(Reader2):
        STORAGE_PLUGINS = _AnyCase(Reader2.STORAGE_PLUGINS)

    class _BagReader(AnyReader):
        def __init__(self, bag: Path) -> None:  # AnyReader's, with the kind told here
            self.paths, self.is2 = [bag], not _is_ros1(bag)
            self.stack, self.connections = None, []
            self.default_typestore = rosmsg.typestore(ros1=not self.is2)
            self.typestore = rosmsg.typestore(ros1=not self.is2)
            self.readers = [_Reader2(bag) if self.is2 else Reader1(bag)]

    return _BagReader(path)


@contextlib.contextmanager
def _damage(path: Path) -> Iterator[None]:
    """Turn what rosbags raises on a damaged bag into one ValueError naming the bag."""
    try:
        yield
    except _reader_errors() as exc:
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise FftnavError(f"{path}: damaged or unreadable bag: {text}") from None


@contextlib.contextmanager
def open_bag(path: str | Path) -> Iterator[Any]:
    """An open rosbags ``AnyReader`` of a checked bag (:func:`check_bag`); damage found while
    opening it becomes one ValueError naming the bag (:func:`messages` and
    :func:`deserialize` do the same for what is read later)."""
    require_rosbags()
    path = check_bag(path)
    with _damage(path):
        reader = _reader(path)
        reader.open()
    try:
        yield reader
    finally:
        with contextlib.suppress(Exception):
            reader.close()


def messages(reader: Any, path: Path, connections: Any) -> Iterator[tuple[Any, int, bytes]]:
    """``reader.messages(connections=...)``, damage becoming one ValueError naming the bag."""
    stream = reader.messages(connections=connections)
    while True:
        with _damage(path):
            try:
                item = next(stream)
            except StopIteration:
                return
        yield item


def deserialize(reader: Any, path: Path, raw: bytes, msgtype: str) -> Any:
    """A message from its bytes; a damaged message is one ValueError naming the bag."""
    with _damage(path):
        return reader.deserialize(raw, msgtype)


def laserscan_topics(reader: Any) -> list[str]:
    """The bag's topics of type LaserScan, sorted."""
    return sorted({c.topic for c in reader.connections if c.msgtype == LASERSCAN})


def _topic(reader: Any, path: Path, topic: str | None) -> str:
    found = laserscan_topics(reader)
    listed = ", ".join(found) if found else "none"
    if topic is None:
        if len(found) == 1:
            return found[0]
        if not found:
            kinds = sorted({c.msgtype for c in reader.connections})
            raise FftnavError(f"{path} holds no sensor_msgs/LaserScan topic to scan (its "
                              f"topics' types: {', '.join(kinds) or 'none, an empty bag'})")
        raise FftnavError(f"{path}: pass --topic, one of the LaserScan topics: {listed}")
    if topic not in found:
        what = ("is not a LaserScan topic" if any(c.topic == topic for c in reader.connections)
                else "has no topic")
        raise FftnavError(f"{path} {what} {topic!r}; its LaserScan topics: {listed}")
    return topic


@dataclass
class _Scan:
    """One LaserScan message waiting in a batch."""

    index: int
    timestamp: int
    msg: Any
    layout: Layout
    range_m: float
    ranges: np.ndarray  # metres in [0, R], pipeline beam order
    out: ScanResult | None = None  # the results, message order and frame


def _read_scan(msg: Any, index: int, timestamp: int, path: Path, range_m: float | None
               ) -> _Scan:
    """A message checked and its readings mapped (REP 117); ValueError naming the message."""
    where = f"{path}: message {index}"
    rmin, rmax = float(msg.range_min), float(msg.range_max)
    if not (math.isfinite(rmin) and math.isfinite(rmax) and 0.0 <= rmin < rmax):
        raise FftnavError(f"{where}: range_min and range_max must be finite with "
                          f"0 <= range_min < range_max, got range_min={rmin!r}, "
                          f"range_max={rmax!r}")
    ranges = np.asarray(msg.ranges)
    check_limit(f"{where}: beams", len(ranges), MAX_BEAMS)
    layout = layout_of(float(msg.angle_min), float(msg.angle_max),
                       float(msg.angle_increment), len(ranges), where=where)
    r = rmax if range_m is None else range_m
    return _Scan(index, timestamp, msg, layout, r,
                 layout.to_pipeline(rep117_ranges(ranges, range_min=rmin, range_max=rmax,
                                                  range_m=r)))


def _row(scan: _Scan, topic: str) -> dict[str, Any]:
    """The JSON line of a processed scan: ``fftnav scan``'s fields, the message's own, then
    ``angle_max_corrected`` (rad) when the message's ``angle_max`` was one increment off and
    ``reason`` when the scan has no safe beam or no P_s for a known cause."""
    fields = scan.out.fields()
    reason = fields.pop("reason", None)
    header = scan.msg.header
    row = {"index": scan.index, **fields, "topic": topic, "stamp_sec": int(header.stamp.sec),
           "stamp_nanosec": int(header.stamp.nanosec), "frame_id": str(header.frame_id)}
    if scan.layout.angle_max_corrected is not None:
        row["angle_max_corrected"] = scan.layout.angle_max_corrected
    if reason is not None:
        row["reason"] = reason
    return row


class _Batch:
    """Messages in bag order until a batch is full: the scans (processed together, one
    pipeline per beam count, field of view and range) and, for the annotated bag, the other
    topics' messages."""

    def __init__(self, geometry: RobotGeometry, path: Path) -> None:
        self.path = path
        self.pipes = LayoutPipelines(geometry)
        self.items: list[tuple[Any, int, bytes, _Scan | None]] = []
        self.readings = self.bytes = 0

    def add(self, conn: Any, timestamp: int, raw: bytes, scan: _Scan | None) -> bool:
        """Hold a message; True when the batch is full."""
        self.items.append((conn, timestamp, raw, scan))
        self.readings += scan.layout.beams if scan is not None else 0
        self.bytes += len(raw)
        return self.readings >= BATCH_READINGS or self.bytes >= BATCH_BYTES

    def process(self) -> tuple[list[tuple[Any, int, bytes, _Scan | None]], ValueError | None]:
        """Run the pipeline on the held scans; return and forget the held messages. A scan no
        pipeline can take ends the batch before it: (the messages before it, its error). A
        scan narrower than the safety window gets its all-unsafe result."""
        groups: dict[int, tuple[Any, list[_Scan]]] = {}
        error = None
        for k, (*_, scan) in enumerate(self.items):
            if scan is not None:
                try:
                    pipe = self.pipes.get(scan.layout, scan.range_m)
                except ValueError as exc:
                    error = FftnavError(f"{self.path}: message {scan.index}: {exc}")
                    self.items = self.items[:k]
                    break
                if pipe is None:
                    scan.out = LayoutPipelines.narrow(scan.layout)
                else:
                    groups.setdefault(id(pipe), (pipe, []))[1].append(scan)
        for pipe, scans in groups.values():
            res = pipe.process(np.stack([s.ranges for s in scans]))
            for j, scan in enumerate(scans):
                scan.out = LayoutPipelines.result(scan.layout, pipe, res, j)
        items, self.items, self.readings, self.bytes = self.items, [], 0, 0
        return items, error


def scan_bag(path: str | Path, *, topic: str | None, geometry: RobotGeometry,
             range_m: float | None, write: Callable[[str], Any],
             out_bag: str | Path | None = None) -> int:
    """Run the pipeline on every LaserScan of ``topic`` in a bag; ``write`` gets one JSON line
    per message, in bag order (up to a bad message, which then raises ValueError). Returns the
    number of messages.

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag``, a ROS 2 bag folder, or a ``.db3`` or ``.mcap`` file (any case).
    topic : str or None
        The LaserScan topic; None: the bag's only one.
    geometry : RobotGeometry
        The robot the safe directions are for.
    range_m : float or None
        The model range R; None: each message's ``range_max``.
    write : callable
        Called with each line (JSON, ending in a newline).
    out_bag : str or Path, optional
        Write the annotated bag there (:class:`AnnotatedBag`).
    """
    path = Path(path)
    if out_bag is not None:
        check_out_bag(path, out_bag)
    with open_bag(path) as reader, contextlib.ExitStack() as stack:
        name = _topic(reader, path, topic)
        writer = None
        if out_bag is not None:
            writer = stack.enter_context(AnnotatedBag(out_bag, reader, path))
        run = _TopicRun(reader, path, name, batch=_Batch(geometry, path), write=write,
                        writer=writer)
        try:
            run.read(range_m)
        finally:  # the lines of the messages before a bad one are not lost
            run.flush()
    return run.count


class _TopicRun:
    """The LaserScans of one topic streamed through the pipeline a batch at a time: one JSON
    line per scan to ``write`` and, with ``writer``, every message into the annotated bag."""

    def __init__(self, reader: Any, path: Path, topic: str, *, batch: _Batch,
                 write: Callable[[str], Any], writer: AnnotatedBag | None) -> None:
        self.reader, self.path, self.topic = reader, path, topic
        self.batch, self.write, self.writer = batch, write, writer
        #: LaserScan messages of the topic read so far.
        self.count = 0

    def read(self, range_m: float | None) -> None:
        """Read the bag's messages in order (those of the topic alone, without ``writer``),
        flushing every full batch."""
        reader, path, writer = self.reader, self.path, self.writer
        conns = [c for c in reader.connections if c.topic == self.topic
                 and c.msgtype == LASERSCAN]
        for conn, timestamp, raw in messages(
                reader, path, reader.connections if writer is not None else conns):
            scan = None
            if conn.topic == self.topic and conn.msgtype == LASERSCAN:
                scan = _read_scan(deserialize(reader, path, raw, conn.msgtype), self.count,
                                  timestamp, path, range_m)
                self.count += 1
            elif writer is not None and conn.topic in (SAFE_SCAN, SAFE_DIRECTIONS):
                continue  # an annotated bag's annotations are written anew
            if self.batch.add(conn, timestamp, raw if writer is not None else b"", scan):
                self.flush()

    def flush(self) -> None:
        """Process the held batch and write it out, in bag order; then raise the error of the
        scan that ended it, if one did."""
        items, error = self.batch.process()
        for conn, timestamp, raw, scan in items:
            if scan is not None:
                self.write(json.dumps(_row(scan, self.topic), separators=(",", ":")) + "\n")
            if self.writer is not None:
                self.writer.copy(conn, timestamp, raw)
                if scan is not None:
                    self.writer.annotate(scan)
        if error is not None:
            raise error


def _out_kind(out: Path, bag: Path) -> tuple[bool, str | None, bool]:
    """(ROS 1, ROS 2 storage, a single file) of the annotated bag: by ``out``'s suffix
    (``.bag``, ``.mcap``, ``.db3``), else the input's kind (a ROS 2 input gives a folder)."""
    name = out.name.lower()
    if name.endswith(".bag"):
        return True, None, True
    if name.endswith((".mcap", ".db3")):
        return False, name.rsplit(".", 1)[1], True
    if _is_ros1(bag):
        return True, None, True
    files = [bag] if bag.is_file() else list(bag.iterdir())
    mcap = any(f.name.lower().endswith(".mcap") for f in files)
    return False, "mcap" if mcap else "db3", False


class BagFile:
    """A bag written into a temporary folder beside ``out`` and moved to ``out`` whole when it
    closes (:meth:`close`), its chunks compressed (MCAP: zstd; ROS 1: LZ4). :meth:`discard`
    leaves nothing behind, and so does an interrupt while it is being made. A temporary folder
    that cannot be made (a folder that is not writable, a read-only file system) is one
    ValueError naming ``out`` and why (:func:`fftnav.files.cannot_write`).

    Parameters
    ----------
    out : Path
        The bag: a ROS 1 ``.bag`` file (``ros1``), a single ``.mcap`` or ``.db3`` file
        (``single``) or a ROS 2 bag folder.
    ros1 : bool
        A ROS 1 bag; else ROS 2 in ``storage`` (``"mcap"`` or ``"db3"``).
    """

    def __init__(self, out: Path, *, ros1: bool, storage: str | None, single: bool) -> None:
        require_rosbags()
        from rosbags.rosbag1 import Writer as Writer1
        from rosbags.rosbag2 import StoragePlugin
        from rosbags.rosbag2 import Writer as Writer2
        from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

        given = Path(out)
        # a symbolic link is written through, not replaced by the bag
        self.out = given.resolve() if given.is_symlink() else given
        self.ros1, self.storage, self.single = ros1, storage, single
        self.tmp = self.temporary(given)
        self.writer: Any = None
        track_temporary(self.tmp)  # before it exists: a second Ctrl-C's exit removes it too
        try:  # everything after the folder is made inside: an interrupt anywhere removes it
            remove_stale_temporaries_of(self.out)  # a killed writer's bag folder beside it
            shutil.rmtree(self.tmp, ignore_errors=True)
            try:
                self.tmp.mkdir(parents=True)
            except OSError as exc:
                raise cannot_write(given, exc, folder=self.tmp.parent) from None
            target = self.tmp / self.out.name
            if ros1:
                self.writer = Writer1(target)
                self.writer.set_compression(Writer1.CompressionFormat.LZ4)
            else:
                plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
                self.writer = Writer2(target, version=8, storage_plugin=plugin)
                if storage == "mcap":  # zstd chunks, as ros2 bag record --storage mcap does
                    self.writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
            self.writer.open()
            self.store = rosmsg.typestore(ros1=ros1)
        except BaseException:
            self.discard()
            raise

    @staticmethod
    def temporary(out: str | Path) -> Path:
        """The temporary folder a bag to ``out`` is written in: ``.NAME.PID.tmp`` beside it (beside
        the target of a symbolic link)."""
        out = Path(out)
        out = out.resolve() if out.is_symlink() else out
        return out.parent / f".{out.name}.{os.getpid()}.tmp"

    def add(self, topic: str, msgtype: str, *, latched: bool = False) -> Any:
        """A connection for ``topic`` with this bag's message definitions; ``latched``: ROS 1's
        ``latching=1``, ROS 2's offered QoS of depth 1, reliable and transient-local (what RViz
        subscribes to a map published once with)."""
        if not latched:
            return self.writer.add_connection(topic, msgtype, typestore=self.store)
        if self.ros1:
            return self.writer.add_connection(topic, msgtype, typestore=self.store, latching=1)
        return self.writer.add_connection(topic, msgtype, typestore=self.store,
                                          offered_qos_profiles=[_latched_qos()])

    def write(self, conn: Any, timestamp: int, msg: Any) -> None:
        """Serialise ``msg`` (of the connection's type) and write it at ``timestamp`` (ns)."""
        self.writer.write(conn, timestamp,
                          rosmsg.serialize(self.store, msg, conn.msgtype, self.ros1))

    def close(self) -> None:
        """Finish the bag and move it to ``out`` (replacing a file there)."""
        try:
            self.writer.close()
            target = self.tmp / self.out.name
            if self.single and not self.ros1:
                target = target / f"{self.out.name}.{self.storage}"
            os.replace(target, self.out)
        finally:
            shutil.rmtree(self.tmp, ignore_errors=True)
            track_temporary(self.tmp, done=True)

    def discard(self) -> None:
        """Drop the bag being written."""
        if self.writer is not None:
            with contextlib.suppress(Exception):
                self.writer.close()
        shutil.rmtree(self.tmp, ignore_errors=True)
        track_temporary(self.tmp, done=True)


def _latched_qos() -> Any:
    """ROS 2's latched profile: keep the last message, reliable, transient-local."""
    require_rosbags()
    from rosbags import interfaces as q

    never = q.QosTime(0, 0)
    return q.Qos(q.QosHistory.KEEP_LAST, 1, q.QosReliability.RELIABLE,
                 q.QosDurability.TRANSIENT_LOCAL, never, never, q.QosLiveliness.AUTOMATIC, never,
                 False)


class BagWriter:
    """A bag written through a :class:`BagFile` in a ``with`` block: :meth:`setup` runs on
    entry; the bag is moved into place when the block ends without error, dropped otherwise
    (an interrupt during the entry too)."""

    def __init__(self, out: str | Path, *, ros1: bool, storage: str | None,
                 single: bool) -> None:
        self.out, self.ros1, self.storage, self.single = Path(out), ros1, storage, single

    def setup(self) -> None:
        """Add the connections (and messages) the bag starts with."""

    def __enter__(self) -> Any:
        self.file: BagFile | None = None
        try:
            self.file = BagFile(self.out, ros1=self.ros1, storage=self.storage,
                                single=self.single)
            self.store = self.file.store
            self.setup()
        except BaseException:
            if self.file is not None:
                self.file.discard()
            # an interrupt between the BagFile's return and its assignment: by its name
            tmp = BagFile.temporary(self.out)
            shutil.rmtree(tmp, ignore_errors=True)
            track_temporary(tmp, done=True)
            raise
        return self

    def __exit__(self, kind: Any, exc: Any, tb: Any) -> None:
        if kind is None:
            try:
                self.file.close()
            except (sqlite3.Error, OSError) as err:
                self.file.discard()
                raise FftnavError(self._failure(err)) from None
            return
        self.file.discard()
        if isinstance(exc, (sqlite3.Error, OSError)) and not isinstance(exc, FftnavError):
            raise FftnavError(self._failure(exc)) from None  # sqlite's traceback as one line

    def _failure(self, err: BaseException) -> str:
        """Why the bag could not be written, in one line naming it (a full disk as such)."""
        text = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        full = (getattr(err, "errno", None) == errno.ENOSPC or "disk is full" in text
                or "No space left" in text)
        return (f"{self.out}: the bag could not be written "
                f"({'no space left on device' if full else text}); nothing was kept")


class AnnotatedBag(BagWriter):
    """The annotated bag of :func:`scan_bag`.

    It holds the input's topics (converted when the kinds differ, by rosbags) and per scan:

    - ``/fftnav/safe_scan``, a LaserScan of the same beams: ``y1 * R`` on safe beams and NaN
      (REP 117 "invalid", which viewers leave out) elsewhere;
    - ``/fftnav/safe_directions``, a MarkerArray: one triangle-list marker holding a wedge per
      safe beam, ``y1 * R`` long and one increment wide, in the scan's frame.
    """

    def __init__(self, out: str | Path, reader: Any, bag: Path) -> None:
        ros1, storage, single = _out_kind(Path(out), bag)
        super().__init__(out, ros1=ros1, storage=storage, single=single)
        self.reader, self.source = reader, bag

    def setup(self) -> None:
        require_rosbags()
        from rosbags.convert.converter import create_connections_converters

        copied = [c for c in self.reader.connections
                  if c.topic not in (SAFE_SCAN, SAFE_DIRECTIONS)]
        with _damage(self.source), contextlib.redirect_stdout(io.StringIO()):  # it prints
            self.connmap, self.convmap = create_connections_converters(
                copied, None, self.reader, self.file.writer)
        self.scan_conn = self.file.add(SAFE_SCAN, LASERSCAN)
        self.marker_conn = self.file.add(SAFE_DIRECTIONS, MARKER_ARRAY)

    def copy(self, conn: Any, timestamp: int, raw: bytes) -> None:
        """Write an input message again (a message rosbags cannot convert is a damaged input:
        one ValueError naming the bag)."""
        with _damage(self.source):
            converted = self.convmap[conn.msgtype](raw)
        self.file.writer.write(self.connmap[(conn.id, conn.owner)], timestamp, converted)

    def annotate(self, scan: _Scan) -> None:
        """Write a processed scan's ``/fftnav/safe_scan`` and ``/fftnav/safe_directions``, in
        the message's beam order and frame (its ``angle_max`` the last beam's angle)."""
        s, msg, lay = self.store, scan.msg, scan.layout
        mask, length = scan.out.safe_mask, scan.out.y1 * scan.range_m
        angle_max = (float(msg.angle_max) if lay.angle_max_corrected is None
                     else lay.angle_max_corrected)
        head = rosmsg.header(s, rosmsg.make(s, "builtin_interfaces/msg/Time",
                                            sec=int(msg.header.stamp.sec),
                                            nanosec=int(msg.header.stamp.nanosec)),
                             str(msg.header.frame_id))
        ranges = np.where(mask, length, np.nan).astype(np.float32)
        safe = rosmsg.make(s, LASERSCAN, header=head, angle_min=float(msg.angle_min),
                           angle_max=angle_max,
                           angle_increment=float(msg.angle_increment),
                           time_increment=float(msg.time_increment),
                           scan_time=float(msg.scan_time), range_min=0.0,
                           range_max=float(scan.range_m), ranges=ranges)
        self.file.write(self.scan_conn, scan.timestamp, safe)
        self.file.write(self.marker_conn, scan.timestamp,
                        rosmsg.make(s, MARKER_ARRAY, markers=[_wedges(s, msg, head, mask, length)]))


def _wedges(s: Any, msg: Any, head: Any, mask: np.ndarray, length: np.ndarray, *,
            ns: str = "fftnav/safe_directions") -> Any:
    """One TRIANGLE_LIST marker in namespace ``ns``: a wedge per safe beam of the LaserScan
    ``msg``'s layout, ``length`` (m) long (DELETE when no beam is safe)."""
    inc = float(msg.angle_increment)
    beams = np.flatnonzero(mask)
    theta = float(msg.angle_min) + beams * inc
    half = 0.5 * abs(inc)
    r = length[beams]
    x0, y0 = r * np.cos(theta - half), r * np.sin(theta - half)
    x1, y1 = r * np.cos(theta + half), r * np.sin(theta + half)
    point = s.types["geometry_msgs/msg/Point"]
    origin = point(0.0, 0.0, 0.0)
    points = []
    for a, b, c, d in zip(x0.tolist(), y0.tolist(), x1.tolist(), y1.tolist(), strict=True):
        points += [origin, point(a, b, 0.0), point(c, d, 0.0)]
    return rosmsg.make(
        s, "visualization_msgs/msg/Marker", header=head, ns=ns, id=0,
        type=rosmsg.TRIANGLE_LIST, action=rosmsg.ADD if len(beams) else rosmsg.DELETE,
        pose=rosmsg.make(s, "geometry_msgs/msg/Pose",
                         orientation=rosmsg.yaw_quaternion(s, 0.0)),
        scale=rosmsg.make(s, "geometry_msgs/msg/Vector3", x=1.0, y=1.0, z=1.0),
        color=rosmsg.color(s, 0.1, 0.8, 0.2, 0.5), points=points)
