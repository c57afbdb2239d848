"""One frame of a swarm, drawn on a matplotlib axes: the drawing that ``fftnav replay`` (PNG,
GIF, MP4), ``fftnav episode --plot`` and :meth:`fftnav.envs.SwarmNavEnv.render` share, so that
the three views agree.

A frame (:class:`SwarmFrame`) is the top-down map with its obstacles and goals, every robot as a
disc of radius ``r0_m`` filled with the colour of its drawn kind (:data:`KIND_COLOURS`), its
heading as a short dark tick out of the disc, its trail, a dashed line to its goal while it
drives, a cross where it failed (with the cause, when known), the picked robot's scan (returns as
dots) and safe sectors (green fans out to the sensor range), a line for each message delivered in
the tick (sender to receiver) and the clock. When the robots estimate their poses (odometry), each
robot's estimated pose is drawn too, as a dashed hollow disc with its heading in the robot's colour,
and its estimated path as a dashed line, with a legend telling truth from estimate.
:class:`FramePainter` draws the map once and updates the robots' artists frame by frame (the
videos); :func:`draw_frame` draws one frame and :class:`RasterRenderer` returns frames as pixels.

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
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from matplotlib.collections import EllipseCollection, LineCollection, PolyCollection
from matplotlib.colors import to_rgb
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from fftnav.report.world_plot import draw_world
from fftnav.states import State, Status
from fftnav.world.model import World

__all__ = ["DRIVING", "ESTIMATE_LABEL", "KINDS", "KIND_COLOURS", "MESSAGE_ALPHA",
           "MESSAGE_COLOUR", "SAFE_ALPHA", "SAFE_COLOUR", "STATE_KINDS", "STATUS_KINDS",
           "TRAIL_ALPHA", "TRUTH_LABEL", "FramePainter", "RasterRenderer", "ScanView",
           "SwarmFrame", "draw_frame", "kind_rgb", "kinds_of", "runs_of"]

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
#: Delivered messages, safe sectors, scan returns.
MESSAGE_COLOUR = "#17becf"
SAFE_COLOUR = "#2ca02c"
SCAN_COLOUR = "#000000"
#: Opacity of the trails, the safe sectors and the message lines.
TRAIL_ALPHA, SAFE_ALPHA, MESSAGE_ALPHA = 0.7, 0.22, 0.8
#: The legend's names of the true poses (filled discs) and the estimated ones (dashed hollow
#: discs), shown when a frame has estimates (the HTML player uses the same).
TRUTH_LABEL, ESTIMATE_LABEL = "truth", "estimate (odometry)"
#: The dash pattern of the estimated poses' outlines and paths (on, off, in points).
ESTIMATE_DASHES = (0, (2.5, 1.5))


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


@dataclass(frozen=True)
class ScanView:
    """One robot's scan: beam angles (rad, CCW from its heading), ranges (m; 0 for blind beams
    and robots not driving) and safe mask, with the sensor range (m)."""

    angles_rad: np.ndarray
    ranges_m: np.ndarray
    safe: np.ndarray
    range_m: float


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
        The clock (not drawn when None).
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
    """The safe sectors of a scan as polygons: the robot, then the sector's arc at the range."""
    m = len(scan.angles_rad)
    full = np.isclose(np.ptp(scan.angles_rad) + np.diff(scan.angles_rad[:2]).sum(), 2 * np.pi)
    step = 2 * np.pi / m if full else (np.ptp(scan.angles_rad) / max(m - 1, 1))
    polys = []
    for start, stop in runs_of(scan.safe, wrap=bool(full)):
        count = (stop - start) % m or m
        a0 = scan.angles_rad[start] - step / 2
        arc = yaw + a0 + np.linspace(0.0, count * step, max(count + 1, 2))
        pts = np.column_stack([x + scan.range_m * np.cos(arc), y + scan.range_m * np.sin(arc)])
        polys.append(np.vstack([[x, y], pts]))
    return polys


