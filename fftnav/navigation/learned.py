"""A trained network as a controller: observation builders, the action spec, ``learned:PATH``.

A learned controller is an :class:`~fftnav.navigation.mlp.MLP` saved as ``.npz`` with
``meta["kind"] == "controller"`` and ``meta["observation"]`` one of :data:`OBSERVATIONS`.
``fftnav episode --policy learned:PATH.npz`` (and ``policies = ["learned:PATH.npz"]`` of
``fftnav run``) runs it through :class:`LearnedController`; its rows carry the name
``learned-<stem of the file>``. It runs in numpy alone.

Observations (each a float64 vector of fixed length for a given config; ``R`` is
``sensor.range_m``, ``M`` ``sensor.beams``):

``goal`` (the last 3 values of every observation)
    ``min(d / R, 1)`` with ``d`` the distance to the goal (m), then ``cos(beta)``,
    ``sin(beta)`` with ``beta`` the goal bearing (rad, CCW from the heading).
``ranges`` (``M + 3``)
    ``ranges_m / R`` beam by beam (in ``[0, 1]``: no return reads 1, blind and invalid beams
    0), then ``goal``.
``safe`` (``2 M + 3``, runs the FFT pipeline)
    the safe mask (1 safe, 0 not) beam by beam, then the filtered scan ``y1`` (already divided
    by R) beam by beam, then ``goal``.
``extrema`` (``3 E + 3``, ``E = EXTREMA = 8``, runs the FFT pipeline)
    the robot's own compressed message (the extrema of its low-passed scan, as neighbours
    receive them: :func:`fftnav.observe.codec.decode_message`), ``E`` slots of
    ``(angle / pi, distance / R, +1 for a minimum or -1 for a maximum)``: the ``E`` nearest
    extrema (ties: by angle) in increasing angle; an empty slot reads ``(0, 1, 0)``. Then
    ``goal``.
``extrema+neighbours`` (``3 E + 3 + N (5 + 3 E)``, ``N = NEIGHBOURS = 4``)
    ``extrema``, then ``N`` neighbour slots, nearest sender first (as ``SwarmNavEnv`` orders
    them): ``1`` (a message is there), the sender's position in the robot's frame divided by
    ``comms.comm_range_m`` and clipped to ``[-1, 1]`` (x ahead, y left), ``cos`` and ``sin`` of
    its heading relative to the robot's, and its message's ``E`` extrema slots as above (in
    the sender's frame). An empty neighbour slot is all zeros except its extrema slots, which
    read empty. A robot with this observation broadcasts its own message as
    ``comms.broadcast`` says (every tick, or when its goal direction is not safe).

Action: the network's 2 outputs ``(a_v, a_w)`` are clipped to ``[-1, 1]`` and scaled to the
robot's limits, ``v = a_v v_max`` (m/s, in ``[-v_max, v_max]``: reversing is allowed, as in
``SwarmNavEnv``'s action space) and ``w = a_w w_max`` (rad/s); a network whose meta holds
``v_range = [lo, hi]`` (fractions of ``v_max``) drives forward speeds
``v = (lo + (a_v + 1) (hi - lo) / 2) v_max`` instead (``[0, 1]``: never reversing). Before
the forward pass the observation is standardised, ``(x - mean) / std``, if ``meta`` holds
``obs_mean`` and ``obs_std`` (lists of ``n_in`` numbers, ``std > 0``).

>>> from fftnav.config import SwarmConfig
>>> [OBSERVATIONS[n].size(SwarmConfig()) for n in OBSERVATIONS]
[363, 723, 27, 143]
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.errors import FftnavError
from fftnav.navigation.controllers import (
    Action,
    Controller,
    ControllerSetup,
    Packet,
    RobotObservation,
    SwarmStep,
    robot_observations,
)
from fftnav.navigation.mlp import MLP, VERSION
from fftnav.observe.codec import MessageError, decode_message
from fftnav.observe.safe import beam_index
from fftnav.observe.scan import wrap_angle
from fftnav.registry import Registry

__all__ = [
    "EXTREMA",
    "LEARNED_PREFIX",
    "NEIGHBOURS",
    "OBSERVATIONS",
    "LearnedController",
    "action_commands",
    "ObservationSpec",
    "extrema_slots",
    "learned_controller",
    "register_observation",
    "untrained",
    "v_range",
]

#: The prefix of a learned controller's reference: ``learned:PATH.npz``.
LEARNED_PREFIX = "learned:"
#: Extremum slots of a message in the ``extrema`` observations.
EXTREMA = 8
#: Neighbour slots of the ``extrema+neighbours`` observation.
NEIGHBOURS = 4
#: Values per extremum slot: angle / pi, distance / R, +1 minimum / -1 maximum.
_SLOT = 3
#: Values per neighbour slot before its extrema: present, x, y, cos and sin of the heading.
_NEIGHBOUR_HEAD = 5
_NAME_CHARS = re.compile(r"[^A-Za-z0-9_.+-]")


@dataclass(frozen=True)
class ObservationSpec:
    """A registered observation: how long it is for a config and how to build it.

    Attributes
    ----------
    name : str
        Its name (``meta["observation"]`` of a network).
    build : callable
        ``build(obs, config) -> ndarray`` of shape ``(size(config),)``, float64.
    size : callable
        ``size(config) -> int``.
    uses_pipeline : bool
        Whether it needs the FFT pipeline (safe mask, y1, own message).
    messages : bool
        Whether a robot observing it broadcasts its message.
    """

    name: str
    build: Callable[[RobotObservation, SwarmConfig], np.ndarray]
    size: Callable[[SwarmConfig], int]
    uses_pipeline: bool
    messages: bool = False


#: The registered observations, by name.
OBSERVATIONS: Registry[ObservationSpec] = Registry("observation", parameter="observation")


def register_observation(name: str, *, size: Callable[[SwarmConfig], int], uses_pipeline: bool,
                         messages: bool = False) -> Callable[..., Any]:
    """Decorator registering an observation builder ``build(obs, config)`` under ``name``."""

    def wrap(build: Callable[[RobotObservation, SwarmConfig], np.ndarray]) -> Any:
        OBSERVATIONS.add(name, ObservationSpec(name, build, size, uses_pipeline, messages))
        return build

    return wrap


def _goal(obs: RobotObservation, config: SwarmConfig) -> np.ndarray:
    """``(min(d / R, 1), cos(beta), sin(beta))`` of the goal."""
    beta = obs.goal_bearing_rad
    return np.array([min(obs.goal_distance_m / config.sensor.range_m, 1.0),
                     math.cos(beta), math.sin(beta)])


def extrema_slots(payload: bytes | None, range_m: float, *, slots: int = EXTREMA) -> np.ndarray:
    """A message's extrema as ``slots`` rows ``(angle / pi, distance / R, +1 min or -1 max)``,
    flattened: the ``slots`` nearest (ties: by angle) in increasing angle, empty rows
    ``(0, 1, 0)``; a missing or undecodable message reads all empty.

    >>> from fftnav.observe.codec import encode_sigma
    >>> msg = encode_sigma(np.array([[0.5 * np.pi, 1.5]]), is_min=np.array([True]), range_m=3.0)
    >>> extrema_slots(msg, 3.0, slots=2).round(3).tolist()
    [0.5, 0.5, 1.0, 0.0, 1.0, 0.0]
    """
    out = np.tile([0.0, 1.0, 0.0], slots)
    if payload is None:
        return out
    try:
        sigma, is_min = decode_message(payload, range_m=range_m)
    except MessageError:
        return out
    keep = np.sort(np.argsort(sigma[:, 1], kind="stable")[:slots])  # nearest, in angle order
    rows = np.column_stack([sigma[keep, 0] / math.pi, np.clip(sigma[keep, 1] / range_m, 0, 1),
                            np.where(is_min[keep], 1.0, -1.0)])
    out[:rows.size] = rows.ravel()
    return out


def _pipeline_output(obs: RobotObservation, name: str) -> None:
    if obs.safe_mask is None or obs.y1 is None:
        raise FftnavError(f"observation {name!r} needs the FFT pipeline's outputs; the "
                          "controller must set uses_pipeline = True")


@register_observation("ranges", size=lambda c: c.sensor.beams + 3, uses_pipeline=False)
def ranges_observation(obs: RobotObservation, config: SwarmConfig) -> np.ndarray:
    """``ranges_m / R`` beam by beam, then the goal's 3 values."""
    r = config.sensor.range_m
    return np.concatenate([np.clip(np.asarray(obs.ranges_m, np.float64) / r, 0.0, 1.0),
                           _goal(obs, config)])


