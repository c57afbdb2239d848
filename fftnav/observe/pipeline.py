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
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.observe import kernels
from fftnav.observe.codec import LAYOUTS, codec_scales, pack_messages
from fftnav.observe.compress import EXTREMUM_EPS, find_extrema_flat, quadrant_areas_batch
from fftnav.observe.filters import FilterBank
from fftnav.observe.fusion import own_probability
from fftnav.observe.geometry import RobotGeometry
from fftnav.observe.safe import nearest_safe_headings, safe_mask, safe_tolerance
from fftnav.observe.scan import as_scan_batch, beam_angles_rad, sanitize_ranges
from fftnav.validate import check_choice

__all__ = ["Pipeline", "PipelineResult", "safe_limit"]

#: The dtype of the scans the single-scan path takes as they are (native float64).
_FLOAT64 = np.dtype(np.float64)
_BOOL = np.dtype(bool)
_CONTIGUOUS = (_FLOAT64.itemsize,)  # strides of a C-contiguous scan (M,)
_NDARRAY, _EMPTY, _NEW = np.ndarray, np.empty, object.__new__
#: The layout byte of compact messages, which the compiled kernels write...
_COMPACT_HEAD = LAYOUTS["compact"]
#: ... and the payload-free parts of their CRCs.
_CRC_HEADS = kernels.crc_heads(_COMPACT_HEAD)
_CRC_HEADS.flags.writeable = False


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


#: x0 and P_s of one scan processed without them (``with_p_s=False``): shared, read-only NaN.
_NAN_X0, _NAN_P_S = _read_only(np.full((1, 4), np.nan)), _read_only(np.full(1, np.nan))


def _offsets(n: int) -> np.ndarray:
    """``offsets`` of one scan with n extrema, ``[0, n]``: shared, read-only."""
    try:
        return _OFFSETS[n]
    except KeyError:
        return _OFFSETS.setdefault(n, _read_only(np.array([0, n])))


_OFFSETS: dict[int, np.ndarray] = {}


def safe_limit(threshold: float) -> float:
    """The value ``y1`` must reach for a safe beam: :func:`fftnav.observe.safe.safe_mask`'s test
    ``y1 >= threshold - tolerance``, for the compiled single-scan path (one place to change if
    the tolerance does)."""
    return threshold - safe_tolerance(threshold)


class _made_once:  # noqa: N801 - used as a decorator, like functools.cached_property
    """A field made on first access and kept in the instance's ``__dict__`` (which then
    shadows this non-data descriptor): :func:`functools.cached_property` without its lock,
    which costs about half a microsecond per access on Python 3.11 (results are not shared
    between threads while their fields are made). The one lazy-field descriptor of results."""

    def __init__(self, make: Callable[[PipelineResult], Any]) -> None:
        self.make, self.name = make, make.__name__
        self.__doc__ = make.__doc__

    def __get__(self, obj: PipelineResult | None, owner: type | None = None):
        if obj is None:
            return self
        value = obj.__dict__[self.name] = self.make(obj)
        return value


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

    Notes
    -----
    Results are read, not written: in a result of one scan by the compiled path, ``offsets``
    (and ``x0`` and ``p_s`` with ``with_p_s=False``) are shared, read-only arrays; copy them
    before changing them.
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

    @_made_once
    def sigma(self) -> list[np.ndarray]:
        return [self.sigma_flat[a:z] for a, z in self._spans]

    @_made_once
    def is_min(self) -> list[np.ndarray]:
        return [self.is_min_flat[a:z] for a, z in self._spans]

    @property
    def _spans(self) -> list[tuple[int, int]]:
        bounds = self.offsets.tolist()
        return list(zip(bounds[:-1], bounds[1:], strict=True))


