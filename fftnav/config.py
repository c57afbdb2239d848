"""Swarm configuration: one frozen dataclass per component, one name per quantity, units in names.

A :class:`SwarmConfig` has six sections, the tables of an experiment TOML file:

- ``[robot]`` :class:`RobotConfig`: collision and protective radii, speed limits, embodiment;
- ``[sensor]`` :class:`SensorConfig`: the lidar (beams, range, field of view, blind sector, noise);
- ``[comms]`` :class:`CommsConfig`: the message channel (range, loss, delay, when to send);
- ``[episode]`` :class:`EpisodeConfig`: time limit, control and physics rates, arrival radius;
- ``[planner]`` :class:`PlannerConfig`: the Bug planner's constants (heading tolerance, loop
  detection, own maps, escapes);
- ``[localization]`` :class:`LocalizationConfig`: exact poses, or odometry with drift and
  relative measurements of the neighbours.

The simulator (:class:`fftnav.sim.swarm.SimConfig` composes ``robot`` and ``sensor``), the
observation pipeline (:meth:`SwarmConfig.pipeline`) and the planner
(:meth:`fftnav.navigation.bug.BugPlanner.for_swarm`) are all built from it. Every field declares
its own check (the field helpers of :mod:`fftnav.validate`, run by its
:class:`~fftnav.validate.Checked` base), so the same rule refuses a bad value from Python, from a
TOML file (``sensor.range_m must be ...``) or from ``fftnav episode --set``:

>>> cfg = SwarmConfig.from_sections({"sensor": {"range_m": 5}, "comms": {"packet_loss": 0.2}})
>>> cfg.sensor.range_m, cfg.comms.packet_loss, cfg.robot.v_max_mps
(5.0, 0.2, 0.5)
>>> cfg.replace({"time_limit_s": 60, "sensor.beams": 180}).episode.time_limit_s
60.0
>>> SwarmConfig.from_sections({"sensor": {"beams": 1}})
Traceback (most recent call last):
...
fftnav.errors.FftnavError: sensor.beams must be an integer in [2, 100000], got sensor.beams=1
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from fftnav.errors import FftnavError
from fftnav.limits import MAX_BEAMS, MAX_EPISODE_PHYSICS_STEPS, MAX_MAP_SIDE_M, check_limit
from fftnav.localization.odometry import DRIFT_PRESETS, OdometryNoise
from fftnav.observe.geometry import RobotGeometry
from fftnav.observe.pipeline import Pipeline
from fftnav.validate import (
    Checked,
    check_integer,
    check_multiple,
    choice_field,
    integer_field,
    number_field,
)

__all__ = ["CommsConfig", "EpisodeConfig", "LocalizationConfig", "PAPER_MOTION", "PlannerConfig",
           "RobotConfig", "SensorConfig", "SwarmConfig", "check_rates"]

#: Upper bounds of the speed limits (a robot, not a projectile).
MAX_SPEED_MPS = 100.0
MAX_YAW_RATE_RADPS = 100.0


def check_rates(control_hz: float, physics_hz: float) -> int:
    """Physics steps per control period: ``physics_hz`` must be an integer multiple of
    ``control_hz`` (the rule of :class:`EpisodeConfig` and :class:`fftnav.sim.swarm.SimConfig`).

    >>> check_rates(10.0, 240.0)
    24
    """
    return check_multiple("physics_hz", physics_hz, "control_hz", control_hz)


class _Section(Checked):
    """A section of :class:`SwarmConfig`, the TOML table :attr:`name`."""

    #: The TOML table of the section.
    name: ClassVar[str]


@dataclass(frozen=True)
class RobotConfig(_Section):
    """``[robot]``: a differential-drive robot of radius r0 (paper Sec. III-A, IV-B).

    Attributes
    ----------
    r0_m : float
        Lateral collision radius r0 (m); the robot's body is a disc (sphere) of this radius.
    r_m : float
        Protective radius r (m), > r0; with r0 it sets l_th = r^2 / r0 and alpha (eqs. 1-2).
    v_max_mps, w_max_radps : float
        Speed limits: linear (m/s) and yaw rate (rad/s).
    embodiment : {"body", "wheeled"}
        The simulated body (:class:`fftnav.sim.swarm.SimConfig`).
    """

    name: ClassVar[str] = "robot"
    r0_m: float = number_field(0.15, low=0, low_open=True)
    r_m: float = number_field(0.30, low=0, low_open=True)
    v_max_mps: float = number_field(0.5, low=0, low_open=True, high=MAX_SPEED_MPS)
    w_max_radps: float = number_field(1.5, low=0, low_open=True, high=MAX_YAW_RATE_RADPS)
    embodiment: str = choice_field("body", ("body", "wheeled"))

    def _check_together(self) -> None:
        if self.r_m <= self.r0_m:
            raise FftnavError(f"r_m must be > r0_m={self.r0_m!r}, got r_m={self.r_m!r}")

    @property
    def geometry(self) -> RobotGeometry:
        """The protective-distance model (l_th, alpha) of this robot."""
        return RobotGeometry(r0_m=self.r0_m, r_m=self.r_m)


@dataclass(frozen=True)
class SensorConfig(_Section):
    """``[sensor]``: a 2D lidar (paper Sec. IV-B: 360 beams, R = 3 m, 360 deg, 15 deg blind).

    Attributes
    ----------
    beams : int
        Number of beams M.
    range_m : float
        Maximum range R (m).
    fov_deg, blind_deg : float
        Field of view Theta and the blind sector at the back (degrees), ``blind < fov <= 360``.
    noise_std_m : float
        Standard deviation of Gaussian range noise on returns (m).
    dropout : float
        Probability in [0, 1) that a beam loses its return (reads R).
    """

    name: ClassVar[str] = "sensor"
    beams: int = integer_field(360, low=2, high=MAX_BEAMS)
    range_m: float = number_field(3.0, low=0, low_open=True, high=MAX_MAP_SIDE_M)
    fov_deg: float = number_field(360.0, low=0, high=360, low_open=True)
    blind_deg: float = number_field(15.0, low=0)
    noise_std_m: float = number_field(0.0, low=0, high=MAX_MAP_SIDE_M)
    dropout: float = number_field(0.0, low=0, high=1, high_open=True)

    def _check_together(self) -> None:
        if self.blind_deg >= self.fov_deg:
            raise FftnavError(f"blind_deg must be < fov_deg={self.fov_deg!r}, "
                              f"got blind_deg={self.blind_deg!r}")

    @property
    def fov_rad(self) -> float:
        """Field of view Theta (rad)."""
        return math.radians(self.fov_deg)

    @property
    def blind_rad(self) -> float:
        """Blind sector at the back (rad)."""
        return math.radians(self.blind_deg)


@dataclass(frozen=True)
class CommsConfig(_Section):
    """``[comms]``: the swarm's message channel (:class:`fftnav.episode.comms.Channel`).

    Attributes
    ----------
    comm_range_m : float
        Robots within this distance (m) of a sender receive its messages (paper: 2 R).
    packet_loss : float
        Probability in [0, 1) that a receiver misses a message.
    delay_ticks : int
        Extra control ticks before a message arrives.
    broadcast : {"on_obstacle", "every_tick"}
        When a robot sends: when its goal direction is blocked (the paper), or every tick.
    pose_noise_m : float
        Standard deviation (m) of the noise on the relative position of a sender.
    """

    name: ClassVar[str] = "comms"
    comm_range_m: float = number_field(6.0, low=0, low_open=True, high=10 * MAX_MAP_SIDE_M)
    packet_loss: float = number_field(0.0, low=0, high=1, high_open=True)
    delay_ticks: int = integer_field(0, low=0, high=1_000_000)
    broadcast: str = choice_field("on_obstacle", ("on_obstacle", "every_tick"))
    pose_noise_m: float = number_field(0.0, low=0, high=MAX_MAP_SIDE_M)


@dataclass(frozen=True)
class EpisodeConfig(_Section):
    """``[episode]``: time, arrival and departures.

    Attributes
    ----------
    time_limit_s : float
        A robot not at its goal this long after its departure has failed (paper: 120 s).
    control_hz, physics_hz : float
        Control / lidar rate and physics rate (Hz); ``physics_hz / control_hz`` is an integer.
    success_radius_m : float
        A robot within this distance (m) of its goal has arrived.
    departure : {"together", "waves", "staggered"}
        When the robots leave their starts: all at once (the paper); in ``waves`` waves
        ``wave_interval_s`` apart (robot i in wave ``i % waves``, so every wave spans the start
        line); or one by one, robot i at ``i * stagger_s``. A robot waits at its start, still,
        silent but listening, until it departs; its path, time and time limit count from then.
    waves : int
        Number of waves (``departure = "waves"``).
    wave_interval_s, stagger_s : float
        Delay between two waves, and between two robots when ``staggered`` (s).
    """

    name: ClassVar[str] = "episode"
    time_limit_s: float = number_field(120.0, low=0, low_open=True)
    control_hz: float = number_field(10.0, low=0, low_open=True)
    physics_hz: float = number_field(240.0, low=0, low_open=True)
    success_radius_m: float = number_field(0.3, low=0, low_open=True, high=MAX_MAP_SIDE_M)
    departure: str = choice_field("together", ("together", "waves", "staggered"))
    waves: int = integer_field(3, low=1)
    wave_interval_s: float = number_field(15.0, low=0)
    stagger_s: float = number_field(2.0, low=0)

    def _check_together(self) -> None:
        check_rates(self.control_hz, self.physics_hz)
        check_limit("physics steps per episode (time_limit_s x physics_hz)",
                    self.time_limit_s * self.physics_hz, MAX_EPISODE_PHYSICS_STEPS,
                    hint="lower time_limit_s or physics_hz")
        if self.max_ticks < 1:
            raise FftnavError(f"control_hz must give at least one control tick within "
                              f"time_limit_s={self.time_limit_s!r} (time_limit_s x control_hz "
                              f"rounds to 0), got control_hz={self.control_hz!r}")
        self.check_departures(2)  # the first departure after the first robot's

    @property
    def max_ticks(self) -> int:
        """Control ticks in the time limit."""
        return int(round(self.time_limit_s * self.control_hz))

    def last_departure_s(self, n_robots: int) -> float:
        """When the last of ``n_robots`` robots departs (s after the start).

        >>> EpisodeConfig(departure="waves", waves=3, wave_interval_s=15).last_departure_s(2)
        15.0
        """
        n = check_integer("n_robots", n_robots, low=1)
        if self.departure == "waves":
            return (min(self.waves, n) - 1) * self.wave_interval_s
        if self.departure == "staggered":
            return (n - 1) * self.stagger_s
        return 0.0

    def check_departures(self, n_robots: int) -> None:
        """Refuse departures that do not fit the physics-step limit: the episode of
        ``n_robots`` robots runs until the last departs plus ``time_limit_s``, so
        ``(last departure + time_limit_s) x physics_hz`` must be at most
        :data:`~fftnav.limits.MAX_EPISODE_PHYSICS_STEPS` (FftnavError naming the key).

        >>> EpisodeConfig(departure="staggered", stagger_s=1e4).check_departures(3)
        Traceback (most recent call last):
        ...
        fftnav.errors.FftnavError: physics steps per episode \
