"""What a ``sensor_msgs/LaserScan`` means: its beam layout and its REP 117 range values.

Pure numpy: the fields arrive as plain numbers and arrays, whatever read them.

A LaserScan's beam ``n`` points at ``angle_min + n * angle_increment`` (radians, counter-clockwise
from the sensor's x axis, REP 103); ``angle_increment`` is negative for a clockwise scanner. The
heading is the laser frame's angle 0 (its +x axis), whatever angle the scan starts at.

The pipeline wants beams counter-clockwise: a full circle from its back (``-pi``, beam ``M / 2``
straight ahead), a partial field of view centred on its own 0. A :class:`Layout` says how a
message's beams map onto the pipeline's (:func:`layout_of`; :meth:`Layout.of_fov` for ``.npy`` and
``.csv`` scans with a stated field of view) and turns the pipeline's angles back into the message's
frame; :class:`LayoutPipelines` runs a layout's scans and gives each one's results in its message's
beam order and frame (:class:`ScanResult`). :func:`rep117_ranges` maps the readings to metres in
``[0, R]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe.compress import quadrant_areas_batch
from fftnav.observe.fusion import own_probability
from fftnav.observe.geometry import RobotGeometry
from fftnav.observe.pipeline import Pipeline, PipelineResult
from fftnav.observe.safe import safe_sectors_rad
from fftnav.observe.scan import FULL_CIRCLE_RAD, angle_increment_rad, is_full_circle, wrap_angle

__all__ = ["NARROW", "NO_HEADING", "Layout", "LayoutPipelines", "ScanResult", "layout_of",
           "rep117_ranges", "window_beams"]

#: Offsets below this are float32 rounding of the angle fields (their spacing near pi is 2.4e-7).
_FLOAT32_ANGLE_RAD = 1e-6
#: The ``reason`` of a scan with fewer beams than the safety window: nothing is safe.
NARROW = "segment narrower than the safety window"
#: The ``reason`` of a partial field of view without the heading: no left/right probability.
NO_HEADING = "the field of view does not contain the heading (angle 0)"


@dataclass(frozen=True)
class Layout:
    """The beam layout of a LaserScan as the pipeline sees it.

    Attributes
    ----------
    beams : int
        Readings per message M.
    fov_rad : float
        The pipeline's field of view: exactly ``2 pi`` for a full circle (``M`` increments make
        a turn), else ``(M - 1) |angle_increment|``.
    clockwise : bool
        ``angle_increment < 0``: the message's beams are reversed for the pipeline.
    offset_rad : float
        Angle in the message frame of the pipeline's 0 (its heading), in ``[-pi, pi)``: the
        centre of a partial field of view; for a full circle the distance from the message's
        angle 0 to the beam the pipeline puts straight ahead (at most half an increment).
    closing : bool
        The last beam points where the first does (``M - 1`` increments make a turn, as
        drivers that publish ``angle_min = -pi``, ``angle_max = pi`` do): the pipeline sees a
        full circle of ``M - 1`` beams, the two readings of that direction merged into the
        nearer (an obstacle either saw blocks it), and both beams get its result.
    shift : int
        Full circle: the pipeline's beam ``n`` is the message's beam ``(n + shift) mod M``
        (counted counter-clockwise, after the merge of a closing beam), so that the pipeline's
        heading is the beam nearest to the message's angle 0 wherever the scan starts; 0 for
        a partial field of view.
    heading_in_view : bool
        The heading, angle 0, lies in the field of view (within half an increment).
    angle_max_corrected : float or None
        The last beam's angle ``angle_min + (M - 1) angle_increment`` (rad) when the message's
        ``angle_max`` is off by more than half an increment and at most one; else None.
    """

    beams: int
    fov_rad: float
    clockwise: bool
    offset_rad: float
    closing: bool = False
    shift: int = 0
    heading_in_view: bool = True
    angle_max_corrected: float | None = None

    @classmethod
    def of_fov(cls, beams: int, fov_rad: float) -> Layout:
        """The layout of a scan file's rows (``.npy``, ``.csv``, CARMEN): ``beams`` readings
        counter-clockwise over a stated field of view, a full circle from ``-pi`` (no closing
        beam), a partial one centred on the heading."""
        angle_increment_rad(beams, fov_rad)  # validates beams and fov_rad
        full = is_full_circle(fov_rad)
        return cls(int(beams), FULL_CIRCLE_RAD if full else float(fov_rad), False, 0.0)

    @property
    def pipeline_beams(self) -> int:
        """Beams of the pipeline: ``M``, or ``M - 1`` with a closing beam."""
        return self.beams - self.closing

    @property
    def full_circle(self) -> bool:
        """Whether the beams cover a full turn (filtered with wrap-around)."""
        return self.fov_rad == FULL_CIRCLE_RAD

    def to_pipeline(self, ranges: np.ndarray) -> np.ndarray:
        """A message's readings (last axis) in the pipeline's beam order."""
        ordered = ranges[..., ::-1] if self.clockwise else ranges
        if self.closing:
            merged = np.array(ordered[..., :-1])
            merged[..., 0] = np.minimum(ordered[..., 0], ordered[..., -1])
            ordered = merged
        return np.roll(ordered, -self.shift, axis=-1) if self.shift else ordered

    def from_pipeline(self, values: np.ndarray) -> np.ndarray:
        """Per-beam values of the pipeline (last axis) in the message's beam order: the inverse
        of :meth:`to_pipeline` (the closing beam gets the first beam's value)."""
        if self.shift:
            values = np.roll(values, self.shift, axis=-1)
        if self.closing:
            values = np.concatenate([values, values[..., :1]], axis=-1)
        return values[..., ::-1] if self.clockwise else values

    def angles_rad(self, pipeline_angles_rad: np.ndarray) -> np.ndarray:
        """Angles of the pipeline (sectors, extrema) in the message frame, in ``[-pi, pi)``;
        unchanged when the pipeline's heading is the message's x axis."""
        if self.offset_rad == 0.0:
            return np.asarray(pipeline_angles_rad, dtype=np.float64)
        return wrap_angle(np.asarray(pipeline_angles_rad) + self.offset_rad)


def layout_of(angle_min: float, angle_max: float, angle_increment: float, beams: int, *,
              where: str) -> Layout:
    """The :class:`Layout` of a message, checked.

    Beam ``n`` points at ``angle_min + n angle_increment``: the count and the increment make
    the layout. The last beam should point at ``angle_max``; a difference of up to half an
    increment is float32 rounding, and one of up to one increment (drivers that publish the
    angle one beam past the last) is corrected (:attr:`Layout.angle_max_corrected`). ``M``
    increments within half an increment of a turn make a full circle, and so do ``M - 1`` (a
    closing beam, :attr:`Layout.closing`), wherever the scan starts; otherwise the beams must
    span less than a turn. ``where`` names the message in the errors (ValueError).

    >>> lay = layout_of(-2.356194, 2.356194, 0.004363323, 1081, where="scan 0")
    >>> round(math.degrees(lay.fov_rad), 3), lay.clockwise, lay.offset_rad == 0.0
    (270.0, False, True)
    >>> lay = layout_of(0.0, 2 * math.pi, math.pi / 180, 360, where="x")  # one beam too far
    >>> lay.fov_rad, lay.shift, round(lay.angle_max_corrected, 6)
    (6.283185307179586, 180, 6.265732)
    """
    values = {"angle_min": angle_min, "angle_max": angle_max,
              "angle_increment": angle_increment}
    if beams < 2:
        raise FftnavError(f"{where}: a LaserScan needs at least 2 ranges, got {beams}")
    if not all(math.isfinite(v) for v in values.values()) or angle_increment == 0.0:
        raise FftnavError(f"{where}: angle_min, angle_max and angle_increment must be finite "
                          f"and angle_increment nonzero, got {_show(values)}")
    inc = abs(angle_increment)
    last = angle_min + (beams - 1) * angle_increment
    miss = abs(last - angle_max)
    if miss > inc + _FLOAT32_ANGLE_RAD:
        raise FftnavError(
            f"{where}: angle_increment disagrees with the angles and the count: "
            f"angle_min + (M - 1) * angle_increment = {last:.6g} rad but angle_max = "
            f"{angle_max:.6g} rad, more than one increment away (M = {beams}; {_show(values)})")
    clockwise = angle_increment < 0
    first = last if clockwise else angle_min  # the message's beam 0, counter-clockwise order
    closing = abs((beams - 1) * inc - FULL_CIRCLE_RAD) <= 0.5 * inc
    shift, fov = 0, FULL_CIRCLE_RAD
    if closing or abs(beams * inc - FULL_CIRCLE_RAD) <= 0.5 * inc:
        # the pipeline's beam 0 is at -pi: the message's beam nearest to it
        shift = round((-math.pi - first) / inc) % (beams - closing)
        offset = float(wrap_angle(first + shift * inc + math.pi))
    else:
        fov = (beams - 1) * inc
        if fov >= FULL_CIRCLE_RAD:
            raise FftnavError(f"{where}: the beams span more than a full turn: "
                              f"(M - 1) * |angle_increment| = {fov:.6g} rad (M = {beams})")
        offset = float(wrap_angle(first + 0.5 * fov))  # the centre of the field of view
    return Layout(beams, fov, clockwise, 0.0 if abs(offset) < _FLOAT32_ANGLE_RAD else offset,
                  closing, shift,
                  fov == FULL_CIRCLE_RAD or abs(offset) <= 0.5 * (fov + inc) + _FLOAT32_ANGLE_RAD,
                  last if miss > 0.5 * inc else None)


def _show(values: dict[str, float]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in values.items())


def window_beams(geometry: RobotGeometry, layout: Layout) -> int:
    """Beams of the safety window of a layout (:attr:`fftnav.observe.filters.FilterBank.
    window_beams`, without designing the filters): ``Tc = ceil(alpha / increment)``, made odd.
    A layout of fewer beams has no safe beam: every window runs past its ends."""
    inc = angle_increment_rad(layout.pipeline_beams, layout.fov_rad)
    tc = math.ceil(geometry.alpha_rad / inc - 1e-9)
    return tc if tc % 2 else tc + 1


@dataclass(frozen=True)
class ScanResult:
    """The pipeline's results of one scan, in its message's beam order and frame.

    Attributes
    ----------
    safe_mask : ndarray of bool, shape (M,)
        Safe beams, message order.
    y1 : ndarray, shape (M,)
        The safety filter's output (normalised, ``/ R``), message order.
    sectors_rad : ndarray, shape (n, 2)
        Safe sectors ``(start, end)``, counter-clockwise, message frame (rad).
    extrema : ndarray, shape (n, 2)
        Sigma: angle (rad, message frame) and distance (m) of each extremum.
    is_min : ndarray of bool, shape (n,)
        Which extrema are minima.
    message_bytes : int
        Size of the compact message (4 bytes for no extremum).
    p_left : float or None
        P_s, the probability of turning left around the heading (angle 0 of the message
        frame); None with :data:`NARROW` or :data:`NO_HEADING`.
    reason : str or None
        Why the scan gives no safe beam (:data:`NARROW`) or no P_s (:data:`NO_HEADING`).
    """

    safe_mask: np.ndarray
    y1: np.ndarray
    sectors_rad: np.ndarray
    extrema: np.ndarray
    is_min: np.ndarray
    message_bytes: int
    p_left: float | None
    reason: str | None = None

    def fields(self) -> dict[str, Any]:
        """The JSON fields of ``fftnav scan`` from ``safe_mask`` to ``p_left`` (degrees and
        metres, rounded), then ``reason`` if there is one."""
        sig = self.extrema
        row = {
            "safe_mask": self.safe_mask.astype(np.uint8).tolist(),
            "safe_sectors_deg": np.round(np.degrees(self.sectors_rad).reshape(-1, 2),
                                         3).tolist(),
            "extrema": np.round(np.column_stack([np.degrees(sig[:, 0]), sig[:, 1]]),
                                4).tolist(),
            "extrema_is_min": self.is_min.tolist(),
            "message_bytes": self.message_bytes,
            "p_left": None if self.p_left is None else round(self.p_left, 6),
        }
        if self.reason is not None:
            row["reason"] = self.reason
        return row


class LayoutPipelines:
    """A :class:`~fftnav.observe.pipeline.Pipeline` per (pipeline beams, field of view, R),
    made on first use: wrap-around filtering (``mode="circular"``) for a full circle, the
    paper's zero padding for a partial field of view; none for a layout narrower than the
    safety window (:func:`window_beams`), whose scans get :meth:`narrow`.

    Parameters
    ----------
    geometry : RobotGeometry
        The robot the safe directions are for.
    """

    def __init__(self, geometry: RobotGeometry) -> None:
        self.geometry = geometry
        self.pipes: dict[tuple[int, float, float], Pipeline | None] = {}

    def get(self, layout: Layout, range_m: float) -> Pipeline | None:
        """The pipeline of a layout and range; None when the layout is narrower than the
        window. Raises ValueError for a range R below ``l_th`` (nothing could be safe)."""
        key = (layout.pipeline_beams, layout.fov_rad, float(range_m))
        if key not in self.pipes:
            if not (math.isfinite(range_m) and range_m >= self.geometry.l_th_m):
                raise FftnavError(f"range_m must be finite and >= l_th_m="
                                  f"{self.geometry.l_th_m:.4g}, got range_m={range_m!r}")
            self.pipes[key] = None if layout.pipeline_beams < window_beams(
                self.geometry, layout) else Pipeline(
                self.geometry, beams=key[0], fov_rad=key[1], range_m=key[2],
                mode="circular" if layout.full_circle else "linear")
        return self.pipes[key]

    @staticmethod
    def narrow(layout: Layout) -> ScanResult:
        """The result of a scan narrower than the safety window: no safe beam, no extremum
        (the 4-byte message of an empty Sigma), no P_s, :data:`NARROW`."""
        return ScanResult(np.zeros(layout.beams, bool), np.zeros(layout.beams),
                          np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, bool), 4, None,
                          NARROW)

    @staticmethod
    def result(layout: Layout, pipe: Pipeline, res: PipelineResult, row: int) -> ScanResult:
        """Scan ``row`` of a pipeline result in its message's beam order and frame. P_s is
        the pipeline's own when its heading is the message's angle 0, else computed again from
        the extrema in the message frame (the same quadrant areas, around angle 0); None when a
        partial field of view does not contain angle 0 (:data:`NO_HEADING`)."""
        mask, sig = res.safe_mask[row], res.sigma[row]
        sectors = layout.angles_rad(np.asarray(safe_sectors_rad(mask, fov_rad=layout.fov_rad)))
        extrema = np.column_stack([layout.angles_rad(sig[:, 0]), sig[:, 1]])
        if not layout.heading_in_view:
            p_left = None
        elif layout.offset_rad == 0.0:
            p_left = float(res.p_s[row])
        else:
            p_left = _p_left_at_zero(layout, pipe, sig)
        return ScanResult(layout.from_pipeline(mask), layout.from_pipeline(res.y1[row]),
                          sectors, extrema, res.is_min[row], len(res.messages[row]), p_left,
                          None if layout.heading_in_view else NO_HEADING)