@register_observation("safe", size=lambda c: 2 * c.sensor.beams + 3, uses_pipeline=True)
def safe_observation(obs: RobotObservation, config: SwarmConfig) -> np.ndarray:
    """The safe mask (0/1), then ``y1`` (normalised by R), beam by beam, then the goal."""
    _pipeline_output(obs, "safe")
    return np.concatenate([np.asarray(obs.safe_mask, np.float64),
                           np.asarray(obs.y1, np.float64), _goal(obs, config)])


@register_observation("extrema", size=lambda c: _SLOT * EXTREMA + 3, uses_pipeline=True)
def extrema_observation(obs: RobotObservation, config: SwarmConfig) -> np.ndarray:
    """The own message's extrema slots, then the goal."""
    _pipeline_output(obs, "extrema")
    return np.concatenate([extrema_slots(obs.message, config.sensor.range_m),
                           _goal(obs, config)])


def _neighbour_slots(pose: np.ndarray, inbox: Sequence[Packet],
                     config: SwarmConfig) -> np.ndarray:
    x, y, yaw = (float(v) for v in pose)
    c, s = math.cos(yaw), math.sin(yaw)
    reach = config.comms.comm_range_m
    width = _NEIGHBOUR_HEAD + _SLOT * EXTREMA
    out = np.zeros((NEIGHBOURS, width))
    packets = sorted(inbox, key=lambda p: (math.hypot(p.sender_pose[0] - x,
                                                      p.sender_pose[1] - y), p.sender))
    for slot in range(NEIGHBOURS):
        if slot >= len(packets):
            out[slot, _NEIGHBOUR_HEAD:] = extrema_slots(None, config.sensor.range_m)
            continue
        pkt = packets[slot]
        dx, dy = pkt.sender_pose[0] - x, pkt.sender_pose[1] - y
        dyaw = float(wrap_angle(pkt.sender_pose[2] - yaw))
        out[slot, :_NEIGHBOUR_HEAD] = (1.0, np.clip((c * dx + s * dy) / reach, -1, 1),
                                       np.clip((-s * dx + c * dy) / reach, -1, 1),
                                       math.cos(dyaw), math.sin(dyaw))
        out[slot, _NEIGHBOUR_HEAD:] = extrema_slots(pkt.payload, config.sensor.range_m)
    return out.ravel()


