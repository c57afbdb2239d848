"""Replays of a recorded episode (:mod:`fftnav.episode.recording`): one frame as a PNG, the
episode as a GIF (Pillow) or an MP4 (imageio-ffmpeg, the optional extra ``video``), all drawn
by :mod:`fftnav.report.frames`; the HTML player is :mod:`fftnav.report.replay_html`.

A robot's drawn kind at a tick (:func:`robot_kinds`) comes from the recording's ``status``
column (:class:`fftnav.states.Status`) and, while it moves, its controller's ``state/mode``
(:class:`fftnav.states.State`; controllers without a ``mode`` draw as moving), by
:func:`fftnav.report.frames.kinds_of`; a robot that failed is drawn failed from the tick of its
failure on (:func:`failure_ticks`, the definition the HTML player is given too). A recording
with the robots' estimated poses (odometry localization, its ``estimates``) draws them too,
beside the true ones. Every frame has its key below the map: the clock over the episode's time
limit (:func:`limit_s`), the picked robot's state in words, a scale bar and the legend
(:func:`fftnav.report.frames.keyed_figure`).
"""

from __future__ import annotations

import errno
import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.colors import to_rgb

from fftnav.episode.recording import Recording
from fftnav.errors import FftnavError, import_extra
from fftnav.report.frames import (
    KIND_COLOURS,
    KINDS,
    MESSAGE_ALPHA,
    MESSAGE_COLOUR,
    SAFE_ALPHA,
    SAFE_COLOUR,
    TRAIL_ALPHA,
    FramePainter,
    ScanView,
    SwarmFrame,
    describe_robot,
    keyed_figure,
    kind_rgb,
    kinds_of,
)
from fftnav.states import Status
from fftnav.validate import check_integer, check_number

__all__ = ["FPS", "default_robot", "drawn_status", "end_s", "failure_ticks", "frame_ticks",
           "limit_s", "recording_frame", "robot_kinds", "safe_radius_m", "window",
           "write_image", "write_video"]

#: The narrowest frame (pixels).
MIN_WIDTH_PX = 160
#: Frames per second of the GIFs and MP4s; at ``speed`` 1 a frame advances 1 / FPS s of the
#: episode (one tick at the default 10 Hz control rate).
FPS = 10
#: The slowest playback: a tenth of real time (a 120 s episode in 12,000 frames).
MIN_SPEED = 0.1
#: Figure width (pixels) of the PNG, GIF and MP4 frames, by default; with another ``width_px``
#: the map scales with the width, text and line widths with its square root (legible when
#: small).
WIDTH_PX = 640


#: The statuses the episode gives at the start of the tick a robot's time is up (its failure
#: tick is the first with that status); every other way of leaving without arriving is judged
#: after a tick's control period (a touch during it, a stop in it), and shows from the next tick.
_AT_THE_START = frozenset({Status.TIMED_OUT})


def failure_ticks(rec: Recording) -> dict[int, int]:
    """The tick of each failed robot's failure, by robot: the robots whose last status is a
    way of leaving without arriving (:class:`fftnav.states.Status`: collided, timed out,
    lost); the others have none.

    The ``status`` column holds each robot's status at the start of each tick, and the episode
    judges collisions and lost robots after a tick's control period
    (:class:`fftnav.episode.core.EpisodeCore`), so a robot that touched an obstacle during tick
    g (its ``contact_obstacle`` at g) or stopped during it where its estimate put its goal
    shows ``COLLIDED`` or ``LOST`` from tick g + 1 on: its failure tick is g, the tick before
    its first such status. A robot out of time is ``TIMED_OUT`` from the tick its time limit
    is reached (the end tick for those still driving at the end): its failure tick is that
    tick.

    Returns
    -------
    dict of int to int
        Robot -> tick (an index of the recording's ticks), in robot order.

    Examples
    --------
    A robot that collides during tick 1, one that times out at the end (tick 2), one that
    arrives:

    >>> from types import SimpleNamespace
    >>> status = np.array([[1, 1, 1], [1, 1, 1], [3, 4, 2]], np.uint8)
    >>> failure_ticks(SimpleNamespace(status=status))
    {0: 1, 1: 2}
    """
    status = np.asarray(rec.status)
    ticks = {}
    for robot in range(status.shape[1]):
        final = int(status[-1, robot])
        if final not in set(Status) or not Status(final).gone or final == Status.ARRIVED:
            continue
        how = Status(final)
        first = int(np.argmax(status[:, robot] == final))
        ticks[robot] = first if how in _AT_THE_START else max(first - 1, 0)
    return ticks


