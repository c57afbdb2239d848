"""The training config of ``fftnav learn``: one TOML file, validated before any work.

Sections (every key optional unless said; a bad value is named ``section.key``):

``[learn]``
    ``method`` (``"controller"``: (v, w) end to end; ``"decider"``: the Bug planner's side),
    ``observation`` (a controller's, one of :data:`fftnav.navigation.learned.OBSERVATIONS`;
    required for a controller, absent for a decider), ``seed`` (int >= 0), ``agent_steps``
    (the training budget, in learner samples: one robot's step for a controller, one decision
    for a decider), ``hidden`` (hidden layer widths, default ``[64, 64]``), ``robots`` (15),
    ``warmup`` (a decider's: decisions with random sides that fix its features'
    standardisation, 512).
``[ppo]``
    Stable-Baselines3 PPO's options: ``n_steps`` (rollout length per robot slot), ``batch_size``,
    ``n_epochs``, ``learning_rate``, ``gamma``, ``gae_lambda``, ``clip_range``, ``ent_coef``,
    ``vf_coef``, ``max_grad_norm``, ``log_std_init`` (a controller's initial Gaussian log
    standard deviation).
``[action]``
    ``kind = "continuous"``: the network's 2 outputs ``(a_v, a_w)``, clipped to [-1, 1], scaled
    to ``robot.v_max_mps`` and ``robot.w_max_radps`` (:mod:`fftnav.navigation.learned`);
    ``v_range = [lo, hi]`` (fractions of ``v_max``, default ``[-1, 1]``) maps ``a_v`` onto
    forward speeds from ``lo v_max`` to ``hi v_max`` (``[0, 1]``: never reversing).
``[reward]``
    A controller's reward (:class:`fftnav.envs.swarm_env.Rewards`): ``progress`` per metre of
    progress, ``arrival`` once, ``collision`` once, ``step`` every step. A decider's:
    ``arrival_bonus_m`` and ``failure_penalty_m`` of :class:`fftnav.envs.DecisionEnv`.
``[train]`` and ``[validation]``
    ``worlds`` (registered world kinds) and ``map_seeds = [first, end)`` (the episode's world is
    drawn uniformly from ``worlds`` x seeds). Validation adds ``every`` (learner samples between
    two validations) and ``episodes`` per world (the first seeds of its range). The two ranges
    must be disjoint, and both disjoint from Table I's maps 1000-1019. ``[train] min_live``
    (a controller's; fraction of the robots, default 0): a training episode is cut short
    when fewer robots than that are still driving, the rest truncated (their value
    bootstrapped), so that slots of ended robots do not fill the rollouts.
``[robot]``, ``[sensor]``, ``[comms]``, ``[episode]``, ...
    The swarm's config, as in an experiment config (:class:`fftnav.config.SwarmConfig`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fftnav.config import SwarmConfig
from fftnav.errors import FftnavError
from fftnav.files import read_toml
from fftnav.navigation.learned import OBSERVATIONS, v_range
from fftnav.validate import (
    Checked,
    check_choice,
    check_integer,
    check_number,
    integer_field,
    number_field,
)
from fftnav.world.kinds import world_kinds

__all__ = ["METHODS", "TABLE1_SEEDS", "LearnConfig", "MapRange", "load_learn_config",
           "parse_learn_config"]

#: What ``fftnav learn`` trains.
METHODS = ("controller", "decider")
#: The Table I maps (``experiments/table1.toml``), never trained or validated on.
TABLE1_SEEDS = (1000, 1020)


@dataclass(frozen=True)
class PPO(Checked):
    """Stable-Baselines3 PPO's options (its defaults where ours are not given)."""

    n_steps: int = integer_field(128, low=2)
    batch_size: int = integer_field(480, low=2)
    n_epochs: int = integer_field(4, low=1)
    learning_rate: float = number_field(3e-4, low=0, low_open=True)
    gamma: float = number_field(0.99, low=0, high=1)
    gae_lambda: float = number_field(0.95, low=0, high=1)
    clip_range: float = number_field(0.2, low=0, low_open=True)
    ent_coef: float = number_field(0.0, low=0)
    vf_coef: float = number_field(0.5, low=0)
    max_grad_norm: float = number_field(0.5, low=0, low_open=True)
    log_std_init: float = number_field(-0.5)


