"""The measures registry: named functions of an episode's per-robot table.

:data:`MEASURES` maps a measure name to a function of an episode's per-robot table (a mapping or
``pandas.DataFrame`` with the columns of :data:`fftnav.episode.record.EPISODE_COLUMNS`), in the
manner of habitat-lab's measure registry: experiment summaries have one column per registered
measure, in registration order (and an interval for those with ``terms``), so a new measure is
one function decorated with :func:`register_measure`. The paper's measures (AR, APL, SPL) are
those of :mod:`fftnav.metrics.paths` over the table's robots; :data:`NEIGHBOUR_REASONS` names
the neighbour accounting's columns. The counts of failure causes are registered by
:mod:`fftnav.metrics.failures`, one per cause.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.metrics.paths import _success, arrival_rate, average_path_length_m, spl, spl_terms
from fftnav.registry import Registry, first_line

__all__ = ["MEASURES", "Measure", "NEIGHBOUR_REASONS", "Table", "believed", "believed_spl_terms",
           "evaluate", "register_measure"]

#: An episode's per-robot table: a mapping (or ``pandas.DataFrame``) from column to values.
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
    requires : str
        A condition of the experiment without which the measure means nothing (``"odometry"``:
        the robots know only their odometry, :attr:`fftnav.config.SwarmConfig.conditions`);
        summaries of other experiments leave its columns out. Empty: always.
    """

    name: str
    fn: Callable[[Table], float]
    terms: Callable[[Table], tuple[np.ndarray, np.ndarray]] | None = None
    interval: str = ""
    description: str = ""
    requires: str = ""

    def applies(self, conditions: Iterable[str]) -> bool:
        """Whether an experiment with ``conditions`` has this measure's columns."""
        return not self.requires or self.requires in set(conditions)

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
    interval: str = "", requires: str = "",
) -> Callable[[Callable[[Table], float]], Callable[[Table], float]]:
    """Decorator registering ``fn(table) -> float`` as measure ``name`` (see :class:`Measure`)."""

    def register(fn: Callable[[Table], float]) -> Callable[[Table], float]:
        MEASURES.add(name, Measure(name, fn, terms, interval, first_line(fn.__doc__), requires))
        return fn

    return register


def _column(table: Table, name: str) -> np.ndarray:
    if name not in table:
        raise FftnavError(f"table must have a column {name!r}, got columns {list(table)}")
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


def believed(table: Table) -> np.ndarray:
    """Per robot: it arrived, or it stopped where its estimate said its goal was (``failure``
    ``lost``)."""
    failure = np.asarray(table["failure"], dtype=object) if "failure" in table else None
    lost = np.zeros(len(_ones(table)), bool) if failure is None else failure == "lost"
    return _column(table, "arrived").astype(bool) | lost


def believed_spl_terms(table: Table) -> np.ndarray:
    """Per robot, its SPL term counting a robot that stopped at its believed goal as arrived."""
    return spl_terms(believed(table), _column(table, "path_length_m").astype(float),
                     _column(table, "optimal_length_m").astype(float))


@register_measure("ar_believed", terms=lambda t: (believed(t).astype(float), _ones(t)),
                  requires="odometry")
def _ar_believed(table: Table) -> float:
    """The fraction of robots that reached their goal as they believed it (arrived, or stopped
    where their own estimate put the goal: ``lost``): how well they navigated, whatever their
    drift (odometry only)."""
    return float(np.mean(believed(table))) if len(_ones(table)) else float("nan")


@register_measure("spl_believed", terms=lambda t: (believed_spl_terms(t), _ones(t)),
                  requires="odometry")
def _spl_believed(table: Table) -> float:
    """SPL with the robots that stopped at their believed goal counted as successes
    (``ar_believed``; odometry only)."""
    terms = believed_spl_terms(table)
    return float(np.mean(terms)) if len(terms) else float("nan")


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
