"""The record of an episode: one :class:`EpisodeRow` per robot, whose fields are the CSV columns.

Adding a column is adding a field here (and filling it in :mod:`fftnav.episode.loop`); the CSV
writers, the runner's ``episodes.csv`` and the resume check follow from the fields.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from fftnav.errors import FftnavError

if TYPE_CHECKING:
    from fftnav.episode.recording import Tape

__all__ = ["EPISODE_COLUMNS", "EpisodeResult", "EpisodeRow", "episode_csv", "failure_tick"]


@dataclass(frozen=True)
class EpisodeRow:
    """The outcome of one robot in one episode.

    Attributes
    ----------
    robot : int
        Index of the robot in the world's starts.
    policy : str
        The decision policy's name.
    arrived, collided : bool
        Within ``success_radius_m`` of its goal by the time limit without touching an obstacle;
        touched an obstacle (fatal).
    path_length_m : float
        Length of the driven path (m).
    optimal_length_m, geodesic_length_m : float
        8-connected grid A* length (the paper's reference) and 32-connected geodesic length (m).
    spl : float
        ``S l / max(p, l)`` against ``optimal_length_m``.
    time_s : float
        Time of arrival (s); NaN if the robot did not arrive.
    bytes_sent, messages_sent : int
        Bytes and messages the robot broadcast.
    decisions_left, decisions_right : int
        Side decisions taken.
    decisions_with_neighbours, decisions_flipped_by_neighbours : int
        ``fusion``: decisions that fused at least one neighbour, and those whose side differs
        from the robot's own (P_s) side.
    robot_contacts : int
        Contact onsets with other robots (not fatal).
    follow_time_s, stall_time_s : float
        Time (s) the planner spent following a boundary, and in its stall fallback (no safe
        heading on the chosen side).
    loop_flips : int
        Loop detections of the planner (a follow that backs off or makes no progress starts
        an escape; at most one per follow, since an escape runs until the leave rule).
    escape_time_s : float
        Time (s) the planner steered along the way to the goal through the robot's own map.
    sides_remembered : int
        Decisions taken from the planner's tried-sides memory (the policy not asked).
    sides_reconsidered : int
        Side changes while following when news arrived (``collab``).
    neighbours_fused, neighbours_out_of_range, neighbours_too_close, neighbours_behind, \
neighbours_no_message, neighbours_lost : int
        ``fusion`` (and policies reading messages): over the robot's decisions, how many times
        another robot in the world was fused, or why not (:data:`fftnav.metrics.
        NEIGHBOUR_REASONS`); they add up to the sum over its decisions of the number of other
        robots in the world.
    failure : str
        Why the robot did not arrive: a cause of :data:`fftnav.metrics.FAILURE_CAUSES`
        (``collision``, ``jam``, ``stuck``, ``loop``, ``slow``, ``detour``;
        :func:`fftnav.metrics.classify_failure`); empty for a robot that arrived.
    """

    robot: int
    policy: str
    arrived: bool
    collided: bool
    path_length_m: float
    optimal_length_m: float
    geodesic_length_m: float
    spl: float
    time_s: float
    bytes_sent: int
    messages_sent: int
    decisions_left: int
    decisions_right: int
    decisions_with_neighbours: int
    decisions_flipped_by_neighbours: int
    robot_contacts: int
    follow_time_s: float = 0.0
    stall_time_s: float = 0.0
    loop_flips: int = 0
    escape_time_s: float = 0.0
    sides_remembered: int = 0
    sides_reconsidered: int = 0
    neighbours_fused: int = 0
    neighbours_out_of_range: int = 0
    neighbours_too_close: int = 0
    neighbours_behind: int = 0
    neighbours_no_message: int = 0
    neighbours_lost: int = 0
    failure: str = ""

    def as_dict(self) -> dict[str, Any]:
        """Column name -> value."""
        return dataclasses.asdict(self)


#: Columns of an episode's per-robot table, in order: the fields of :class:`EpisodeRow`.
EPISODE_COLUMNS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(EpisodeRow))


def failure_tick(trajectory: np.ndarray, departure: int, *, timed_out: bool) -> int:
    """The tick a robot that left without arriving failed at: the last control period it drove
    for one that touched something or stopped (its trajectory's sample k is tick
    ``departure + k``, the last one the pose after that period), the tick its time was up for
    one out of time (its last sample), as :func:`fftnav.report.replay.failure_ticks` reads them
    from a recording.

    >>> failure_tick(np.zeros((5, 3)), 2, timed_out=False), failure_tick(np.zeros((5, 3)), 2,
    ...                                                                   timed_out=True)
    (5, 6)
    """
    return int(departure) + len(trajectory) - (1 if timed_out else 2)


@dataclass
class EpisodeResult:
    """Outcome of one episode: one row per robot and the trajectories."""

    rows: list[EpisodeRow]
    #: One (T_i, 3) array of x, y, yaw per robot, sampled at the control rate.
    trajectories: list[np.ndarray]
    #: The episode's recording while it is made (``run_episode(record=True)``), else None.
    tape: Tape | None = None
    #: Wall-clock seconds of the method's compute over the episode (the FFT pipeline when the
    #: controller uses it, and the controller's ``step``) and the robot-ticks it served.
    compute_s: float = 0.0
    robot_ticks: int = 0
    #: The :class:`~fftnav.states.Status` each robot left the world with (arrived, collided,
    #: timed out, lost), one code per robot.
    left: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=np.uint8))

    @property
    def compute_ms(self) -> float:
        """The method's compute per robot per control tick (ms; NaN without a tick): a wall
        clock, so it depends on the machine and its load, unlike every row."""
        return 1000.0 * self.compute_s / self.robot_ticks if self.robot_ticks else float("nan")

    def recording(self) -> bytes:
        """The recording file's bytes (:mod:`fftnav.episode.recording`); needs
        ``run_episode(record=True)``."""
        if self.tape is None:
            raise FftnavError("record must be True in run_episode to get a recording, "
                              "got record=False")
        return self.tape.to_bytes([row.as_dict() for row in self.rows])

    @property
    def failed(self) -> bool:
        """Whether a robot did not arrive."""
        return not all(row.arrived for row in self.rows)


def _cell(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (float, np.floating)):
        return "" if np.isnan(value) else f"{value:.6f}"
    return str(value)


def episode_csv(rows: Iterable[EpisodeRow | Mapping[str, Any]], *,
                columns: tuple[str, ...] = EPISODE_COLUMNS, header: bool = True) -> str:
    """Rows as CSV text: ``columns`` in order, booleans ``true``/``false``, floats ``%.6f``
    (fixed, so the same episode gives byte-identical files), NaN as an empty field."""
    lines = [",".join(columns)] if header else []
    for row in rows:
        values = row.as_dict() if isinstance(row, EpisodeRow) else row
        lines.append(",".join(_cell(values[c]) for c in columns))
    return "\n".join(lines) + "\n"
