"""Controllers: whole per-robot control laws, looked up by name like decision policies.

A decision policy (:mod:`fftnav.navigation.policies`) only picks the side on which the Bug
planner passes an obstacle. A *controller* replaces the planner: every control tick, each active
robot's :class:`RobotObservation` (its scan, the FFT pipeline's outputs, its pose and goal, its
inbox of received messages) goes to :meth:`Controller.act`, which returns the velocity command
``(v_mps, w_radps)`` or an :class:`Action` that may also carry a message. Messages travel
through the episode's channel (:class:`fftnav.episode.comms.Channel`): the same lossy, delayed,
range-limited broadcast ``fusion`` uses, with its bytes counted in ``bytes_sent``; they arrive
as :class:`Packet` objects.

A controller is a subclass of :class:`Controller`; the episode makes one instance per episode
from its :class:`ControllerSetup` alone (``Controller(setup)``, through
:meth:`fftnav.navigation.resolve.Resolved.make`, the same for every controller) and calls it for
every robot, so per-robot memory is kept by robot index.
Registered controllers (:data:`CONTROLLERS`) are the classic reactive baselines of
:mod:`fftnav.navigation.baselines`: ``vfh``, ``ftg`` and ``fft-go``. The Bug planner with a
decision policy is itself a controller (:class:`fftnav.navigation.bugcontrol.BugController`)
that sees nothing but the :class:`SwarmStep` every controller gets, which is how every policy
and controller runs through the same loop, runner, metrics and reports.

>>> class Straight(Controller):
...     uses_pipeline = False
...     def act(self, obs):
...         return self.v_max_mps, 2.0 * obs.goal_bearing_rad
>>> Straight.__name__, Controller.uses_pipeline
('Straight', True)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.errors import FftnavError
from fftnav.observe.scan import is_full_circle, wrap_angle
from fftnav.registry import Registry, first_line
from fftnav.world.model import World

__all__ = [
    "Action",
    "CONTROLLERS",
    "ENTRY_POINT_GROUP",
    "Controller",
    "ControllerSetup",
    "ControllerSpec",
    "Packet",
    "RobotObservation",
    "SwarmStep",
    "register_controller",
    "robot_observations",
]

#: Entry-point group in which installed packages declare policies and controllers.
ENTRY_POINT_GROUP = "fftnav.policies"

#: Counters of a robot's row that a controller may fill (the Bug planner's decisions).
COUNTERS = ("decisions_left", "decisions_right", "decisions_with_neighbours",
            "decisions_flipped_by_neighbours")


@dataclass(frozen=True)
class Packet:
    """One received message.

    Attributes
    ----------
    sender : int
        Index of the sending robot.
    tick : int
        Control tick at which it was sent.
    payload : bytes
        The message's bytes.
    sender_pose : tuple of float
        Where the receiver places the sender when it sent the message, ``(x_m, y_m, yaw_rad)``
        in the receiver's own frame: the sender's true pose with ``localization.mode =
        "exact"`` (every robot's frame is the world's), else the receiver's estimate moved by
        its noisy measurement of the sender's range, bearing and relative heading
        (:class:`fftnav.episode.localize.Localizer`). The receiver turns it into a relative
        pose, e.g. to rotate the sender's Sigma into its own frame.
    """

    sender: int
    tick: int
    payload: bytes
    sender_pose: tuple[float, float, float]


@dataclass(frozen=True)
class ControllerSetup:
    """What a controller knows when an episode starts: the same for every controller, the
    default Bug controller included.

    Attributes
    ----------
    n_robots : int
        Robots in the episode (indices ``0 .. n_robots - 1``).
    config : SwarmConfig
        Robot (r0, r, speed limits), sensor, comms, episode and planner parameters.
    rng : numpy.random.Generator
        The episode's generator: the only source of randomness a controller may use.
    area_m : (float, float) or None
        Width and height (m) of the mission area, the world's map with its corner at the origin
        (None: unknown, e.g. a controller made outside an episode).
    walled : bool
        Whether walls enclose the mission area (the world's boundary is ``"walls"``).

    Examples
    --------
    >>> setup = ControllerSetup(3, SwarmConfig(), np.random.default_rng(0), area_m=(20.0, 20.0))
    >>> setup.full_circle, setup.walled
    (True, False)
    """

    n_robots: int
    config: SwarmConfig
    rng: np.random.Generator
    area_m: tuple[float, float] | None = None
    walled: bool = False

    @property
    def full_circle(self) -> bool:
        """Whether the lidar's scans cover 360 degrees (``sensor.fov_deg``)."""
        return is_full_circle(self.config.sensor.fov_rad)

    @classmethod
    def for_world(cls, world: World, config: SwarmConfig,
                  rng: np.random.Generator) -> ControllerSetup:
        """The setup of an episode in ``world``: one robot per start, its map's size as the
        mission area, walled if its boundary is ``"walls"``."""
        return cls(len(world.starts), config, rng, area_m=tuple(world.size_m),
                   walled=world.boundary == "walls")


@dataclass(frozen=True)
class RobotObservation:
    """What one robot has at one control tick.

    Attributes
    ----------
    robot, tick : int
        Robot index and control tick.
    time_s : float
        Episode time (s).
    pose : ndarray, shape (3,)
        ``x_m, y_m, yaw_rad`` as the robot knows it: its true pose with
        ``localization.mode = "exact"``, its odometry's estimate with ``"odometry"``.
    goal : ndarray, shape (2,)
        Goal position, in the same frame as ``pose``.
    ranges_m : ndarray, shape (M,)
        The lidar scan, sanitised (no return reads R, blind and invalid beams read 0).
    angles_rad : ndarray, shape (M,)
        Beam angles, CCW from the heading.
    safe_mask, y1 : ndarray or None
        The FFT pipeline's safe beams and filtered scan (``y1``, normalised by R); None when the
        controller sets ``uses_pipeline = False``.
    message : bytes or None
        The robot's own compressed observation (the 28-byte message ``fusion`` broadcasts),
        ready to send; None without the pipeline.
    inbox : sequence of Packet
        The newest message of each neighbour received within the last second
        (:class:`Packet`: ``sender``, ``tick``, ``payload`` bytes, ``sender_pose``).
    """

    robot: int
    tick: int
    time_s: float
    pose: np.ndarray
    goal: np.ndarray
    ranges_m: np.ndarray
    angles_rad: np.ndarray
    safe_mask: np.ndarray | None
    y1: np.ndarray | None
    message: bytes | None
    inbox: Sequence[Packet]

    @property
    def goal_distance_m(self) -> float:
        """Distance to the goal (m)."""
        return float(math.hypot(*(self.goal - self.pose[:2])))

    @property
    def goal_bearing_rad(self) -> float:
        """Goal direction in the robot frame, in (-pi, pi], CCW from the heading."""
        d = self.goal - self.pose[:2]
        return float(wrap_angle(math.atan2(d[1], d[0]) - self.pose[2]))


@dataclass(frozen=True)
class Action:
    """A robot's command for one control period and an optional message to broadcast."""

    v_mps: float
    w_radps: float
    message: bytes | None = None


def _no_packets(robot: int) -> Sequence[Packet]:
    return ()


def _no_reasons(robot: int) -> Mapping[int, str]:
    return {}


@dataclass(frozen=True)
class SwarmStep:
    """The whole swarm at one tick (what :meth:`Controller.step` receives).

    ``active`` are the indices of the robots still driving; the arrays have one row per robot
    (rows of inactive robots are meaningless). ``safe``, ``y1`` and ``messages`` (one per active
    robot, in ``active`` order) and ``sigma`` (the extrema of each active robot's scan) are
    None without the pipeline.

    Attributes
    ----------
    poses : ndarray, shape (K, 3)
        Every robot's pose as it knows it (``x_m, y_m, yaw_rad``): the true poses with
        ``localization.mode = "exact"``, the odometry's estimates with ``"odometry"``; a
        controller never sees more.
    goals : ndarray, shape (K, 2)
        Every robot's goal, in the frame of its pose.
    inbox : callable
        ``inbox(i)``: robot ``i``'s received packets, the newest of each sender sent within the
        last second, in sender order.
    arrived : callable
        ``arrived(i)``: the packets that reached robot ``i`` at this tick (each packet is
        delivered once), in sender order.
    unheard : callable
        ``unheard(i)``: for each other robot in the world with no packet in ``inbox(i)``, why:
        ``"no_message"`` (it sent nothing within the last second, or its packet is still in
        flight), ``"lost"`` (its packet to ``i`` was lost) or ``"out_of_range"`` (``i`` was out of
        its communication range when it sent).
    present : ndarray of bool or None
        Robots in the world (driving, or waiting at their start to depart:
        ``episode.departure``), a mask of K; None: those of ``active``.
    """

    tick: int
    time_s: float
    poses: np.ndarray
    goals: np.ndarray
    active: np.ndarray
    ranges_m: np.ndarray
    angles_rad: np.ndarray
    safe: np.ndarray | None
    y1: np.ndarray | None
    messages: list[bytes] | None
    inbox: Callable[[int], Sequence[Packet]]
    sigma: list[np.ndarray] | None = None
    present: np.ndarray | None = None
    arrived: Callable[[int], Sequence[Packet]] = _no_packets
    unheard: Callable[[int], Mapping[int, str]] = _no_reasons

    def present_mask(self) -> np.ndarray:
        """``present``, or the mask of ``active`` when it is None."""
        if self.present is not None:
            return self.present
        mask = np.zeros(len(self.poses), dtype=bool)
        mask[self.active] = True
        return mask


def robot_observations(swarm: SwarmStep, *, inbox: bool = True
                       ) -> Iterator[tuple[int, RobotObservation]]:
    """``(robot, its RobotObservation)`` of every active robot of ``swarm``, in index order
    (``inbox=False``: without its received packets, for a controller that reads none)."""
    for j, i in enumerate(swarm.active.tolist()):
        yield i, RobotObservation(
            robot=i, tick=swarm.tick, time_s=swarm.time_s, pose=swarm.poses[i],
            goal=swarm.goals[i], ranges_m=swarm.ranges_m[i], angles_rad=swarm.angles_rad,
            safe_mask=None if swarm.safe is None else swarm.safe[i],
            y1=None if swarm.y1 is None else swarm.y1[i],
            message=None if swarm.messages is None else swarm.messages[j],
            inbox=swarm.inbox(i) if inbox else ())


class Controller:
    """Base class of controllers: subclass it and write :meth:`act`.

    Parameters
    ----------
    setup : ControllerSetup
        Swarm size, configuration and the episode's generator (kept as ``self.setup``; the
        speed limits as ``self.v_max_mps`` and ``self.w_max_radps``).

    Attributes
    ----------
    name : str
        The name its rows carry (``policy`` column); set by the registry or the resolver.
    uses_pipeline : bool
        Whether the episode runs the FFT pipeline for it (safe mask, y1, own message).
    """

    name: ClassVar[str] = ""
    uses_pipeline: ClassVar[bool] = True

    def __init__(self, setup: ControllerSetup) -> None:
        self.setup = setup
        self.config = setup.config
        self.v_max_mps = setup.config.robot.v_max_mps
        self.w_max_radps = setup.config.robot.w_max_radps

    def act(self, obs: RobotObservation) -> Action | tuple[float, float]:
        """The command of one robot for one control period."""
        raise NotImplementedError(f"{type(self).__name__} must define act(obs)")

    def step(self, swarm: SwarmStep) -> tuple[np.ndarray, dict[int, bytes]]:
        """Commands ``(K, 2)`` of every robot and the messages to broadcast (robot -> bytes).

        The default calls :meth:`act` for each active robot in index order; a controller that
        works on the whole swarm at once (the Bug planner) overrides it.
        """
        commands = np.zeros((len(swarm.poses), 2))
        outgoing: dict[int, bytes] = {}
        for i, obs in robot_observations(swarm):
            action = self.act(obs)
            if not isinstance(action, Action):
                try:
                    if isinstance(action, (str, bytes, Mapping)):
                        raise TypeError
                    v, w = action
                    action = Action(float(v), float(w))
                except (TypeError, ValueError):
                    raise FftnavError(f"{type(self).__name__}.act must return a pair of numbers "
                                      f"(v_mps, w_radps) or an Action, got "
                                      f"{type(action).__name__} {action!r:.80} for robot {i}"
                                      ) from None
            if not (math.isfinite(action.v_mps) and math.isfinite(action.w_radps)):
                raise FftnavError(f"{type(self).__name__}.act must return finite commands, got "
                                  f"({action.v_mps!r}, {action.w_radps!r}) for robot {i}")
            commands[i] = (action.v_mps, action.w_radps)
            if action.message is not None:
                if not isinstance(action.message, (bytes, bytearray)):
                    raise FftnavError(f"{type(self).__name__}: a message must be bytes, got "
                                      f"{type(action.message).__name__} for robot {i}")
                outgoing[i] = bytes(action.message)
        return commands, outgoing

    def finish(self, robot: int) -> None:
        """Robot ``robot`` left the episode: it arrived, failed or ran out of time (nothing by
        default). Called once for every robot."""

    def hold(self, robot: int) -> None:
        """Robot ``robot`` waits at its start until :meth:`release` (``episode.departure``); it
        is not in ``active`` meanwhile (nothing by default)."""

    def release(self, robot: int) -> None:
        """Robot ``robot`` departs now (nothing by default)."""

    def counters(self, robot: int) -> dict[str, int]:
        """The decision counters of ``robot``'s row (all zero unless the controller has them)."""
        return dict.fromkeys(COUNTERS, 0)

    def state(self, robot: int) -> Mapping[str, float]:
        """A few named scalars describing ``robot``'s state at this tick (none by default).

        Recordings keep them per tick (``fftnav episode --record``) and replays plot them;
        use stable names and plain numbers (a flag as 0 or 1). The key ``"mode"``, if present,
        holds a :class:`fftnav.states.State` code (``int(State.FOLLOW)``, ...): what the
        controller is doing with the robot, which replays draw; a controller without such
        states leaves it out.
        """
        return {}


@dataclass(frozen=True)
class ControllerSpec:
    """A named controller class and its description."""

    name: str
    factory: type[Controller]
    description: str


#: The registered controllers, by name.
CONTROLLERS: Registry[ControllerSpec] = Registry("controller", parameter="policy",
                                                 entry_point_group=ENTRY_POINT_GROUP)


def register_controller(name: str, *, description: str = ""
                        ) -> Callable[[type[Controller]], type[Controller]]:
    """Class decorator registering a :class:`Controller` subclass under ``name``
    (``description``: default, the first line of its docstring)."""

    def wrap(cls: type[Controller]) -> type[Controller]:
        if not (isinstance(cls, type) and issubclass(cls, Controller)):
            raise FftnavError(f"register_controller expects a Controller subclass, got {cls!r}")
        CONTROLLERS.add(name, ControllerSpec(name, cls, description or first_line(cls.__doc__)))
        cls.name = name
        return cls

    return wrap
