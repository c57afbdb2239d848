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
    Robots share the *walls* they see (a few line segments a second,
    :mod:`fftnav.navigation.collab`), drawn into the receivers' own maps once they have seen a
    wall longer than R themselves (before that, ``collab`` is ``own-only``); at a decision the
    side whose way to the goal through that map is clearly shorter (by 1 m, a step through a
    cell the robot never saw counting three), else P_s as ``own-only``; and, heading for its
    goal, a robot steers along its way through the walls of that map where they block the
    straight line (the planner's ``guide``).
``collab-reconsider``
    ``collab`` that also asks again while following a wall, when wall segments arrived since
    it decided (``Policy.reconsiders``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fftnav.navigation.controllers import ENTRY_POINT_GROUP
from fftnav.navigation.messages import MESSAGE_KINDS, MessageKind
from fftnav.registry import Registry, first_line

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


def _message_kind(messages: str | type[MessageKind] | None) -> type[MessageKind] | None:
    """The registered kind named ``messages`` (a :class:`MessageKind` subclass or None passes
    through)."""
    if messages is None or (isinstance(messages, type) and issubclass(messages, MessageKind)):
        return messages
    return MESSAGE_KINDS.lookup(messages)


@dataclass(frozen=True)
class Policy:
    """A named decision rule.

    Attributes
    ----------
    name : str
        The name its rows carry.
    decide : callable
        ``(DecisionContext) -> LEFT | RIGHT``.
    messages : type of MessageKind or None
        What its robots broadcast and how they read it: a kind's class
        (:data:`~fftnav.navigation.messages.MESSAGE_KINDS`: ``"observation"``, ``"walls"``; a
        name is looked up there), of which the Bug controller makes one instance per episode;
        None: nothing.
    description : str
        One line.
    reconsiders : bool
        Whether the planner asks ``decide`` again while following a boundary, when messages
        arrived since the robot decided (at most one change of side per follow).
    """

    name: str
    decide: Callable[[DecisionContext], int]
    messages: type[MessageKind] | None
    description: str
    reconsiders: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "messages", _message_kind(self.messages))

    @property
    def uses_messages(self) -> bool:
        """Whether its robots broadcast anything."""
        return self.messages is not None


#: The registered decision policies, by name.
POLICIES: Registry[Policy] = Registry("policy", parameter="policy",
                                      entry_point_group=ENTRY_POINT_GROUP)


def register_policy(
    name: str, *, messages: str | None = None, reconsiders: bool = False, description: str = ""
) -> Callable[[Callable[[DecisionContext], int]], Callable[[DecisionContext], int]]:
    """Decorator registering a decision function under ``name`` (``messages``: what its robots
    broadcast, a name of :data:`~fftnav.navigation.messages.MESSAGE_KINDS` or None;
    ``description``: default, the first line of its docstring)."""
    kind = _message_kind(messages)

    def wrap(fn: Callable[[DecisionContext], int]) -> Callable[[DecisionContext], int]:
        POLICIES.add(name, Policy(name, fn, kind, description or first_line(fn.__doc__),
                                  reconsiders))
        return fn

    return wrap


def get_policy(name: str) -> Policy:
    """The registered policy ``name``; ValueError listing the known names otherwise."""
    return POLICIES.lookup(name)


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


@register_policy("collab", messages="walls")
def _collab(ctx: DecisionContext) -> int:
    """The side whose way to the goal through the robot's map (its own scans and the walls its
    neighbours shared) is clearly shorter; else P_s, as ``own-only``."""
    shared = ctx.shared_side()
    if shared is not None:
        return shared
    return LEFT if ctx.own_probability() > 0.5 else RIGHT


@register_policy("collab-reconsider", messages="walls", reconsiders=True)
def _collab_reconsider(ctx: DecisionContext) -> int:
    """``collab``, asked again while following when wall segments arrived since it decided."""
    return _collab(ctx)
