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
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from types import MethodType

import numpy as np

from fftnav.observe import kernels
from fftnav.observe.codec import LAYOUTS, codec_scales, pack_messages
from fftnav.observe.compress import EXTREMUM_EPS, find_extrema_flat, quadrant_areas_batch
from fftnav.observe.filters import FilterBank
from fftnav.observe.fusion import own_probability
from fftnav.observe.geometry import RobotGeometry
from fftnav.observe.safe import nearest_safe_headings, safe_mask, safe_tolerance
from fftnav.observe.scan import as_scan_batch, beam_angles_rad, sanitize_ranges
from fftnav.validate import check_choice

# The single-scan path calls pocketfft through scipy's binding, without the Python wrappers of
# numpy.fft / scipy.fft (a few microseconds per call), else numpy.fft itself. Both run
# pocketfft; that the results equal numpy.fft's bit for bit is tested
# (tests/observe/test_kernels.py).
try:
    from scipy.fft._pocketfft import pypocketfft as _pp
except ImportError:  # pragma: no cover - other scipy layouts
    _pp = None

__all__ = ["Pipeline", "PipelineResult", "safe_limit"]

#: pypocketfft's axes argument: transform along axis 1 of (2, L) arrays.
_AXIS = (1,)
#: The dtype of the scans the single-scan path takes as they are (native float64).
_FLOAT64 = np.dtype(np.float64)
_BOOL = np.dtype(bool)
_CONTIGUOUS = (_FLOAT64.itemsize,)  # strides of a C-contiguous scan (M,)
#: The layout byte of compact messages, which the compiled kernel writes...
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


class _made_once:  # noqa: N801 - used as a decorator, like functools.cached_property
    """A field made on first access and kept in the instance's ``__dict__`` (which then
    shadows this non-data descriptor): :func:`functools.cached_property` without its lock,
    which costs about half a microsecond per access on Python 3.11 (one-scan results are not
    shared between threads while they are made)."""

    def __init__(self, make: Callable[[_OneScanResult], np.ndarray]) -> None:
        self.make, self.name = make, make.__name__
        self.__doc__ = make.__doc__

    def __get__(self, obj: _OneScanResult | None, owner: type | None = None):
        if obj is None:
            return self
        value = obj.__dict__[self.name] = self.make(obj)
        return value


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


# A compiled pipeline's ``process`` (bound to it at construction, see Pipeline.process): the
# single-scan path inline for a native float64 C-contiguous scan (M,) without P_s, one Python
# call less than the method; anything else goes to the method's general path. A module-level
# function bound as a method, so that ``pipe.process`` pickles (by pickle and cloudpickle) with
# its pipeline, as the method does. Its docstring is the method's (set below the class).
def _process_scan(self: Pipeline, ranges: np.ndarray, *,
                  with_p_s: bool = True) -> PipelineResult:
    (any_scan, process_one, m, prepare, range_m, threshold, work, spec, spectra, size,
     mask_shape, sigma_shape, finish, reals, ints, valid, angles, message, view, compact,
     layout, tau) = self._scan_state
    # strides (8,) means one dimension, contiguous
    if (type(ranges) is not _NDARRAY or ranges.strides != _CONTIGUOUS or len(ranges) != m
            or ranges.dtype is not _FLOAT64):
        return any_scan(ranges, with_p_s)
    if with_p_s:
        return process_one(ranges, True)
    prepare(ranges, range_m, threshold, work)
    _R2C(work, _AXIS, True, 0, spec, 1)
    _MULTIPLY(spec, spectra, spec)
    out = _C2R(spec, _AXIS, size, False, 2, None, 1)  # inorm=2: 1/n, as numpy.fft.irfft
    mask, sigma, is_min = _EMPTY(mask_shape, _BOOL), _EMPTY(sigma_shape), _EMPTY(m, _BOOL)
    n = finish(out, reals, ints, valid, angles, mask, sigma, is_min, message, _CRC_TABLE,
               _CRC_HEADS)
    if compact and n <= 255:
        msgs = [view[: 3 * n + 4].tobytes()]
    else:  # float32 layout, or too many extrema (pack_messages raises)
        msgs = pack_messages(sigma[:n], is_min[:n], [n], layout=layout, range_m=range_m)
    result = _NEW(_OneScanResult)  # the fields set directly: no dataclass __init__
    result.__dict__.update(safe_mask=mask, messages=msgs, _filtered=out, _tau=tau,
                           _sigma=sigma, _is_min=is_min, _n=n)
    return result