def drawn_status(rec: Recording) -> np.ndarray:
    """Every robot's status as drawn, ``(G, N)`` :class:`~fftnav.states.Status` codes: the
    recording's, each failed robot's last status from its failure tick on
    (:func:`failure_ticks`)."""
    status = np.array(rec.status, copy=True)
    for robot, tick in failure_ticks(rec).items():
        status[tick:, robot] = status[-1, robot]
    return status


def robot_kinds(rec: Recording, status: np.ndarray | None = None) -> np.ndarray:
    """Every robot's drawn kind at every tick, ``(G, N)`` codes of
    :data:`fftnav.report.frames.KINDS`: :func:`~fftnav.report.frames.kinds_of` of the
    statuses as drawn (``status``, default :func:`drawn_status`: a failed robot is drawn failed
    from its failure tick on) and the recorded modes, each robot keeping its last mode where it
    has none (the end tick)."""
    mode = rec.state.get("mode")
    if mode is not None:
        last = np.where(np.isnan(mode), 0, np.arange(len(mode))[:, None])
        mode = mode[np.maximum.accumulate(last, axis=0), np.arange(mode.shape[1])]
    return kinds_of(drawn_status(rec) if status is None else status, mode)


def limit_s(rec: Recording) -> float:
    """The episode's time limit (s), the clock's end: ``episode.time_limit_s`` after the last
    robot's departure."""
    episode = rec.config.episode
    return episode.time_limit_s + episode.last_departure_s(rec.n_robots)


def safe_radius_m(rec: Recording) -> float:
    """The radius the safe sectors are drawn to (m): the FFT pipeline's safe-distance
    threshold l_th of the recorded robot (``config.geometry.l_th_m``; a beam is safe when every
    beam of its centred window reads at least l_th), at most the sensor range."""
    return min(rec.config.geometry.l_th_m, rec.config.sensor.range_m)


def end_s(rec: Recording) -> float:
    """The episode's end (s), rounded to the microsecond (the ticks' times are sums of the
    control period)."""
    return round(float(rec.time_s[-1]), 6)


def default_robot(rec: Recording) -> int:
    """The robot a replay picks by default: the first that did not arrive, else robot 0."""
    failed = [i for i, row in enumerate(rec.rows) if not row.get("arrived")]
    return failed[0] if failed else 0


def check_robot(rec: Recording, robot: int | None) -> int:
    """``robot`` checked against the recording's robots (None: :func:`default_robot`)."""
    if robot is None:
        return default_robot(rec)
    return check_integer("robot", robot, low=0, high=rec.n_robots - 1)


def recording_frame(rec: Recording, tick: int, picked: int | None,
                    kinds: np.ndarray | None = None,
                    status: np.ndarray | None = None) -> SwarmFrame:
    """The frame of ``tick``: poses, states, trails since the start, the messages delivered in
    the tick, the picked robot's scan (its safe sectors to :func:`safe_radius_m`) and state in
    words, the failure causes, the clock and the time limit (:func:`limit_s`); and, when the
    recording has estimated poses, those of the tick and the estimated paths since the start.
    ``kinds`` and ``status`` are :func:`robot_kinds` and :func:`drawn_status` (made when None)."""
    status = drawn_status(rec) if status is None else status
    kinds = robot_kinds(rec, status) if kinds is None else kinds
    causes = [str(r.get("failure") or "") for r in rec.rows]
    scan, label = None, ""
    if picked is not None:
        scan = ScanView(rec.angles_rad, rec.scan_m[tick, picked], rec.safe[tick, picked],
                        rec.config.sensor.range_m, safe_radius_m(rec))
        state = {name: rec.state[name][tick, picked] for name in ("mode", "side")
                 if name in rec.state}
        label = describe_robot(picked, int(status[tick, picked]), **state,
                               cause=causes[picked])
    delivered = rec.delivered[rec.delivered[:, 0] == tick]
    est = rec.estimates
    return SwarmFrame(
        poses=rec.pose[tick], kinds=kinds[tick],
        trails=[rec.pose[: tick + 1, i, :2] for i in range(rec.n_robots)],
        time_s=float(rec.time_s[tick]), picked=picked, scan=scan,
        messages=delivered[:, 1:3], causes=causes,
        estimates=None if est is None else est[tick],
        estimate_trails=() if est is None else [est[: tick + 1, i, :2]
                                                for i in range(rec.n_robots)],
        end_s=limit_s(rec), picked_label=label)


