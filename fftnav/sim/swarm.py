"""PyBullet swarm of differential-drive robots with lidars: a Gymnasium-style many-robot API.

``SwarmSim(world)`` builds the world's solids (obstacles and boundary walls) as one static
triangle mesh of vertical prisms (rocks and walls over their polygons, trunks over 64-gons
circumscribing their circles: Bullet ray-casts triangle meshes exactly and faster than convex
hulls or capsules), or, for a world beyond one mesh, as 10 m tiles built when a robot first
comes near them (:mod:`fftnav.sim.mesh`), and one robot per start pose (a planar sphere, or
optionally a wheeled URDF). ``reset(seed=...)`` returns the first observation;
``step(commands)`` applies (v, w) commands for one control period. Only ``fftnav.sim``
imports pybullet.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as p

from fftnav.config import RobotConfig, SensorConfig, SwarmConfig, check_rates
from fftnav.errors import FftnavError
from fftnav.limits import MAX_RAYS_PER_TICK, check_limit
from fftnav.sim import fastrays
from fftnav.sim.fastrays import StaticMesh
from fftnav.sim.lidar import CULL_MARGIN_M, BeamPattern, Lidar, RayTargets
from fftnav.sim.mesh import (
    MAX_MESH_INDICES,
    MAX_MESH_VERTICES,
    join_meshes,
    obstacle_meshes,
    static_tiles,
)
from fftnav.validate import Checked, check_integer, integer_field, number_field
from fftnav.world import World

__all__ = ["SimConfig", "Observation", "SwarmSim"]

# Collision-filter groups. Bullet's rays belong to group 1 (_RAYS): a body is visible to the
# lidar iff its mask has that bit and the lidar's mask has its group (obstacles, robots).
_RAYS, _OBSTACLE, _ROBOT, _GROUND = 1, 2, 4, 8
_ROBOT_MASK = _GROUND | _OBSTACLE | _ROBOT | _RAYS
_PARKED_XY = (-1000.0, -1000.0)
#: A tile of obstacles is built once a robot comes within max(lidar range, r0 + one control
#: period at full speed) plus this margin (m) of it: before a ray or a contact can reach it.
_TILE_MARGIN_M = 1.0
#: The wheeled robot: URDF built for r0 = _URDF_R0_M (scaled to r0 when loaded), wheel joints.
_URDF = Path(__file__).with_name("wheeled.urdf")
_URDF_R0_M = 0.15
_WHEELS = (0, 1)  # left, right
#: Maximum wheel motor torque (N m) of the velocity controllers.
_WHEEL_TORQUE_NM = 0.5


#: Robot-steps of planar velocities made at once (a control period of any length in bounded
#: memory: a few hundred kB per block).
_VELOCITY_BLOCK = 4096


def _planar_velocities(yaw0: np.ndarray, v: np.ndarray, w: np.ndarray, *, first: int, steps: int,
                       physics_hz: float) -> list[list[list[float]]]:
    """The body robots' linear velocities (v cos(yaw), v sin(yaw), 0) during physics steps
    ``first .. first + steps - 1`` of a control period, ``[step][robot]``: frictionless spheres
    feel no contact torque, so the heading during step k is exactly ``yaw0 + k w / physics_hz``
    and the velocities are known up front."""
    yaw = yaw0 + np.outer(np.arange(first, first + steps) / physics_hz, w)
    return np.stack([v * np.cos(yaw), v * np.sin(yaw), np.zeros_like(yaw)], axis=-1).tolist()


class _PlanarDrive:
    """The body robots' velocities during one control period: before each physics step, every
    robot's base velocity is (re)set to (v cos(yaw), v sin(yaw), 0) and yaw rate w, but only
    where it can have changed.

    Without gravity, damping or contact a body keeps its velocity bit for bit: after the first
    step only robots on an arc (v and w != 0) and those that touched something in the last step
    need their velocity set again. The planar velocities are made :data:`_VELOCITY_BLOCK`
    robot-steps at a time (:func:`_planar_velocities`).
    """

    def __init__(self, bodies: list[int], yaw0: np.ndarray, v: np.ndarray, w: np.ndarray, *,
                 substeps: int, physics_hz: float) -> None:
        self._bodies, self._yaw0, self._v, self._w = bodies, yaw0, v, w
        self._substeps, self._physics_hz = substeps, physics_hz
        self._block = max(1, _VELOCITY_BLOCK // max(1, len(bodies)))
        self._angular = [(0.0, 0.0, wi) for wi in w.tolist()]
        self._steered = set(np.flatnonzero((v != 0) & (w != 0)).tolist())
        # without contacts the velocities to set are those of the steered robots (a fixed list)
        self._steered_order = sorted(self._steered)
        self._linear: list[list[list[float]]] = []

    def set_velocities(self, k: int, touched: set[int], client: int) -> None:
        """Set the velocities before physics step ``k`` of the period: of the robots (indices
        into ``bodies``) ``touched`` in the last step and of the steered ones."""
        block = self._block
        if k % block == 0:
            self._linear = _planar_velocities(self._yaw0, self._v, self._w, first=k,
                                              steps=min(block, self._substeps - k),
                                              physics_hz=self._physics_hz)
        velocity, bodies, angular = self._linear[k % block], self._bodies, self._angular
        reset_velocity = p.resetBaseVelocity  # positional arguments: cheaper to parse
        for j in (touched | self._steered) if touched else self._steered_order:
            reset_velocity(bodies[j], velocity[j], angular[j], client)


def _record_contacts(contacts: tuple, *, ground: int, slot: dict[int, int],
                     index: dict[int, int], obstacle_hit: np.ndarray,
                     robot_hit: np.ndarray) -> set[int]:
    """Mark, from one physics step's ``contacts`` (pybullet's getContactPoints), the robots
    that touched an obstacle or another robot (``index``: body -> robot index, in
    ``obstacle_hit`` / ``robot_hit``); return the driven robots that touched anything
    (``slot``: body -> index among the driven bodies). Contacts with the ground do not count."""
    touched = set()
    for contact in contacts:
        a, b = contact[1], contact[2]
        if a == ground or b == ground:
            continue
        for this, other in ((a, b), (b, a)):
            if this in index:
                (robot_hit if other in index else obstacle_hit)[index[this]] = True
                touched.add(slot[this])
    return touched


@dataclass(frozen=True)
class SimConfig(Checked):
    """Simulation parameters: the robot and its lidar (:mod:`fftnav.config`), rates and physics.

    Attributes
    ----------
    robot : RobotConfig
        Collision radius r0 (the robot body is a sphere of this radius), command limits
        ``v_max_mps`` and ``w_max_radps`` (commands are clipped) and the embodiment:
        ``"body"`` (default), a rigid sphere of radius r0 (centre at height r0) driven at its
        commanded planar velocity, without gravity or ground (planar): its horizontal section
        through the centre is exactly the robot's disc, it touches vertical obstacles and other
        robots only at that height, and every contact normal passes through its centre, so
        contacts are those of the 2D disc, nothing can tip it over, and sphere contacts are
        Bullet's cheapest; ``"wheeled"``: ``wheeled.urdf`` scaled to r0 (chassis of radius r0,
        two wheels under velocity control, frictionless casters) rolling on a ground plane
        under gravity.
    sensor : SensorConfig
        The lidar: M beams, range R, field of view, blind sector at the back, Gaussian range
        noise on returns and dropout (a dropped beam reads R), drawn from the episode seed.
    physics_hz, control_hz : float
        Physics step rate and control / lidar rate (Hz); their ratio must be an integer.
    lidar_height_m : float or None
        Height of the lidar beams above the ground (m); None (default) puts them at height r0:
        the body sphere's equator, or 5 cm below the wheeled robot's chassis top, where every
        robot appears to the others as its exact r0 disc.
    robot_mass_kg : float
        Mass of the body embodiment (kg); the wheeled URDF carries its own (5 kg).
    gravity_mps2 : float
        Gravity magnitude (m/s^2) along -z, for the wheeled embodiment.
    solver_iterations : int
        Bullet constraint-solver iterations per physics step.
    mesh_max_vertices, mesh_max_indices : int
        Size limit of one static obstacle mesh (default: Bullet's own, :mod:`fftnav.sim.mesh`);
        a world that needs more is split into tiles of several meshes.
    """

    robot: RobotConfig = field(default_factory=RobotConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    physics_hz: float = number_field(240.0, low=0, low_open=True)
    control_hz: float = number_field(10.0, low=0, low_open=True)
    lidar_height_m: float | None = number_field(None, optional=True, low=0)
    robot_mass_kg: float = number_field(5.0, low=0, low_open=True)
    gravity_mps2: float = number_field(9.81, low=0)
    solver_iterations: int = integer_field(10, low=1)
    mesh_max_vertices: int = integer_field(MAX_MESH_VERTICES, low=3, high=MAX_MESH_VERTICES)
    mesh_max_indices: int = integer_field(MAX_MESH_INDICES, low=3, high=MAX_MESH_INDICES)

    def _check_together(self) -> None:
        check_rates(self.control_hz, self.physics_hz)

    @classmethod
    def for_swarm(cls, config: SwarmConfig, **sim_only: Any) -> SimConfig:
        """The simulator of a swarm configuration (``sim_only``: the fields above that are
        not part of it, e.g. ``lidar_height_m``)."""
        return cls(robot=config.robot, sensor=config.sensor,
                   physics_hz=config.episode.physics_hz, control_hz=config.episode.control_hz,
                   **sim_only)

    @property
    def substeps(self) -> int:
        """Physics steps per control period."""
        return round(self.physics_hz / self.control_hz)


@dataclass(frozen=True)
class Observation:
    """What the swarm reports after ``reset`` or one ``step``.

    Attributes
    ----------
    scans : numpy.ndarray, (K, M) float64
        Lidar ranges in metres ordered from -Theta/2 to +Theta/2 about the heading; blind
        beams read 0, misses read R; rows of parked robots are NaN.
    poses : numpy.ndarray, (K, 3)
        x (m), y (m), yaw (rad, in (-pi, pi]) per robot; parked robots keep their last pose.
    obstacle_contact, robot_contact : numpy.ndarray, (K,) bool
        Whether Bullet reported a contact with an obstacle / another robot during the period.
    time_s : float
        Simulated time since ``reset`` (s).
    odometer_m : numpy.ndarray, (K,)
        Driven path length per robot (m): sum of the straight segments between poses at the
        control rate.
    active : numpy.ndarray, (K,) bool
        False for parked robots.
    """

    scans: np.ndarray
    poses: np.ndarray
    obstacle_contact: np.ndarray
    robot_contact: np.ndarray
    time_s: float
    odometer_m: np.ndarray
    active: np.ndarray


class SwarmSim:
    """A PyBullet world with one robot per start pose of ``world``.

    Parameters
    ----------
    world : World
        Obstacles and start poses (``fftnav.world.model``).
    config : SimConfig, optional
        Simulation parameters; default ``SimConfig()``.
    gui : bool, optional
        Open the PyBullet GUI instead of the headless DIRECT server.

    Notes
    -----
    Deterministic: the same world, ``reset`` seed and commands give bitwise-equal poses. The
    Bullet world is built once; ``reset`` restores the Bullet state saved right after building
    (a world of one tile) or puts every robot back at its stored start pose, at rest (wheel
    joints too; a tiled world, whose state would be slow to save), and re-inserts every robot,
    parked or not, into the broadphase (dropping the last episode's contact caches), so every
    episode starts from the same state. In a tiled world, the tiles first built during the last
    episode are taken out again (their collision shapes are kept, so building them again is
    cheap), so that every episode builds them in the same order as a fresh world would. The
    episode seed only drives lidar noise and dropout.
    """

    def __init__(self, world: World, *, config: SimConfig | None = None, gui: bool = False) -> None:
        self.world = world
        self.config = config or SimConfig()
        check_limit(f"lidar rays per control tick ({len(world.starts)} robots x beams)",
                    len(world.starts) * self.config.sensor.beams, MAX_RAYS_PER_TICK,
                    hint="lower sensor.beams or the number of robots")
        if gui and sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
            # PyBullet's GUI would print "cannot connect to X server" and exit the process
            raise FftnavError("gui needs a display, got DISPLAY unset (run without --gui, or "
                              "with a virtual display such as xvfb-run)")
        try:
            self._client = p.connect(p.GUI if gui else p.DIRECT)
        except p.error:
            self._client = -1
        if self._client < 0:
            raise FftnavError("gui: cannot open the PyBullet GUI (is a display available? "
                              "DISPLAY is " + repr(os.environ.get("DISPLAY")) + ")")
        # the obstacles alone, for the lidar's rays that cannot hit a robot (faster there)
        self._static_client = p.connect(p.DIRECT)
        self._build()
        # A world of one tile keeps the Bullet state saved right after building and restores
        # it at every reset: poses come back bit for bit as Bullet stored them (a pose set from
        # a quaternion again may differ in its last bit, which can change an episode). Saving
        # the state of a tiled world would take most of its building time, so its robots are
        # put back at their start poses instead.
        self._built_state = (p.saveState(physicsClientId=self._client)
                             if len(self._tiles) == 1 else None)
        self._reset_state(np.random.default_rng(0))

    # ------------------------------------------------------------------ building

    def _build(self) -> None:
        """Build the Bullet world: physics parameters and ground, the obstacles (or the tiles
        near the starts), the robots, and the lidar."""
        wheeled = self.config.robot.embodiment == "wheeled"
        self._build_physics(wheeled)
        self._plan_obstacles(wheeled)
        if len(self._tiles) == 1:
            self._build_tiles([0])
        else:
            self._build_near(self.world.starts[:, :2])
        # tiles built before the first robot: those near the starts (all of a one-mesh world)
        self._first_tiles = set(self._tile_bodies)
        self._build_robots(wheeled)
        self._lidar = self._make_lidar(wheeled)
        if len(self._tiles) < 2:
            self._parts = []  # every mesh is built

    def _build_physics(self, wheeled: bool) -> None:
        """Gravity, the physics engine's parameters and, for the wheeled robot, the ground."""
        cfg, cid = self.config, self._client
        # The body embodiment is planar (no gravity, no ground: its vertical velocity is held at
        # 0); the wheeled robot rolls on a ground plane under gravity.
        p.setGravity(0.0, 0.0, -cfg.gravity_mps2 if wheeled else 0.0, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=1.0 / cfg.physics_hz,
                                    numSolverIterations=cfg.solver_iterations,
                                    deterministicOverlappingPairs=1, physicsClientId=cid)
        self._ground = -1
        if wheeled:
            self._ground = p.createMultiBody(
                0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
            self._filter(self._ground, _GROUND, _ROBOT)  # invisible to rays
            p.changeDynamics(self._ground, -1, lateralFriction=1.0, physicsClientId=cid)

    def _plan_obstacles(self, wheeled: bool) -> None:
        """The obstacles' meshes, cut into tiles, and the clients that will hold them (nothing
        is built in Bullet yet)."""
        cfg, cid = self.config, self._client
        # All obstacles form ONE static triangle mesh where Bullet's mesh limits allow (Bullet
        # updates every body's bounding box every step, so one body instead of 80 makes a
        # physics step several times cheaper), else 10 m tiles of as few meshes as they need,
        # each built when a robot first comes near it; the same meshes go into the static
        # client, which the lidar uses for rays that cannot hit a robot (faster there), unless
        # the world is tiled and the lidar's compiled scan (numba, sphere robots) leaves only a
        # few rays to Bullet: those then go to the full client, with the obstacles' mask. Every
        # obstacle's mesh is made once, here.
        solids = self.world.solids
        parts = obstacle_meshes(solids)
        self._parts = parts
        self._tiles = static_tiles(solids, parts=parts, max_vertices=cfg.mesh_max_vertices,
                                   max_indices=cfg.mesh_max_indices)
        self._tile_boxes = np.array([t.box for t in self._tiles]).reshape(-1, 4)
        # the triangles of the compiled lidar, added tile by tile as the tiles are built
        self._static_mesh = StaticMesh(parts, [(x, y, r + CULL_MARGIN_M) for x, y, r in
                                               (o.bounding_circle() for o in solids)],
                                       lazy=True) if fastrays.AVAILABLE else None
        #: Bullet shapes of each tile once made (per client), and the bodies of the built tiles.
        self._tile_shapes: dict[int, list[tuple[int, ...]]] = {}
        self._tile_bodies: dict[int, list[tuple[int, int]]] = {}
        self._reach_m = max(cfg.sensor.range_m,
                            cfg.robot.r0_m + cfg.robot.v_max_mps / cfg.control_hz) + _TILE_MARGIN_M
        #: Number of static obstacle meshes (1 unless Bullet's limits split the world).
        self.static_meshes = sum(len(t.meshes) for t in self._tiles)
        compiled = fastrays.AVAILABLE and not wheeled
        self._mesh_clients = ((cid,) if len(self._tiles) > 1 and compiled
                              else (cid, self._static_client))

    def _build_robots(self, wheeled: bool) -> None:
        """One robot per start pose, their start poses and joints, and the wheeled robot's
        track and wheel radius."""
        cfg, cid = self.config, self._client
        self._robots = [self._add_robot(x, y, yaw) for x, y, yaw in self.world.starts]
        self._start_poses = [([x, y, cfg.robot.r0_m], p.getQuaternionFromEuler([0.0, 0.0, yaw]))
                             for x, y, yaw in self.world.starts]
        self._joints = [j for j in range(p.getNumJoints(self._robots[0], physicsClientId=cid))
                        if p.getJointInfo(self._robots[0], j, physicsClientId=cid)[2]
                        != p.JOINT_FIXED] if self._robots else []
        if wheeled and self._robots:
            body = self._robots[0]
            joints = [p.getJointInfo(body, j, physicsClientId=cid) for j in _WHEELS]
            self._track_m = abs(joints[0][14][1] - joints[1][14][1])  # parent-frame y offsets
            wheel = p.getCollisionShapeData(body, _WHEELS[0], physicsClientId=cid)[0]
            self._wheel_radius_m = wheel[3][0]  # sphere dimensions: (radius, ...)

    def _make_lidar(self, wheeled: bool) -> Lidar:
        """The swarm's lidar: the sensor's beams at the lidar height, starting 5 mm outside the
        robot; obstacles and robots as its targets."""
        cfg = self.config
        sensor, r0 = cfg.sensor, cfg.robot.r0_m
        pattern = BeamPattern(beams=sensor.beams, range_m=sensor.range_m, fov_deg=sensor.fov_deg,
                              blind_deg=sensor.blind_deg,
                              height_m=r0 if cfg.lidar_height_m is None else cfg.lidar_height_m,
                              start_m=r0 + 0.005)
        targets = RayTargets(mask=_OBSTACLE | _ROBOT,
                             bodies=[(o.bounding_circle(), o.cull_vertices())
                                     for o in self.world.solids],
                             robot_radius_m=cfg.robot.r0_m, robot_mask=_ROBOT,
                             robot_spheres=not wheeled)
        return Lidar(self._client, pattern, targets,
                     static_client=self._mesh_clients[-1] if len(self._mesh_clients) > 1
                     else None,
                     static_mesh=self._static_mesh,
                     prepare=None if len(self._tiles) < 2 else self._build_near)

    def _build_near(self, xy: np.ndarray) -> None:
        """Build every tile that lies within reach (``_reach_m``) of a point of ``xy`` (K, 2),
        in tile order, unless it is built already."""
        box = self._tile_boxes
        xy = np.asarray(xy, dtype=float).reshape(-1, 1, 2)
        dx = np.maximum(np.maximum(box[:, 0] - xy[..., 0], xy[..., 0] - box[:, 2]), 0.0)
        dy = np.maximum(np.maximum(box[:, 1] - xy[..., 1], xy[..., 1] - box[:, 3]), 0.0)
        near = np.flatnonzero((np.hypot(dx, dy) <= self._reach_m).any(axis=0))
        self._build_tiles([int(t) for t in near if t not in self._tile_bodies])

    def _build_tiles(self, tiles: list[int]) -> None:
        """Create the static bodies of ``tiles`` in the clients that hold obstacles (their
        shapes made once), and add their triangles to the compiled lidar's."""
        if not tiles:
            return
        new = [t for t in tiles if t not in self._tile_shapes]
        if new and self._static_mesh is not None:
            self._static_mesh.add(np.concatenate([k for t in new for k in self._tiles[t].meshes]))
        for t in tiles:
            if t not in self._tile_shapes:
                shapes = []
                for mesh in self._tiles[t].meshes:
                    verts, triangles = join_meshes([self._parts[k] for k in mesh])
                    shapes.append(tuple(
                        p.createCollisionShape(p.GEOM_MESH, vertices=verts, indices=triangles,
                                               physicsClientId=client)
                        for client in self._mesh_clients))
                self._tile_shapes[t] = shapes
            bodies = []
            for pair in self._tile_shapes[t]:
                for client, shape in zip(self._mesh_clients, pair, strict=True):
                    body = p.createMultiBody(0, shape, physicsClientId=client)
                    p.changeDynamics(body, -1, lateralFriction=0.0, physicsClientId=client)
                    p.setCollisionFilterGroupMask(body, -1, _OBSTACLE, _ROBOT | _RAYS,
                                                  physicsClientId=client)
                    bodies.append((client, body))
            self._tile_bodies[t] = bodies
        # the static client's broadphase holds the meshes' bounding boxes from the start
        p.performCollisionDetection(physicsClientId=self._static_client)

    def _add_robot(self, x: float, y: float, yaw: float) -> int:
        cfg, cid = self.config, self._client
        position = [x, y, cfg.robot.r0_m]
        orientation = p.getQuaternionFromEuler([0.0, 0.0, yaw])
        if cfg.robot.embodiment == "wheeled":
            body = p.loadURDF(str(_URDF), position, orientation,
                              globalScaling=cfg.robot.r0_m / _URDF_R0_M,
                              flags=p.URDF_USE_INERTIA_FROM_FILE | p.URDF_USE_IMPLICIT_CYLINDER,
                              physicsClientId=cid)
            p.changeDynamics(body, -1, lateralFriction=0.0, rollingFriction=0.0,
                             spinningFriction=0.0, physicsClientId=cid)  # chassis and casters
            for joint in _WHEELS:
                p.changeDynamics(body, joint, lateralFriction=1.0, physicsClientId=cid)
        else:
            shape = p.createCollisionShape(p.GEOM_SPHERE, radius=cfg.robot.r0_m,
                                           physicsClientId=cid)
            body = p.createMultiBody(cfg.robot_mass_kg, shape, basePosition=position,
                                     baseOrientation=orientation, physicsClientId=cid)
            p.changeDynamics(body, -1, lateralFriction=0.0, linearDamping=0.0,
                             angularDamping=0.0, physicsClientId=cid)
        self._filter(body, _ROBOT, _ROBOT_MASK)
        return body

    def _filter(self, body: int, group: int, mask: int) -> None:
        """Set the collision group and mask of every link of ``body``."""
        cid = self._client
        for link in range(-1, p.getNumJoints(body, physicsClientId=cid)):
            p.setCollisionFilterGroupMask(body, link, group, mask, physicsClientId=cid)

    def _reset_state(self, rng: np.random.Generator) -> None:
        cid = self._client
        # the tiles built during the last episode go (a fresh world builds them later, after
        # its robots, and Bullet orders its contact pairs by insertion)
        for t in [t for t in self._tile_bodies if t not in self._first_tiles]:
            for client, body in self._tile_bodies.pop(t):
                p.removeBody(body, physicsClientId=client)
        if self._built_state is not None:
            p.restoreState(self._built_state, physicsClientId=cid)
        else:
            for body, (position, orientation) in zip(self._robots, self._start_poses,
                                                      strict=True):
                p.resetBasePositionAndOrientation(body, position, orientation,
                                                  physicsClientId=cid)
                p.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=cid)
                for joint in self._joints:
                    p.resetJointState(body, joint, 0.0, 0.0, physicsClientId=cid)
        # Setting a body's collision filter re-inserts it into the broadphase: its bounding box
        # is recomputed at the start pose (rays use it) and the contact caches of the last
        # episode are dropped, as in a freshly built world. Robots are re-inserted in index
        # order, which keeps Bullet's (deterministic) pair order that of a fresh world.
        for body in self._robots:
            self._filter(body, _ROBOT, _ROBOT_MASK)
        k = self.num_robots
        self._rng = rng
        self._active = np.ones(k, dtype=bool)
        self._time_s = 0.0
        self._odometer = np.zeros(k)
        self._z = np.zeros(k)  # height of each robot's base (the body sphere's centre)
        self._poses = self._read_poses(np.arange(k))

    # ------------------------------------------------------------------ API

    @property
    def num_robots(self) -> int:
        """Number of robots K (parked ones included)."""
        return len(self._robots)

    @property
    def tiles_built(self) -> tuple[int, int]:
        """Obstacle tiles built in Bullet so far, and all of them: a world that fits one mesh
        is one tile, built at once; a larger one is cut into 10 m tiles, built when a robot
        first comes near them (:mod:`fftnav.sim.mesh`)."""
        return len(self._tile_bodies), len(self._tiles)

    @property
    def lidar(self) -> Lidar:
        """The swarm's lidar model (beam angles, live beams, time spent scanning)."""
        return self._lidar

    def reset(self, *, seed: int) -> Observation:
        """Put every robot back at its start, active and at rest, as in a freshly built world;
        ``seed`` drives sensor noise and dropout."""
        self._reset_state(np.random.default_rng(seed))
        k = self.num_robots
        return self._observe(np.zeros(k, dtype=bool), np.zeros(k, dtype=bool))

    def step(self, commands: np.ndarray) -> Observation:
        """Drive every active robot with ``commands`` ``(K, 2)`` = (v m/s, w rad/s) for one control
        period (``physics_hz / control_hz`` physics steps), then scan.

        Commands are clipped to ``[-v_max, v_max]`` and ``[-w_max, w_max]``; rows of parked
        robots are ignored. Body embodiment: before each physics step every active robot's base
        velocity is (re)set to (v cos(yaw), v sin(yaw), 0) and yaw rate w (only where it can
        have changed: on arcs and after contacts), then Bullet resolves the contacts. Wheeled:
        the wheel velocity controllers get (v -+ w b / 2) / r_wheel (rad/s, track b) for the
        whole period and Bullet integrates the rolling robot.
        """
        cmd = np.asarray(commands, dtype=float)
        if cmd.shape != (self.num_robots, 2) or not np.all(np.isfinite(cmd)):
            raise FftnavError(f"commands must be a finite array of shape ({self.num_robots}, 2), "
                              f"got shape={cmd.shape}")
        cfg = self.config
        # (a tiled world's tiles within reach of these poses were built by the last scan)
        active = np.flatnonzero(self._active)
        v = np.clip(cmd[active, 0], -cfg.robot.v_max_mps, cfg.robot.v_max_mps)
        w = np.clip(cmd[active, 1], -cfg.robot.w_max_radps, cfg.robot.w_max_radps)
        bodies = [self._robots[i] for i in active]
        drive = None
        if cfg.robot.embodiment == "wheeled":
            self._drive_wheels(bodies, v, w)
        else:
            drive = _PlanarDrive(bodies, self._poses[active, 2], v, w, substeps=cfg.substeps,
                                 physics_hz=cfg.physics_hz)
        obstacle_hit, robot_hit = self._run_physics(bodies, drive)
        self._time_s += cfg.substeps / cfg.physics_hz
        previous = self._poses.copy()
        self._poses[active] = self._read_poses(active)
        self._odometer += np.hypot(*(self._poses[:, :2] - previous[:, :2]).T)
        return self._observe(obstacle_hit, robot_hit)

    def _drive_wheels(self, bodies: list[int], v: np.ndarray, w: np.ndarray) -> None:
        """Wheeled robots: the wheel velocity controllers get (v -+ w b / 2) / r_wheel (rad/s,
        track b) for the whole period."""
        half_track = 0.5 * self._track_m * w
        for body, left, right in zip(bodies, (v - half_track) / self._wheel_radius_m,
                                     (v + half_track) / self._wheel_radius_m, strict=True):
            p.setJointMotorControlArray(body, _WHEELS, p.VELOCITY_CONTROL,
                                        targetVelocities=[left, right],
                                        forces=[_WHEEL_TORQUE_NM] * 2, physicsClientId=self._client)

    def _run_physics(self, bodies: list[int], drive: _PlanarDrive | None,
                     ) -> tuple[np.ndarray, np.ndarray]:
        """Run the physics steps of one control period, the body robots' velocities set by
        ``drive`` before each (None: wheeled robots, driven by their motors); return which
        robots touched an obstacle, and which another robot, during the period."""
        cid = self._client
        slot = {body: j for j, body in enumerate(bodies)}
        index = {body: i for i, body in enumerate(self._robots)}
        obstacle_hit = np.zeros(self.num_robots, dtype=bool)
        robot_hit = np.zeros(self.num_robots, dtype=bool)
        # This loop runs physics_hz / control_hz times per tick: pybullet's functions are bound
        # once and called with positional arguments (cheaper to parse).
        step_physics, contact_points, ground = p.stepSimulation, p.getContactPoints, self._ground
        touched = set(range(len(bodies)))  # every velocity is set before the first step
        for k in range(self.config.substeps):
            if drive is not None:
                drive.set_velocities(k, touched, cid)
            step_physics(cid)
            touched = _record_contacts(contact_points(physicsClientId=cid), ground=ground,
                                       slot=slot, index=index, obstacle_hit=obstacle_hit,
                                       robot_hit=robot_hit)
        return obstacle_hit, robot_hit

    def base_states(self) -> np.ndarray:
        """Full 3D base state of every robot body, ``(K, 7)``: position x, y, z (m) and the
        orientation quaternion qx, qy, qz, qw (for checks that robots stay upright on the
        ground, at height r0)."""
        return np.array([
            [*pos, *q] for pos, q in (
                p.getBasePositionAndOrientation(body, physicsClientId=self._client)
                for body in self._robots)
        ])

    def park(self, i: int) -> None:
        """Take robot ``i`` out of the world (it arrived or failed): it stops colliding, no longer
        appears in any lidar and is no longer driven; its pose and odometer are frozen."""
        check_integer("i", i, low=0, high=self.num_robots - 1)
        if not self._active[i]:
            return
        body, cid = self._robots[i], self._client
        self._active[i] = False
        # Far away, colliding with nothing and at rest (a parked wheeled robot falls freely
        # under gravity). Its mass is kept: toggling a multibody between static and dynamic
        # changes Bullet's later results for the other robots, which reset() could not undo.
        self._filter(body, 0, 0)
        p.resetBasePositionAndOrientation(body, [_PARKED_XY[0] - 2.0 * i, _PARKED_XY[1], 1.0],
                                          [0, 0, 0, 1], physicsClientId=cid)
        p.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=cid)

    def close(self) -> None:
        """Disconnect from the physics server (idempotent)."""
        if self._client >= 0:
            p.disconnect(physicsClientId=self._client)
            p.disconnect(physicsClientId=self._static_client)
            self._client = -1

    def __enter__(self) -> SwarmSim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ internals

    def _read_poses(self, which: np.ndarray) -> np.ndarray:
        poses = np.empty((len(which), 3))
        for row, i in enumerate(which):
            pos, q = p.getBasePositionAndOrientation(self._robots[i], physicsClientId=self._client)
            poses[row] = pos[0], pos[1], p.getEulerFromQuaternion(q)[2]
            self._z[i] = pos[2]
        return poses

    def _observe(self, obstacle_hit: np.ndarray, robot_hit: np.ndarray) -> Observation:
        cfg = self.config
        scans = np.full((self.num_robots, cfg.sensor.beams), np.nan)
        live = self._active
        ranges = self._lidar.scan(self._poses[live], robot_z=self._z[live])
        if cfg.sensor.noise_std_m > 0 or cfg.sensor.dropout > 0:
            noisy = ranges + self._rng.normal(0.0, cfg.sensor.noise_std_m, ranges.shape)
            hit = (ranges > 0) & (ranges < cfg.sensor.range_m)  # returns; blind, misses stay
            ranges = np.where(hit, np.clip(noisy, 0.0, cfg.sensor.range_m), ranges)
            dropped = (self._rng.random(ranges.shape) < cfg.sensor.dropout) & self._lidar.live
            ranges[dropped] = cfg.sensor.range_m
        scans[live] = ranges
        return Observation(scans=scans, poses=self._poses.copy(),
                           obstacle_contact=obstacle_hit, robot_contact=robot_hit,
                           time_s=self._time_s, odometer_m=self._odometer.copy(),
                           active=self._active.copy())