@register_observation("extrema+neighbours", uses_pipeline=True, messages=True,
                      size=lambda c: _SLOT * EXTREMA + 3
                      + NEIGHBOURS * (_NEIGHBOUR_HEAD + _SLOT * EXTREMA))
def neighbours_observation(obs: RobotObservation, config: SwarmConfig) -> np.ndarray:
    """``extrema``, then the nearest neighbours' slots."""
    return np.concatenate([extrema_observation(obs, config),
                           _neighbour_slots(obs.pose, obs.inbox, config)])


def v_range(value: Any, *, where: str = "v_range") -> tuple[float, float]:
    """A checked forward-speed range ``(lo, hi)``, fractions of ``v_max``, ``-1 <= lo < hi <= 1``.

    >>> v_range([0, 1])
    (0.0, 1.0)
    >>> v_range([0.5, 0.2])
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: v_range must be [lo, hi] with -1 <= lo < hi <= 1, got [0.5, 0.2]
    """
    ok = (isinstance(value, (list, tuple)) and len(value) == 2
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value))
    if not ok or not -1.0 <= value[0] < value[1] <= 1.0:
        raise FftnavError(f"{where} must be [lo, hi] with -1 <= lo < hi <= 1, got {value!r:.80}")
    return float(value[0]), float(value[1])