class FramePainter:
    """Draws a world once on ``ax`` and the swarm over it, frame after frame (:meth:`update`).

    Parameters
    ----------
    ax : matplotlib Axes
    world : World
    r0_m : float
        The robots' radius (m).
    scale_bar : bool
        Draw the 1 m scale bar under the map.
    """

    def __init__(self, ax: Any, world: World, r0_m: float, *, scale_bar: bool = True) -> None:
        self.ax, self.world, self.r0_m = ax, world, float(r0_m)
        draw_world(world, ax, starts=False, scale_bar=scale_bar)
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
        self.crosses = LineCollection([], colors=KIND_COLOURS["failed"], linewidths=2.2,
                                      zorder=7)
        ax.add_collection(self.crosses)
        self.ring = Circle((0, 0), 2.2 * self.r0_m, fill=False, ec="k", lw=1.0, zorder=7,
                           visible=False)
        ax.add_patch(self.ring)
        self.clock = ax.text(0.01, 0.99, "", transform=ax.transAxes, ha="left", va="top",
                             fontsize=9, zorder=8,
                             bbox={"fc": "white", "ec": "0.6", "alpha": 0.85, "pad": 2})
        self.labels: list[Any] = []
        self._add_estimate_artists()

    def _add_estimate_artists(self) -> None:
        """The estimated poses' artists (empty until a frame has estimates): dashed paths,
        dashed hollow discs under the true ones, headings; the legend is made when first
        needed."""
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
        self.legend: Any = None

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
        failed = kinds == KINDS.index("failed")
        d = 1.8 * self.r0_m  # the cross's half-width, beyond the disc
        self.crosses.set_segments([seg for x, y in poses[failed, :2]
                                   for seg in (np.array([[x - d, y - d], [x + d, y + d]]),
                                               np.array([[x - d, y + d], [x + d, y - d]]))])
        self._draw_labels(poses, failed, frame.causes)
        self._draw_scan(poses, frame)
        self._draw_estimates(frame, colours)
        self.clock.set_text("" if frame.time_s is None else f"t = {frame.time_s:5.1f} s")
        self.clock.set_visible(frame.time_s is not None)

    def _draw_estimates(self, frame: SwarmFrame, colours: Sequence[str]) -> None:
        """The estimated poses (dashed hollow discs and headings) and paths (dashed) in each
        robot's colour, and the legend; nothing when ``frame`` has no estimates."""
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
        if shown and self.legend is None:
            self.legend = self.ax.legend(handles=_estimate_legend(), loc="lower right",
                                         ncol=2, fontsize=7, framealpha=0.85)
            self.legend.set_zorder(8)
        if self.legend is not None:
            self.legend.set_visible(shown)

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
    """The legend's two entries: a true pose (a filled disc) and an estimated one (a dashed
    hollow disc on its dashed path), in grey (the colours are the robots' kinds)."""
    return [Line2D([], [], marker="o", ms=7, mfc="0.6", mec="0.15", mew=0.4, ls="-",
                   color="0.45", lw=1.1, label=TRUTH_LABEL),
            Line2D([], [], marker="o", ms=7, mfc="none", mec="0.3", mew=1.1,
                   ls=ESTIMATE_DASHES, color="0.45", lw=1.0, label=ESTIMATE_LABEL)]


def draw_frame(ax: Any, world: World, frame: SwarmFrame, r0_m: float, *,
               scale_bar: bool = True) -> FramePainter:
    """Draw ``world`` and one ``frame`` of its swarm on ``ax``; returns the painter (whose
    :meth:`FramePainter.update` draws further frames)."""
    painter = FramePainter(ax, world, r0_m, scale_bar=scale_bar)
    painter.update(frame)
    return painter


class RasterRenderer:
    """Frames of one world as RGB arrays at ``resolution_m`` metres per pixel, the first row the
    top of the world (:meth:`fftnav.envs.SwarmNavEnv.render`): pixel ``(row, col)`` covers
    ``x = col * res .. (col + 1) * res``, ``y = h - (row + 1) * res .. h - row * res``. It draws
    on a figure of its own (:func:`fftnav.report.new_figure`): matplotlib's backend stays as it
    was.

    >>> from fftnav.world.model import World
    >>> world = World("forest", 0, (2.0, 1.0), (), np.array([[1.0, 0.5, 0.0]]),
    ...               np.array([[1.5, 0.5]]))
    >>> frame = SwarmFrame(poses=world.starts, kinds=np.array([KINDS.index("moving")]))
    >>> rgb = RasterRenderer(world, r0_m=0.15, resolution_m=0.05)(frame)
    >>> rgb.shape, tuple(rgb[10, 20]) == kind_rgb("moving")
    ((20, 40, 3), True)
    """

    def __init__(self, world: World, *, r0_m: float, resolution_m: float) -> None:
        from fftnav.report import new_figure

        self.world, self.r0_m = world, float(r0_m)
        w, h = world.size_m
        self.shape = (round(h / resolution_m), round(w / resolution_m))
        self.figure = new_figure(figsize=(self.shape[1] / 100, self.shape[0] / 100), dpi=100)
        ax = self.figure.add_axes((0, 0, 1, 1))
        self.painter = FramePainter(ax, world, r0_m, scale_bar=False)
        ax.set_xlim(0, w)
        ax.set_ylim(0, h)
        ax.set_axis_off()

    def __call__(self, frame: SwarmFrame) -> np.ndarray:
        """The frame as an ``(H, W, 3)`` uint8 array."""
        self.painter.update(frame)
        self.figure.canvas.draw()
        return np.asarray(self.figure.canvas.buffer_rgba())[..., :3].copy()