_NDARRAY, _EMPTY, _MULTIPLY, _NEW = np.ndarray, np.empty, np.multiply, object.__new__
_R2C, _C2R = (_pp.r2c, _pp.c2r) if _pp is not None else (None, None)
_CRC_TABLE = kernels.CRC_TABLE


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
    A compiled pipeline writes each scan into workspaces of its own: use one pipeline per
    thread (a copy, ``copy.copy(pipe)``, gets workspaces of its own). Results never share
    them.
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
            raise ValueError("compiled must be False or None without numba (pip install "
                             "fftnav[fast]), got compiled=True")
        self.layout = layout
        self.angles_rad = beam_angles_rad(beams, fov_rad)
        self.compiled = kernels.AVAILABLE if compiled is None else bool(compiled)
        # the shape of one scan that goes straight to the compiled path (None: none does)
        self._one_scan = (beams,) if self.compiled else None
        if self.compiled:
            self._install_compiled_paths()

    def _install_compiled_paths(self) -> None:
        """Build the compiled paths; make the instance's ``process`` :func:`_process_scan`
        bound to this pipeline, unless a subclass overrides :meth:`process`."""
        self._process_one, self._process_many, self._scan_state = self._compiled_paths()
        if type(self).process is Pipeline.process and _pp is not None:
            self.process = MethodType(_process_scan, self)

    def __getstate__(self) -> dict:
        """Pickled and copied without the compiled paths' closures (rebuilt on arrival, with
        workspaces of their own)."""
        state = self.__dict__.copy()
        for name in ("_process_one", "_process_many", "_scan_state", "process"):
            state.pop(name, None)
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
        (A compiled pipeline's ``process`` is a module-level function with this signature,
        bound to the pipeline when it is made, which takes one native float64 C-contiguous scan
        ``(M,)`` itself and hands everything else to this method's general path; a subclass
        that overrides ``process`` keeps its own, and a replacement of ``Pipeline.process``
        reaches pipelines made after it.)
        """
        if (type(ranges) is np.ndarray and ranges.shape == self._one_scan
                and ranges.dtype is _FLOAT64 and ranges.strides == _CONTIGUOUS):
            return self._process_one(ranges, with_p_s)  # one scan, nothing to convert or check
        return self._process_any(ranges, with_p_s)

    def _process_any(self, ranges: np.ndarray, with_p_s: bool) -> PipelineResult:
        """:meth:`process` of anything but a native float64 C-contiguous scan ``(M,)``."""
        b = self.bank
        batch = as_scan_batch(ranges, beams=b.beams)[0]
        if self.compiled and batch.shape[0] == 1:
            return self._process_one(np.ascontiguousarray(batch[0]), with_p_s)
        if self.compiled:
            return self._process_many(np.ascontiguousarray(batch, dtype=float), with_p_s)
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
        return self._result(safe_mask(y1, threshold=b.threshold), y1, y2, flat, flat_min, off,
                            msgs, with_p_s)

    def _compiled_paths(self) -> tuple[Callable[[np.ndarray, bool], PipelineResult],
                                       Callable[[np.ndarray, bool], PipelineResult], tuple]:
        """The compiled paths: ``process_one(ranges, with_p_s)`` for one C-contiguous float64
        scan ``(M,)``, ``process_many(ranges, with_p_s)`` for a C-contiguous float64 batch
        ``(K, M)``, by the compiled kernels around pocketfft (the same FFT calls as
        :meth:`FilterBank.filter_ranges`), and the state of :func:`_process_scan` (the
        instance's ``process``: ``process_one`` inline for such a scan, else
        :meth:`_process_any`).

        Closures over their workspaces and constants, so that a call does no attribute lookup:
        at a dozen microseconds per scan, the interpreter's own work is a tenth of the cost.
        """
        b, m, linear = self.bank, self.bank.beams, self.bank.mode == "linear"
        range_m, threshold, size = b.range_m, b.threshold, b.fft_size
        tau = b.tau if linear else 0
        rows_y1, rows_y2 = (slice(0, 1), slice(tau, tau + m)), (slice(1, 2), slice(tau, tau + m))
        width = m if linear else m + 2  # the row searched for extrema
        bound = 3 * width + 4  # bytes of a message of at most width extrema
        work = np.zeros((2, size))  # columns M.. stay 0: the zero padding
        spec, spectra = np.empty((2, size // 2 + 1), dtype=complex), b._spectra
        message = np.empty(bound, dtype=np.uint8)  # head, n, 3 bytes per extremum, CRC
        view = memoryview(message)  # sliced and copied to bytes faster than the array
        mask_shape, sigma_shape = (1, m), (m, 2)
        # columns of the row that may hold an extremum, as find_extrema_flat
        valid = np.zeros(width, bool)
        inner = self.angles_rad[1:-1] if linear else self.angles_rad
        np.less_equal(np.abs(inner), math.pi - b.blind_rad / 2.0, out=valid[1:-1])
        limit, scales, angles = safe_limit(threshold), codec_scales(range_m), self.angles_rad
        constants = (tau, limit, valid, not linear, EXTREMUM_EPS, angles, range_m, *scales)
        tables = (_COMPACT_HEAD, _CRC_TABLE, _CRC_HEADS)
        # finish's scalars packed into two arrays (its tables are the module's)
        reals, ints = kernels.finish_constants(tau, limit, not linear, EXTREMUM_EPS, range_m,
                                               *scales, _COMPACT_HEAD)
        compact, layout, result_of = self.layout == "compact", self.layout, self._result
        empty, multiply, new = np.empty, np.multiply, object.__new__
        prepare, finish = kernels.entry("prepare"), kernels.entry("finish")
        prepare_batch, finish_batch = kernels.entry("prepare_batch"), kernels.entry("finish_batch")
        r2c = c2r = None
        if _pp is not None:  # inorm=2: scaled by 1/n on the way back, as numpy.fft.irfft
            r2c, c2r = _pp.r2c, _pp.c2r

            def filtered(work: np.ndarray, spec: np.ndarray | None,
                         spectra: np.ndarray) -> np.ndarray:
                spec = r2c(work, _AXIS, True, 0, spec, 1)
                multiply(spec, spectra, spec)
                return c2r(spec, _AXIS, size, False, 2, None, 1)
        else:  # pragma: no cover - other scipy layouts

            def filtered(work: np.ndarray, spec: np.ndarray | None,
                         spectra: np.ndarray) -> np.ndarray:
                return np.fft.irfft(np.fft.rfft(work, axis=1) * spectra, size, axis=1)

        def process_one(ranges: np.ndarray, with_p_s: bool) -> PipelineResult:
            prepare(ranges, range_m, threshold, work)
            if r2c is not None:  # filtered(work, spec, spectra), inline: one call less
                r2c(work, _AXIS, True, 0, spec, 1)
                multiply(spec, spectra, spec)
                out = c2r(spec, _AXIS, size, False, 2, None, 1)
            else:  # pragma: no cover - other scipy layouts
                out = filtered(work, spec, spectra)
            mask, sigma, is_min = empty(mask_shape, _BOOL), empty(sigma_shape), empty(m, _BOOL)
            n = finish(out, reals, ints, valid, angles, mask, sigma, is_min, message, _CRC_TABLE,
                       _CRC_HEADS)
            sigma, is_min = sigma[:n], is_min[:n]
            if compact and n <= 255:
                msgs = [view[: 3 * n + 4].tobytes()]
            else:  # float32 layout, or too many extrema (pack_messages raises)
                msgs = pack_messages(sigma, is_min, [n], layout=layout, range_m=range_m)
            if with_p_s:
                return result_of(mask, out[rows_y1], out[rows_y2], sigma, is_min, _offsets(n),
                                 msgs, True)
            # the fields set directly: the frozen dataclass's __init__ costs a microsecond
            result = new(_OneScanResult)
            result.__dict__.update(safe_mask=mask, sigma_flat=sigma, is_min_flat=is_min,
                                   offsets=_offsets(n), messages=msgs, _filtered=out, _tau=tau)
            return result

        def process_many(ranges: np.ndarray, with_p_s: bool) -> PipelineResult:
            k = ranges.shape[0]
            stacked = np.zeros((2 * k, size))
            prepare_batch(ranges, range_m, threshold, stacked)
            out = filtered(stacked, None, b.repeated_spectra(k))
            mask, offsets = empty((k, m), bool), empty(k + 1, np.int64)
            sigma, is_min = empty((k * width, 2)), empty(k * width, bool)
            messages = empty((k, bound), np.uint8)
            total = finish_batch(out, *constants, mask, sigma, is_min, offsets, messages,
                                 *tables)
            sigma, is_min = sigma[:total], is_min[:total]
            counts = np.diff(offsets).tolist()
            if compact and max(counts) <= 255:
                msgs = [row[: 3 * n + 4].tobytes() for row, n in zip(messages, counts, strict=True)]
            else:  # float32 layout, or too many extrema (pack_messages raises)
                msgs = pack_messages(sigma, is_min, counts, layout=layout, range_m=range_m)
            return result_of(mask, out[:k, tau : tau + m], out[k:, tau : tau + m], sigma,
                             is_min, offsets, msgs, with_p_s)

        # what _process_scan needs, in the order it unpacks it
        state = (self._process_any, process_one, m, prepare, range_m, threshold, work, spec,
                 spectra, size, mask_shape, sigma_shape, finish, reals, ints, valid, angles,
                 message, view, compact, layout, tau)
        return process_one, process_many, state

    def _result(self, mask: np.ndarray, y1: np.ndarray, y2: np.ndarray, flat: np.ndarray,
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


_process_scan.__doc__ = Pipeline.process.__doc__
# pickle reduces a bound method to getattr(instance, __name__): the pipeline's own process;
# cloudpickle finds the function by module and __qualname__ (_process_scan)
_process_scan.__name__ = "process"
