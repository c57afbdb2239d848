"""One frame of a swarm, drawn on a matplotlib axes: the drawing that ``fftnav replay`` (PNG,
GIF, MP4), ``fftnav episode --plot`` and :meth:`fftnav.envs.SwarmNavEnv.render` share, so that
the three views agree.

A frame (:class:`SwarmFrame`) is the top-down map with its obstacles and goals, every robot as a
disc of radius ``r0_m`` filled with the colour of its drawn kind (:data:`KIND_COLOURS`), its
heading as a short dark tick out of the disc, its trail, a dashed line to its goal while it
drives, a red cross where it failed (with the cause, when known), the picked robot's scan
(returns as dots) and safe sectors (green fans out to the safe-distance threshold l_th of the
FFT pipeline: a beam is safe when its centred window reads at least l_th), a line for each
message delivered in the tick (sender to receiver). When the robots estimate their poses
(odometry), each robot's estimated pose is drawn too, as a dashed hollow disc with its heading
in the robot's colour, and its estimated path as a dashed line.

Beside the map, the key (:class:`FrameKey`): the clock (``t = 54.2 s / 120 s``, the episode
time over its time limit), the picked robot's state in words (``robot 3: follow (left)``, the
names of :mod:`fftnav.states`: :func:`describe_robot`), a scale bar (metres) and a legend of
every colour, marker and line. :class:`FramePainter` draws the map once and updates the robots'
artists frame by frame (the videos); :func:`draw_frame` draws one frame,
:func:`keyed_figure` lays out a figure of a map with its key below it, and
:class:`RasterRenderer` returns frames as pixels.

A robot's drawn kind comes from the one state vocabulary, :mod:`fftnav.states`
(:func:`kinds_of`): its :class:`~fftnav.states.Status` (waiting, arrived, or failed for
collided and timed out, or a kind of its own for any other status, named by its label, such as
``lost``) and, while it moves, the planner's :class:`~fftnav.states.State` (``mode``; none:
moving). The replays (PNG, GIF, MP4, the HTML player) and :meth:`fftnav.envs.SwarmNavEnv.render`
all draw by it.

>>> KINDS[:3]
('waiting', 'moving', 'following')
>>> runs_of(np.array([True, True, False, True]), wrap=True)
[(3, 2)]
>>> runs_of(np.array([True, True, False, True]), wrap=False)
[(0, 2), (3, 4)]
>>> clock_text(54.23, 120.0), state_name(1, 1), state_name(float("nan"))
('t = 54.2 s / 120 s', 'follow (left)', '')
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from matplotlib.collections import EllipseCollection, LineCollection, PolyCollection
from matplotlib.colors import to_rgb
from matplotlib.lines import Line2D
from matplotlib.offsetbox import AnchoredOffsetbox, AuxTransformBox, HPacker, TextArea
from matplotlib.patches import Circle, Patch, Rectangle
from matplotlib.transforms import offset_copy

from fftnav.report.world_plot import draw_world
from fftnav.states import State, Status
from fftnav.world.model import World

__all__ = ["DRIVING", "ESTIMATE_LABEL", "FAILED_KINDS", "KEY_LABELS", "KINDS", "KIND_COLOURS",
           "MESSAGE_ALPHA", "MESSAGE_COLOUR", "SAFE_ALPHA", "SAFE_COLOUR", "SIDE_NAMES",
           "STATE_KINDS", "STATUS_KINDS", "TRAIL_ALPHA", "TRUTH_LABEL", "FrameKey",
           "FramePainter", "RasterRenderer", "ScanView", "SwarmFrame", "clock_text",
           "describe_robot", "draw_frame", "keyed_figure", "kind_rgb", "kinds_of", "runs_of",
           "safe_label", "scale_bar_m", "seconds_text", "state_name"]

#: The kinds every robot may be drawn as, whatever statuses :class:`~fftnav.states.Status` has.
_SHARED_KINDS = ("waiting", "moving", "following", "escaping", "guided", "arrived", "failed")
#: The statuses drawn as one of the shared kinds; every other status is drawn as a kind of its
#: own, named by its label.
_STATUS_SHARED_KINDS = {Status.WAITING: "waiting", Status.MOVING: "moving",
                        Status.ARRIVED: "arrived", Status.COLLIDED: "failed",
                        Status.TIMED_OUT: "failed"}
#: The kind of a robot by its episode status (every member of :class:`~fftnav.states.Status`);
#: a moving robot is drawn by its state.
STATUS_KINDS = {status: _STATUS_SHARED_KINDS.get(status, status.label) for status in Status}
#: What a robot is drawn as, by its code in :attr:`SwarmFrame.kinds` (:func:`kinds_of`): the
#: shared kinds, then those of the statuses drawn as themselves, in code order.
KINDS = _SHARED_KINDS + tuple(dict.fromkeys(kind for kind in STATUS_KINDS.values()
                                            if kind not in _SHARED_KINDS))
#: The kinds of the robots that failed (every status a robot leaves by without arriving):
#: drawn with a red cross and their failure cause.
FAILED_KINDS = tuple(dict.fromkeys(STATUS_KINDS[s] for s in Status
                                   if s.gone and s != Status.ARRIVED))
#: The fill colour of each shared kind.
_SHARED_COLOURS = {"waiting": "#9e9e9e", "moving": "#1f77b4", "following": "#ff7f0e",
                   "escaping": "#9467bd", "guided": "#e377c2", "arrived": "#2ca02c",
                   "failed": "#d62728"}
#: The colours of the statuses drawn as themselves, by label (``lost``: brown); a status not
#: listed is drawn in :data:`_OTHER_STATUS_COLOUR`.
_STATUS_COLOURS = {"lost": "#8c564b"}
_OTHER_STATUS_COLOUR = "#bcbd22"
#: The fill colour of each kind of :data:`KINDS` (the HTML player uses the same).
KIND_COLOURS = {kind: _SHARED_COLOURS.get(kind) or _STATUS_COLOURS.get(kind, _OTHER_STATUS_COLOUR)
                for kind in KINDS}
#: The kind of a moving robot by the planner's state; the states not listed (``DONE``, a
#: robot let go, and no state at all) draw as moving.
STATE_KINDS = {State.GOAL: "moving", State.FOLLOW: "following", State.ESCAPE: "escaping",
               State.GUIDED: "guided", State.WAIT: "waiting"}
#: The kinds of a robot that drives (drawn with a line to its goal).
DRIVING = ("moving", "following", "escaping", "guided")
#: The side a Bug planner follows or escapes on, by the sign of its ``side`` state value (+1
#: left: the obstacle on its right; -1 right); 0 (none) has no name.
SIDE_NAMES = {1: "left", -1: "right"}
#: Delivered messages, safe sectors, scan returns, goals.
MESSAGE_COLOUR = "#17becf"
SAFE_COLOUR = "#2ca02c"
SCAN_COLOUR = "#000000"
GOAL_COLOUR = "#2ca02c"
#: Opacity of the trails, the safe sectors and the message lines.
TRAIL_ALPHA, SAFE_ALPHA, MESSAGE_ALPHA = 0.7, 0.22, 0.8
#: The legend's names of the true poses (filled discs) and the estimated ones (dashed hollow
#: discs), shown when a frame has estimates (the HTML player uses the same).
TRUTH_LABEL, ESTIMATE_LABEL = "truth", "estimate (odometry)"
#: The dash pattern of the estimated poses' outlines and paths (on, off, in points).
ESTIMATE_DASHES = (0, (2.5, 1.5))
#: The legend's names of what is drawn besides the robots' kinds, by key, in the legend's order
#: (the HTML player's legend uses the same; ``safe``: :func:`safe_label`).
KEY_LABELS = {"heading": "heading", "trail": "trail", "goal": "goal",
              "goal_line": "line to goal", "failure": "failed here (cause)",
              "picked": "picked robot", "scan": "scan returns", "safe": "safe sectors",
              "message": "message delivered"}
#: The key's font size (points).
KEY_FONTSIZE = 7.0


def kind_rgb(kind: str) -> tuple[int, int, int]:
    """The 8-bit RGB of a state's colour.

    >>> kind_rgb("moving")
    (31, 119, 180)
    """
    return tuple(round(255 * c) for c in to_rgb(KIND_COLOURS[kind]))  # type: ignore[return-value]


def kinds_of(status: np.ndarray, mode: np.ndarray | None = None) -> np.ndarray:
    """The drawn kind (a code of :data:`KINDS`) of robots by their
    :class:`~fftnav.states.Status` codes ``status`` and, for those moving, the
    :class:`~fftnav.states.State` codes ``mode`` (same shape; NaN or None: no state, drawn as
    moving): :data:`STATUS_KINDS`, then :data:`STATE_KINDS`.

    >>> s, m = [Status.WAITING, Status.MOVING, Status.MOVING, Status.TIMED_OUT], [0, 1, 5, 1]
    >>> [KINDS[k] for k in kinds_of(np.array(s), np.array(m, float))]
    ['waiting', 'following', 'guided', 'failed']
    """
    status = np.asarray(status)
    kinds = np.full(status.shape, KINDS.index("moving"), dtype=np.uint8)
    if mode is not None:
        mode = np.asarray(mode)
        for state, kind in STATE_KINDS.items():
            kinds[mode == int(state)] = KINDS.index(kind)
    for code, kind in STATUS_KINDS.items():
        if code != Status.MOVING:
            kinds[status == int(code)] = KINDS.index(kind)
    return kinds


def seconds_text(seconds: float) -> str:
    """A duration (s) as the clock writes it: a tenth of a second at most, no trailing zeros.

    >>> seconds_text(120.0), seconds_text(7.25), seconds_text(0.0)
    ('120', '7.2', '0')
    """
    return f"{seconds:.1f}".rstrip("0").rstrip(".")


def clock_text(time_s: float, end_s: float | None = None) -> str:
    """The clock: the episode time (s, one decimal) over ``end_s``, the episode's time limit
    (s; none when None)."""
    return f"t = {time_s:.1f} s" + ("" if end_s is None else f" / {seconds_text(end_s)} s")


def state_name(mode: float | None, side: float | None = None) -> str:
    """The planner's state in words: the label of the :class:`~fftnav.states.State` of code
    ``mode`` and, when ``side`` is +1 or -1 (:data:`SIDE_NAMES`), the side it follows or escapes
    on: ``"follow (left)"``; "" for no state (None or NaN), ``"mode 9"`` for a code that is no
    state.

    >>> state_name(2, -1), state_name(0, 0), state_name(9)
    ('escape (right)', 'goal', 'mode 9')
    """
    if mode is None or not math.isfinite(mode):
        return ""
    code = int(mode)
    name = State(code).label if code in set(State) else f"mode {code}"
    side_name = (SIDE_NAMES.get(int(np.sign(side)))
                 if side is not None and math.isfinite(side) else None)
    return f"{name} ({side_name})" if side_name else name


def describe_robot(robot: int, status: int, *, mode: float | None = None,
                   side: float | None = None, cause: str = "") -> str:
    """What robot ``robot`` is doing, in the names of :mod:`fftnav.states`: while it moves, its
    planner's state (:func:`state_name`; ``moving`` without one), else its status's label, with
    the failure ``cause`` of a robot that left without arriving.

    >>> describe_robot(3, Status.MOVING, mode=1, side=1)
    'robot 3: follow (left)'
    >>> describe_robot(2, Status.COLLIDED, cause="collision")
    'robot 2: collided (collision)'
    """
    code = Status(int(status))
    if code == Status.MOVING:
        return f"robot {robot}: {state_name(mode, side) or 'moving'}"
    failed = code.gone and code != Status.ARRIVED
    return f"robot {robot}: {code.label}" + (f" ({cause})" if failed and cause else "")


def safe_label(safe_m: float | None) -> str:
    """The legend's name of the safe sectors, with their radius ``safe_m`` (l_th, m) if known.

    >>> safe_label(0.6), safe_label(None)
    ('safe (to l_th = 0.60 m)', 'safe sectors')
    """
    return KEY_LABELS["safe"] if safe_m is None else f"safe (to l_th = {safe_m:.2f} m)"


def scale_bar_m(width_m: float) -> float:
    """The scale bar's length (m) for a map ``width_m`` wide: the longest of 1, 2 or 5 times a
    power of ten that is at most a fifth of the width.

    >>> scale_bar_m(10.0), scale_bar_m(40.0), scale_bar_m(8.0), scale_bar_m(2.0)
    (2.0, 5.0, 1.0, 0.2)
    """
    fifth = width_m / 5.0
    power = 10.0 ** math.floor(math.log10(fifth))
    return max(f * power for f in (1.0, 2.0, 5.0) if f * power <= fifth * (1 + 1e-9))


@dataclass(frozen=True)
class ScanView:
    """One robot's scan: beam angles (rad, CCW from its heading), ranges (m; 0 for blind beams
    and robots not driving) and safe mask, with the sensor range (m) and the radius the safe
    sectors are drawn to, ``safe_m`` (m): the FFT pipeline's safe-distance threshold l_th
    (``config.geometry.l_th_m``; None: the sensor range)."""

    angles_rad: np.ndarray
    ranges_m: np.ndarray
    safe: np.ndarray
    range_m: float
    safe_m: float | None = None


@dataclass(frozen=True)
class SwarmFrame:
    """What one frame shows.

    Attributes
    ----------
    poses : ndarray, (N, 3)
        x (m), y (m), yaw (rad) of every robot.
    kinds : ndarray, (N,)
        Each robot's state, a code of :data:`KINDS`.
    trails : sequence of ndarray, (T_i, 2)
        Each robot's path so far (may be empty).
    time_s : float or None
        The clock (s; not drawn when None).
    picked : int or None
        The robot whose scan is drawn (``scan``), ringed.
    scan : ScanView or None
    messages : ndarray, (K, 2)
        Sender and receiver of each message delivered in the tick.
    causes : sequence of str
        Each robot's failure cause ("" for none), written next to its cross.
    estimates : ndarray, (N, 3), or None
        x (m), y (m), yaw (rad) of every robot's estimated pose (NaN: none), or None when the
        robots know their true poses (nothing of estimates is drawn).
    estimate_trails : sequence of ndarray, (T_i, 2)
        Each robot's estimated path so far (may be empty).
    end_s : float or None
        The episode's time limit (s), after the clock's time (none when None).
    picked_label : str
        What the picked robot is doing (:func:`describe_robot`), under the clock.
    """

    poses: np.ndarray
    kinds: np.ndarray
    trails: Sequence[np.ndarray] = ()
    time_s: float | None = None
    picked: int | None = None
    scan: ScanView | None = None
    messages: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), int))
    causes: Sequence[str] = ()
    estimates: np.ndarray | None = None
    estimate_trails: Sequence[np.ndarray] = ()
    end_s: float | None = None
    picked_label: str = ""


def runs_of(mask: np.ndarray, *, wrap: bool) -> list[tuple[int, int]]:
    """The runs of True in ``mask`` as ``(start, stop)`` index pairs; with ``wrap`` (a full
    circle of beams) a run over the end continues at the start (then ``stop`` may be
    ``<= start``, meaning ``start .. M-1, 0 .. stop-1``)."""
    m = np.asarray(mask, bool)
    if m.all():
        return [(0, len(m))]
    edges = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    runs = list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))
    if wrap and len(runs) > 1 and runs[0][0] == 0 and runs[-1][1] == len(m):
        runs = [(runs[-1][0], runs[0][1])] + runs[1:-1]
    return runs


def _fans(x: float, y: float, yaw: float, scan: ScanView) -> list[np.ndarray]:
    """The safe sectors of a scan as polygons: the robot, then the sector's arc at the safe
    radius (``scan.safe_m``, l_th; the sensor range when None)."""
    m = len(scan.angles_rad)
    radius = scan.range_m if scan.safe_m is None else min(scan.safe_m, scan.range_m)
    full = np.isclose(np.ptp(scan.angles_rad) + np.diff(scan.angles_rad[:2]).sum(), 2 * np.pi)
    step = 2 * np.pi / m if full else (np.ptp(scan.angles_rad) / max(m - 1, 1))
    polys = []
    for start, stop in runs_of(scan.safe, wrap=bool(full)):
        count = (stop - start) % m or m
        a0 = scan.angles_rad[start] - step / 2
        arc = yaw + a0 + np.linspace(0.0, count * step, max(count + 1, 2))
        pts = np.column_stack([x + radius * np.cos(arc), y + radius * np.sin(arc)])
        polys.append(np.vstack([[x, y], pts]))
    return polys


def _legend_handles(kinds: Sequence[str], *, estimates: bool,
                    safe_m: float | None) -> list[Any]:
    """The legend's entries: each kind's disc, then what else a frame draws
    (:data:`KEY_LABELS`), then, with ``estimates``, a true pose and an estimated one."""
    disc = {"marker": "o", "ms": 7, "mec": "0.15", "mew": 0.4, "ls": "none"}
    handles: list[Any] = [Line2D([], [], mfc=KIND_COLOURS[k], label=k, **disc) for k in kinds]
    handles += [
        Line2D([], [], color="0.1", lw=1.4, label=KEY_LABELS["heading"]),
        Line2D([], [], color="0.45", lw=1.1, alpha=TRAIL_ALPHA, label=KEY_LABELS["trail"]),
        Line2D([], [], marker="*", ms=8, color=GOAL_COLOUR, ls="none", label=KEY_LABELS["goal"]),
        Line2D([], [], color="0.55", lw=0.8, ls=(0, (3, 3)), label=KEY_LABELS["goal_line"]),
        Line2D([], [], marker="x", ms=7, mew=2.0, color=KIND_COLOURS["failed"], ls="none",
               label=KEY_LABELS["failure"]),
        Line2D([], [], marker="o", ms=9, mfc="none", mec="k", mew=1.0, ls="none",
               label=KEY_LABELS["picked"]),
        Line2D([], [], marker=".", ms=4, color=SCAN_COLOUR, ls="none", label=KEY_LABELS["scan"]),
        Patch(facecolor=SAFE_COLOUR, alpha=SAFE_ALPHA, edgecolor="none", label=safe_label(safe_m)),
        Line2D([], [], color=MESSAGE_COLOUR, lw=1.0, alpha=MESSAGE_ALPHA,
               label=KEY_LABELS["message"]),
    ]
    if estimates:
        handles += _estimate_legend()
    return handles


class FrameKey:
    """The key of a frame, on its own axes ``key_ax`` (its axis off), from the top left down:
    the clock, the picked robot's state in words, a scale bar of :func:`scale_bar_m` metres of
    the map axes ``map_ax`` and the legend in ``ncol`` columns.

    Parameters
    ----------
    key_ax, map_ax : matplotlib Axes
    width_m : float
        The map's width (m), for the scale bar's length.
    kinds : sequence of str
        The kinds the legend lists (default: all of :data:`KINDS`).
    estimates : bool
        List a true pose and an estimated one too.
    safe_m : float or None
        The safe sectors' radius (l_th, m) in their entry.
    ncol : int
        The legend's columns.
    fontsize : float
        Points.
    """

    def __init__(self, key_ax: Any, map_ax: Any, width_m: float, *,
                 kinds: Sequence[str] = KINDS, estimates: bool = False,
                 safe_m: float | None = None, ncol: int = 1,
                 fontsize: float = KEY_FONTSIZE) -> None:
        self.ax, self.fontsize, self.kinds = key_ax, float(fontsize), tuple(kinds)
        key_ax.set_axis_off()
        fs = self.fontsize
        self.clock = key_ax.annotate("", (0, 1), xycoords="axes fraction", xytext=(0, 0),
                                     textcoords="offset points", ha="left", va="top",
                                     fontsize=fs)
        self.robot = key_ax.annotate("", (0, 1), xycoords="axes fraction",
                                     xytext=(0, -1.5 * fs), textcoords="offset points",
                                     ha="left", va="top", fontsize=fs)
        self.bar_m = scale_bar_m(width_m)
        bar = AuxTransformBox(map_ax.transData)
        bar.add_artist(Rectangle((0, 0), self.bar_m, 0.0, fill=False, lw=0))  # its extent
        bar.add_artist(Line2D([0, self.bar_m], [0, 0], color="k", lw=3.0,
                              solid_capstyle="butt"))
        text = TextArea(f"{self.bar_m:g} m", textprops={"fontsize": fs})
        fig = key_ax.figure
        self.scale_bar = AnchoredOffsetbox(
            "upper left", child=HPacker(children=[bar, text], align="center", pad=0, sep=4),
            pad=0, borderpad=0, frameon=False, bbox_to_anchor=(0, 1),
            bbox_transform=offset_copy(key_ax.transAxes, fig=fig, y=-3.2 * fs, units="points"))
        key_ax.add_artist(self.scale_bar)
        self._legend_anchor = offset_copy(key_ax.transAxes, fig=fig, y=-4.8 * fs,
                                          units="points")
        self.legend: Any = None
        self.shown: tuple[bool, float | None, int] | None = None
        self.set_legend(estimates=estimates, safe_m=safe_m, ncol=ncol)

    def set_legend(self, *, estimates: bool, safe_m: float | None, ncol: int) -> None:
        """The legend's own entries and columns: with ``estimates`` (also listed for a frame
        with estimates), the safe sectors' radius ``safe_m`` (None: the first scan's)."""
        self.estimates, self.safe_m, self.ncol = bool(estimates), safe_m, int(ncol)
        self._show(self.estimates, safe_m)

    def _show(self, estimates: bool, safe_m: float | None) -> None:
        """(Re)make the legend when its entries change."""
        shown = (estimates, safe_m, self.ncol)
        if shown == self.shown:
            return
        if self.legend is not None:
            self.legend.remove()
        self.shown = shown
        self.legend = self.ax.legend(
            handles=_legend_handles(self.kinds, estimates=estimates, safe_m=safe_m),
            loc="upper left", bbox_to_anchor=(0, 1), bbox_transform=self._legend_anchor,
            ncols=self.ncol, fontsize=self.fontsize, frameon=False, borderaxespad=0,
            borderpad=0, handlelength=1.8, columnspacing=1.2, handletextpad=0.5)

    def update(self, frame: SwarmFrame) -> None:
        """The clock, the picked robot's state and the legend of ``frame``."""
        self.clock.set_text("" if frame.time_s is None else clock_text(frame.time_s,
                                                                         frame.end_s))
        self.robot.set_text(frame.picked_label if frame.picked is not None else "")
        safe_m = self.safe_m
        if safe_m is None and frame.scan is not None:
            safe_m = frame.scan.safe_m
        self._show(self.estimates or frame.estimates is not None, safe_m)

    def height_pt(self, renderer: Any) -> float:
        """The key's height (points): the three rows above the legend and the legend."""
        legend = self.legend.get_window_extent(renderer).height * 72.0 / self.ax.figure.dpi
        return 4.8 * self.fontsize + legend


