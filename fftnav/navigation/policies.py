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
``collab``
    Ours (issue 10): robots share the *walls* they see (a few line segments a second,
    :mod:`fftnav.episode.collab`), drawn into the receivers' own maps; at a decision the side
    whose way to the goal through that map is clearly shorter (by 1 m, a step through a cell
    the robot never saw counting three), else P_s as ``own-only``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = [
    "LEFT",
    "MESSAGES",
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
    shared_side : callable
        ``() -> int | None``: the side whose way to the goal through the robot's own map (its
        scans and the walls its neighbours shared, ``collab``'s messages) is clearly shorter,
        None if neither is.
    """

    robot: int
    own_probability: Callable[[], float]
    fused_probability: Callable[[], float]
    rng: np.random.Generator
    shared_side: Callable[[], int | None] = lambda: None


#: What a policy's robots broadcast: nothing, their compressed observation (the paper's
#: Sigma, ``fusion``) or the wall segments they see (``collab``).
MESSAGES: tuple[str | None, ...] = (None, "observation", "walls")


@dataclass(frozen=True)
class Policy:
    """A named decision rule. ``messages`` says what its robots broadcast (:data:`MESSAGES`);
    ``reconsiders``: the planner asks ``decide`` again, while following, when news arrives."""

    name: str
    decide: Callable[[DecisionContext], int]
    messages: str | None
    description: str
    reconsiders: bool = False

    def __post_init__(self) -> None:
        if self.messages not in MESSAGES:
            raise ValueError(f"messages must be one of {list(MESSAGES)}, got "
                             f"messages={self.messages!r}")

    @property
    def uses_messages(self) -> bool:
        """Whether its robots broadcast anything."""
        return self.messages is not None


POLICIES: dict[str, Policy] = {}


def register_policy(
    name: str, *, messages: str | None = None, reconsiders: bool = False, description: str = ""
) -> Callable[[Callable[[DecisionContext], int]], Callable[[DecisionContext], int]]:
    """Decorator registering a decision function under ``name`` (``messages``: what its robots
    broadcast, one of :data:`MESSAGES`)."""
    if messages not in MESSAGES:
        raise ValueError(f"messages must be one of {list(MESSAGES)}, got messages={messages!r}")

    def wrap(fn: Callable[[DecisionContext], int]) -> Callable[[DecisionContext], int]:
        if name in POLICIES:
            raise ValueError(f"policy name {name!r} is already registered")
        POLICIES[name] = Policy(name, fn, messages, description or (fn.__doc__ or ""),
                                reconsiders)
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


@register_policy("fusion", messages="observation")
def _fusion(ctx: DecisionContext) -> int:
    """Left iff the fused P > 0.5 (the paper's method)."""
    return LEFT if ctx.fused_probability() > 0.5 else RIGHT


@register_policy("collab", messages="walls", reconsiders=False)
def _collab(ctx: DecisionContext) -> int:
    """The side whose way to the goal through the robot's map (its own scans and the walls its
    neighbours shared) is clearly shorter; else P_s, as ``own-only``."""
    shared = ctx.shared_side()
    if shared is not None:
        return shared
    return LEFT if ctx.own_probability() > 0.5 else RIGHT
