"""Failure causes: why a robot did not arrive, from the end of its trajectory.

:func:`failure_features` measures the last ``window_s`` seconds of a robot's trajectory
(:class:`FailureFeatures`) with the :class:`FailureThresholds` of its robot;
:func:`classify_failure` gives the first cause of :data:`FAILURE_CAUSES` whose test holds on
them. The causes are tested in a declared order: :func:`register_failure_cause` places a cause at
the end or ``before`` a registered one, and the catch-all cause (``detour``, the complement of
``slow``: every robot the causes before it leave gets it) stays last, so a cause that would come
after it, and never be tested, is refused when it is registered. Every cause has a measure
``failures_<cause>`` (:data:`fftnav.metrics.measures.MEASURES`), the number of robots with that
cause.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from fftnav.errors import FftnavError
from fftnav.metrics.measures import Table, register_measure
from fftnav.metrics.paths import _positions, arrived, path_length_m
from fftnav.registry import Registry
from fftnav.validate import Checked, check_choice, check_number, number_field

__all__ = [
    "FAILURE_CAUSES",
    "FailureCause",
    "FailureCauses",
    "FailureFeatures",
    "FailureThresholds",
    "classify_failure",
    "failure_features",
    "register_failure_cause",
]


@dataclass(frozen=True)
class FailureThresholds(Checked):
    """The thresholds of the failure causes; the defaults are those of the paper's robot
    (r0 = 0.15 m, 0.5 m/s: :meth:`for_robot`). Every field is checked when an instance is made.

    Attributes
    ----------
    window_s : float
        The seconds at the end of the trajectory that are looked at (the whole trajectory if
        shorter): 20 s, 10 m at the paper's 0.5 m/s, a whole turn round a 1.5 m obstacle (> 0).
    still_m : float
        ``stuck``: largest distance between two positions of the window (2 r0; > 0).
    loop_ratio : float
        ``loop``: path length over that diameter (> 1; 2.5: a circle gives pi, a single
        back-and-forth 2, half a circle pi/2).
    progress_m : float
        ``slow``: how much closer to the goal at the window's end (a tenth of the 10 m the robot
        drives in the window at top speed); ``jam``: the most the robot may end the window from
        where it began it (> 0).
    jam_distance_m : float
        ``jam``: centre distance to another robot (4 r0: the bodies at most a robot width
        apart; > 0).
    jam_share : float
        ``jam``: the fraction of the window's samples at which another robot is that near,
        in (0, 1].

    Examples
    --------
    >>> FailureThresholds(loop_ratio=3).loop_ratio
    3.0
    >>> FailureThresholds(jam_share=0)
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: jam_share must be a finite number in (0, 1], got jam_share=0
    """

    window_s: float = number_field(20.0, low=0, low_open=True)
    still_m: float = number_field(0.3, low=0, low_open=True)
    loop_ratio: float = number_field(2.5, low=1, low_open=True)
    progress_m: float = number_field(1.0, low=0, low_open=True)
    jam_distance_m: float = number_field(0.6, low=0, low_open=True)
    jam_share: float = number_field(0.5, low=0, high=1, low_open=True)

    @classmethod
    def for_robot(cls, *, r0_m: float = 0.15, v_max_mps: float = 0.5,
                  window_s: float = 20.0) -> FailureThresholds:
        """The thresholds for a robot of radius ``r0_m`` and top speed ``v_max_mps`` over its
        last ``window_s`` seconds: ``still_m`` = 2 r0 (its own width), ``jam_distance_m`` = 4 r0
        (centres one robot width apart), ``progress_m`` = a tenth of what it drives in
        ``window_s`` at top speed; ``loop_ratio`` and ``jam_share`` keep their defaults.

        >>> FailureThresholds.for_robot() == FailureThresholds()
        True
        >>> FailureThresholds.for_robot(r0_m=0.25, v_max_mps=1.0, window_s=10.0)
        ... # doctest: +NORMALIZE_WHITESPACE
        FailureThresholds(window_s=10.0, still_m=0.5, loop_ratio=2.5, progress_m=1.0,
                          jam_distance_m=1.0, jam_share=0.5)
        """
        r0 = check_number("r0_m", r0_m, low=0, low_open=True)
        v = check_number("v_max_mps", v_max_mps, low=0, low_open=True)
        w = check_number("window_s", window_s, low=0, low_open=True)
        return cls(window_s=w, still_m=2 * r0, jam_distance_m=4 * r0,
                   progress_m=round(0.1 * v * w, 12))


@dataclass(frozen=True)
class FailureFeatures:
    """What :func:`failure_features` measures on the last ``window_s`` seconds of a trajectory.

    Attributes
    ----------
    arrived, collided : bool
        Success S_i (:func:`fftnav.metrics.paths.arrived`) and contact with an obstacle.
    window_s : float
        The seconds looked at: ``thresholds.window_s``, or the whole trajectory if it is
        shorter.
    extent_m : float
        Diameter of the visited positions: the largest distance between two of them (m).
    path_m : float
        Path length driven in the window (m).
    displacement_m : float
        Distance between the window's first and last positions (m).
    progress_m : float
        How much closer to the goal the robot ended the window than it began it (m; negative
        if it got farther).
    near_share : float
        Fraction of the window's samples at which another robot's centre was within
        ``thresholds.jam_distance_m`` of the robot's centre (0 without other robots).
    thresholds : FailureThresholds
        The thresholds the features were measured with (``window_s`` and ``jam_distance_m``)
        and that the causes test them against.
    lost : bool
        The episode's lost flag: the robot stopped where its own estimate of its pose said its
        goal was, short of it (odometry; ``dataclasses.replace(features, lost=True)``).
    """

    arrived: bool
    collided: bool
    window_s: float
    extent_m: float
    path_m: float
    displacement_m: float
    progress_m: float
    near_share: float
    thresholds: FailureThresholds
    lost: bool = False


#: A cause's test: ``test(features, thresholds) -> bool``.
CauseTest = Callable[[FailureFeatures, FailureThresholds], bool]


@dataclass(frozen=True)
class FailureCause:
    """A reason why a robot did not arrive.

    Attributes
    ----------
    name : str
        The cause, as written in the ``failure`` column.
    definition : str
        One sentence: when this cause is given (the earlier causes' tests having failed).
    thresholds : tuple of str
        The fields of :class:`FailureThresholds` its test uses; a name that is not a field is
        refused.
    test : callable
        ``test(features, thresholds) -> bool`` on :class:`FailureFeatures` and
        :class:`FailureThresholds`.
    catch_all : bool
        Its test holds for every robot that the causes before it leave, so no cause after it
        could ever be given: it must be the last.
    requires : str
        The experiment condition without which it is never given (``"odometry"``; its measure's
        :attr:`~fftnav.metrics.measures.Measure.requires`); empty: always possible.
    """

    name: str
    definition: str
    thresholds: tuple[str, ...]
    test: CauseTest
    catch_all: bool = False
    requires: str = ""

    def __post_init__(self) -> None:
        fields = FailureThresholds.keys()
        names = tuple(self.thresholds) if not isinstance(self.thresholds, str) else None
        if names is None or not set(names) <= set(fields):
            raise FftnavError(f"thresholds of failure cause {self.name!r} must be fields of "
                              f"FailureThresholds {fields}, got thresholds={self.thresholds!r}")
        object.__setattr__(self, "thresholds", names)


class FailureCauses(Registry[FailureCause]):
    """The failure causes in the order they are tested.

    :meth:`add` places a cause at the end, or ``before`` a registered cause, and refuses an
    order in which a cause could never be given: a cause after the catch-all, or a catch-all
    before another cause.
    """

    def __init__(self) -> None:
        super().__init__("failure cause", parameter="cause")

    def catch_all(self) -> str | None:
        """The name of the registered catch-all cause (None before it is registered)."""
        return next((name for name, cause in self.items() if cause.catch_all), None)

    def add(self, name: str, item: FailureCause, *, before: str | None = None) -> FailureCause:
        """Register ``item`` under ``name``, tested just before the cause ``before`` (after
        every registered cause by default); ValueError for a name taken or an order in which
        ``item``, or a registered cause, would never be tested. Returns ``item``."""
        last = self.catch_all()
        if before is not None:
            check_choice("before", before, list(self))
            if item.catch_all:
                raise FftnavError(f"failure cause {name!r} is a catch-all and must be tested "
                                  f"last, got before={before!r}")
        elif last is not None:
            raise FftnavError(f"failure cause {name!r} would never be tested after the catch-all "
                              f"{last!r} (every robot the causes before {last!r} leave gets it); "
                              f"register it with before={last!r} or an earlier cause")
        super().add(name, item)
        if before is not None:
            order = list(self)
            order.insert(order.index(before), order.pop())
            entries = {n: self[n] for n in order}
            self.clear()
            self.update(entries)
        return item

    def copy(self) -> FailureCauses:
        """A registry with the same causes in the same order (for tests that register more)."""
        new = FailureCauses()
        new.update(self)
        return new


#: Causes of failure in the order they are tested: a robot that did not arrive gets the first
#: whose test holds. The last, ``detour``, is the catch-all (the complement of ``slow``), so
#: every such robot gets one.
FAILURE_CAUSES: FailureCauses = FailureCauses()


def _failure_count(cause: str, definition: str) -> Callable[[Table], float]:
    def count(table: Table) -> float:
        if "failure" not in table:
            return float("nan")  # a table written before the failure column
        return float(np.sum(np.asarray(table["failure"], dtype=object) == cause))

    count.__doc__ = (f"Number of robots whose ``failure`` is ``{cause}``: {definition}; NaN for "
                     f"a table without the column.")
    return count


def register_failure_cause(
    name: str, definition: str, *, thresholds: Iterable[str] = (), before: str | None = None,
    catch_all: bool = False, requires: str = "",
) -> Callable[[CauseTest], CauseTest]:
    """Decorator registering ``test(features, thresholds) -> bool`` as failure cause ``name``
    (see :class:`FailureCause`), with its measure ``failures_<name>``.

    Parameters
    ----------
    name, definition : str
        The cause and one sentence saying when it is given.
    thresholds : iterable of str
        The fields of :class:`FailureThresholds` the test uses.
    before : str, optional
        The registered cause it is tested just before; by default it is tested last, which is
        refused once the catch-all is registered (name the catch-all, ``detour``, or an earlier
        cause).
    catch_all : bool
        The test holds for every robot the causes before it leave (it must be the last).
    requires : str
        The experiment condition without which the cause is never given (see
        :class:`FailureCause`).

    Examples
    --------
    A cause that would come after the catch-all is refused (``before="detour"`` places it):

    >>> register_failure_cause("away", "it ended the window farther from its goal")(
    ...     lambda f, t: f.progress_m < 0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: failure cause 'away' would never be tested after the catch-all ...
    """

    def register(test: CauseTest) -> CauseTest:
        cause = FailureCause(name, definition, thresholds, test, catch_all, requires)
        FAILURE_CAUSES.add(name, cause, before=before)
        try:
            register_measure(f"failures_{name}", requires=requires)(
                _failure_count(name, definition))
        except ValueError:
            del FAILURE_CAUSES[name]  # a cause is registered with its measure or not at all
            raise
        return test

    return register


@register_failure_cause("collision", "it touched an obstacle (the episode's collided flag)")
def _collision(f: FailureFeatures, t: FailureThresholds) -> bool:
    return f.collided


@register_failure_cause(
    "lost", "it stopped where its own estimate of its pose said its goal was, and its true pose "
    "was not within the arrival radius (the episode's lost flag: odometry only)",
    requires="odometry")
def _lost(f: FailureFeatures, t: FailureThresholds) -> bool:
    return f.lost


@register_failure_cause(
    "jam", "for at least jam_share of the window another robot's centre was within "
    "jam_distance_m (in contact or within a robot width) and the robot ended the window less "
    "than progress_m from where it began it (blocked)",
    thresholds=("jam_share", "jam_distance_m", "progress_m"))
def _jam(f: FailureFeatures, t: FailureThresholds) -> bool:
    return f.near_share >= t.jam_share and f.displacement_m < t.progress_m


@register_failure_cause(
    "stuck", "it barely moved: every position of the window lies within still_m of every other "
    "(standing or turning on the spot)", thresholds=("still_m",))
def _stuck(f: FailureFeatures, t: FailureThresholds) -> bool:
    return f.extent_m <= t.still_m


@register_failure_cause(
    "loop", "it moved but circled: the window's path is at least loop_ratio times the diameter "
    "of the region it covers (revisiting the same places)", thresholds=("loop_ratio",))
def _loop(f: FailureFeatures, t: FailureThresholds) -> bool:
    return f.path_m >= t.loop_ratio * f.extent_m


@register_failure_cause(
    "slow", "it was still getting closer to its goal: at least progress_m closer at the end of "
    "the window than at its start", thresholds=("progress_m",))
def _slow(f: FailureFeatures, t: FailureThresholds) -> bool:
    return f.progress_m >= t.progress_m


@register_failure_cause(
    "detour", "it moved without circling and without coming progress_m closer to its goal "
    "(following a boundary or escaping away from it)", thresholds=("progress_m",),
    catch_all=True)
def _detour(f: FailureFeatures, t: FailureThresholds) -> bool:
    return f.progress_m < t.progress_m


def _others(others: ArrayLike | None, n: int) -> np.ndarray:
    if others is None:
        return np.zeros((n, 0, 2))
    arr = np.asarray(others, dtype=float)
    if arr.ndim != 3 or arr.shape[0] != n or arr.shape[2] != 2 or np.isinf(arr).any():
        raise FftnavError(f"others must be a ({n}, M, 2) array of the other robots' positions at "
                          f"the trajectory's samples (NaN where absent, no inf), "
                          f"got others.shape={arr.shape}")
    return arr


def _checked_inputs(
    trajectory: ArrayLike, goal: ArrayLike, collided: bool, thresholds: FailureThresholds | None,
) -> tuple[np.ndarray, np.ndarray, FailureThresholds]:
    """(positions x, y; goal; thresholds) of :func:`failure_features`, checked."""
    pos = _positions(trajectory)
    if pos.shape[1] == 3:
        pos = pos[:, :2]  # x, y, yaw poses
    goal_arr = np.asarray(goal, dtype=float)
    if goal_arr.shape != (2,) or not np.isfinite(goal_arr).all():
        raise FftnavError(f"goal must be 2 finite coordinates, got goal={goal!r}")
    if not isinstance(collided, (bool, np.bool_)):
        raise FftnavError(f"collided must be a bool, got collided={collided!r}")
    if thresholds is None:
        thresholds = FailureThresholds()
    elif not isinstance(thresholds, FailureThresholds):
        raise FftnavError(f"thresholds must be a FailureThresholds, got thresholds={thresholds!r}")
    return pos, goal_arr, thresholds


def failure_features(
    trajectory: ArrayLike,
    goal: ArrayLike,
    *,
    collided: bool = False,
    others: ArrayLike | None = None,
    dt_s: float = 0.1,
    time_limit_s: float = 120.0,
    success_radius_m: float = 0.3,
    thresholds: FailureThresholds | None = None,
) -> FailureFeatures:
    """What a robot did in the last ``thresholds.window_s`` seconds of its trajectory: the
    measurements the failure causes test.

    Parameters
    ----------
    trajectory : array_like, shape (T, 2) or (T, 3)
        Positions ``x, y`` (or poses ``x, y, yaw``; the yaw is ignored) at the control rate,
        from the robot's departure to its last tick.
    goal : array_like, shape (2,)
        Its goal (m).
    collided : bool
        It touched an obstacle.
    others : array_like, shape (T, M, 2), optional
        The other robots' positions at the same ticks, NaN where a robot is not in the world
        (parked after arriving or failing); default none.
    dt_s, time_limit_s, success_radius_m : float
        Control period, time limit and arrival radius (:func:`fftnav.metrics.paths.arrived`).
    thresholds : FailureThresholds, optional
        The window, the jam distance and the thresholds the causes test (default
        ``FailureThresholds()``, the paper's robot).

    Returns
    -------
    FailureFeatures

    Examples
    --------
    >>> f = failure_features(np.c_[np.zeros(401), np.linspace(0.0, 4.0, 401)], [0.0, 20.0])
    >>> round(f.window_s, 9), round(f.path_m, 9), round(f.progress_m, 9), f.arrived
    (20.0, 2.0, 2.0, False)
    """
    pos, goal_arr, limits = _checked_inputs(trajectory, goal, collided, thresholds)
    check_number("dt_s", dt_s, low=0, low_open=True)
    near_to = _others(others, len(pos))
    ok = arrived(pos, goal_arr, success_radius_m=success_radius_m, time_limit_s=time_limit_s,
                 dt_s=dt_s, collided=bool(collided))
    start = max(0, len(pos) - 1 - max(1, round(limits.window_s / dt_s)))
    win = pos[start:]
    extent = float(np.hypot(*(win[:, None, :] - win[None, :, :]).transpose(2, 0, 1)).max())
    to_goal = np.hypot(*(win[[0, -1]] - goal_arr).T)
    with np.errstate(invalid="ignore"):
        gaps = np.hypot(*(near_to[start:] - win[:, None, :]).transpose(2, 0, 1))
    near = (gaps <= limits.jam_distance_m).any(axis=1)  # NaN (absent) is never near
    return FailureFeatures(arrived=ok, collided=bool(collided),
                           window_s=(len(win) - 1) * float(dt_s), extent_m=extent,
                           path_m=path_length_m(win),
                           displacement_m=float(np.hypot(*(win[-1] - win[0]))),
                           progress_m=float(to_goal[0] - to_goal[1]),
                           near_share=float(near.mean()), thresholds=limits)


def classify_failure(features: FailureFeatures) -> str:
    """Why a robot did not arrive: ``""`` if it arrived, else the first cause of
    :data:`FAILURE_CAUSES` whose test holds on its :func:`failure_features`.

    Parameters
    ----------
    features : FailureFeatures
        The robot's last seconds, measured with the thresholds the causes test
        (``features.thresholds``).

    Returns
    -------
    str
        ``""``, or the name of a cause (``collision``, ``jam``, ``stuck``, ``loop``, ``slow``,
        ``detour``, then any registered later).

    Examples
    --------
    >>> spin = np.zeros((1201, 2))  # 120 s on the spot, 5 m short of its goal
    >>> classify_failure(failure_features(spin, [0.0, 5.0]))
    'stuck'
    >>> classify_failure(failure_features(spin, [0.0, 5.0], collided=True))
    'collision'
    """
    if not isinstance(features, FailureFeatures):
        raise FftnavError(f"features must be a FailureFeatures (failure_features(...)), "
                          f"got features={features!r:.80}")
    if features.arrived:
        return ""
    for cause in FAILURE_CAUSES.values():
        if cause.test(features, features.thresholds):
            return cause.name
    raise AssertionError(f"no failure cause matched {features} (the catch-all is "
                         f"{FAILURE_CAUSES.catch_all()!r})")