class FramePainter:
    """Draws a world once on ``ax`` and the swarm over it, frame after frame (:meth:`update`),
    with its key (:class:`FrameKey`) on ``key_ax``.

    Parameters
    ----------
    ax : matplotlib Axes
    world : World
    r0_m : float
        The robots' radius (m).
    key_ax : matplotlib Axes, optional
        Where the key goes; default: an axes of its own right of ``ax``.
    estimates : bool
        List the estimated poses in the legend from the start (otherwise from the first frame
        with estimates).
    safe_m : float or None
        The safe sectors' radius (l_th, m) the legend names (otherwise the first scan's).
    ncol : int
        The legend's columns.
    """

    def __init__(self, ax: Any, world: World, r0_m: float, *, key_ax: Any = None,
                 estimates: bool = False, safe_m: float | None = None, ncol: int = 1) -> None:
        self.ax, self.world, self.r0_m = ax, world, float(r0_m)
        draw_world(world, ax, starts=False, scale_bar=False)
        self.safe = PolyCollection([], facecolors=SAFE_COLOUR, alpha=SAFE_ALPHA, edgecolors="none",
                                   zorder=2)
        self.trails = LineCollection([], linewidths=1.1, alpha=TRAIL_ALPHA, zorder=3)
        self.goal_lines = LineCollection([], colors="0.55", linewidths=0.6,
                                         linestyles=(0, (3, 3)), zorder=3)
        self.messages = LineCollection([], colors=MESSAGE_COLOUR, linewidths=0.8,
                                       alpha=MESSAGE_ALPHA, zorder=4)
        for artist in (self.safe, self.trails, self.goal_lines, self.messages):
            ax.add_collection(artist)
        (self.returns,) = ax.plot([], [], ".", color=SCAN_COLOUR, ms=2.0, zorder=5)
        size = 2 * self.r0_m
        self.robots = EllipseCollection(size, size, 0.0, units="xy", offsets=np.zeros((0, 2)),
                                        offset_transform=ax.transData, edgecolors="0.15",
                                        linewidths=0.4, zorder=6)
        ax.add_collection(self.robots)
        self.headings = LineCollection([], colors="0.1", linewidths=1.4, zorder=6)
        ax.add_collection(self.headings)
        # under the discs: the arms show beyond them, the disc keeps its kind's colour
        self.crosses = LineCollection([], colors=KIND_COLOURS["failed"], linewidths=2.2,
                                      zorder=5.5)
        ax.add_collection(self.crosses)
        self.ring = Circle((0, 0), 2.2 * self.r0_m, fill=False, ec="k", lw=1.0, zorder=7,
                           visible=False)
        ax.add_patch(self.ring)
        self.labels: list[Any] = []
        self._add_estimate_artists()
        if key_ax is None:
            key_ax = ax.inset_axes((1.03, 0.0, 0.5, 1.0))
        self.key = FrameKey(key_ax, ax, world.size_m[0], estimates=estimates, safe_m=safe_m,
                            ncol=ncol)

    @property
    def legend(self) -> Any:
        """The key's legend."""
        return self.key.legend

    def _add_estimate_artists(self) -> None:
        """The estimated poses' artists (empty until a frame has estimates): dashed paths,
        dashed hollow discs under the true ones, headings."""
        ax, size = self.ax, 2 * self.r0_m
        self.estimate_trails = LineCollection([], linewidths=1.0, alpha=TRAIL_ALPHA,
                                              linestyles=ESTIMATE_DASHES, zorder=3)
        self.estimate_robots = EllipseCollection(size, size, 0.0, units="xy",
                                                 offsets=np.zeros((0, 2)),
                                                 offset_transform=ax.transData,
                                                 facecolors="none", linewidths=1.1,
                                                 linestyles=ESTIMATE_DASHES, zorder=5)
        self.estimate_headings = LineCollection([], linewidths=1.1, zorder=5)
        for artist in (self.estimate_trails, self.estimate_robots, self.estimate_headings):
            ax.add_collection(artist)

    def update(self, frame: SwarmFrame) -> None:
        """Draw ``frame`` over the map, replacing the previous one."""
        poses = np.asarray(frame.poses, dtype=np.float64).reshape(-1, 3)
        kinds = np.asarray(frame.kinds, dtype=np.int64)
        colours = [KIND_COLOURS[KINDS[k]] for k in kinds]
        self.robots.set_offsets(poses[:, :2])
        self.robots.set_facecolors(colours)
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        tick = np.stack([np.column_stack([poses[:, 0] + f * self.r0_m * c,
                                          poses[:, 1] + f * self.r0_m * s]) for f in (1.0, 2.0)],
                        axis=1)
        self.headings.set_segments(list(tick))
        trails = [(np.asarray(t)[:, :2], col) for t, col in zip(frame.trails, colours,
                                                                strict=False) if len(t) > 1]
        self.trails.set_segments([t for t, _ in trails])
        self.trails.set_color([col for _, col in trails])
        driving = np.isin(kinds, [KINDS.index(k) for k in DRIVING])
        goals = np.asarray(self.world.goals)[: len(poses)]
        self.goal_lines.set_segments([np.array([poses[i, :2], goals[i]])
                                      for i in np.flatnonzero(driving)])
        pairs = np.asarray(frame.messages, dtype=np.int64).reshape(-1, 2)
        self.messages.set_segments([poses[[a, b], :2] for a, b in pairs])
        failed = np.isin(kinds, [KINDS.index(k) for k in FAILED_KINDS])
        d = 1.8 * self.r0_m  # the cross's half-width, beyond the disc
        self.crosses.set_segments([seg for x, y in poses[failed, :2]
                                   for seg in (np.array([[x - d, y - d], [x + d, y + d]]),
                                               np.array([[x - d, y + d], [x + d, y - d]]))])
        self._draw_labels(poses, failed, frame.causes)
        self._draw_scan(poses, frame)
        self._draw_estimates(frame, colours)
        self.key.update(frame)

    def _draw_estimates(self, frame: SwarmFrame, colours: Sequence[str]) -> None:
        """The estimated poses (dashed hollow discs and headings) and paths (dashed) in each
        robot's colour; nothing when ``frame`` has no estimates."""
        shown = frame.estimates is not None
        est = (np.asarray(frame.estimates, dtype=np.float64).reshape(-1, 3) if shown
               else np.zeros((0, 3)))
        known = np.flatnonzero(np.isfinite(est).all(axis=1))
        est, colour = est[known], [colours[i] for i in known]
        self.estimate_robots.set_offsets(est[:, :2])
        self.estimate_robots.set_edgecolors(colour)
        c, s = np.cos(est[:, 2]), np.sin(est[:, 2])
        self.estimate_headings.set_segments(
            [np.array([[x + self.r0_m * ci, y + self.r0_m * si],
                       [x + 2 * self.r0_m * ci, y + 2 * self.r0_m * si]])
             for (x, y, _), ci, si in zip(est, c, s, strict=True)])
        self.estimate_headings.set_color(colour)
        trails = [(np.asarray(t)[:, :2], col) for t, col in
                  zip(frame.estimate_trails if shown else (), colours, strict=False)
                  if len(t) > 1]
        self.estimate_trails.set_segments([t for t, _ in trails])
        self.estimate_trails.set_color([col for _, col in trails])

    def _draw_labels(self, poses: np.ndarray, failed: np.ndarray, causes: Sequence[str]) -> None:
        for label in self.labels:
            label.remove()
        self.labels = [self.ax.annotate(causes[i], poses[i, :2], xytext=(10, 6),
                                        textcoords="offset points", fontsize=7, zorder=8,
                                        color=KIND_COLOURS["failed"])
                       for i in np.flatnonzero(failed) if i < len(causes) and causes[i]]

    def _draw_scan(self, poses: np.ndarray, frame: SwarmFrame) -> None:
        picked, scan = frame.picked, frame.scan
        self.ring.set_visible(picked is not None)
        if picked is not None:
            self.ring.set_center(tuple(poses[picked, :2]))
        if picked is None or scan is None:
            self.safe.set_verts([])
            self.returns.set_data([], [])
            return
        x, y, yaw = poses[picked]
        self.safe.set_verts(_fans(x, y, yaw, scan))
        hit = (scan.ranges_m > 0) & (scan.ranges_m < scan.range_m - 1e-6)
        a, r = yaw + scan.angles_rad[hit], scan.ranges_m[hit]
        self.returns.set_data(x + r * np.cos(a), y + r * np.sin(a))