def action_commands(a: np.ndarray, *, v_max_mps: float, w_max_radps: float,
                    speeds: tuple[float, float] | None = None) -> np.ndarray:
    """Commands ``(B, 2)`` (m/s, rad/s) of network outputs ``a`` ``(B, 2)``: clipped to
    [-1, 1]; ``w = a_w w_max``; ``v = a_v v_max``, or with ``speeds = (lo, hi)`` (meta
    ``v_range``) ``v = (lo + (a_v + 1) (hi - lo) / 2) v_max``.

    >>> action_commands(np.array([[-1.0, 0.5], [3.0, -2.0]]), v_max_mps=0.5, w_max_radps=1.5,
    ...                 speeds=(0.0, 1.0)).tolist()
    [[0.0, 0.75], [0.5, -1.5]]
    """
    a = np.clip(np.asarray(a, dtype=np.float64), -1.0, 1.0)
    if speeds is not None:
        lo, hi = speeds
        a[:, 0] = lo + (a[:, 0] + 1.0) * (0.5 * (hi - lo))
    return a * np.array([v_max_mps, w_max_radps])


def _check_controller_net(net: MLP, where: str) -> ObservationSpec:
    """The observation of a controller network, or FftnavError naming ``where`` (the file)."""
    if net.meta.get("kind") != "controller":
        raise FftnavError(f"{where}: meta['kind'] must be 'controller' for a learned controller, "
                          f"got kind={net.meta.get('kind')!r}")
    name = net.meta.get("observation")
    if name not in OBSERVATIONS:
        raise FftnavError(f"{where}: meta['observation'] must be one of "
                          f"{', '.join(OBSERVATIONS)}, got observation={name!r}")
    if net.n_out != 2:
        raise FftnavError(f"{where}: the network must have 2 outputs (v, w), got "
                          f"n_out={net.n_out}")
    for key in ("obs_mean", "obs_std"):
        if key in net.meta:
            value = np.asarray(net.meta[key], dtype=object)
            ok = (value.shape == (net.n_in,) and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in value.tolist()))
            if not ok or (key == "obs_std" and min(value.tolist()) <= 0):
                raise FftnavError(f"{where}: meta[{key!r}] must be {net.n_in} finite numbers"
                                  f"{' > 0' if key == 'obs_std' else ''}, got "
                                  f"{str(net.meta[key])[:80]}")
    if "v_range" in net.meta:
        v_range(net.meta["v_range"], where=f"{where}: meta['v_range']")
    if ("obs_mean" in net.meta) != ("obs_std" in net.meta):
        raise FftnavError(f"{where}: meta must hold both obs_mean and obs_std, or neither")
    return OBSERVATIONS[name]


class LearnedController(Controller):
    """A trained :class:`~fftnav.navigation.mlp.MLP` driving every robot (numpy only).

    Subclassed once per weights file by :func:`learned_controller`, which sets ``net``,
    ``path`` and ``name``; every robot of a tick goes through one batched forward pass.

    Raises
    ------
    FftnavError
        When made, if the network's input size is not the observation's for the episode's
        config (e.g. another ``sensor.beams``), naming the file.
    """

    net: ClassVar[MLP]
    path: ClassVar[Path]
    observation: ClassVar[ObservationSpec]

    def __init__(self, setup: ControllerSetup) -> None:
        super().__init__(setup)
        size = self.observation.size(setup.config)
        if self.net.n_in != size:
            raise FftnavError(f"{self.path}: the network takes {self.net.n_in} inputs, the "
                              f"observation {self.observation.name!r} has {size} with "
                              f"sensor.beams={setup.config.sensor.beams}")
        meta = self.net.meta
        self._mean = np.asarray(meta.get("obs_mean", np.zeros(size)), dtype=np.float64)
        self._std = np.asarray(meta.get("obs_std", np.ones(size)), dtype=np.float64)
        speeds = meta.get("v_range")
        self._speeds = None if speeds is None else v_range(speeds)

    def commands(self, x: np.ndarray) -> np.ndarray:
        """Commands ``(B, 2)`` (m/s, rad/s) for observations ``x`` of shape ``(B, n_in)``."""
        a = self.net((np.asarray(x, np.float64) - self._mean) / self._std)
        return action_commands(a, v_max_mps=self.v_max_mps, w_max_radps=self.w_max_radps,
                               speeds=self._speeds)

    def act(self, obs: RobotObservation) -> Action:
        """One robot's command (and its message, with a messaging observation)."""
        v, w = self.commands(self.observation.build(obs, self.config)[None, :])[0]
        return Action(float(v), float(w), self._message(obs))

    def _message(self, obs: RobotObservation) -> bytes | None:
        if not self.observation.messages or obs.message is None:
            return None
        if self.config.comms.broadcast == "every_tick" or obs.safe_mask is None:
            return obs.message
        sensor = self.config.sensor
        beam = int(beam_index(obs.goal_bearing_rad, beams=sensor.beams, fov_rad=sensor.fov_rad))
        return None if obs.safe_mask[beam] else obs.message

    def step(self, swarm: SwarmStep) -> tuple[np.ndarray, dict[int, bytes]]:
        """Every active robot's command from one forward pass over their observations."""
        commands = np.zeros((len(swarm.poses), 2))
        outgoing: dict[int, bytes] = {}
        active = swarm.active.tolist()
        if not active:
            return commands, outgoing
        rows = []
        for i, obs in robot_observations(swarm, inbox=self.observation.messages):
            rows.append(self.observation.build(obs, self.config))
            message = self._message(obs)
            if message is not None:
                outgoing[i] = message
        commands[active] = self.commands(np.stack(rows))
        return commands, outgoing