@dataclass(frozen=True)
class Reward(Checked):
    """A controller's reward terms and a decider's bonus and penalty (metres)."""

    progress: float = number_field(1.0)
    arrival: float = number_field(10.0)
    collision: float = number_field(-10.0)
    step: float = number_field(0.0)
    arrival_bonus_m: float = number_field(5.0)
    failure_penalty_m: float = number_field(20.0)


@dataclass(frozen=True)
class MapRange:
    """Worlds and a half-open range of map seeds ``[first, end)``."""

    worlds: tuple[str, ...]
    first: int
    end: int

    def overlaps(self, other: tuple[int, int]) -> bool:
        return self.first < other[1] and other[0] < self.end


@dataclass(frozen=True)
class LearnConfig:
    """A validated training config (:func:`parse_learn_config`)."""

    method: str
    observation: str | None
    seed: int
    agent_steps: int
    hidden: tuple[int, ...]
    v_range: tuple[float, float]
    min_live: float
    robots: int
    warmup: int
    ppo: PPO
    reward: Reward
    train: MapRange
    validation: MapRange
    validate_every: int
    validate_episodes: int
    swarm: SwarmConfig
    source: str = field(default="", compare=False)

    @property
    def speeds(self) -> tuple[float, float] | None:
        """``v_range`` as the learned controller's meta holds it: None for the default
        ``[-1, 1]`` (``v = a_v v_max``)."""
        return None if self.v_range == (-1.0, 1.0) else self.v_range

    def to_json(self) -> dict[str, Any]:
        """Everything that shapes the training (its ``config.json``; the source text aside)."""
        out = dataclasses.asdict(self)
        out.pop("source")
        out["swarm"] = self.swarm.to_sections()
        return out

    def sha256(self) -> str:
        """SHA-256 of :meth:`to_json` but ``agent_steps`` (a resumed run must have the same;
        it may train longer)."""
        shaped = {k: v for k, v in self.to_json().items() if k != "agent_steps"}
        text = json.dumps(shaped, sort_keys=True, default=list)
        return hashlib.sha256(text.encode()).hexdigest()


_LEARN_KEYS = ("method", "observation", "seed", "agent_steps", "hidden", "robots", "warmup")


def _table(data: dict[str, Any], name: str) -> dict[str, Any]:
    value = data.get(name, {})
    if not isinstance(value, dict):
        raise FftnavError(f"[{name}] must be a table, got {name}={value!r:.80}")
    return value


def _map_range(data: dict[str, Any], name: str, *, extra: tuple[str, ...] = ()) -> MapRange:
    table = _table(data, name)
    for key in table:
        if key not in ("worlds", "map_seeds", *extra):
            raise FftnavError(f"unknown key {name}.{key}; expected one of "
                              f"{['worlds', 'map_seeds', *extra]}")
    worlds = table.get("worlds", ["forest"])
    if not isinstance(worlds, list) or not worlds:
        raise FftnavError(f"{name}.worlds must be a non-empty list of world kinds, got "
                          f"worlds={worlds!r:.80}")
    kinds = tuple(check_choice(f"{name}.worlds", w, world_kinds()) for w in worlds)
    if "map_seeds" not in table:
        raise FftnavError(f"{name}.map_seeds is required: [first, end), e.g. [5000, 6000]")
    seeds = table["map_seeds"]
    if not isinstance(seeds, list) or len(seeds) != 2:
        raise FftnavError(f"{name}.map_seeds must be [first, end), two integers, got "
                          f"map_seeds={seeds!r:.80}")
    first = check_integer(f"{name}.map_seeds[0]", seeds[0], low=0)
    end = check_integer(f"{name}.map_seeds[1]", seeds[1], low=first + 1)
    return MapRange(kinds, first, end)


def _method(learn: dict[str, Any]) -> tuple[str, str | None]:
    """``learn.method`` and ``learn.observation`` (a controller's only)."""
    method = check_choice("learn.method", learn.get("method", "controller"), METHODS)
    observation = learn.get("observation")
    if method == "controller":
        if observation is None:
            raise FftnavError(f"learn.observation is required for a controller: one of "
                              f"{list(OBSERVATIONS)}")
        observation = check_choice("learn.observation", observation, list(OBSERVATIONS))
    elif observation is not None:
        raise FftnavError(f"learn.observation is for a controller; a decider observes "
                          f"decision-v1, got observation={observation!r}")
    return method, observation