def _estimate_legend() -> list[Line2D]:
    """The legend's two entries of estimates: a true pose (a filled disc) and an estimated one
    (a dashed hollow disc on its dashed path), in grey (the colours are the robots' kinds)."""
    return [Line2D([], [], marker="o", ms=7, mfc="0.6", mec="0.15", mew=0.4, ls="-",
                   color="0.45", lw=1.1, label=TRUTH_LABEL),
            Line2D([], [], marker="o", ms=7, mfc="none", mec="0.3", mew=1.1,
                   ls=ESTIMATE_DASHES, color="0.45", lw=1.0, label=ESTIMATE_LABEL)]


def draw_frame(ax: Any, world: World, frame: SwarmFrame, r0_m: float, *,
               key_ax: Any = None) -> FramePainter:
    """Draw ``world`` and one ``frame`` of its swarm on ``ax``, its key on ``key_ax`` (default:
    right of ``ax``); returns the painter (whose :meth:`FramePainter.update` draws further
    frames)."""
    painter = FramePainter(ax, world, r0_m, key_ax=key_ax,
                           estimates=frame.estimates is not None,
                           safe_m=None if frame.scan is None else frame.scan.safe_m)
    painter.update(frame)
    return painter


def _inches(px: int, dpi: float) -> float:
    """``px`` pixels in inches at ``dpi``, a thousandth of a pixel over: the canvas truncates
    its size in pixels, and ``px / dpi * dpi`` may round below ``px``."""
    return (px + 1e-3) / dpi


