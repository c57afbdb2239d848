"""Swarm configuration: one frozen dataclass per component, one name per quantity, units in names.

A :class:`SwarmConfig` has four sections, the tables of an experiment TOML file:

- ``[robot]`` :class:`RobotConfig`: collision and protective radii, speed limits, embodiment;
- ``[sensor]`` :class:`SensorConfig`: the lidar (beams, range, field of view, blind sector, noise);
- ``[comms]`` :class:`CommsConfig`: the message channel (range, loss, delay, when to send);
- ``[episode]`` :class:`EpisodeConfig`: time limit, control and physics rates, arrival radius.

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
ValueError: sensor.beams must be an integer in [2, 100000], got sensor.beams=1
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from fftnav.limits import MAX_BEAMS, MAX_EPISODE_PHYSICS_STEPS, MAX_MAP_SIDE_M, check_limit
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

__all__ = ["CommsConfig", "EpisodeConfig", "RobotConfig", "SensorConfig", "SwarmConfig",
           "check_rates"]

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
            raise ValueError(f"r_m must be > r0_m={self.r0_m!r}, got r_m={self.r_m!r}")

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
            raise ValueError(f"blind_deg must be < fov_deg={self.fov_deg!r}, "
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
            raise ValueError(f"control_hz must give at least one control tick within "
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
        :data:`~fftnav.limits.MAX_EPISODE_PHYSICS_STEPS` (ValueError naming the key).

        >>> EpisodeConfig(departure="staggered", stagger_s=3e5).check_departures(3)
        Traceback (most recent call last):
        ...
        ValueError: physics steps per episode ((last departure + time_limit_s) x physics_hz, \
3 robots staggered by stagger_s=300000.0): 144,028,800 estimated, above the limit of \
100,000,000; lower stagger_s
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


_SECTIONS: dict[str, type[_Section]] = {
    cls.name: cls for cls in (RobotConfig, SensorConfig, CommsConfig, EpisodeConfig)}


@dataclass(frozen=True)
class SwarmConfig(Checked):
    """Everything about an episode except the world, the policy and the seed."""

    robot: RobotConfig = field(default_factory=RobotConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    comms: CommsConfig = field(default_factory=CommsConfig)
    episode: EpisodeConfig = field(default_factory=EpisodeConfig)

    #: Section name -> its dataclass.
    SECTIONS: ClassVar[dict[str, type[_Section]]] = _SECTIONS

    def _check_together(self) -> None:
        """Rules between sections: a robot moves at most its radius r0 per physics step (else
        it could tunnel through a thin obstacle or another robot between two steps)."""
        step_m = self.robot.v_max_mps / self.episode.physics_hz
        if step_m > self.robot.r0_m:
            raise ValueError(f"robot.v_max_mps must be <= robot.r0_m x episode.physics_hz = "
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
                raise ValueError(f"unknown section [{name}]; expected one of {list(_SECTIONS)}")
            if not isinstance(values, Mapping):
                raise ValueError(f"[{name}] must be a table, got {values!r:.80}")
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
        raise ValueError(f"unknown key {key!r}; expected one of {known}")

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

    def pipeline(self) -> Pipeline:
        """The FFT observation pipeline of this robot and lidar."""
        return Pipeline(self.geometry, beams=self.sensor.beams, fov_rad=self.sensor.fov_rad,
                        range_m=self.sensor.range_m, blind_rad=self.sensor.blind_rad)


def _parse(text: str, kind: type, key: str) -> Any:
    """A command-line value as ``kind`` (int or float); ValueError naming the key."""
    try:
        return kind(text)
    except ValueError:
        raise ValueError(f"{key} must be {'an integer' if kind is int else 'a number'}, "
                         f"got {key}={text!r}") from None