def _action(action: dict[str, Any]) -> tuple[float, float]:
    """``[action]``: its ``v_range``."""
    for key in action:
        if key not in ("kind", "v_range"):
            raise FftnavError(f"unknown key action.{key}; expected one of ['kind', 'v_range']")
    check_choice("action.kind", action.get("kind", "continuous"), ("continuous",))
    return v_range(action.get("v_range", [-1.0, 1.0]), where="action.v_range")


def parse_learn_config(data: dict[str, Any], *, source: str = "") -> LearnConfig:
    """Validate a parsed training TOML document (module docstring); ValueError naming the key.

    >>> c = parse_learn_config({"learn": {"observation": "extrema"},
    ...                         "train": {"map_seeds": [5000, 6000]},
    ...                         "validation": {"map_seeds": [7000, 7100]}})
    >>> c.method, c.observation, c.agent_steps, c.validation.worlds
    ('controller', 'extrema', 1000000, ('forest',))
    >>> parse_learn_config({"learn": {"observation": "extrema"},
    ...                     "train": {"map_seeds": [990, 1001]},
    ...                     "validation": {"map_seeds": [7000, 7100]}})
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: train.map_seeds=[990, 1001] overlaps Table I's maps [1000, 1020)
    """
    allowed = ("learn", "ppo", "action", "reward", "train", "validation", *SwarmConfig.SECTIONS)
    for name in data:
        if name not in allowed:
            raise FftnavError(f"unknown section [{name}]; expected one of {list(allowed)}")
    learn = _table(data, "learn")
    for key in learn:
        if key not in _LEARN_KEYS:
            raise FftnavError(f"unknown key learn.{key}; expected one of {list(_LEARN_KEYS)}")
    method, observation = _method(learn)
    hidden = learn.get("hidden", [64, 64])
    if not isinstance(hidden, list) or not hidden:
        raise FftnavError(f"learn.hidden must be a non-empty list of widths, got "
                          f"hidden={hidden!r:.80}")
    speeds = _action(_table(data, "action"))
    train = _map_range(data, "train", extra=("min_live",))
    min_live = check_number("train.min_live", _table(data, "train").get("min_live", 0.0),
                            low=0, high=1)
    validation = _map_range(data, "validation", extra=("every", "episodes"))
    vtable = _table(data, "validation")
    for name, rng in (("train", train), ("validation", validation)):
        if rng.overlaps(TABLE1_SEEDS):
            raise FftnavError(f"{name}.map_seeds=[{rng.first}, {rng.end}] overlaps Table I's "
                              f"maps [{TABLE1_SEEDS[0]}, {TABLE1_SEEDS[1]})")
    if train.overlaps((validation.first, validation.end)):
        raise FftnavError(f"train.map_seeds=[{train.first}, {train.end}] and "
                          f"validation.map_seeds=[{validation.first}, {validation.end}] overlap")
    episodes = check_integer("validation.episodes", vtable.get("episodes", 4), low=1,
                             high=validation.end - validation.first)
    swarm = SwarmConfig.from_sections({s: _table(data, s) for s in SwarmConfig.SECTIONS})
    return LearnConfig(
        method=method, observation=observation,
        seed=check_integer("learn.seed", learn.get("seed", 0), low=0),
        agent_steps=check_integer("learn.agent_steps", learn.get("agent_steps", 1_000_000),
                                  low=1),
        v_range=speeds, min_live=min_live,
        hidden=tuple(check_integer("learn.hidden", h, low=1, high=4096) for h in hidden),
        robots=check_integer("learn.robots", learn.get("robots", 15), low=1, high=200),
        warmup=check_integer("learn.warmup", learn.get("warmup", 512), low=2),
        ppo=PPO.from_table("ppo", _table(data, "ppo")),
        reward=Reward.from_table("reward", _table(data, "reward")),
        train=train, validation=validation,
        validate_every=check_integer("validation.every", vtable.get("every", 100_000), low=1),
        validate_episodes=episodes, swarm=swarm, source=source)


def load_learn_config(path: str | Path) -> LearnConfig:
    """Read and validate a training TOML file; errors are prefixed with the file."""
    data, text = read_toml(path)
    try:
        return parse_learn_config(data, source=text)
    except ValueError as exc:
        raise FftnavError(f"{path}: {exc}") from None

