"""An episode written as a bag: ``fftnav episode ... --bag OUT.mcap``.

:class:`EpisodeBag` is the episode's ``on_tick`` hook (:func:`fftnav.episode.run_episode`). At
simulated time (the stamps and the bag's times) it writes:

- ``/world``: a ``visualization_msgs/MarkerArray`` in frame ``map``, once: the outline of every
  obstacle and boundary wall (a LINE_LIST) and the goals (a SPHERE_LIST);
- ``/tf``: ``map -> robot_i/base_link`` of every robot in the world, each tick (its true pose);
- per robot ``i`` driving at that tick: ``/robot_i/scan`` (the simulated lidar's raw readings
  as a LaserScan in ``robot_i/base_link``: misses read ``range_max`` = R, the blind sector at the
  back reads 0), ``/robot_i/odom`` (``nav_msgs/Odometry``: the pose the robot knows, in ``map``:
  its true pose, or its odometry's estimate with ``localization.mode = "odometry"``; the
  commanded twist) and ``/robot_i/cmd_vel`` (``geometry_msgs/Twist``);
- ``/robot_i/messages``: each swarm message robot ``i`` broadcast, as
  ``std_msgs/UInt8MultiArray``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.errors import FftnavError
from fftnav.navigation.controllers import SwarmStep
from fftnav.ros import messages as rosmsg
from fftnav.ros import require_rosbags
from fftnav.ros.bags import LASERSCAN, MARKER_ARRAY, BagWriter
from fftnav.world.model import World

__all__ = ["EpisodeBag", "check_episode_bag"]

_KINDS = {".mcap": (False, "mcap"), ".db3": (False, "db3"), ".bag": (True, None)}


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


class EpisodeBag(BagWriter):
    """The bag of one episode; use as a context manager and pass it as ``on_tick``.

    Parameters
    ----------
    path : str or Path
        ``.mcap``, ``.db3`` (single ROS 2 files) or ``.bag`` (ROS 1); written beside and moved
        there when the episode ends without error.
    world : World
        The episode's world (``/world``).
    config : SwarmConfig
        The episode's configuration (the lidar's layout and range).
    """

    def __init__(self, path: str | Path, world: World, config: SwarmConfig) -> None:
        ros1, storage = check_episode_bag(path)
        super().__init__(path, ros1=ros1, storage=storage, single=True)
        self.world, self.config = world, config
        self.angles = config.pipeline().angles_rad
        self.conns: dict[str, Any] = {}

    def _put(self, topic: str, msgtype: str, t_ns: int, msg: Any) -> None:
        if topic not in self.conns:
            self.conns[topic] = self.file.add(topic, msgtype)
        self.file.write(self.conns[topic], t_ns, msg)

    def setup(self) -> None:
        """Write ``/world``."""
        s = self.store
        head = rosmsg.header(s, 0.0, "map")
        edges = []
        for obstacle in self.world.solids:
            ring = np.asarray(obstacle.outline(), dtype=float)
            for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
                edges += [rosmsg.point(s, *a), rosmsg.point(s, *b)]
        pose = rosmsg.make(s, "geometry_msgs/msg/Pose", orientation=rosmsg.yaw_quaternion(s, 0))
        outline = rosmsg.make(
            s, "visualization_msgs/msg/Marker", header=head, ns="obstacles", id=0,
            type=rosmsg.LINE_LIST, action=rosmsg.ADD, pose=pose,
            scale=rosmsg.make(s, "geometry_msgs/msg/Vector3", x=0.03),
            color=rosmsg.color(s, 0.2, 0.2, 0.2, 1.0), points=edges)
        goals = rosmsg.make(
            s, "visualization_msgs/msg/Marker", header=head, ns="goals", id=1,
            type=rosmsg.SPHERE_LIST, action=rosmsg.ADD, pose=pose,
            scale=rosmsg.make(s, "geometry_msgs/msg/Vector3", x=0.2, y=0.2, z=0.2),
            color=rosmsg.color(s, 0.9, 0.6, 0.1, 1.0),
            points=[rosmsg.point(s, *g) for g in np.asarray(self.world.goals, dtype=float)])
        self._put("/world", MARKER_ARRAY, 0, rosmsg.make(s, MARKER_ARRAY,
                                                         markers=[outline, goals]))

    def __call__(self, step: SwarmStep, scans: np.ndarray, commands: np.ndarray,
                 outgoing: dict[int, bytes], truth: np.ndarray | None = None) -> None:
        """Write one control tick (:data:`fftnav.episode.loop.OnTick`): ``/tf`` from the true
        poses ``truth`` (default ``step.poses``), each robot's ``odom`` from the pose it knows
        (``step.poses``: its odometry's estimate with ``localization.mode = "odometry"``)."""
        s, t_ns = self.store, round(step.time_s * 1e9)
        when = rosmsg.stamp(s, step.time_s)
        poses = np.asarray(step.poses, dtype=float)
        true = poses if truth is None else np.asarray(truth, dtype=float)
        present = np.flatnonzero(step.present_mask())
        self._put("/tf", "tf2_msgs/msg/TFMessage", t_ns, rosmsg.make(
            s, "tf2_msgs/msg/TFMessage",
            transforms=[self._transform(when, i, true[i]) for i in present]))
        for i in np.asarray(step.active, dtype=int).tolist():
            frame = f"robot_{i}/base_link"
            self._put(f"/robot_{i}/scan", LASERSCAN, t_ns, self._scan(when, frame, scans[i]))
            twist = self._twist(commands[i])
            self._put(f"/robot_{i}/odom", "nav_msgs/msg/Odometry", t_ns, rosmsg.make(
                s, "nav_msgs/msg/Odometry", header=rosmsg.header(s, when, "map"),
                child_frame_id=frame,
                pose=rosmsg.make(s, "geometry_msgs/msg/PoseWithCovariance",
                                 pose=self._pose(poses[i])),
                twist=rosmsg.make(s, "geometry_msgs/msg/TwistWithCovariance", twist=twist)))
            self._put(f"/robot_{i}/cmd_vel", "geometry_msgs/msg/Twist", t_ns, twist)
        for i, data in sorted(outgoing.items()):
            self._put(f"/robot_{int(i)}/messages", "std_msgs/msg/UInt8MultiArray", t_ns,
                      rosmsg.make(s, "std_msgs/msg/UInt8MultiArray",
                                  data=np.frombuffer(bytes(data), dtype=np.uint8)))

    def _scan(self, when: Any, frame: str, ranges: np.ndarray) -> Any:
        a = self.angles
        return rosmsg.make(
            self.store, LASERSCAN, header=rosmsg.header(self.store, when, frame),
            angle_min=float(a[0]), angle_max=float(a[-1]), angle_increment=float(a[1] - a[0]),
            scan_time=1.0 / self.config.episode.control_hz, range_min=0.0,
            range_max=float(self.config.sensor.range_m),
            ranges=np.asarray(ranges, dtype=np.float32))

    def _pose(self, pose: np.ndarray) -> Any:
        s = self.store
        return rosmsg.make(s, "geometry_msgs/msg/Pose",
                           position=rosmsg.point(s, pose[0], pose[1]),
                           orientation=rosmsg.yaw_quaternion(s, float(pose[2])))

    def _twist(self, command: np.ndarray) -> Any:
        s = self.store
        return rosmsg.make(s, "geometry_msgs/msg/Twist",
                           linear=rosmsg.make(s, "geometry_msgs/msg/Vector3", x=float(command[0])),
                           angular=rosmsg.make(s, "geometry_msgs/msg/Vector3",
                                               z=float(command[1])))

    def _transform(self, when: Any, i: int, pose: np.ndarray) -> Any:
        s = self.store
        return rosmsg.make(
            s, "geometry_msgs/msg/TransformStamped", header=rosmsg.header(s, when, "map"),
            child_frame_id=f"robot_{i}/base_link",
            transform=rosmsg.make(
                s, "geometry_msgs/msg/Transform",
                translation=rosmsg.make(s, "geometry_msgs/msg/Vector3", x=float(pose[0]),
                                        y=float(pose[1])),
                rotation=rosmsg.yaw_quaternion(s, float(pose[2]))))
