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
    "DecisionObservation",
    "Policy",
    "POLICIES",
    "register_policy",
    "get_policy",
]

LEFT = 1
RIGHT = -1


@dataclass(frozen=True)
class DecisionObservation:
    """What the paper's Bayesian fusion uses at one decision, in the robot's goal frame (the
    robot frame rotated by the goal bearing: x towards the goal, y to its left).

    Attributes
    ----------
    p_s : float
        The robot's own P_s (eq. (P_s)).
    sigma : ndarray, (n, 2)
        The extrema of its own scan (the compressed message's numbers): angle (rad, goal frame,
        in ``[-pi, pi)``) and distance (m).
    p_neighbours : ndarray, (k,)
        Each received message's P_i (eq. (P_ni)), towards the goal, computed for every sender
        of the inbox (fusion fuses only those beside the robot, within range).
    rel_poses : ndarray, (k, 3)
        Each sender's pose (x m, y m, yaw rad) in the goal frame, as fusion places it (with
        ``comms.pose_noise_m``), in the order of ``p_neighbours``.
    range_m : float
        The sensor range R (m).
    comm_range_m : float
        The communication range (m).
    """

    p_s: float
    sigma: np.ndarray
    p_neighbours: np.ndarray
    rel_poses: np.ndarray
    range_m: float
    comm_range_m: float


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
    observation : callable
        ``() -> DecisionObservation | None``: P_s, the own extrema, the neighbours' P_i and
        relative poses (computed once per decision on the first call, drawing the pose noise
        from ``rng`` as ``fused_probability`` does); None where the controller does not
        provide it.
    """

    robot: int
    own_probability: Callable[[], float]
    fused_probability: Callable[[], float]
    rng: np.random.Generator
    shared_side: Callable[[], int | None] = lambda: None
    observation: Callable[[], DecisionObservation | None] = lambda: None


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