def window(rec: Recording, from_s: float | None, to_s: float | None) -> tuple[float, float]:
    """The window ``from_s`` .. ``to_s`` (s) checked against the episode; None: its start, its
    end.

    Raises
    ------
    ValueError
        A bound outside the episode or ``from_s > to_s``.
    """
    end = end_s(rec)
    start = check_number("from_s", 0.0 if from_s is None else from_s, low=0.0, high=end)
    stop = check_number("to_s", end if to_s is None else to_s, low=0.0, high=end)
    if start > stop:
        raise FftnavError(f"from_s must be <= to_s, got from_s={start!r}, to_s={stop!r}")
    return start, stop


def frame_ticks(rec: Recording, *, from_s: float | None = None, to_s: float | None = None,
                speed: float = 1.0, fps: float = FPS) -> np.ndarray:
    """The ticks of a video's frames: from ``from_s`` to ``to_s`` (s; default the whole
    episode), ``speed / fps`` s of the episode per frame.

    Raises
    ------
    ValueError
        A bound outside the episode, ``from_s > to_s`` or a speed that is not positive.
    """
    start, stop = window(rec, from_s, to_s)
    speed = check_number("speed", speed, low=MIN_SPEED, high=1000.0)
    times = np.arange(start, stop + 1e-9, speed / fps)
    return np.array([rec.tick_at(t + 1e-9) for t in times], dtype=np.int64)


def _figure(rec: Recording, width_px: int) -> tuple[Any, FramePainter]:
    """The figure of a recording's frames, ``width_px`` wide: its title, the map (with a
    margin of 2 % round the world) and the key below it, an even number of pixel rows (as
    H.264 needs)."""
    w, h = rec.world.size_m
    dpi = 100 * (width_px / WIDTH_PX) ** 0.5
    title = (f"{rec.policy} on {rec.world.env} (map seed {rec.world.seed}, episode seed "
             f"{rec.seed})")
    return keyed_figure(rec.world, rec.config.robot.r0_m, dpi=dpi,
                        map_px=(round(width_px * h / w), width_px), margin=0.02, title=title,
                        estimates=rec.estimates is not None, safe_m=safe_radius_m(rec))


def _pixels(fig: Any) -> np.ndarray:
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()


class _Panels:
    """One figure per recording, drawn at the same episode time and put side by side (the first
    recording on the left): an episode beside another one, e.g. two policies on one map."""

    def __init__(self, recs: Sequence[Recording], robot: int | None, width_px: int) -> None:
        picked = check_robot(recs[0], robot)
        self.recs = list(recs)
        self.picked = [picked] + [check_robot(r, picked if picked < r.n_robots else None)
                                  for r in recs[1:]]
        self.status = [drawn_status(r) for r in recs]
        self.kinds = [robot_kinds(r, status) for r, status in zip(recs, self.status,
                                                                  strict=True)]
        self.figures = [_figure(r, width_px) for r in recs]

    def pixels(self, time_s: float) -> np.ndarray:
        """The frame of every recording at ``time_s`` (each clamped to its end), side by side
        on white."""
        images = []
        for rec, picked, kinds, status, (fig, painter) in zip(
                self.recs, self.picked, self.kinds, self.status, self.figures, strict=True):
            painter.update(recording_frame(rec, rec.tick_at(time_s + 1e-9), picked, kinds,
                                           status))
            images.append(_pixels(fig))
        height = max(image.shape[0] for image in images)
        return np.hstack([np.pad(image, ((0, height - image.shape[0]), (0, 0), (0, 0)),
                                 constant_values=255) for image in images])