def keyed_figure(world: World, r0_m: float, *, map_px: tuple[int, int], dpi: float,
                 margin: float = 0.0, title: str = "", estimates: bool = False,
                 safe_m: float | None = None) -> tuple[Any, FramePainter]:
    """A figure of its own (:func:`fftnav.report.new_figure`) of ``world``'s map above its key:
    ``title`` above the map, the map axes (its axis off) ``map_px`` = (rows, columns) pixels
    showing the world and a ``margin`` round it (a fraction of its width and height), and below
    it the key (:class:`FrameKey`, ``estimates`` and ``safe_m`` as there), its legend in as
    many columns as the width holds, its height measured: the figure grows to fit it, to an
    even number of pixel rows (as H.264 needs). Returns the figure and its painter."""
    from fftnav.report import new_figure

    rows, cols = (int(v) for v in map_px)
    w, h = world.size_m
    title_px = math.ceil(24 * dpi / 100) if title else 0
    fig = new_figure(figsize=(_inches(cols, dpi), _inches(title_px + rows + 200, dpi)), dpi=dpi)
    ax = fig.add_axes((0, 0.5, 1, 0.5))
    key_ax = fig.add_axes((0, 0, 1, 0.5))
    painter = FramePainter(ax, world, r0_m, key_ax=key_ax, estimates=estimates, safe_m=safe_m)
    ax.set_xlim(-margin * w, (1 + margin) * w)
    ax.set_ylim(-margin * h, (1 + margin) * h)
    ax.set_axis_off()
    if title:
        ax.set_title(title, fontsize=9)
    renderer = fig.canvas.get_renderer()
    pad_px = 4
    for ncol in range(len(painter.key.legend.legend_handles), 0, -1):
        painter.key.set_legend(estimates=estimates, safe_m=safe_m, ncol=ncol)
        if painter.key.legend.get_window_extent(renderer).width <= cols - 2 * pad_px:
            break
    key_px = math.ceil(painter.key.height_pt(renderer) * dpi / 72.0) + 2 * pad_px
    key_px += (title_px + rows + key_px) % 2
    total = title_px + rows + key_px
    fig.set_size_inches(_inches(cols, dpi), _inches(total, dpi))
    ax.set_position((0, key_px / total, 1, rows / total))
    key_ax.set_position((pad_px / cols, pad_px / total, 1 - 2 * pad_px / cols,
                         (key_px - 2 * pad_px) / total))
    return fig, painter