class _OneScanResult(PipelineResult):
    """:class:`PipelineResult` of one scan by the compiled path without P_s: ``y1`` and ``y2``
    are views of the filter output ``_filtered`` ``(2, L)`` from column ``_tau``, and
    ``sigma_flat``, ``is_min_flat`` and ``offsets`` the first ``_n`` rows of the kernel's
    buffers ``_sigma`` and ``_is_min`` and ``[0, _n]``, all made on first access (five objects
    less per scan for the callers that use only the mask and the message); ``x0`` and ``p_s``
    are the shared NaN arrays."""

    x0 = _NAN_X0
    p_s = _NAN_P_S

    @_made_once
    def sigma_flat(self) -> np.ndarray:  # type: ignore[override]
        return self._sigma[: self._n]

    @_made_once
    def is_min_flat(self) -> np.ndarray:  # type: ignore[override]
        return self._is_min[: self._n]

    @_made_once
    def offsets(self) -> np.ndarray:  # type: ignore[override]
        return _offsets(self._n)

    @_made_once
    def y1(self) -> np.ndarray:  # type: ignore[override]
        return self._filtered[0:1, self._tau : self._tau + self.safe_mask.shape[1]]

    @_made_once
    def y2(self) -> np.ndarray:  # type: ignore[override]
        return self._filtered[1:2, self._tau : self._tau + self.safe_mask.shape[1]]