def _p_left_at_zero(layout: Layout, pipe: Pipeline, sigma: np.ndarray) -> float:
    """P_s of one scan's extrema (pipeline frame) around the message's angle 0: the angles
    shifted by the layout's offset (wrapped and sorted again for a full circle; a partial
    field of view holding angle 0 stays inside ``(-2 pi, 2 pi)`` and in order)."""
    b = pipe.bank
    phi = sigma[:, 0] + layout.offset_rad
    shifted = np.column_stack([phi, sigma[:, 1]])
    if layout.full_circle:
        shifted[:, 0] = wrap_angle(phi)
        shifted = shifted[np.argsort(shifted[:, 0], kind="stable")]
    x0 = quadrant_areas_batch(shifted, np.array([0, len(shifted)]), alpha_rad=b.geometry.alpha_rad,
                              range_m=b.range_m, full_circle=b.full_circle)
    return float(own_probability(x0)[0])


def rep117_ranges(ranges: np.ndarray, *, range_min: float, range_max: float,
                  range_m: float) -> np.ndarray:
    """LaserScan readings in metres in ``[0, R]`` (a new float64 array), by REP 117.

    ``+inf`` (no return) and readings above ``range_max`` read ``R``; ``-inf`` (closer than
    ``range_min``), NaN (an invalid reading) and finite readings below ``range_min`` (invalid)
    read 0, which the pipeline counts as blocked; everything else is clipped to ``R``.

    >>> rep117_ranges(np.array([np.inf, -np.inf, np.nan, 0.05, 1.0, 40.0, 8.0]),
    ...               range_min=0.1, range_max=30.0, range_m=5.0)
    array([5., 0., 0., 0., 1., 5., 5.])
    """
    d = np.asarray(ranges, dtype=np.float64)
    out = np.where(d > range_max, range_m, np.minimum(d, range_m))  # +inf is > range_max
    out[~(d >= range_min)] = 0.0  # NaN, -inf, below range_min
    return out