def _name(path: Path) -> str:
    return "learned-" + (_NAME_CHARS.sub("_", path.stem) or "net")


def learned_controller(reference: str) -> tuple[str, type[LearnedController], Path]:
    """The controller class of ``learned:PATH.npz``: its name (``learned-<stem>``), a
    :class:`LearnedController` subclass bound to the loaded network, and the file (resolved;
    a relative path is taken from the current directory).

    Raises
    ------
    FftnavError
        A missing or invalid file, or a network that is not a controller (see
        :meth:`fftnav.navigation.mlp.MLP.load`), naming the file.
    """
    text = reference[len(LEARNED_PREFIX):] if reference.startswith(LEARNED_PREFIX) else ""
    if not text:
        raise FftnavError(f"a learned controller must be named {LEARNED_PREFIX}PATH.npz, got "
                          f"{reference!r}")
    path = Path(text).expanduser().resolve()
    net = MLP.load(path)
    spec = _check_controller_net(net, str(path))
    name = _name(path)
    cls = type(f"Learned_{_NAME_CHARS.sub('_', path.stem)}", (LearnedController,), {
        "name": name, "net": net, "path": path, "observation": spec,
        "uses_pipeline": spec.uses_pipeline, "__module__": __name__})
    return name, cls, path


def untrained(observation: str, *, seed: int, hidden: Sequence[int] = (64, 64),
              config: SwarmConfig | None = None) -> MLP:
    """An untrained controller network for ``observation``: the baseline a trained one is
    compared against.

    Weights are drawn uniformly in ``+-sqrt(6 / (n_in + n_out))`` per layer (Glorot) from
    ``numpy.random.default_rng(seed)``, biases are 0, hidden layers ``tanh``, the output
    ``tanh``; the same seed gives the same network.

    Parameters
    ----------
    observation : str
        A registered observation (:data:`OBSERVATIONS`).
    seed : int
        Seed of the weights.
    hidden : sequence of int
        Widths of the hidden layers (each >= 1).
    config : SwarmConfig, optional
        The config whose ``sensor.beams`` sets the input size (default: ``SwarmConfig()``).

    >>> net = untrained("extrema", seed=0, hidden=(8,))
    >>> net.sizes, net.meta["observation"], net == untrained("extrema", seed=0, hidden=(8,))
    ((27, 8, 2), 'extrema', True)
    """
    spec = OBSERVATIONS.lookup(observation)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise FftnavError(f"seed must be an integer >= 0, got seed={seed!r}")
    widths = list(hidden)
    if any(isinstance(h, bool) or not isinstance(h, (int, np.integer)) or h < 1
           for h in widths):
        raise FftnavError(f"hidden must be integers >= 1, got hidden={tuple(hidden)!r}")
    sizes = [spec.size(config or SwarmConfig()), *widths, 2]
    rng = np.random.default_rng(seed)
    weights, biases = [], []
    for n_in, n_out in zip(sizes[:-1], sizes[1:], strict=True):
        bound = math.sqrt(6.0 / (n_in + n_out))
        weights.append(rng.uniform(-bound, bound, (n_in, n_out)))
        biases.append(np.zeros(n_out))
    return MLP(weights=weights, biases=biases, activation="tanh", output="tanh",
               meta={"kind": "controller", "observation": observation, "version": VERSION,
                     "seed": int(seed)})