((last departure + time_limit_s) x physics_hz, 3 robots staggered by stagger_s=10000.0): \
4,828,800 estimated, above the limit of 3,000,000; lower stagger_s
        """
        key = {"waves": "wave_interval_s", "staggered": "stagger_s"}.get(self.departure)
        if key is None:
            return
        ticks = self.max_ticks + self.last_departure_s(n_robots) * self.control_hz
        how = (f"in waves {self.wave_interval_s!r} s apart (waves={self.waves})"
               if self.departure == "waves" else f"staggered by stagger_s={self.stagger_s!r}")
        check_limit(f"physics steps per episode ((last departure + time_limit_s) x physics_hz, "
                    f"{n_robots} robots {how})",
                    ticks * round(self.physics_hz / self.control_hz), MAX_EPISODE_PHYSICS_STEPS,
                    hint=f"lower {key}")

    def departure_ticks(self, n_robots: int) -> list[int]:
        """The control tick at which each of ``n_robots`` robots departs
        (:meth:`check_departures` first).

        >>> EpisodeConfig(departure="waves", waves=2, wave_interval_s=1.5).departure_ticks(5)
        [0, 15, 0, 15, 0]
        >>> EpisodeConfig(departure="staggered", stagger_s=0.2).departure_ticks(3)
        [0, 2, 4]
        """
        self.check_departures(n_robots)
        if self.departure == "waves":
            delays = [(i % self.waves) * self.wave_interval_s for i in range(n_robots)]
        elif self.departure == "staggered":
            delays = [i * self.stagger_s for i in range(n_robots)]
        else:
            delays = [0.0] * n_robots
        return [int(round(d * self.control_hz)) for d in delays]


@dataclass(frozen=True)
class PlannerConfig(_Section):
    """``[planner]``: the Bug planner's constants (:class:`fftnav.navigation.bug.BugPlanner`,
    whose state machine ``docs/planner.md`` documents; its speed limits and control rate are
    the ``[robot]`` and ``[episode]`` keys). The defaults are the project's planner; the paper
    gives none of these.

    Attributes
    ----------
    heading_tol_deg, way_heading_tol_deg : float
        Drive only when the heading error is at most this (degrees; default 20); else rotate
        in place toward the heading. ``way_heading_tol_deg`` applies while the robot steers
        along its own map's way (escaping, or guided), ``heading_tol_deg`` otherwise.
    drive : {"steered", "straight"}
        Motion within the heading tolerance: ``"steered"`` (default) drives at full speed and
        turns toward the heading at the same time (the rotation command, so the robot follows
        an arc of radius at least v_max / w_max that closes the error); ``"straight"`` drives
        straight (the paper's robots "move straight or rotate in place";
        :data:`PAPER_MOTION`). The defaults were chosen on the tuning maps (docs/history.md,
        "Turning while driving").
    progress_m : float
        Leave rule: the goal distance must be this much below the distance at the hit point.
    loop_timeout_s : float
        Loop detection: following for this long without getting ``progress_m`` closer to the
        goal than ever before during the follow (circling, shuttling in a corner, boxed in by
        other robots) starts an escape.
    retreat_m : float
        Once a following robot is this much farther from the goal than its best distance of
        the follow (it backs out of a pocket, or runs along a wall away from the goal), it
        escapes too. An escaping robot steers along the shortest way to its goal through its
        own map (:class:`~fftnav.navigation.ownmap.OwnMaps`) instead of toward the goal, until
        the leave rule.
    map_resolution_m, map_clearance_m : float
        Cell size of the robots' own maps, and the distance from a seen obstacle within which
        the escape way may not pass.
    map_squeeze_m, squeeze_after_s : float
        A robot that has stayed within 2 r0 of one point for ``squeeze_after_s`` seconds and
        whose own map leaves it no way at ``map_clearance_m`` (its pocket closed, as by another
        robot standing beside it and seen as an obstacle) plans its way again with obstacles
        widened by only ``map_squeeze_m`` (at most ``map_clearance_m``;
        :class:`~fftnav.navigation.ownmap.OwnMaps`, ``squeeze_m``): narrower ways, on which the
        clearance guard still keeps it off what its scan sees.
    map_margin_m : float
        The own maps cover the mission area, the swarm's starts and goals, and this margin
        around them.
    escape_lookahead_m, replan_s : float
        An escaping robot steers to the point this far along its way, replanned every
        ``replan_s`` seconds from its map as it is then.
    escape_bound_s, escape_block_m : float
        Loop detection in escape: when the planned way's length has not become ``progress_m``
        shorter than its best for ``escape_bound_s`` seconds, the robot closes the next
        ``escape_block_m`` of that way in its own map
        (:meth:`~fftnav.navigation.ownmap.OwnMaps.block_way`) and plans another (a loop detection,
        counted in ``loop_flips``).
    give_way_s : float
        Right of way: a robot heading for its goal whose goal direction is blocked, and which
        goes before the robots in its way (the planner's ``wait``), waits for them to clear
        the way instead of taking a side, at most this long within 2 r0 of one point (the
        squeezed plan's timer: time spent waiting there counts toward ``squeeze_after_s``).
    guide_margin_m, guide_bound_s : float
        Guided robots (the planner's ``guide``): a robot heading for its goal steers along its way
        through the walls of its own map (:meth:`~fftnav.navigation.ownmap.OwnMaps.plan`,
        ``walls_only``; trunks, rocks and robots are left to the safe directions), as an escaping
        robot does, while that way is more than ``guide_margin_m`` longer than the 8-connected grid
        distance to the goal (what it knows blocks the straight line); else it heads for the goal.
        When the way has not become ``progress_m`` shorter than its best for ``guide_bound_s``
        seconds, the robot gives it up until it is R closer to its goal than where it gave up. The
        guided way and its timer outlast a follow: heading for its goal again, a robot steers down
        its map's last planned field (a decision's or an escape's, if they planned since) until its
        next plan, and gives the way up at that plan if the follow kept it from becoming
        ``progress_m`` shorter for ``guide_bound_s``. A robot the planner may guide (its ``guide``
        says so) also escapes along its way through the walls, and closes that way when it has not
        become ``progress_m`` shorter for ``guide_bound_s`` (not ``escape_bound_s``): what it cannot
        pass there, the next way goes round.
    map_every : int
        The own maps take every other beam of the scans of one control tick in ``map_every``.
    memory_radius_m : float
        Tried sides: at a new decision within this distance of one of its earlier hit points,
        and no closer to the goal than it was there, a robot takes the side it did not take
        there (without asking the policy).
    clearance_m, lookahead_m : float
        Clearance guard: a heading is drivable only if no scan point lies within ``r0 +
        clearance_m`` of its line over the next ``r0 + lookahead_m``
        (:func:`~fftnav.navigation.bug.corridor_free`).
    """

    name: ClassVar[str] = "planner"
    heading_tol_deg: float = number_field(20.0, low=0, low_open=True, high=90)
    way_heading_tol_deg: float = number_field(20.0, low=0, low_open=True, high=90)
    drive: str = choice_field("steered", ("straight", "steered"))
    progress_m: float = number_field(0.05, low=0)
    loop_timeout_s: float = number_field(10.0, low=0, low_open=True)
    clearance_m: float = number_field(0.03, low=0)
    lookahead_m: float = number_field(0.1, low=0)
    retreat_m: float = number_field(0.5, low=0, low_open=True)
    memory_radius_m: float = number_field(1.0, low=0)
    map_resolution_m: float = number_field(0.2, low=0, low_open=True)
    map_clearance_m: float = number_field(0.3, low=0)
    map_squeeze_m: float = number_field(0.2, low=0)
    squeeze_after_s: float = number_field(10.0, low=0, low_open=True)
    map_margin_m: float = number_field(2.0, low=0)
    escape_lookahead_m: float = number_field(1.0, low=0, low_open=True)
    replan_s: float = number_field(1.0, low=0, low_open=True)
    escape_bound_s: float = number_field(15.0, low=0, low_open=True)
    escape_block_m: float = number_field(1.0, low=0, low_open=True)
    give_way_s: float = number_field(10.0, low=0, low_open=True)
    guide_margin_m: float = number_field(1.0, low=0)
    guide_bound_s: float = number_field(5.0, low=0, low_open=True)
    map_every: int = integer_field(2, low=1)

    def _check_together(self) -> None:
        if self.map_squeeze_m > self.map_clearance_m:
            raise FftnavError(f"map_squeeze_m must be <= map_clearance_m={self.map_clearance_m!r}, "
                              f"got map_squeeze_m={self.map_squeeze_m!r}")


#: ``SwarmConfig().replace(PAPER_MOTION)``: the paper's motion, straight or rotation in place,
#: the latter beyond 3 degrees of heading error everywhere.
PAPER_MOTION: Mapping[str, Any] = {"planner.heading_tol_deg": 3.0,
                                   "planner.way_heading_tol_deg": 3.0,
                                   "planner.drive": "straight"}


@dataclass(frozen=True)
class LocalizationConfig(_Section):
    """``[localization]``: what a robot knows of where it is (docs/localization.md).

    Attributes
    ----------
    mode : {"exact", "odometry"}
        ``exact``: every robot reads its true pose, and a message's sender is placed at its
        true pose. ``odometry``: a robot knows its start pose and its goal, and from then on
        only its wheel odometry (:func:`fftnav.localization.sample_motion_model_odometry`);
        its map, its goal bearing and everything it sends are in its estimated frame, and it
        places a sender by measuring it (range, bearing, relative heading, with noise).
    drift : {"none", "low", "typical", "high", "custom"}
        The odometry's noise (``odometry`` mode): a preset of
        :data:`fftnav.localization.DRIFT_PRESETS` (about 0, 0.5, 2 and 5 % of the distance
        driven), or ``custom``: ``alpha1`` to ``alpha4``.
    alpha1, alpha2, alpha3, alpha4 : float
        The odometry motion model's noise parameters (``drift = "custom"`` only).
    gyro_bias_degps : float
        A constant error of every robot's heading rate (deg/s; positive turns the estimate
        left of the truth), added to the preset's noise.
    range_noise_m, bearing_noise_deg, heading_noise_deg : float
        Standard deviations of a robot's measurement of a sender's range (m), bearing and
        relative heading (deg) (``odometry`` mode).
    stop_radius_m : float
        A robot stops, believing it has arrived, when its estimate is within this distance (m)
        of its goal (``odometry`` mode). The benchmark judges arrival on the true pose with
        ``episode.success_radius_m``: a robot drives for the point it believes is its goal and
        arrives on its way in when its true pose comes within the arrival radius.
    """

    name: ClassVar[str] = "localization"
    mode: str = choice_field("exact", ("exact", "odometry"))
    drift: str = choice_field("typical", ("none", "low", "typical", "high", "custom"))
    alpha1: float = number_field(0.0, low=0, high=1e6)
    alpha2: float = number_field(0.0, low=0, high=1e6)
    alpha3: float = number_field(0.0, low=0, high=1e6)
    alpha4: float = number_field(0.0, low=0, high=1e6)
    gyro_bias_degps: float = number_field(0.0, low=-360.0, high=360.0)
    range_noise_m: float = number_field(0.05, low=0, high=MAX_MAP_SIDE_M)
    bearing_noise_deg: float = number_field(2.0, low=0, high=180.0)
    heading_noise_deg: float = number_field(3.0, low=0, high=180.0)
    stop_radius_m: float = number_field(0.1, low=0, low_open=True, high=MAX_MAP_SIDE_M)

    def _check_together(self) -> None:
        alphas = (self.alpha1, self.alpha2, self.alpha3, self.alpha4)
        if self.drift != "custom" and any(alphas):
            raise FftnavError(f"alpha1 to alpha4 need drift = \"custom\" (drift {self.drift!r} "
                              f"is a preset), got drift={self.drift!r} with alphas {list(alphas)}")

    @property
    def odometry(self) -> bool:
        """Whether the robots know only their odometry (``mode = "odometry"``)."""
        return self.mode == "odometry"

    @property
    def noise(self) -> OdometryNoise:
        """The odometry's noise: the preset's (or the custom alphas) and the gyro bias."""
        base = (OdometryNoise(self.alpha1, self.alpha2, self.alpha3, self.alpha4)
                if self.drift == "custom" else DRIFT_PRESETS[self.drift])
        return OdometryNoise(*base.alphas, gyro_bias_radps=math.radians(self.gyro_bias_degps))


_SECTIONS: dict[str, type[_Section]] = {
    cls.name: cls for cls in (RobotConfig, SensorConfig, CommsConfig, EpisodeConfig,
                              PlannerConfig, LocalizationConfig)}


@dataclass(frozen=True)
class SwarmConfig(Checked):
    """Everything about an episode except the world, the policy and the seed."""

    robot: RobotConfig = field(default_factory=RobotConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    comms: CommsConfig = field(default_factory=CommsConfig)
    episode: EpisodeConfig = field(default_factory=EpisodeConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    localization: LocalizationConfig = field(default_factory=LocalizationConfig)

    #: Section name -> its dataclass.
    SECTIONS: ClassVar[dict[str, type[_Section]]] = _SECTIONS

    def _check_together(self) -> None:
        """Rules between sections: a robot moves at most its radius r0 per physics step (else
        it could tunnel through a thin obstacle or another robot between two steps)."""
        step_m = self.robot.v_max_mps / self.episode.physics_hz
        if step_m > self.robot.r0_m:
            raise FftnavError(f"robot.v_max_mps must be <= robot.r0_m x episode.physics_hz = "
                              f"{self.robot.r0_m * self.episode.physics_hz:g} (at most r0 per "
                              f"physics step), got robot.v_max_mps={self.robot.v_max_mps!r}")

    @classmethod
    def from_sections(cls, sections: Mapping[str, Mapping[str, Any]]) -> SwarmConfig:
        """Build from TOML-like tables; an unknown section or key, or a bad value, raises
        ValueError naming it (``sensor.range_m must be ...``, ``[sensor] blind_deg must be
        ...`` for a rule between keys)."""
        kwargs = {}
        for name, values in sections.items():
            if name not in _SECTIONS:
                raise FftnavError(f"unknown section [{name}]; expected one of {list(_SECTIONS)}")
            if not isinstance(values, Mapping):
                raise FftnavError(f"[{name}] must be a table, got {values!r:.80}")
            kwargs[name] = _SECTIONS[name].from_table(name, values)
        return cls(**kwargs)

    def to_sections(self) -> dict[str, dict[str, Any]]:
        """The sections as plain dictionaries (the inverse of :meth:`from_sections`)."""
        return {name: dataclasses.asdict(getattr(self, name)) for name in _SECTIONS}

    @classmethod
    def locate(cls, key: str) -> tuple[str, str]:
        """``(section, key)`` of ``"section.key"`` or of a key that only one section has."""
        section, dot, name = key.rpartition(".")
        if dot:
            if section in _SECTIONS and name in _SECTIONS[section].keys():
                return section, name
        else:
            owners = [s for s, c in _SECTIONS.items() if key in c.keys()]
            if len(owners) == 1:
                return owners[0], key
        known = [f"{s}.{k}" for s, c in _SECTIONS.items() for k in c.keys()]
        raise FftnavError(f"unknown key {key!r}; expected one of {known}")

    def replace(self, overrides: Mapping[str, Any]) -> SwarmConfig:
        """A copy with ``overrides`` applied: keys ``"section.key"`` or a bare key, values
        typed (``{"packet_loss": 0.3}``) or text as on a command line (``{"beams": "180"}``)."""
        sections = self.to_sections()
        for key, value in overrides.items():
            section, name = self.locate(key)
            if isinstance(value, str) and _SECTIONS[section].value_type(name) is not str:
                value = _parse(value, _SECTIONS[section].value_type(name), f"{section}.{name}")
            sections[section][name] = value
        return self.from_sections(sections)

    @property
    def geometry(self) -> RobotGeometry:
        """The robot's protective-distance model."""
        return self.robot.geometry

    @property
    def conditions(self) -> frozenset[str]:
        """The conditions of this configuration that some measures and failure causes require
        (:attr:`fftnav.metrics.measures.Measure.requires`): ``"odometry"`` when the robots
        know only their odometry.

        >>> sorted(SwarmConfig().conditions), sorted(SwarmConfig().replace(
        ...     {"localization.mode": "odometry"}).conditions)
        ([], ['odometry'])
        """
        return frozenset({"odometry"} if self.localization.odometry else ())

    def pipeline(self) -> Pipeline:
        """The FFT observation pipeline of this robot and lidar."""
        return Pipeline(self.geometry, beams=self.sensor.beams, fov_rad=self.sensor.fov_rad,
                        range_m=self.sensor.range_m, blind_rad=self.sensor.blind_rad)


def _parse(text: str, kind: type, key: str) -> Any:
    """A command-line value as ``kind`` (int or float); ValueError naming the key."""
    try:
        return kind(text)
    except ValueError:
        raise FftnavError(f"{key} must be {'an integer' if kind is int else 'a number'}, "
                          f"got {key}={text!r}") from None
