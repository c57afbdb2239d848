"""What a ``sensor_msgs/LaserScan`` means: its beam layout and its REP 117 range values.

Pure numpy: the fields arrive as plain numbers and arrays, whatever read them.

A LaserScan's beam ``n`` points at ``angle_min + n * angle_increment`` (radians, counter-clockwise
from the sensor's x axis, REP 103); ``angle_increment`` is negative for a clockwise scanner.
The pipeline wants beams counter-clockwise, centred on the heading: a :class:`Layout` says how a
message's beams map onto the pipeline's (:func:`layout_of`) and turns the pipeline's angles back
into the message's frame. :func:`rep117_ranges` maps the readings to metres in ``[0, R]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe.scan import FULL_CIRCLE_RAD, wrap_angle

__all__ = ["Layout", "layout_of", "rep117_ranges"]

#: Offsets below this are float32 rounding of the angle fields (their spacing near pi is 2.4e-7).
_FLOAT32_ANGLE_RAD = 1e-6


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
        Angle in the message frame of the pipeline's 0 (its heading).
    closing : bool
        The last beam points where the first does (``M - 1`` increments make a turn, as
        drivers that publish ``angle_min = -pi``, ``angle_max = pi`` do): the pipeline sees a
        full circle of ``M - 1`` beams, the two readings of that direction merged into the
        nearer (an obstacle either saw blocks it), and both beams get its result.
    """

    beams: int
    fov_rad: float
    clockwise: bool
    offset_rad: float
    closing: bool = False

    @property
    def pipeline_beams(self) -> int:
        """Beams of the pipeline: ``M``, or ``M - 1`` with a closing beam."""
        return self.beams - self.closing

    def to_pipeline(self, ranges: np.ndarray) -> np.ndarray:
        """A message's readings (last axis) in the pipeline's beam order."""
        ordered = ranges[..., ::-1] if self.clockwise else ranges
        if not self.closing:
            return ordered
        out = np.array(ordered[..., :-1])
        out[..., 0] = np.minimum(ordered[..., 0], ordered[..., -1])
        return out

    def from_pipeline(self, values: np.ndarray) -> np.ndarray:
        """Per-beam values of the pipeline (last axis) in the message's beam order."""
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

    The last beam must point at ``angle_max``: ``angle_min + (M - 1) angle_increment`` may
    differ from it by less than half an increment (the float32 fields round). ``M`` increments
    within half an increment of a turn make a full circle, and so do ``M - 1`` (a closing beam,
    :attr:`Layout.closing`); otherwise the beams must span less than a turn. ``where`` names
    the message in the errors (ValueError).

    >>> lay = layout_of(-2.356194, 2.356194, 0.004363323, 1081, where="scan 0")
    >>> round(math.degrees(lay.fov_rad), 3), lay.clockwise, lay.offset_rad == 0.0
    (270.0, False, True)
    >>> layout_of(-math.pi, math.pi - math.pi / 180, math.pi / 180, 360, where="x").fov_rad
    6.283185307179586
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
    if abs(last - angle_max) > 0.5 * inc:
        raise FftnavError(
            f"{where}: angle_increment disagrees with the angles and the count: "
            f"angle_min + (M - 1) * angle_increment = {last:.6g} rad but angle_max = "
            f"{angle_max:.6g} rad (M = {beams}; {_show(values)})")
    clockwise = angle_increment < 0
    first = last if clockwise else angle_min  # the pipeline's beam 0, counter-clockwise order
    closing = abs((beams - 1) * inc - FULL_CIRCLE_RAD) <= 0.5 * inc
    if closing or abs(beams * inc - FULL_CIRCLE_RAD) <= 0.5 * inc:
        fov = FULL_CIRCLE_RAD
    else:
        fov = (beams - 1) * inc
        if fov >= FULL_CIRCLE_RAD:
            raise FftnavError(f"{where}: the beams span more than a full turn: "
                              f"(M - 1) * |angle_increment| = {fov:.6g} rad (M = {beams})")
    # the pipeline's beams run from -pi (full circle) or -fov/2: where its 0 is in the message
    offset = (first + math.pi if fov == FULL_CIRCLE_RAD else 0.5 * (angle_min + angle_max))
    return Layout(beams, fov, clockwise, 0.0 if abs(offset) < _FLOAT32_ANGLE_RAD else offset,
                  closing)


def _show(values: dict[str, float]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in values.items())


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
