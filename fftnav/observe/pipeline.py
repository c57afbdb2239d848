"""One batched call for the whole observation pipeline of K robots (paper Sec. III-B to III-E).

>>> import numpy as np
>>> from fftnav import SIM_ROBOT, Pipeline
>>> pipe = Pipeline(SIM_ROBOT, beams=360, range_m=3.0)
>>> res = pipe.process(np.full(360, 3.0))      # one open scan
>>> bool(res.safe_mask[0, 180]), res.messages[0][:1].hex()
(True, 'c1')
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fftnav.observe.codec import LAYOUTS, pack_messages
from fftnav.observe.compress import find_extrema_flat, quadrant_areas_batch
from fftnav.observe.filters import FilterBank
from fftnav.observe.fusion import own_probability
from fftnav.observe.geometry import RobotGeometry
from fftnav.observe.safe import nearest_safe_headings, safe_mask
from fftnav.observe.scan import as_scan_batch, beam_angles_rad, sanitize_ranges
from fftnav.validate import check_choice

__all__ = ["Pipeline", "PipelineResult"]


@dataclass(frozen=True)
class PipelineResult:
    """Outputs of :meth:`Pipeline.process` for K scans (K = 1 for a single scan).

    Attributes
    ----------
    safe_mask : ndarray of bool, shape (K, M)
        Safe beams, eq. (y1 for safe), in input beam order.
    y1, y2 : ndarray, shape (K, M)
        Filter outputs, normalised units (``/ R``).
    sigma_flat : ndarray, shape (N, 2)
        Extrema of y2 of all scans, scan by scan
        (:func:`fftnav.observe.compress.find_extrema_flat`):
        angle (rad, CCW from heading), distance (m).
    is_min_flat : ndarray of bool, shape (N,)
        Which of them are minima.
    offsets : ndarray of int, shape (K + 1,)
        Scan k owns rows ``offsets[k]:offsets[k + 1]`` of the flat arrays.
    messages : list of bytes
        Compact messages (:func:`fftnav.observe.codec.encode_sigma`), one per scan.
    x0 : ndarray, shape (K, 4)
        Normalised quadrant areas [I, II, III, IV], eq. (x_i).
    p_s : ndarray, shape (K,)
        Own probability of turning left, eq. (P_s).
    sigma : list of ndarray (n_k, 2)
        Per-scan views of ``sigma_flat`` (made on first access).
    is_min : list of ndarray of bool (n_k,)
        Per-scan views of ``is_min_flat`` (made on first access).
    """

    safe_mask: np.ndarray
    y1: np.ndarray
    y2: np.ndarray
    sigma_flat: np.ndarray
    is_min_flat: np.ndarray
    offsets: np.ndarray
    messages: list[bytes]
    x0: np.ndarray
    p_s: np.ndarray

    @cached_property
    def sigma(self) -> list[np.ndarray]:
        return [self.sigma_flat[a:z] for a, z in self._spans]

    @cached_property
    def is_min(self) -> list[np.ndarray]:
        return [self.is_min_flat[a:z] for a, z in self._spans]

    @property
    def _spans(self) -> list[tuple[int, int]]:
        bounds = self.offsets.tolist()
        return list(zip(bounds[:-1], bounds[1:], strict=True))


class Pipeline:
    """Filter bank plus every per-scan step: safe mask, Sigma, compact message, P_s.

    Parameters
    ----------
    geometry : RobotGeometry
        Robot model (eqs. (1)-(2)).
    beams, fov_rad, range_m, mode, blind_rad
        Passed to :class:`fftnav.observe.filters.FilterBank` (defaults: the paper's simulated lidar,
        M = 360, 360 degrees, R = 3 m, linear mode, 15 degree blind sector).
    layout : {"compact", "float32"}
        Message layout.
    """

    def __init__(
        self,
        geometry: RobotGeometry,
        *,
        beams: int = 360,
        fov_rad: float = 2.0 * math.pi,
        range_m: float = 3.0,
        mode: str = "linear",
        blind_rad: float | None = None,
        layout: str = "compact",
    ) -> None:
        self.bank = FilterBank(
            geometry, beams=beams, fov_rad=fov_rad, range_m=range_m, mode=mode, blind_rad=blind_rad
        )
        check_choice("layout", layout, LAYOUTS)
        self.layout = layout
        self.angles_rad = beam_angles_rad(beams, fov_rad)

    def normalise(self, ranges: np.ndarray) -> np.ndarray:
        """Validated, sanitised ``(K, M)`` normalised scans ``d / R`` (a new array)."""
        batch, _ = as_scan_batch(ranges, beams=self.bank.beams)
        return sanitize_ranges(batch, range_m=self.bank.range_m) / self.bank.range_m

    def safe_mask(self, ranges: np.ndarray) -> np.ndarray:
        """Only the safe mask, ``(K, M)`` bool (or ``(M,)`` for one scan)."""
        _, single = as_scan_batch(ranges, beams=self.bank.beams)
        y1 = self.bank.filter_h1(self.normalise(ranges))
        mask = safe_mask(y1, threshold=self.bank.threshold)
        return mask[0] if single else mask

    def process(self, ranges: np.ndarray, *, with_p_s: bool = True) -> PipelineResult:
        """Run the pipeline on one scan ``(M,)`` or a batch ``(K, M)`` of ranges in metres.

        Readings are sanitised first (``+inf`` and ``>= R``: open, NaN and negative: blocked);
        the input is not modified. ``with_p_s=False`` skips the quadrant areas and P_s (NaN).
        """
        b = self.bank
        y1, y2 = b.filter_ranges(as_scan_batch(ranges, beams=b.beams)[0])
        flat, flat_min, off = find_extrema_flat(
            y2,
            angles_rad=self.angles_rad,
            range_m=b.range_m,
            blind_rad=b.blind_rad,
            circular=b.mode == "circular",
        )
        msgs = pack_messages(
            flat, flat_min, np.diff(off).tolist(), layout=self.layout, range_m=b.range_m
        )
        if with_p_s:
            x0 = quadrant_areas_batch(
                flat,
                off,
                alpha_rad=b.geometry.alpha_rad,
                range_m=b.range_m,
                full_circle=b.full_circle,
            )
            p_s = own_probability(x0)
        else:
            nan = np.full((len(msgs), 5), np.nan)
            x0, p_s = nan[:, :4], nan[:, 4]
        return PipelineResult(
            safe_mask=safe_mask(y1, threshold=b.threshold),
            y1=y1,
            y2=y2,
            sigma_flat=flat,
            is_min_flat=flat_min,
            offsets=off,
            messages=msgs,
            x0=x0,
            p_s=p_s,
        )

    def nearest_safe_headings(
        self, mask: np.ndarray, target_rad: np.ndarray | float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Nearest safe heading left and right of each target (rad, NaN if none); batched."""
        return nearest_safe_headings(mask, target_rad, fov_rad=self.bank.fov_rad)
