"""An episode written as a bag: ``fftnav episode ... --bag OUT.mcap``.

:class:`EpisodeBag` is the episode's ``on_tick`` hook (:func:`fftnav.episode.run_episode`). At
simulated time (the stamps and the bag's times) it writes:

- latched (ROS 1 ``latching=1``; ROS 2 transient-local durability, depth 1: what RViz asks for
  to show a map published once), at time 0:

  - ``/world``: a ``visualization_msgs/MarkerArray`` in frame ``map``: the outline of every
    obstacle and boundary wall (a LINE_LIST) and the goals (a SPHERE_LIST);
  - ``/tf_static``: ``robot_i/base_link -> robot_i/laser`` of every robot, the lidar's mount
    (its height: the robot radius r0);

- each tick:

  - ``/tf``: ``map -> robot_i/base_link`` of every robot in the world (its true pose);
  - ``/fftnav/robots``: a MarkerArray of every robot in the world, in namespaces
    ``robot_i/footprint`` (a disc of radius r0), ``robot_i/heading`` (an arrow),
    ``robot_i/label`` (its name) and ``robot_i/goal`` (a sphere at its goal, in ``map``), in
    the robot's colour while it drives and grey while it waits to depart; the tick it leaves
    (arrived, collided, lost, out of time) they are deleted;
  - per robot ``i`` driving: ``/robot_i/scan`` (the simulated lidar's raw readings as a
    LaserScan in ``robot_i/laser``: misses read ``range_max`` = R, the blind sector at the back
    reads 0), ``/robot_i/odom`` (``nav_msgs/Odometry``: the pose the robot knows, in ``map``:
    its true pose, or its odometry's estimate with ``localization.mode = "odometry"``; the
    commanded twist), ``/robot_i/cmd_vel`` (``geometry_msgs/Twist``) and, when its method runs
    the FFT pipeline, ``/robot_i/fftnav/safe_scan`` (a LaserScan of the same beams: ``y1 * R``
    on safe beams, NaN elsewhere) and ``/robot_i/fftnav/safe_directions`` (a MarkerArray, one
    wedge per safe beam, namespace ``robot_i/safe_directions``), as ``fftnav scan --out-bag``
    annotates a recorded scan;
  - ``/robot_i/messages``: each swarm message robot ``i`` broadcast, as
    ``std_msgs/UInt8MultiArray``;

- after the episode (:meth:`EpisodeBag.finish`), ``/fftnav/failures``: for each robot that did
  not arrive, at its failure tick (the tick the replays turn it red,
  :func:`fftnav.report.replay.failure_ticks`), a red cross where it was (namespace
  ``robot_i/failure``) and its cause as text (``robot_i/cause``), in ``map``.
"""

from __future__ import annotations

import colorsys
import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.episode.record import EpisodeResult, failure_tick
from fftnav.errors import FftnavError
from fftnav.navigation.controllers import SwarmStep
from fftnav.ros import messages as rosmsg
from fftnav.ros import require_rosbags
from fftnav.ros.bags import LASERSCAN, MARKER_ARRAY, BagWriter, _wedges
from fftnav.states import Status
from fftnav.world.model import World

__all__ = ["EpisodeBag", "check_episode_bag"]

_KINDS = {".mcap": (False, "mcap"), ".db3": (False, "db3"), ".bag": (True, None)}
#: The latched topics.
LATCHED = ("/world", "/tf_static")
ROBOTS, FAILURES = "/fftnav/robots", "/fftnav/failures"
#: The namespaces of a robot's markers on ``/fftnav/robots`` (each holds one marker, id 0).
_ROBOT_NS = ("footprint", "heading", "label", "goal")
_GREY = (0.6, 0.6, 0.6)


