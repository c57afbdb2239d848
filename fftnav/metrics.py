"""Navigation metrics: pure functions of trajectories and per-robot tables (no simulator).

Definitions follow Anderson et al. 2018, "On Evaluation of Embodied Navigation Agents"
(arXiv:1807.06757), as used by the paper (Sec. IV, Table I): Arrival Rate (AR), Average Path
Length (APL) and Success weighted by (normalised inverse) Path Length,

    SPL = (1/N) sum_i S_i l_i / max(p_i, l_i),

with S_i the success indicator, p_i the length of the path the robot actually took and l_i the
optimal (shortest-path) length from its start to its goal. Distances in metres, times in seconds.
``docs/metrics.md`` states every definition and the l = 0 guard.

:data:`MEASURES` maps a measure name to a function of an episode's per-robot table (a mapping or
``pandas.DataFrame`` with the columns of :data:`fftnav.episode.record.EPISODE_COLUMNS`), in the
manner of habitat-lab's measure registry: experiment summaries have one column per registered
measure (and an interval for those with ``terms``), so a new measure is one registered function.

:func:`classify_failure` names why a robot did not arrive: the first of the causes of
:data:`FAILURE_CAUSES` (collision, jam, stuck, loop, slow, detour) whose test holds on the last
``window_s`` seconds of its trajectory; each cause has a ``failures_<cause>`` measure.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from fftnav.registry import Registry, first_line
from fftnav.validate import check_number

__all__ = [
    "FAILURE_CAUSES",
    "FailureCause",
    "FailureFeatures",
    "MEASURES",
    "MOTIONS",
    "Measure",
    "NEIGHBOUR_REASONS",
    "arrival_rate",
    "arrived",
    "average_path_length_m",
    "classify_failure",
    "evaluate",
    "failure_features",
    "failure_thresholds",
    "motions",
    "register_measure",
    "path_length_m",
    "spl",
    "spl_terms",
    "time_to_goal_s",
]


def _positions(trajectory: ArrayLike) -> np.ndarray:
    pos = np.asarray(trajectory, dtype=float)
    if pos.ndim != 2 or pos.shape[1] not in (2, 3) or pos.shape[0] == 0:
        raise ValueError(
            f"trajectory must be a (T, 2) or (T, 3) array of positions with T >= 1, "
            f"got trajectory.shape={pos.shape}"
        )
    if not np.isfinite(pos).all():
        raise ValueError("trajectory must be finite, got trajectory with NaN or inf")
    return pos


def path_length_m(trajectory: ArrayLike) -> float:
    """Length of a trajectory: the sum of its segment lengths, sum_t |x_(t+1) - x_t|.

    Parameters
    ----------
    trajectory : array_like, shape (T, 2) or (T, 3)
        Ground-truth positions ``x, y`` (or ``x, y, z``) in metres, in time order. Pass
        positions only, not poses: a yaw column would be summed as a coordinate.

    Returns
    -------
    float
        p_i of Anderson et al. 2018, in metres (0 for a single sample).
    """
    pos = _positions(trajectory)
    return float(np.linalg.norm(np.diff(pos, axis=0), axis=1).sum())


def _times(n: int, dt_s: float | None, times_s: ArrayLike | None) -> np.ndarray:
    if (dt_s is None) == (times_s is None):
        raise ValueError(
            f"give exactly one of dt_s and times_s, got dt_s={dt_s}, times_s={times_s}"
        )
    if dt_s is not None:
        check_number("dt_s", dt_s, low=0, low_open=True)
        return np.arange(n) * dt_s
    times = np.asarray(times_s, dtype=float)
    if times.shape != (n,) or not np.isfinite(times).all() or np.any(np.diff(times) < 0):
        raise ValueError(
            f"times_s must be {n} finite non-decreasing times (one per trajectory sample), "
            f"got times_s with shape={times.shape}"
        )
    return times


def time_to_goal_s(
    trajectory: ArrayLike,
    goal: ArrayLike,
    *,
    success_radius_m: float = 0.3,
    dt_s: float | None = None,
    times_s: ArrayLike | None = None,
) -> float:
    """First time the robot is within ``success_radius_m`` of its goal.

    Parameters
    ----------
    trajectory : array_like, shape (T, 2) or (T, 3)
        Positions in metres.
    goal : array_like, shape (2,) or (3,)
        Goal position in metres (same dimension as the trajectory).
    success_radius_m : float, optional
        Arrival radius r (default 0.3 m, the paper's robot radius); "within" includes the boundary.
    dt_s, times_s : optional
        Sample times: either a fixed step ``dt_s`` (sample t at ``t * dt_s``) or the (T,) times.
        Exactly one must be given.

    Returns
    -------
    float
        Seconds; NaN if the robot never comes within the radius.
    """
    pos = _positions(trajectory)
    goal_arr = np.asarray(goal, dtype=float)
    if goal_arr.shape != (pos.shape[1],) or not np.isfinite(goal_arr).all():
        raise ValueError(
            f"goal must be {pos.shape[1]} finite coordinates like the trajectory, got goal={goal}"
        )
    check_number("success_radius_m", success_radius_m, low=0, low_open=True)
    times = _times(len(pos), dt_s, times_s)
    inside = np.flatnonzero(np.linalg.norm(pos - goal_arr, axis=1) <= success_radius_m)
    return float(times[inside[0]]) if inside.size else float("nan")


def arrived(
    trajectory: ArrayLike,
    goal: ArrayLike,
    *,
    success_radius_m: float = 0.3,
    time_limit_s: float = 120.0,
    dt_s: float | None = None,
    times_s: ArrayLike | None = None,
    collided: bool = False,
) -> bool:
    """Success S_i: within ``success_radius_m`` of the goal by ``time_limit_s``, no collision.

    Parameters
    ----------
    trajectory, goal, success_radius_m, dt_s, times_s
        As in :func:`time_to_goal_s`.
    time_limit_s : float, optional
        Episode time limit (default 120 s); arriving exactly at the limit counts (up to
        floating-point rounding: ``1200 * 0.1`` exceeds 120 by 1.4e-14).
    collided : bool, optional
        Whether the robot hit an obstacle (a collision is fatal; robot-robot contacts are
        counted separately and are not).

    Returns
    -------
    bool
    """
    check_number("time_limit_s", time_limit_s, low=0, low_open=True)
    t = time_to_goal_s(
        trajectory, goal, success_radius_m=success_radius_m, dt_s=dt_s, times_s=times_s
    )
    return bool(not collided and (t <= time_limit_s or math.isclose(t, time_limit_s)))


def _success(success: ArrayLike) -> np.ndarray:
    s = np.asarray(success)
    if s.ndim != 1 or s.size == 0 or not np.isin(s, (0, 1)).all():
        raise ValueError(
            f"success must be a non-empty 1-D array of booleans, got success={success!r}"
        )
    return s.astype(bool)


def _lengths(values: ArrayLike, name: str, n: int) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.shape != (n,) or not np.isfinite(arr).all() or np.any(arr < 0):
        raise ValueError(
            f"{name} must be {n} finite lengths >= 0 (one per robot), got {name}={values!r}"
        )
    return arr


def spl_terms(
    success: ArrayLike, path_length_m: ArrayLike, optimal_length_m: ArrayLike
) -> np.ndarray:
    """Per-robot SPL terms S_i l_i / max(p_i, l_i) (Anderson et al. 2018, eq. 1).

    Guard: a robot with ``max(p_i, l_i) = 0`` (it starts on its goal and never moves) scores
    S_i, the limit of the ratio l / max(p, l) as p, l -> 0 with p <= l. A robot with l_i = 0 that
    moves (p_i > 0) scores 0 by the formula.

    Parameters
    ----------
    success : array_like of bool, shape (N,)
        S_i.
    path_length_m : array_like of float, shape (N,)
        p_i, metres travelled (>= 0).
    optimal_length_m : array_like of float, shape (N,)
        l_i, shortest-path length (>= 0), e.g. grid A* at 0.05 m as in the paper.

    Returns
    -------
    ndarray of float, shape (N,)
        Each in [0, 1]; p_i < l_i (possible when the grid reference is longer than the true
        optimum) is capped at 1.
    """
    s = _success(success)
    p = _lengths(path_length_m, "path_length_m", s.size)
    l = _lengths(optimal_length_m, "optimal_length_m", s.size)
    longest = np.maximum(p, l)
    ratio = np.divide(l, longest, out=np.ones_like(l), where=longest > 0)
    return np.where(s, ratio, 0.0)


def spl(success: ArrayLike, path_length_m: ArrayLike, optimal_length_m: ArrayLike) -> float:
    """SPL = (1/N) sum_i S_i l_i / max(p_i, l_i) over all N robots (Anderson et al. 2018).

    Parameters and the l = 0 guard as in :func:`spl_terms`. Returns a fraction in [0, 1].
    """
    return float(spl_terms(success, path_length_m, optimal_length_m).mean())


def arrival_rate(success: ArrayLike) -> float:
    """AR: the fraction of robots that arrived, (1/N) sum_i S_i, in [0, 1]."""
    return float(_success(success).mean())


def average_path_length_m(success: ArrayLike, path_length_m: ArrayLike) -> float:
    """APL: mean path length p_i over the robots that arrived, in metres; NaN if none arrived."""
    s = _success(success)
    p = _lengths(path_length_m, "path_length_m", s.size)
    return float(p[s].mean()) if s.any() else float("nan")


Table = Mapping[str, Any]


@dataclass(frozen=True)
class Measure:
    """A named measure of a per-robot table, and how to put an interval on it.

    Attributes
    ----------
    name : str
        The measure's name: its key in :data:`MEASURES` and its column in experiment summaries.
    fn : callable
        ``fn(table) -> float``, the point estimate over the table's robots.
    terms : callable, optional
        ``terms(table) -> (numerator, denominator)``, per-robot arrays whose per-map sums give
        the measure as ``sum(numerator) / sum(denominator)``; summaries then report a 95%
        bootstrap interval over maps in the columns ``<interval>_ci_low`` and ``_ci_high``.
    interval : str
        Prefix of the interval columns (default: the name).
    description : str
        One line (the function's docstring).
    """

    name: str
    fn: Callable[[Table], float]
    terms: Callable[[Table], tuple[np.ndarray, np.ndarray]] | None = None
    interval: str = ""
    description: str = ""

    def __call__(self, table: Table) -> float:
        return self.fn(table)

    @property
    def columns(self) -> tuple[str, ...]:
        """The summary columns of this measure: its value, then its interval if it has one."""
        if self.terms is None:
            return (self.name,)
        prefix = self.interval or self.name
        return (self.name, f"{prefix}_ci_low", f"{prefix}_ci_high")


#: Measures by name, in the order of the summary columns (habitat-lab style registry).
MEASURES: Registry[Measure] = Registry("measure", parameter="names")


def register_measure(
    name: str, *, terms: Callable[[Table], tuple[np.ndarray, np.ndarray]] | None = None,
    interval: str = "",
) -> Callable[[Callable[[Table], float]], Callable[[Table], float]]:
    """Decorator registering ``fn(table) -> float`` as measure ``name`` (see :class:`Measure`)."""

    def register(fn: Callable[[Table], float]) -> Callable[[Table], float]:
        MEASURES.add(name, Measure(name, fn, terms, interval, first_line(fn.__doc__)))
        return fn

    return register


def _column(table: Table, name: str) -> np.ndarray:
    if name not in table:
        raise ValueError(f"table must have a column {name!r}, got columns {list(table)}")
    return np.asarray(table[name])


def _ones(table: Table) -> np.ndarray:
    return np.ones(len(_column(table, "arrived")))


def _share(part: float, whole: float) -> float:
    return float(part / whole) if whole else float("nan")


def _mean(table: Table, name: str) -> float:
    return float(np.mean(_column(table, name).astype(float)))


@register_measure("ar", terms=lambda t: (_column(t, "arrived").astype(float), _ones(t)))
def _ar(table: Table) -> float:
    """AR, the fraction of robots with ``arrived``."""
    return arrival_rate(_column(table, "arrived"))


@register_measure("apl_m", interval="apl", terms=lambda t: (
    np.where(_column(t, "arrived").astype(bool), _column(t, "path_length_m"), 0.0),
    _column(t, "arrived").astype(float)))
def _apl(table: Table) -> float:
    """APL, the mean ``path_length_m`` of arrived robots (m); NaN if none arrived."""
    return average_path_length_m(_column(table, "arrived"), _column(table, "path_length_m"))


@register_measure("spl", terms=lambda t: (_column(t, "spl").astype(float), _ones(t)))
def _spl(table: Table) -> float:
    """SPL against ``optimal_length_m`` (8-connected A*, the paper's reference)."""
    return spl(
        _column(table, "arrived"),
        _column(table, "path_length_m"),
        _column(table, "optimal_length_m"),
    )


@register_measure("spl_geodesic")
def _spl_geodesic(table: Table) -> float:
    """SPL against ``geodesic_length_m`` (near-Euclidean, 32-connected)."""
    return spl(
        _column(table, "arrived"),
        _column(table, "path_length_m"),
        _column(table, "geodesic_length_m"),
    )


@register_measure("collision_rate")
def _collision_rate(table: Table) -> float:
    """The fraction of robots that hit an obstacle (``collided``)."""
    return float(np.mean(_column(table, "collided").astype(bool)))


@register_measure("bytes_per_robot")
def _bytes_per_robot(table: Table) -> float:
    """Mean ``bytes_sent`` per robot."""
    return _mean(table, "bytes_sent")


@register_measure("messages_per_robot")
def _messages_per_robot(table: Table) -> float:
    """Mean ``messages_sent`` per robot."""
    return _mean(table, "messages_sent")


def _decisions(table: Table) -> np.ndarray:
    return _column(table, "decisions_left") + _column(table, "decisions_right")


@register_measure("decisions_per_robot")
def _decisions_per_robot(table: Table) -> float:
    """Mean side decisions (left and right) per robot."""
    decisions = _decisions(table)
    return float(decisions.sum() / len(decisions))


@register_measure("share_with_neighbours")
def _share_with_neighbours(table: Table) -> float:
    """The fraction of side decisions that fused at least one neighbour (NaN: no decision)."""
    return _share(_column(table, "decisions_with_neighbours").sum(), _decisions(table).sum())


@register_measure("share_flipped_by_neighbours")
def _share_flipped(table: Table) -> float:
    """Among the decisions that fused a neighbour, the fraction whose side differs from the
    robot's own (P_s) side (NaN: none fused a neighbour)."""
    return _share(_column(table, "decisions_flipped_by_neighbours").sum(),
                  _column(table, "decisions_with_neighbours").sum())


@register_measure("time_to_goal_s")
def _time_to_goal(table: Table) -> float:
    """Mean ``time_s`` of arrived robots (s); NaN if none arrived."""
    s = _success(_column(table, "arrived"))
    return float(np.mean(_column(table, "time_s")[s].astype(float))) if s.any() else float("nan")


@register_measure("robot_contacts_per_robot")
def _robot_contacts(table: Table) -> float:
    """Mean ``robot_contacts`` (robot-robot contact onsets, not fatal) per robot."""
    return _mean(table, "robot_contacts")


#: Why a neighbour was or was not fused in a decision that may fuse neighbours (the episode
#: columns ``neighbours_<reason>``): fused; its message arrived but it was out of the
#: communication range, too close (protective circles overlapping) or behind (or exactly
#: ahead); no message arrived because the last fresh one was lost, or sent while the receiver
#: was out of range (counted as ``out_of_range``), or none was sent in the last second.
NEIGHBOUR_REASONS: tuple[str, ...] = ("fused", "out_of_range", "too_close", "behind",
                                      "no_message", "lost")


def _neighbour_share(reason: str) -> Callable[[Table], float]:
    def share(table: Table) -> float:
        if any(f"neighbours_{r}" not in table for r in NEIGHBOUR_REASONS):
            return float("nan")  # a table written before the neighbour accounting
        total = sum(_column(table, f"neighbours_{r}").sum() for r in NEIGHBOUR_REASONS)
        return _share(_column(table, f"neighbours_{reason}").sum(), total)

    share.__doc__ = (f"Share of ``neighbours_{reason}`` among the neighbours counted in "
                     f"decisions (every other robot in the world, each decision that may fuse "
                     f"neighbours); NaN: no such decision, or a table without these columns.")
    return share


for _reason in NEIGHBOUR_REASONS:
    register_measure(f"share_neighbours_{_reason}")(_neighbour_share(_reason))


@dataclass(frozen=True)
class FailureFeatures:
    """What :func:`classify_failure` measures on the last ``window_s`` seconds of a trajectory.

    Attributes
    ----------
    arrived, collided : bool
        Success S_i (:func:`arrived`) and contact with an obstacle.
    window_s : float
        The seconds looked at: ``window_s``, or the whole trajectory if it is shorter.
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
        ``jam_distance_m`` of the robot's centre (0 without other robots).
    """

    arrived: bool
    collided: bool
    window_s: float
    extent_m: float
    path_m: float
    displacement_m: float
    progress_m: float
    near_share: float


#: Thresholds of the causes, by the name of their :func:`classify_failure` parameter.
Thresholds = Mapping[str, float]


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
        The :func:`classify_failure` parameters its test uses.
    test : callable
        ``test(features, thresholds) -> bool`` on :class:`FailureFeatures`.
    """

    name: str
    definition: str
    thresholds: tuple[str, ...]
    test: Callable[[FailureFeatures, Thresholds], bool]


#: Causes of failure in the order they are tested: a robot that did not arrive gets the first
#: whose test holds. The last two tests are complements, so every such robot gets one.
FAILURE_CAUSES: Registry[FailureCause] = Registry("failure cause", parameter="cause")


def _cause(name: str, definition: str, thresholds: tuple[str, ...],
           test: Callable[[FailureFeatures, Thresholds], bool]) -> None:
    FAILURE_CAUSES.add(name, FailureCause(name, definition, thresholds, test))


_cause("collision", "it touched an obstacle (the episode's collided flag)", (),
       lambda f, t: f.collided)
_cause("jam", "for at least jam_share of the window another robot's centre was within "
       "jam_distance_m (in contact or within a robot width) and the robot ended the window "
       "less than progress_m from where it began it (blocked)",
       ("jam_share", "jam_distance_m", "progress_m"),
       lambda f, t: f.near_share >= t["jam_share"] and f.displacement_m < t["progress_m"])
_cause("stuck", "it barely moved: every position of the window lies within still_m of every "
       "other (standing or turning on the spot)", ("still_m",),
       lambda f, t: f.extent_m <= t["still_m"])
_cause("loop", "it moved but circled: the window's path is at least loop_ratio times the "
       "diameter of the region it covers (revisiting the same places)", ("loop_ratio",),
       lambda f, t: f.path_m >= t["loop_ratio"] * f.extent_m)
_cause("slow", "it was still getting closer to its goal: at least progress_m closer at the "
       "end of the window than at its start", ("progress_m",),
       lambda f, t: f.progress_m >= t["progress_m"])
_cause("detour", "it moved without circling and without coming progress_m closer to its goal "
       "(following a boundary or escaping away from it)", ("progress_m",),
       lambda f, t: f.progress_m < t["progress_m"])


def failure_thresholds(*, r0_m: float = 0.15, v_max_mps: float = 0.5,
                       window_s: float = 20.0) -> dict[str, float]:
    """The length thresholds of :func:`classify_failure` for a robot of radius ``r0_m`` and
    top speed ``v_max_mps``: ``still_m`` = 2 r0 (its own width), ``jam_distance_m`` = 4 r0
    (centres one robot width apart), ``progress_m`` = a tenth of what it drives in
    ``window_s`` at top speed. The defaults give :func:`classify_failure`'s defaults.

    >>> failure_thresholds()
    {'window_s': 20.0, 'still_m': 0.3, 'jam_distance_m': 0.6, 'progress_m': 1.0}
    """
    r0 = check_number("r0_m", r0_m, low=0, low_open=True)
    v = check_number("v_max_mps", v_max_mps, low=0, low_open=True)
    w = check_number("window_s", window_s, low=0, low_open=True)
    return {"window_s": w, "still_m": 2 * r0, "jam_distance_m": 4 * r0,
            "progress_m": round(0.1 * v * w, 12)}


def _others(others: ArrayLike | None, n: int) -> np.ndarray:
    if others is None:
        return np.zeros((n, 0, 2))
    arr = np.asarray(others, dtype=float)
    if arr.ndim != 3 or arr.shape[0] != n or arr.shape[2] != 2 or np.isinf(arr).any():
        raise ValueError(f"others must be a ({n}, M, 2) array of the other robots' positions at "
                         f"the trajectory's samples (NaN where absent, no inf), "
                         f"got others.shape={arr.shape}")
    return arr


def failure_features(
    trajectory: ArrayLike,
    goal: ArrayLike,
    *,
    collided: bool = False,
    others: ArrayLike | None = None,
    dt_s: float = 0.1,
    time_limit_s: float = 120.0,
    success_radius_m: float = 0.3,
    window_s: float = 20.0,
    jam_distance_m: float = 0.6,
) -> FailureFeatures:
    """The measurements behind :func:`classify_failure` (same parameters)."""
    pos = _positions(trajectory)
    if pos.shape[1] == 3:
        pos = pos[:, :2]  # x, y, yaw poses
    goal_arr = np.asarray(goal, dtype=float)
    if goal_arr.shape != (2,) or not np.isfinite(goal_arr).all():
        raise ValueError(f"goal must be 2 finite coordinates, got goal={goal!r}")
    if not isinstance(collided, (bool, np.bool_)):
        raise ValueError(f"collided must be a bool, got collided={collided!r}")
    check_number("dt_s", dt_s, low=0, low_open=True)
    check_number("window_s", window_s, low=0, low_open=True)
    check_number("jam_distance_m", jam_distance_m, low=0, low_open=True)
    near_to = _others(others, len(pos))
    ok = arrived(pos, goal_arr, success_radius_m=success_radius_m, time_limit_s=time_limit_s,
                 dt_s=dt_s, collided=bool(collided))
    start = max(0, len(pos) - 1 - max(1, round(window_s / dt_s)))
    win = pos[start:]
    extent = float(np.hypot(*(win[:, None, :] - win[None, :, :]).transpose(2, 0, 1)).max())
    to_goal = np.hypot(*(win[[0, -1]] - goal_arr).T)
    with np.errstate(invalid="ignore"):
        gaps = np.hypot(*(near_to[start:] - win[:, None, :]).transpose(2, 0, 1))
    near = (gaps <= jam_distance_m).any(axis=1)  # NaN (absent) is never near
    return FailureFeatures(arrived=ok, collided=bool(collided),
                           window_s=(len(win) - 1) * float(dt_s), extent_m=extent,
                           path_m=path_length_m(win),
                           displacement_m=float(np.hypot(*(win[-1] - win[0]))),
                           progress_m=float(to_goal[0] - to_goal[1]),
                           near_share=float(near.mean()))


#: What a moving robot does at a control tick (:func:`motions`), in the order of its codes.
MOTIONS: tuple[str, ...] = ("drive", "correct", "turn", "stand")


def motions(command: ArrayLike, moving: ArrayLike, *, control_hz: float,
            turn_s: float = 1.0) -> np.ndarray:
    """What each robot does at each control tick while it moves: drive, correct its heading,
    turn, or stand.

    A tick whose command has a forward speed ``v != 0`` drives. One with ``v = 0`` and a turn
    rate ``w != 0`` rotates in place: it belongs to a *turn* when its run of consecutive
    ticks rotating the same way (of that robot, while it moves) lasts at least ``turn_s``,
    i.e. at least ``ceil(turn_s * control_hz)`` ticks (turning round, as to go back), and to
    a heading *correction* otherwise; a robot that swings left and right on the spot makes
    one-tick corrections. ``v = w = 0`` stands (waiting, or blocked).

    Parameters
    ----------
    command : array_like, shape (G, N, 2)
        ``v`` (m/s) and ``w`` (rad/s) of G control ticks and N robots.
    moving : array_like of bool, shape (G, N)
        Whether the robot was on its way at the tick (departed, not arrived, not stopped).
    control_hz : float
        Control ticks per second.
    turn_s : float
        Shortest turn (s); 0 makes every rotation a turn.

    Returns
    -------
    numpy.ndarray of int8, shape (G, N)
        The index into :data:`MOTIONS` of each tick, -1 where the robot is not moving.

    Examples
    --------
    One robot, 10 Hz: it drives, corrects for one tick, drives, turns left for 10 ticks,
    swings right and left, stands, then arrives.

    >>> import numpy as np
    >>> v = [0.5, 0.0, 0.5] + [0.0] * 10 + [0.0, 0.0, 0.0, 0.0]
    >>> w = [0.0, 1.5, 0.0] + [1.5] * 10 + [-1.5, 1.5, 0.0, 0.0]
    >>> moving = [True] * 16 + [False]
    >>> kinds = motions(np.c_[v, w][:, None, :], np.array(moving)[:, None], control_hz=10.0)
    >>> [MOTIONS[k] if k >= 0 else "-" for k in kinds[:, 0]]  # doctest: +NORMALIZE_WHITESPACE
    ['drive', 'correct', 'drive', 'turn', 'turn', 'turn', 'turn', 'turn', 'turn', 'turn',
     'turn', 'turn', 'turn', 'correct', 'correct', 'stand', '-']
    """
    command = np.asarray(command, dtype=float)
    moving = np.asarray(moving, dtype=bool)
    if command.ndim != 3 or command.shape[2] != 2:
        raise ValueError(f"command must have shape (G, N, 2), got shape {command.shape}")
    if moving.shape != command.shape[:2]:
        raise ValueError(f"moving must have shape {command.shape[:2]} (command's G, N), "
                         f"got shape {moving.shape}")
    check_number("control_hz", control_hz, low=0, low_open=True)
    check_number("turn_s", turn_s, low=0)
    drive, correct, turn, stand = (MOTIONS.index(k) for k in ("drive", "correct", "turn", "stand"))
    v, w = command[..., 0], command[..., 1]
    rotating = moving & (v == 0) & (w != 0)
    kinds = np.where(v != 0, drive, np.where(w != 0, correct, stand)).astype(np.int8)
    # runs of ticks rotating the same way: where each begins and ends (per robot, in order)
    way = np.pad(np.where(rotating, np.sign(w), 0.0), ((1, 1), (0, 0)))
    change = way[1:] != way[:-1]
    first, robot = np.nonzero(change[:-1] & (way[1:-1] != 0))
    last, robot_end = np.nonzero(change[1:] & (way[1:-1] != 0))
    order, order_end = np.lexsort((first, robot)), np.lexsort((last, robot_end))
    first, robot, last = first[order], robot[order], last[order_end] + 1
    long_run = (last - first) >= math.ceil(turn_s * control_hz - 1e-9)
    for a, b, r in zip(first[long_run], last[long_run], robot[long_run], strict=True):
        kinds[a:b, r] = turn
    kinds[~moving] = -1
    return kinds


def classify_failure(
    trajectory: ArrayLike,
    goal: ArrayLike,
    *,
    collided: bool = False,
    others: ArrayLike | None = None,
    dt_s: float = 0.1,
    time_limit_s: float = 120.0,
    success_radius_m: float = 0.3,
    window_s: float = 20.0,
    still_m: float = 0.3,
    loop_ratio: float = 2.5,
    progress_m: float = 1.0,
    jam_distance_m: float = 0.6,
    jam_share: float = 0.5,
) -> str:
    """Why a robot did not arrive: ``""`` if it arrived, else the first cause of
    :data:`FAILURE_CAUSES` whose test holds on the last ``window_s`` seconds.

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
        Control period, time limit and arrival radius (:func:`arrived`).
    window_s : float
        The seconds at the end of the trajectory that are looked at (the whole trajectory if
        shorter): 20 s, 10 m at the paper's 0.5 m/s, a whole turn round a 1.5 m obstacle.
    still_m : float
        ``stuck``: largest distance between two positions of the window (default 2 r0).
    loop_ratio : float
        ``loop``: path length over that diameter (> 1; 2.5: a circle gives pi, a single
        back-and-forth 2, half a circle pi/2).
    progress_m : float
        ``slow``: how much closer to the goal at the window's end (default a tenth of 10 m);
        ``jam``: the most the robot may end the window from where it began it.
    jam_distance_m, jam_share : float
        ``jam``: centre distance to another robot (default 4 r0: the bodies at most a robot
        width apart) and the fraction of the window's samples it holds for (``(0, 1]``).

    Returns
    -------
    str
        ``""``, or the name of a cause (``collision``, ``jam``, ``stuck``, ``loop``, ``slow``,
        ``detour``).

    Examples
    --------
    >>> spin = np.zeros((1201, 2))  # 120 s on the spot, 5 m short of its goal
    >>> classify_failure(spin, [0.0, 5.0])
    'stuck'
    >>> classify_failure(spin, [0.0, 5.0], collided=True)
    'collision'
    """
    thresholds = {
        "still_m": check_number("still_m", still_m, low=0, low_open=True),
        "loop_ratio": check_number("loop_ratio", loop_ratio, low=1, low_open=True),
        "progress_m": check_number("progress_m", progress_m, low=0, low_open=True),
        "jam_share": check_number("jam_share", jam_share, low=0, high=1, low_open=True),
    }
    f = failure_features(trajectory, goal, collided=collided, others=others, dt_s=dt_s,
                         time_limit_s=time_limit_s, success_radius_m=success_radius_m,
                         window_s=window_s, jam_distance_m=jam_distance_m)
    if f.arrived:
        return ""
    for cause in FAILURE_CAUSES.values():
        if cause.test(f, thresholds):
            return cause.name
    raise AssertionError(f"no failure cause matched {f}")  # the last two tests are complements


def _failure_count(cause: str) -> Callable[[Table], float]:
    def count(table: Table) -> float:
        if "failure" not in table:
            return float("nan")  # a table written before the failure column
        return float(np.sum(np.asarray(table["failure"], dtype=object) == cause))

    count.__doc__ = (f"Number of robots whose ``failure`` is ``{cause}``: "
                     f"{FAILURE_CAUSES[cause].definition}; NaN for a table without the column.")
    return count


for _name in FAILURE_CAUSES:
    register_measure(f"failures_{_name}")(_failure_count(_name))


def evaluate(table: Table, names: Iterable[str] | None = None) -> dict[str, float]:
    """Evaluate measures by name on a per-robot table.

    Parameters
    ----------
    table : mapping or pandas.DataFrame
        Per-robot columns (see each measure's docstring for the columns it needs).
    names : iterable of str, optional
        Measure names from :data:`MEASURES`; all of them by default.

    Returns
    -------
    dict
        ``{name: value}`` in the order requested.

    Examples
    --------
    >>> evaluate({"arrived": [True, False], "path_length_m": [20.0, 3.0],
    ...           "optimal_length_m": [18.0, 18.0]}, ["ar", "apl_m", "spl"])
    {'ar': 0.5, 'apl_m': 20.0, 'spl': 0.45}
    """
    names = list(MEASURES) if names is None else list(names)
    return {n: MEASURES.lookup(n)(table) for n in names}
