"""Decision policies: which side to pass an obstacle on, looked up by name.

A policy is called once per decision (when the goal direction becomes blocked, paper
Sec. III-E) with a :class:`DecisionContext` and returns ``LEFT`` (+1) or ``RIGHT`` (-1).
The context computes the probabilities lazily, so a baseline never pays for them.

Registered policies:

``bug-left``, ``bug-right``
    The paper's baselines: always the same side.
``fusion``
    The paper's method: left iff the fused probability P > 0.5 (eq. (P)), from the robot's own
    P_s and its neighbours' P_i. Robots broadcast their compressed observation.
``own-only``
    Ablation: left iff P_s > 0.5, no neighbours (tells whether the gain comes from sharing).
``random``
    A seeded coin per decision.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = [
    "LEFT",
    "RIGHT",
    "DecisionContext",
    "Policy",
    "POLICIES",
    "register_policy",
    "get_policy",
]

LEFT = 1
RIGHT = -1


@dataclass
class DecisionContext:
    """What a policy may look at when it decides.

    Attributes
    ----------
    robot : int
        Index of the deciding robot.
    own_probability : callable
        ``() -> float``: P_s, the robot's own probability of turning left (eq. (P_s)).
    fused_probability : callable
        ``() -> float``: P, own and neighbours' probabilities fused (eq. (P)).
    rng : numpy.random.Generator
        The episode's generator (for ``random``).
    """

    robot: int
    own_probability: Callable[[], float]
    fused_probability: Callable[[], float]
    rng: np.random.Generator


@dataclass(frozen=True)
class Policy:
    """A named decision rule; ``uses_messages`` says whether robots broadcast observations."""

    name: str
    decide: Callable[[DecisionContext], int]
    uses_messages: bool
    description: str


POLICIES: dict[str, Policy] = {}


def register_policy(
    name: str, *, uses_messages: bool = False, description: str = ""
) -> Callable[[Callable[[DecisionContext], int]], Callable[[DecisionContext], int]]:
    """Decorator registering a decision function under ``name``."""

    def wrap(fn: Callable[[DecisionContext], int]) -> Callable[[DecisionContext], int]:
        if name in POLICIES:
            raise ValueError(f"policy name {name!r} is already registered")
        POLICIES[name] = Policy(name, fn, uses_messages, description or (fn.__doc__ or ""))
        return fn

    return wrap


def get_policy(name: str) -> Policy:
    """The registered policy ``name``; ValueError listing the known names otherwise."""
    try:
        return POLICIES[name]
    except KeyError:
        raise ValueError(f"unknown policy {name!r}; known policies: {sorted(POLICIES)}") from None


@register_policy("bug-left")
def _bug_left(ctx: DecisionContext) -> int:
    """Always pass obstacles on the left (paper baseline "Bug (left)")."""
    return LEFT


@register_policy("bug-right")
def _bug_right(ctx: DecisionContext) -> int:
    """Always pass obstacles on the right (paper baseline "Bug (right)")."""
    return RIGHT


@register_policy("random")
def _random(ctx: DecisionContext) -> int:
    """A fair coin from the episode's generator."""
    return LEFT if ctx.rng.random() < 0.5 else RIGHT


@register_policy("own-only")
def _own_only(ctx: DecisionContext) -> int:
    """Left iff the robot's own P_s > 0.5 (no neighbours)."""
    return LEFT if ctx.own_probability() > 0.5 else RIGHT


@register_policy("fusion", uses_messages=True)
def _fusion(ctx: DecisionContext) -> int:
    """Left iff the fused P > 0.5 (the paper's method)."""
    return LEFT if ctx.fused_probability() > 0.5 else RIGHT