class RasterRenderer:
    """Frames of one world as RGB arrays at ``resolution_m`` metres per pixel: the map in the
    first rows, the first row the top of the world (:meth:`fftnav.envs.SwarmNavEnv.render`):
    pixel ``(row, col)`` with ``row < map_shape[0]`` covers ``x = col * res .. (col + 1) *
    res``, ``y = h - (row + 1) * res .. h - row * res``; the world's border on its edge pixels
    (wider for boundary walls); below the map, the key (:class:`FrameKey`: clock, the picked
    robot's state, scale bar, legend), of a height fixed for the renderer. It draws on a figure
    of its own (:func:`keyed_figure`): matplotlib's backend stays as it was.

    >>> from fftnav.world.model import World
    >>> world = World("forest", 0, (4.0, 1.0), (), np.array([[1.0, 0.5, 0.0]]),
    ...               np.array([[3.5, 0.5]]))
    >>> frame = SwarmFrame(poses=world.starts, kinds=np.array([KINDS.index("moving")]))
    >>> renderer = RasterRenderer(world, r0_m=0.15, resolution_m=0.05)
    >>> rgb = renderer(frame)
    >>> renderer.map_shape, rgb.shape[1:], rgb.shape[0] > 20, tuple(rgb[10, 20]) == kind_rgb(
    ...     "moving")
    ((20, 80), (80, 3), True, True)
    """

    def __init__(self, world: World, *, r0_m: float, resolution_m: float,
                 estimates: bool = False, safe_m: float | None = None) -> None:
        self.world, self.r0_m = world, float(r0_m)
        w, h = world.size_m
        self.map_shape = (round(h / resolution_m), round(w / resolution_m))
        self.figure, self.painter = keyed_figure(world, r0_m, map_px=self.map_shape, dpi=100,
                                                 estimates=estimates, safe_m=safe_m)
        edge_px = 4 if world.boundary == "walls" else 2
        # centred on the map's edge and clipped by it: half its width is inside
        self.painter.ax.add_patch(Rectangle((0, 0), 1, 1, transform=self.painter.ax.transAxes,
                                            fill=False, ec="k", lw=2 * edge_px * 72 / 100,
                                            zorder=9))

    def __call__(self, frame: SwarmFrame) -> np.ndarray:
        """The frame as an ``(H, W, 3)`` uint8 array."""
        self.painter.update(frame)
        self.figure.canvas.draw()
        return np.asarray(self.figure.canvas.buffer_rgba())[..., :3].copy()
