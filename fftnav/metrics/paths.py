"""Path measures: pure functions of one robot's trajectory and of per-robot arrays.

Definitions follow Anderson et al. 2018, "On Evaluation of Embodied Navigation Agents"
(arXiv:1807.06757), as used by the paper (Sec. IV, Table I): Arrival Rate (AR), Average Path
Length (APL) and Success weighted by (normalised inverse) Path Length,

    SPL = (1/N) sum_i S_i l_i / max(p_i, l_i),

with S_i the success indicator, p_i the length of the path the robot actually took and l_i the
optimal (shortest-path) length from its start to its goal. Distances in metres, times in seconds.
``docs/metrics.md`` states every definition and the l = 0 guard. :func:`motions` splits a
robot's control ticks into driving, correcting its heading, turning and standing.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from fftnav.errors import FftnavError
from fftnav.validate import check_number

__all__ = [
    "MOTIONS",
    "arrival_rate",
    "arrived",
    "average_path_length_m",
    "motions",
    "path_length_m",
    "spl",
    "spl_terms",
    "time_to_goal_s",
]


def _positions(trajectory: ArrayLike) -> np.ndarray:
    pos = np.asarray(trajectory, dtype=float)
    if pos.ndim != 2 or pos.shape[1] not in (2, 3) or pos.shape[0] == 0:
        raise FftnavError(
            f"trajectory must be a (T, 2) or (T, 3) array of positions with T >= 1, "
            f"got trajectory.shape={pos.shape}"
        )
    if not np.isfinite(pos).all():
        raise FftnavError("trajectory must be finite, got trajectory with NaN or inf")
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
        raise FftnavError(
            f"give exactly one of dt_s and times_s, got dt_s={dt_s}, times_s={times_s}"
        )
    if dt_s is not None:
        check_number("dt_s", dt_s, low=0, low_open=True)
        return np.arange(n) * dt_s
    times = np.asarray(times_s, dtype=float)
    if times.shape != (n,) or not np.isfinite(times).all() or np.any(np.diff(times) < 0):
        raise FftnavError(
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
        raise FftnavError(
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
        raise FftnavError(
            f"success must be a non-empty 1-D array of booleans, got success={success!r}"
        )
    return s.astype(bool)


def _lengths(values: ArrayLike, name: str, n: int) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.shape != (n,) or not np.isfinite(arr).all() or np.any(arr < 0):
        raise FftnavError(
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
        raise FftnavError(f"command must have shape (G, N, 2), got shape {command.shape}")
    if moving.shape != command.shape[:2]:
        raise FftnavError(f"moving must have shape {command.shape[:2]} (command's G, N), "
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