def write_image(rec: Recording, path: str | Path, *, at_s: float = 0.0,
                robot: int | None = None, beside: Sequence[Recording] = (),
                width_px: int = WIDTH_PX) -> Path:
    """Write one frame, at ``at_s`` (s), as a PNG (with the recordings ``beside`` at the same
    time to its right, each ``width_px`` wide); returns the path."""
    at_s = check_number("at_s", at_s, low=0.0, high=end_s(rec))
    width_px = check_integer("width_px", width_px, low=MIN_WIDTH_PX, high=4096)
    rgb = _Panels([rec, *beside], robot, width_px).pixels(at_s)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    from PIL import Image

    Image.fromarray(rgb).save(path)
    return path


def write_video(rec: Recording, path: str | Path, *, robot: int | None = None,
                from_s: float | None = None, to_s: float | None = None,
                speed: float = 1.0, beside: Sequence[Recording] = (),
                width_px: int = WIDTH_PX) -> Path:
    """Write the episode (or its window ``from_s`` .. ``to_s``) as a GIF or an MP4, by the
    suffix of ``path``, with the recordings ``beside`` at the same times to its right (each
    still after its end), every panel ``width_px`` wide, :data:`FPS` frames per second;
    returns the path.

    Raises
    ------
    ValueError
        Another suffix, bad bounds (:func:`frame_ticks`).
    fftnav.errors.MissingExtraError
        An MP4 without imageio-ffmpeg (the extra ``video``).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise FftnavError(f"path must end in .gif or .mp4, got path={str(path)!r}")
    if suffix == ".mp4":
        imageio_ffmpeg = import_extra("imageio_ffmpeg", extra="video", needed_for="MP4 videos")
    ticks = frame_ticks(rec, from_s=from_s, to_s=to_s, speed=speed)
    width_px = check_integer("width_px", width_px, low=MIN_WIDTH_PX, high=4096)
    panels = _Panels([rec, *beside], robot, width_px)
    path.parent.mkdir(parents=True, exist_ok=True)
    frames = (panels.pixels(float(rec.time_s[g])) for g in ticks)
    try:
        if suffix == ".gif":
            _write_gif(path, frames, FPS)
        else:
            _write_mp4(imageio_ffmpeg, path, frames, FPS)
    except OSError as exc:  # ffmpeg's many lines, or the file system's refusal, as one line
        raise FftnavError(f"{path}: the {suffix[1:].upper()} could not be written "
                          f"({_write_failure(exc)})") from None
    _check_decodes(path, len(ticks), imageio_ffmpeg if suffix == ".mp4" else None)
    return path


def _write_failure(exc: OSError) -> str:
    """The cause of a failed video write in a few words (a full disk named as such)."""
    text = str(exc)
    if exc.errno == errno.ENOSPC or "No space left on device" in text:
        return "no space left on device"
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else type(exc).__name__


def _check_decodes(path: Path, frames: int, imageio_ffmpeg: Any | None) -> None:
    """Read the written GIF (Pillow) or MP4 (ffmpeg) back: it must decode to ``frames``
    frames, else FftnavError (a file cut short, e.g. by a full disk, is not a video)."""
    try:
        if imageio_ffmpeg is None:
            from PIL import Image

            with Image.open(path) as image:
                decoded = image.n_frames
        else:
            decoded, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    except (OSError, RuntimeError, ValueError, SyntaxError) as exc:
        raise FftnavError(f"{path}: the written video does not decode "
                          f"({str(exc).strip().splitlines()[-1] if str(exc).strip() else exc!r})"
                          f"; is the disk full?") from None
    if decoded != frames:
        raise FftnavError(f"{path}: the written video decodes to {decoded} frames, not "
                          f"{frames}; is the disk full?")


#: The GIF palette's index that no colour takes: the pixels of a frame that have not changed
#: since the frame before (transparent, over what is already shown).
UNCHANGED = 255


def _gif_palette() -> Any:
    """A fixed GIF palette: the state, message and safe colours exactly and as drawn over white
    (trails, message lines, safe sectors), greys and the 6 x 6 x 6 colour cube, each once, so
    that every frame maps the same colours the same way; at most :data:`UNCHANGED` colours, the
    index :data:`UNCHANGED` left free."""
    from PIL import Image

    colours = [kind_rgb(k) for k in KINDS] + [_rgb(c) for c in (MESSAGE_COLOUR, SAFE_COLOUR)]
    colours += [_rgb(KIND_COLOURS[k], TRAIL_ALPHA) for k in KINDS]
    colours += [_rgb(MESSAGE_COLOUR, MESSAGE_ALPHA), _rgb(SAFE_COLOUR, SAFE_ALPHA)]
    colours += [(v, v, v) for v in np.linspace(0, 255, 24).round().astype(int).tolist()]
    colours += [(r, g, b) for r in range(0, 256, 51) for g in range(0, 256, 51)
                for b in range(0, 256, 51)]
    colours = list(dict.fromkeys(colours))[:UNCHANGED]
    palette = Image.new("P", (1, 1))
    palette.putpalette([v for c in colours for v in c])
    return palette


def _rgb(colour: str, alpha: float = 1.0) -> tuple[int, int, int]:
    """``colour`` drawn with opacity ``alpha`` over white, 8-bit RGB."""
    return tuple(round(255 * (alpha * c + 1 - alpha)) for c in to_rgb(colour))  # type: ignore


def _write_gif(path: Path, frames: Any, fps: float) -> None:
    """Frames as a looping GIF on :func:`_gif_palette`, written as they come: each frame after
    the first only as the rectangle that changed, drawn over the frame before (disposal 1),
    its pixels that did not change transparent (:data:`UNCHANGED`), so that long runs of one
    index compress (Pillow's GIF encoder per frame)."""
    from PIL import GifImagePlugin, Image

    palette, duration = _gif_palette(), round(1000 / fps)
    previous = None
    with open(path, "wb") as fp:
        for rgb in frames:
            image = Image.fromarray(rgb).quantize(palette=palette, dither=Image.Dither.NONE)
            index = np.asarray(image)
            if previous is None:
                header, _ = GifImagePlugin.getheader(image, info={"loop": 0,
                                                                  "duration": duration})
                fp.write(b"".join(header))
                fp.write(b"".join(GifImagePlugin.getdata(image, duration=duration,
                                                         disposal=1)))
            else:
                fp.write(b"".join(_changed_part(image, index, previous, duration)))
            previous = index
        fp.write(b";")


def _changed_part(image: Any, index: np.ndarray, previous: np.ndarray,
                  duration: int) -> list[bytes]:
    """A frame's GIF data: the rectangle where ``index`` differs from ``previous``, its
    unchanged pixels :data:`UNCHANGED` (transparent)."""
    from PIL import GifImagePlugin

    changed = index != previous
    where = np.argwhere(changed)
    (y0, x0), (y1, x1) = ((where.min(0), where.max(0) + 1) if len(where)
                          else ((0, 0), (1, 1)))
    part = np.where(changed, index, UNCHANGED)[y0:y1, x0:x1].astype(np.uint8)
    crop = image.crop((int(x0), int(y0), int(x1), int(y1)))
    crop.frombytes(np.ascontiguousarray(part).tobytes())
    return GifImagePlugin.getdata(crop, offset=(int(x0), int(y0)), duration=duration,
                                  transparency=UNCHANGED, disposal=1)


def _write_mp4(imageio_ffmpeg: Any, path: Path, frames: Any, fps: float) -> None:
    """Frames as an H.264 MP4 (yuv420p, plays in browsers and players)."""
    frames = iter(frames)
    first = next(frames)
    height, width = first.shape[:2]
    frames = itertools.chain([first], frames)
    writer = imageio_ffmpeg.write_frames(str(path), (width, height), fps=fps, codec="libx264",
                                         pix_fmt_out="yuv420p", macro_block_size=1,
                                         output_params=["-movflags", "+faststart"])
    writer.send(None)
    try:
        for rgb in frames:
            writer.send(np.ascontiguousarray(rgb))
    finally:
        writer.close()