class _Workspaces:
    """The compiled paths' state, made per pipeline: its buffers, its constants and its kernels
    with the constants bound (so that a scan reads few attributes).

    Attributes
    ----------
    m, size, tau, width : int
        Beams M, FFT length L, group delay (0 in circular mode), and the width of the row
        searched for extrema (M, or M + 2 in circular mode).
    compact : bool
        Compact message layout (written by the kernel itself).
    out_shape, mask_shape, sigma_shape : tuple
        Shapes of one scan's fresh outputs: ``(2, L)``, ``(1, M)``, ``(M, 2)``.
    message, view : ndarray of uint8 and its memoryview
        The message buffer of one scan (sliced and copied to bytes through the view, faster
        than through the array).
    run : callable
        ``run(ranges, out, mask, sigma, is_min) -> n``: :func:`fftnav.observe.kernels.scan`
        (or :func:`~fftnav.observe.kernels.scan_numpy_fft`) with its constants and one-scan
        workspaces bound.
    run_batch : callable
        ``run_batch(ranges, work, spec, out, mask, sigma, is_min, offsets, messages) -> N``:
        :func:`~fftnav.observe.kernels.scan_batch` (or its numpy-FFT twin), constants bound.
    fft_in_kernel : bool
        Whether the kernels run the FFT themselves (else ``numpy.fft`` between two calls).
    """

    __slots__ = ("m", "size", "tau", "width", "compact", "out_shape", "mask_shape",
                 "sigma_shape", "message", "view", "run", "run_batch", "fft_in_kernel")

    def __init__(self, pipe: Pipeline, fft_in_kernel: bool, fused: bool) -> None:
        b, linear = pipe.bank, pipe.bank.mode == "linear"
        m, self.size = b.beams, b.fft_size
        self.m, self.tau, self.width = m, b.tau if linear else 0, m if linear else m + 2
        self.compact, self.fft_in_kernel = pipe.layout == "compact", fft_in_kernel
        self.out_shape, self.mask_shape, self.sigma_shape = (2, self.size), (1, m), (m, 2)
        # head, n, 3 bytes per extremum, CRC: a message of at most width extrema
        self.message = np.empty(3 * self.width + 4, dtype=np.uint8)
        self.view = memoryview(self.message)
        valid = np.zeros(self.width, bool)  # columns that may hold an extremum
        inner = pipe.angles_rad[1:-1] if linear else pipe.angles_rad
        np.less_equal(np.abs(inner), math.pi - b.blind_rad / 2.0, out=valid[1:-1])
        reals, ints = kernels.finish_constants(
            self.tau, safe_limit(b.threshold), not linear, EXTREMUM_EPS, b.range_m,
            *codec_scales(b.range_m), _COMPACT_HEAD, b.threshold)
        if fft_in_kernel:
            scan, scan_batch = kernels.entry("scan"), kernels.entry("scan_batch")
        else:
            scan, scan_batch = kernels.scan_numpy_fft, kernels.scan_batch_numpy_fft
        work = np.zeros((2, self.size))  # columns M.. stay 0: the zero padding
        spec = np.empty((2, self.size // 2 + 1), dtype=complex)
        constants = (reals, ints, valid, pipe.angles_rad)
        self.run = partial(scan, work, spec, b._spectra, fused, *constants, self.message,
                           kernels.CRC_TABLE, _CRC_HEADS)
        self.run_batch = partial(scan_batch, b._spectra, fused, *constants, kernels.CRC_TABLE,
                                 _CRC_HEADS)


class _PerThread(threading.local):
    """A pipeline's :class:`_Workspaces`, one set per thread: made when a thread first uses the
    pipeline (``threading.local`` calls this with the same arguments in every thread)."""

    def __init__(self, pipe: Pipeline, fft_in_kernel: bool, fused: bool) -> None:
        self.w = _Workspaces(pipe, fft_in_kernel, fused)


def _probe_scans(beams: int, range_m: float) -> np.ndarray:
    """Two deterministic scans ``(2, M)`` with open, blocked, invalid and arbitrary readings, on
    which the compiled paths must reproduce the numpy path bit for bit."""
    i = np.arange(beams)
    scans = range_m * np.stack([0.55 + 0.5 * np.sin(0.137 * i) * np.cos(0.0311 * i),
                                0.6 + 0.45 * np.cos(0.071 * i + 0.3)])
    scans[0, 3:7], scans[1, beams // 2], scans[1, -3:] = np.inf, np.nan, -1.0
    return scans


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
    compiled : bool or None
        Process single scans with the compiled kernels of :mod:`fftnav.observe.kernels`
        (bit-identical results, several times faster): None (default) uses them when numba is
        installed; False never does (the numpy path, the reference); True requires numba.

    Notes
    -----
    A pipeline is safe to call from many threads at once: the compiled paths write each scan
    into workspaces of the calling thread (``threading.local``), and results never share them.
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
        compiled: bool | None = None,
    ) -> None:
        self.bank = FilterBank(
            geometry, beams=beams, fov_rad=fov_rad, range_m=range_m, mode=mode, blind_rad=blind_rad
        )
        check_choice("layout", layout, LAYOUTS)
        if compiled and not kernels.AVAILABLE:
            raise FftnavError("compiled must be False or None without numba (pip install "
                              "fftnav[fast]), got compiled=True")
        self.layout = layout
        self.angles_rad = beam_angles_rad(beams, fov_rad)
        self.compiled = kernels.AVAILABLE if compiled is None else bool(compiled)
        # the shape of one scan that goes straight to the compiled path (None: none does)
        self._one_scan = (beams,) if self.compiled else None
        if self.compiled:
            self._install_compiled_paths()

    def _install_compiled_paths(self) -> None:
        """Make the compiled paths' :class:`_Workspaces`: with the FFT inside the kernels if
        they reproduce the numpy path bit for bit on :func:`_probe_scans` (with the complex
        product fused or not, whichever numpy computes on this machine), else with
        ``numpy.fft`` between the compiled steps."""
        if kernels.FFT_IN_KERNEL:
            for fused in (True, False):
                self._local = _PerThread(self, True, fused)
                if self._reproduces_numpy_path():
                    return
        self._local = _PerThread(self, False, False)

    def _reproduces_numpy_path(self) -> bool:
        """Whether the compiled paths, one scan and a batch, give the numpy path's masks,
        filter outputs and messages bit for bit on :func:`_probe_scans`."""
        scans = _probe_scans(self.bank.beams, self.bank.range_m)
        expected = self._process_numpy(scans, False)
        batch = self._process_many(scans, False)
        ones = [self._process_one(scan, False) for scan in scans]
        return (batch.messages == expected.messages
                and [one.messages[0] for one in ones] == expected.messages
                and all(np.array_equal(getattr(batch, name), getattr(expected, name))
                        and np.array_equal(np.concatenate([getattr(one, name) for one in ones]),
                                           getattr(expected, name))
                        for name in ("safe_mask", "y1", "y2")))

    @property
    def fft_in_kernel(self) -> bool:
        """Whether this pipeline's compiled kernels run the FFT themselves (rocket-fft installed
        and bit-identical to ``numpy.fft`` here); False for the numpy path."""
        return self.compiled and self._local.w.fft_in_kernel

    def __getstate__(self) -> dict:
        """Pickled and copied without the compiled paths' workspaces (rebuilt on arrival, its
        own)."""
        state = self.__dict__.copy()
        state.pop("_local", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        if self.compiled:
            self._install_compiled_paths()

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
        A compiled pipeline takes one native float64 C-contiguous scan ``(M,)`` straight to
        its single-scan path, one compiled call; anything else is checked and converted first.
        """
        if (type(ranges) is _NDARRAY and ranges.shape == self._one_scan
                and ranges.dtype is _FLOAT64 and ranges.strides == _CONTIGUOUS):
            return self._process_one(ranges, with_p_s)  # one scan, nothing to convert or check
        return self._process_any(ranges, with_p_s)

    def _process_any(self, ranges: np.ndarray, with_p_s: bool) -> PipelineResult:
        """:meth:`process` of anything but a native float64 C-contiguous scan ``(M,)``."""
        batch = as_scan_batch(ranges, beams=self.bank.beams)[0]
        if not self.compiled:
            return self._process_numpy(batch, with_p_s)
        if batch.shape[0] == 1:
            return self._process_one(np.ascontiguousarray(batch[0]), with_p_s)
        return self._process_many(np.ascontiguousarray(batch, dtype=float), with_p_s)

    def _process_numpy(self, batch: np.ndarray, with_p_s: bool) -> PipelineResult:
        """The numpy path (the reference) of a float batch ``(K, M)``."""
        b = self.bank
        y1, y2 = b.filter_ranges(batch)
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
        return self._result(safe_mask(y1, threshold=b.threshold), y1, y2, flat=flat,
                            flat_min=flat_min, off=off, msgs=msgs, with_p_s=with_p_s)

    def _process_one(self, ranges: np.ndarray, with_p_s: bool) -> PipelineResult:
        """The single-scan path: one C-contiguous float64 scan ``(M,)`` through one compiled
        call (:func:`fftnav.observe.kernels.scan`) into fresh outputs; without P_s, the result
        is a :class:`_OneScanResult` over them."""
        w = self._local.w
        out, mask = _EMPTY(w.out_shape), _EMPTY(w.mask_shape, _BOOL)
        sigma, is_min = _EMPTY(w.sigma_shape), _EMPTY(w.m, _BOOL)
        n = w.run(ranges, out, mask, sigma, is_min)
        if w.compact and n <= 255:
            msgs = [w.view[: 3 * n + 4].tobytes()]
        else:  # float32 layout, or too many extrema (pack_messages raises)
            msgs = pack_messages(sigma[:n], is_min[:n], [n], layout=self.layout,
                                 range_m=self.bank.range_m)
        if with_p_s:
            y = out[:, w.tau : w.tau + w.m]
            return self._result(mask, y[0:1], y[1:2], flat=sigma[:n], flat_min=is_min[:n],
                                off=_offsets(n), msgs=msgs, with_p_s=True)
        result = _NEW(_OneScanResult)  # the fields set directly: no dataclass __init__
        result.__dict__.update(safe_mask=mask, messages=msgs, _filtered=out, _tau=w.tau,
                               _sigma=sigma, _is_min=is_min, _n=n)
        return result

    def _process_many(self, ranges: np.ndarray, with_p_s: bool) -> PipelineResult:
        """The compiled path of a C-contiguous float64 batch ``(K, M)``: one compiled call
        (:func:`fftnav.observe.kernels.scan_batch`)."""
        w, k = self._local.w, ranges.shape[0]
        work = np.zeros((2 * k, w.size))  # columns M.. stay 0: the zero padding
        spec, out = _EMPTY((2 * k, w.size // 2 + 1), complex), _EMPTY((2 * k, w.size))
        mask, offsets = _EMPTY((k, w.m), bool), _EMPTY(k + 1, np.int64)
        sigma, is_min = _EMPTY((k * w.width, 2)), _EMPTY(k * w.width, bool)
        messages = _EMPTY((k, len(w.message)), np.uint8)
        total = w.run_batch(ranges, work, spec, out, mask, sigma, is_min, offsets, messages)
        sigma, is_min = sigma[:total], is_min[:total]
        counts = np.diff(offsets).tolist()
        if w.compact and max(counts) <= 255:
            msgs = [row[: 3 * n + 4].tobytes() for row, n in zip(messages, counts, strict=True)]
        else:  # float32 layout, or too many extrema (pack_messages raises)
            msgs = pack_messages(sigma, is_min, counts, layout=self.layout,
                                 range_m=self.bank.range_m)
        y = out[:, w.tau : w.tau + w.m]
        return self._result(mask, y[:k], y[k:], flat=sigma, flat_min=is_min, off=offsets,
                            msgs=msgs, with_p_s=with_p_s)

    def _result(self, mask: np.ndarray, y1: np.ndarray, y2: np.ndarray, *, flat: np.ndarray,
                flat_min: np.ndarray, off: np.ndarray, msgs: list[bytes],
                with_p_s: bool) -> PipelineResult:
        b = self.bank
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
            safe_mask=mask,
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