def check_episode_bag(path: str | Path) -> tuple[bool, str | None]:
    """(ROS 1, ROS 2 storage) of ``--bag PATH`` by its suffix; FftnavError for another suffix,
    MissingExtraError without rosbags."""
    suffix = Path(path).suffix.lower()
    if suffix not in _KINDS:
        raise FftnavError(f"--bag must end in .mcap, .db3 or .bag, got --bag={str(path)!r}")
    if Path(path).exists() and not Path(path).resolve().is_file():
        raise FftnavError(f"--bag must be a file path, not a folder, pipe or device, got "
                          f"--bag={str(path)!r}")
    require_rosbags()
    return _KINDS[suffix]


def robot_color(i: int) -> tuple[float, float, float]:
    """Robot ``i``'s colour (RGB in [0, 1]): hues a golden angle apart, so neighbours differ."""
    return colorsys.hsv_to_rgb((i * 0.618033988749895) % 1.0, 0.75, 0.9)


class EpisodeBag(BagWriter):
    """The bag of one episode; use as a context manager, pass it as ``on_tick`` and call
    :meth:`finish` with the episode's result inside the ``with`` block.

    Parameters
    ----------
    path : str or Path
        ``.mcap``, ``.db3`` (single ROS 2 files) or ``.bag`` (ROS 1); written beside and moved
        there when the episode ends without error.
    world : World
        The episode's world (``/world``, the goals).
    config : SwarmConfig
        The episode's configuration (the lidar's layout and range, the robot radius, the
        control rate and departures).
    """

    def __init__(self, path: str | Path, world: World, config: SwarmConfig) -> None:
        ros1, storage = check_episode_bag(path)
        super().__init__(path, ros1=ros1, storage=storage, single=True)
        self.world, self.config = world, config
        self.angles = config.pipeline().angles_rad
        self.conns: dict[str, Any] = {}
        self.robots = len(world.starts)
        #: Robots whose markers are shown, with their pipeline's wedges (True) or not.
        self.shown: dict[int, bool] = {}
        #: Each robot's markers, driving and waiting (:meth:`_robot_templates`).
        self.templates: dict[tuple[int, bool], tuple[Any, ...]] = {}
        #: Simulated time of each tick written (s).
        self.times: dict[int, float] = {}

    def _put(self, topic: str, msgtype: str, t_ns: int, msg: Any) -> None:
        if topic not in self.conns:
            self.conns[topic] = self.file.add(topic, msgtype, latched=topic in LATCHED)
        self.file.write(self.conns[topic], t_ns, msg)

    def setup(self) -> None:
        """Write ``/world`` and ``/tf_static``."""
        s = self.store
        head = rosmsg.header(s, 0.0, "map")
        edges = []
        for obstacle in self.world.solids:
            ring = np.asarray(obstacle.outline(), dtype=float)
            for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
                edges += [rosmsg.point(s, *a), rosmsg.point(s, *b)]
        outline = rosmsg.make(
            s, "visualization_msgs/msg/Marker", header=head, ns="obstacles", id=0,
            type=rosmsg.LINE_LIST, action=rosmsg.ADD, pose=rosmsg.pose(s),
            scale=rosmsg.vector(s, 0.03), color=rosmsg.color(s, 0.2, 0.2, 0.2, 1.0),
            points=edges)
        goals = rosmsg.make(
            s, "visualization_msgs/msg/Marker", header=head, ns="goals", id=1,
            type=rosmsg.SPHERE_LIST, action=rosmsg.ADD, pose=rosmsg.pose(s),
            scale=rosmsg.vector(s, 0.2, 0.2, 0.2), color=rosmsg.color(s, 0.9, 0.6, 0.1, 1.0),
            points=[rosmsg.point(s, *g) for g in np.asarray(self.world.goals, dtype=float)])
        self._put("/world", MARKER_ARRAY, 0, rosmsg.make(s, MARKER_ARRAY,
                                                         markers=[outline, goals]))
        mount = rosmsg.make(s, "geometry_msgs/msg/Transform",
                            translation=rosmsg.vector(s, z=self.config.robot.r0_m),
                            rotation=rosmsg.yaw_quaternion(s, 0.0))
        self._put("/tf_static", "tf2_msgs/msg/TFMessage", 0, rosmsg.make(
            s, "tf2_msgs/msg/TFMessage", transforms=[
                rosmsg.make(s, "geometry_msgs/msg/TransformStamped",
                            header=rosmsg.header(s, 0.0, f"robot_{i}/base_link"),
                            child_frame_id=f"robot_{i}/laser", transform=mount)
                for i in range(self.robots)]))

    def __call__(self, step: SwarmStep, scans: np.ndarray, commands: np.ndarray,
                 outgoing: dict[int, bytes], truth: np.ndarray | None = None) -> None:
        """Write one control tick (:data:`fftnav.episode.loop.OnTick`): ``/tf`` from the true
        poses ``truth`` (default ``step.poses``), each robot's ``odom`` from the pose it knows
        (``step.poses``: its odometry's estimate with ``localization.mode = "odometry"``)."""
        s, t_ns = self.store, round(step.time_s * 1e9)
        self.times[int(step.tick)] = float(step.time_s)
        when = rosmsg.stamp(s, step.time_s)
        poses = np.asarray(step.poses, dtype=float)
        true = poses if truth is None else np.asarray(truth, dtype=float)
        present = np.flatnonzero(step.present_mask()).tolist()
        active = np.asarray(step.active, dtype=int).tolist()
        self._put("/tf", "tf2_msgs/msg/TFMessage", t_ns, rosmsg.make(
            s, "tf2_msgs/msg/TFMessage",
            transforms=[self._transform(when, i, true[i]) for i in present]))
        self._robot_markers(t_ns, when, present, set(active))
        for i in active:
            frame = f"robot_{i}/laser"
            self._put(f"/robot_{i}/scan", LASERSCAN, t_ns, self._scan(when, frame, scans[i]))
            if step.safe is not None and step.y1 is not None:
                self._safe(t_ns, when, i, np.asarray(step.safe[i], dtype=bool),
                           np.asarray(step.y1[i], dtype=float))
            twist = self._twist(commands[i])
            self._put(f"/robot_{i}/odom", "nav_msgs/msg/Odometry", t_ns, rosmsg.make(
                s, "nav_msgs/msg/Odometry", header=rosmsg.header(s, when, "map"),
                child_frame_id=f"robot_{i}/base_link",
                pose=rosmsg.make(s, "geometry_msgs/msg/PoseWithCovariance",
                                 pose=self._pose(poses[i])),
                twist=rosmsg.make(s, "geometry_msgs/msg/TwistWithCovariance", twist=twist)))
            self._put(f"/robot_{i}/cmd_vel", "geometry_msgs/msg/Twist", t_ns, twist)
        for i, data in sorted(outgoing.items()):
            self._put(f"/robot_{int(i)}/messages", "std_msgs/msg/UInt8MultiArray", t_ns,
                      rosmsg.make(s, "std_msgs/msg/UInt8MultiArray",
                                  data=np.frombuffer(bytes(data), dtype=np.uint8)))

    def finish(self, result: EpisodeResult) -> None:
        """Write ``/fftnav/failures`` from the episode's result: each robot that did not arrive,
        at its failure tick (:func:`failure_tick`, by the status it left with), at its true
        position then. Each message holds the markers of every robot failed so far (a viewer
        that jumps to a time shows the latest message of a topic, so all of them). Then delete
        the markers of the robots still shown at the end."""
        s, hz = self.store, self.config.episode.control_hz
        departure = self.config.episode.departure_ticks(self.robots)
        last = max(self.times, default=0)
        end_ns = round((self.times.get(last, 0.0) + 1.0 / hz) * 1e9)
        self._delete_robots(end_ns, rosmsg.stamp(s, end_ns * 1e-9), sorted(self.shown))
        failures = []
        for row in result.rows:
            if row.arrived:
                continue
            i = int(row.robot)
            trajectory = np.asarray(result.trajectories[i], dtype=float)
            timed_out = Status(int(result.left[i])) == Status.TIMED_OUT
            tick = failure_tick(trajectory, departure[i], timed_out=timed_out)
            time_s = (self.times[tick] if tick in self.times
                      else self.times.get(last, 0.0) + (tick - last) / hz)
            x, y = trajectory[tick - int(departure[i]), :2]
            failures.append((round(time_s * 1e9), i, self._failure(
                i, time_s, x, y, row.failure or "no cause")))
        shown: list[Any] = []
        for t_ns, _, markers in sorted(failures, key=lambda f: f[:2]):
            shown += markers
            self._put(FAILURES, MARKER_ARRAY, t_ns, rosmsg.make(s, MARKER_ARRAY,
                                                                markers=list(shown)))

    # -- markers ------------------------------------------------------------------------------

    def _robot_markers(self, t_ns: int, when: Any, present: list[int], active: set[int]
                       ) -> None:
        """``/fftnav/robots`` at one tick: the markers of the robots in the world, and the
        deletion of those that left since the last tick (their wedges too)."""
        s = self.store
        gone = sorted(set(self.shown) - set(present))
        if gone:
            self._delete_robots(t_ns, when, gone)
        markers = []
        for i in present:
            key = (i, i in active)
            if key not in self.templates:
                self.templates[key] = self._robot_templates(*key)
            for marker in self.templates[key]:
                head = dataclasses.replace(marker.header, stamp=when)
                markers.append(dataclasses.replace(marker, header=head))
            self.shown.setdefault(i, False)
        self._put(ROBOTS, MARKER_ARRAY, t_ns, rosmsg.make(s, MARKER_ARRAY, markers=markers))

    def _robot_templates(self, i: int, driving: bool) -> tuple[Any, ...]:
        """Robot ``i``'s markers (time 0): its footprint, heading and label frame-locked to
        ``robot_i/base_link`` and its goal in ``map``; its colour driving, grey waiting."""
        s, r0 = self.store, self.config.robot.r0_m
        rgb = robot_color(i) if driving else _GREY
        common = {"header": rosmsg.header(s, 0.0, f"robot_{i}/base_link"),
                  "action": rosmsg.ADD, "frame_locked": True}
        return (
            self._marker(f"robot_{i}/footprint", rosmsg.CYLINDER, rgb, 0.8, **common,
                         pose=rosmsg.pose(s, z=0.01),
                         scale=rosmsg.vector(s, 2 * r0, 2 * r0, 0.02)),
            self._marker(f"robot_{i}/heading", rosmsg.ARROW, rgb, 1.0, **common,
                         pose=rosmsg.pose(s, z=0.03),
                         scale=rosmsg.vector(s, 2 * r0, 0.3 * r0, 0.3 * r0)),
            self._marker(f"robot_{i}/label", rosmsg.TEXT, rgb, 1.0, **common,
                         pose=rosmsg.pose(s, z=2 * r0 + 0.15), scale=rosmsg.vector(s, z=0.2),
                         text=f"robot_{i}"),
            self._marker(f"robot_{i}/goal", rosmsg.SPHERE, rgb, 0.7,
                         header=rosmsg.header(s, 0.0, "map"), action=rosmsg.ADD,
                         pose=rosmsg.pose(s, *np.asarray(self.world.goals[i], float), 0.1),
                         scale=rosmsg.vector(s, 0.2, 0.2, 0.2)))

    def _delete_robots(self, t_ns: int, when: Any, robots: list[int]) -> None:
        """Delete robots' markers on ``/fftnav/robots`` and their wedges."""
        if not robots:
            return
        s = self.store
        self._put(ROBOTS, MARKER_ARRAY, t_ns, rosmsg.make(s, MARKER_ARRAY, markers=[
            self._marker(f"robot_{i}/{ns}", 0, _GREY, 0.0, action=rosmsg.DELETE,
                         header=rosmsg.header(s, when, "map"))
            for i in robots for ns in _ROBOT_NS]))
        for i in robots:
            if self.shown.pop(i):
                self._put(f"/robot_{i}/fftnav/safe_directions", MARKER_ARRAY, t_ns,
                          rosmsg.make(s, MARKER_ARRAY, markers=[self._marker(
                              f"robot_{i}/safe_directions", rosmsg.TRIANGLE_LIST, _GREY, 0.0,
                              action=rosmsg.DELETE,
                              header=rosmsg.header(s, when, f"robot_{i}/laser"))]))

    def _failure(self, i: int, time_s: float, x: float, y: float, cause: str) -> list[Any]:
        """Robot ``i``'s failure markers: a red cross at ``(x, y)`` and its cause above it."""
        s, r0 = self.store, self.config.robot.r0_m
        head = rosmsg.header(s, time_s, "map")
        d = 1.5 * r0
        cross = [rosmsg.point(s, x + a, y + b, 0.05) for a, b in
                 ((-d, -d), (d, d), (-d, d), (d, -d))]
        return [self._marker(f"robot_{i}/failure", rosmsg.LINE_LIST, (0.9, 0.1, 0.1), 1.0,
                             header=head, action=rosmsg.ADD, pose=rosmsg.pose(s),
                             scale=rosmsg.vector(s, 0.06), points=cross),
                self._marker(f"robot_{i}/cause", rosmsg.TEXT, (0.9, 0.1, 0.1), 1.0,
                             header=head, action=rosmsg.ADD,
                             pose=rosmsg.pose(s, x, y, 2 * r0 + 0.4),
                             scale=rosmsg.vector(s, z=0.2), text=f"robot_{i}: {cause}")]

    def _marker(self, ns: str, kind: int, rgb: tuple[float, float, float], alpha: float,
                **fields: Any) -> Any:
        return rosmsg.make(self.store, "visualization_msgs/msg/Marker", ns=ns, id=0, type=kind,
                           color=rosmsg.color(self.store, *rgb, alpha), **fields)

    # -- messages -----------------------------------------------------------------------------

    def _safe(self, t_ns: int, when: Any, i: int, mask: np.ndarray, y1: np.ndarray) -> None:
        """Robot ``i``'s ``fftnav/safe_scan`` and ``fftnav/safe_directions``."""
        s, frame = self.store, f"robot_{i}/laser"
        length = y1 * float(self.config.sensor.range_m)
        safe = self._scan(when, frame, np.where(mask, length, np.nan))
        self._put(f"/robot_{i}/fftnav/safe_scan", LASERSCAN, t_ns, safe)
        self._put(f"/robot_{i}/fftnav/safe_directions", MARKER_ARRAY, t_ns, rosmsg.make(
            s, MARKER_ARRAY, markers=[_wedges(s, safe, safe.header, mask, length,
                                              ns=f"robot_{i}/safe_directions")]))
        self.shown[i] = True

    def _scan(self, when: Any, frame: str, ranges: np.ndarray) -> Any:
        a = self.angles
        return rosmsg.make(
            self.store, LASERSCAN, header=rosmsg.header(self.store, when, frame),
            angle_min=float(a[0]), angle_max=float(a[-1]), angle_increment=float(a[1] - a[0]),
            scan_time=1.0 / self.config.episode.control_hz,
            range_min=float(self.config.robot.r0_m),
            range_max=float(self.config.sensor.range_m),
            ranges=np.asarray(ranges, dtype=np.float32))

    def _pose(self, pose: np.ndarray) -> Any:
        return rosmsg.pose(self.store, pose[0], pose[1], yaw_rad=float(pose[2]))

    def _twist(self, command: np.ndarray) -> Any:
        s = self.store
        return rosmsg.make(s, "geometry_msgs/msg/Twist", linear=rosmsg.vector(s, command[0]),
                           angular=rosmsg.vector(s, z=command[1]))

    def _transform(self, when: Any, i: int, pose: np.ndarray) -> Any:
        s = self.store
        return rosmsg.make(
            s, "geometry_msgs/msg/TransformStamped", header=rosmsg.header(s, when, "map"),
            child_frame_id=f"robot_{i}/base_link",
            transform=rosmsg.make(s, "geometry_msgs/msg/Transform",
                                  translation=rosmsg.vector(s, pose[0], pose[1]),
                                  rotation=rosmsg.yaw_quaternion(s, float(pose[2]))))

