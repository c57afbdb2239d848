"""Compiled per-scan steps of the pipeline (optional: needs numba, extra ``fast``).

One scan through :meth:`fftnav.observe.pipeline.Pipeline.process` costs about 45 numpy calls on
360-element arrays, each with its fixed dispatch cost; the arithmetic itself is a few
microseconds. The compiled paths (one scan, and a batch of K scans) keep the paper's FFT
formulation and pocketfft's algorithms (the reference filtering, bit for bit) and run the whole
scan in one compiled call, :func:`scan` (one scan) or :func:`scan_batch` (K scans):

- :func:`prepare` / :func:`prepare_batch`: sanitise and normalise the ranges and write the
  clipped rows (for h1) and the raw rows (for h2) into the zero-padded FFT input, exactly as
  :meth:`fftnav.observe.filters.FilterBank.filter_ranges` does;
- :func:`filter_rows`: the real FFT, the product with the stored spectra and the inverse FFT,
  by rocket-fft's public low-level transforms (``numpy.fft`` / ``scipy.fft`` for numba, built
  on DUCC0, pocketfft's successor) and the complex product as numpy computes it
  (:func:`complex_product`);
- :func:`finish` / :func:`finish_batch`: the safe mask ``y1 >= limit`` (``limit = l_th/R -
  tolerance``, computed by the caller, :func:`fftnav.observe.safe.safe_mask`'s test), the
  extrema of y2 exactly as :func:`fftnav.observe.compress.find_extrema_flat` (same slopes, same
  plateau rule, same clipping of distances) and the whole compact message (header, payload
  words, CRC-16), as :func:`fftnav.observe.codec.encode_sigma` writes it.

Without rocket-fft (:data:`FFT_IN_KERNEL` False) :func:`scan_numpy_fft` and
:func:`scan_batch_numpy_fft` run the same steps with the FFT by ``numpy.fft`` between two
compiled calls.

:func:`entry` returns a kernel's compiled entry point for the one signature the pipeline uses,
which skips numba's per-call type dispatch (about half a microsecond per call with 16
arguments); the pipeline gets its kernels through it once, when it is built.

Every kernel caches its machine code on disk (``cache=True``): only the first run after an
install compiles (numba writes beside this file, or in its user cache directory where the
package folder is read-only, see docs/pipeline.md).

Every operation is the same IEEE double operation as in the numpy path, in the same order, so
masks, y1, y2, extrema and messages are bit-identical (``tests/observe/test_kernels.py`` checks it
on random scans and batches and on every scan of the four Radish logs; the pipeline checks it
on probe scans when it is built). Without numba, :data:`AVAILABLE` is False and the pipeline uses
its numpy path.
"""

from __future__ import annotations

import binascii
import math
from fractions import Fraction

import numpy as np

__all__ = ["AVAILABLE", "CRC_TABLE", "FFT_IN_KERNEL", "complex_product", "crc_heads", "entry",
           "filter_rows", "finish", "finish_batch", "finish_constants", "nearest_safe_beams",
           "prepare", "prepare_batch", "scan", "scan_batch", "scan_batch_numpy_fft",
           "scan_numpy_fft"]

try:  # optional dependency: pip install fftnav[fast]
    from numba import njit, types
except ImportError:  # pragma: no cover - exercised where numba is missing
    AVAILABLE = False
    types = None

    def njit(*args, **kwargs):  # type: ignore[no-redef]
        """Stand-in decorator: the functions stay plain Python (correct, slow, unused)."""
        return args[0] if args and callable(args[0]) else (lambda fn: fn)
else:
    AVAILABLE = True

try:  # optional dependency of the extra ``fast``: the FFT inside the compiled kernels
    import rocket_fft
except ImportError:  # pragma: no cover - exercised where rocket-fft is missing
    rocket_fft = None

#: The compiled kernels run the FFT themselves (numba and rocket-fft installed).
FFT_IN_KERNEL = AVAILABLE and rocket_fft is not None
#: rocket-fft's ``axes`` argument: transform along axis 1 of ``(rows, L)`` arrays.
_ROW_AXIS = np.array([1], dtype=np.int64)


def _crc_table() -> np.ndarray:
    """CRC-16/CCITT (polynomial 0x1021, most significant bit first) of every byte value, the
    table behind :func:`binascii.crc_hqx`."""
    table = np.empty(256, dtype=np.int64)
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
        table[byte] = crc & 0xFFFF
    return table


#: :func:`binascii.crc_hqx`'s table, for the messages :func:`finish` writes (read-only).
CRC_TABLE = _crc_table()
CRC_TABLE.flags.writeable = False


def crc_heads(head: int) -> np.ndarray:
    """``(256,)`` int64: for each count n, :func:`binascii.crc_hqx` from 0xFFFF of the header
    ``(head, n)`` followed by 3 n zero bytes (the part of a compact message's CRC that does not
    depend on its payload)."""
    return np.array([binascii.crc_hqx(bytes((head, n)) + bytes(3 * n), 0xFFFF)
                     for n in range(256)], dtype=np.int64)


def _signatures() -> dict[str, tuple]:
    """The one signature of each kernel in the pipeline (C-contiguous arrays)."""
    f8, i8, b1, u1, c16 = types.float64, types.int64, types.boolean, types.uint8, types.complex128
    return {
        "scan": (f8[:, ::1], c16[:, ::1], c16[:, ::1], b1, f8[::1], i8[::1], b1[::1], f8[::1],
                 u1[::1], i8[::1], i8[::1], f8[::1], f8[:, ::1], b1[:, ::1], f8[:, ::1], b1[::1]),
        "scan_batch": (c16[:, ::1], b1, f8[::1], i8[::1], b1[::1], f8[::1], i8[::1], i8[::1],
                       f8[:, ::1], f8[:, ::1], c16[:, ::1], f8[:, ::1], b1[:, ::1], f8[:, ::1],
                       b1[::1], i8[::1], u1[:, ::1]),
        "prepare": (f8[::1], f8, f8, f8[:, ::1]),
        "finish": (f8[:, ::1], f8[::1], i8[::1], b1[::1], f8[::1], b1[:, ::1], f8[:, ::1],
                   b1[::1], u1[::1], i8[::1], i8[::1]),
        "prepare_batch": (f8[:, ::1], f8, f8, f8[:, ::1]),
        "finish_batch": (f8[:, ::1], i8, f8, b1[::1], b1, f8, f8[::1], f8, f8, f8, b1[:, ::1],
                         f8[:, ::1], b1[::1], i8[::1], u1[:, ::1], i8, i8[::1], i8[::1]),
    }


def entry(name: str):
    """The kernel ``name`` (``"scan"``, ``"scan_batch"``, ``"prepare"``, ``"finish"``,
    ``"prepare_batch"`` or ``"finish_batch"``) as the pipeline calls it: numba's
    compiled entry point for the pipeline's argument types (loaded from numba's cache after
    the first run), or the function itself when it is plain Python (no numba, or a test's
    replacement). The entry point does no type dispatch: the caller passes exactly the types
    of the signature (C-contiguous float64/bool/uint8/int64 arrays, Python floats, ints and
    bools)."""
    fn = globals()[name]
    compile_ = getattr(fn, "compile", None)
    return fn if compile_ is None else compile_(_signatures()[name])


@njit(cache=True, nogil=True)
def _prepare_row(ranges: np.ndarray, range_m: float, threshold: float, work: np.ndarray,
                 clipped: int, raw: int) -> None:
    """Write one scan into rows ``clipped`` (``min(s, l_th/R)``) and ``raw`` (``s = d / R``) of
    ``work``, with ``d = max(min(r, R), 0)`` and NaN read as 0 (columns ``M..L-1`` stay as
    they are, 0).

    The same operations as ``np.minimum``, ``np.fmax``, ``np.divide`` and ``np.minimum`` of
    :meth:`~fftnav.observe.filters.FilterBank.filter_ranges`.
    """
    for i in range(ranges.shape[0]):
        r = ranges[i]
        if r != r:  # NaN: invalid beam, blocked
            d = 0.0
        else:
            d = r if r <= range_m else range_m  # np.minimum (+inf -> R)
            d = d if d >= 0.0 else 0.0  # np.fmax(d, 0)
        s = d / range_m
        work[raw, i] = s
        work[clipped, i] = s if s <= threshold else threshold


@njit(cache=True, nogil=True)
def prepare(ranges: np.ndarray, range_m: float, threshold: float, work: np.ndarray) -> None:
    """Write one scan ``(M,)`` into ``work`` ``(2, L)``: row 0 clipped (for h1), row 1 raw (for
    h2); see :func:`_prepare_row`."""
    _prepare_row(ranges, range_m, threshold, work, 0, 1)


@njit(cache=True, nogil=True)
def prepare_batch(ranges: np.ndarray, range_m: float, threshold: float,
                  work: np.ndarray) -> None:
    """Write K scans ``(K, M)`` into ``work`` ``(2 K, L)``: row k clipped, row K + k raw, the
    layout of :meth:`~fftnav.observe.filters.FilterBank.filter_ranges`."""
    k = ranges.shape[0]
    for i in range(k):
        _prepare_row(ranges[i], range_m, threshold, work, i, k + i)


@njit(cache=True, nogil=True)
def _scan(out: np.ndarray, h1: int, h2: int, tau: int, limit: float, valid: np.ndarray,
          circular: bool, eps: float, angles: np.ndarray, range_m: float, angle_scale: float,
          dist_scale: float, mask: np.ndarray, row: int, sigma: np.ndarray, is_min: np.ndarray,
          start: int, message: np.ndarray, head: int, crc_table: np.ndarray,
          crc_heads: np.ndarray) -> int:
    """Safe mask, extrema and compact message of one filtered scan.

    Parameters
    ----------
    out : ndarray, shape (2 K, L)
        Inverse FFT output: row ``h1`` is the scan's y1, row ``h2`` its y2, both aligned at
        column ``tau``.
    h1, h2 : int
        The scan's rows of ``out``.
    tau : int
        Group delay (0 in circular mode).
    limit : float
        Beam i is safe iff ``y1[i] >= limit``.
    valid : ndarray of bool, shape (W,)
        Columns of the (wrapped, if ``circular``) row that may hold an extremum.
    circular : bool
        The row wraps: one beam of each end is copied beyond the other, as in
        :func:`~fftnav.observe.compress.find_extrema_flat`.
    eps : float
        Flat-slope threshold (``EXTREMUM_EPS``).
    angles : ndarray, shape (M,)
        Beam angles (rad).
    range_m : float
        R (m).
    angle_scale, dist_scale : float
        Quantisation factors of the compact layout (``4096 / 2 pi`` and ``2047 / R``).
    mask : ndarray of bool, shape (K, M)
        Output: row ``row`` is the scan's safe mask.
    row : int
        The scan's row of ``mask``.
    sigma, is_min : ndarray
        Outputs, ``(N, 2)`` float and ``(N,)`` bool: rows ``start .. start + n - 1`` are
        filled with the scan's extrema.
    start : int
        Where the scan's extrema go in ``sigma`` and ``is_min``.
    message : ndarray of uint8, shape (3 (M + 2) + 4,)
        Output: the compact message in its first ``3 n + 4`` bytes: ``head``, n (modulo 256:
        the caller refuses n > 255), 3 big-endian bytes per extremum, and the CRC-16 of all
        that (:func:`binascii.crc_hqx` from 0xFFFF, big-endian).
    head : int
        The layout/version byte of the compact layout.
    crc_table : ndarray of int64, shape (256,)
        :data:`CRC_TABLE`.
    crc_heads : ndarray of int64, shape (256,)
        ``crc_heads[n]``: the CRC-16 of the header of n extrema followed by 3 n zero bytes
        (:func:`crc_heads`), which the payload's CRC from 0 completes.

    Returns
    -------
    int
        The number n of extrema.
    """
    m = angles.shape[0]
    for i in range(m):
        mask[row, i] = out[h1, tau + i] >= limit
    # the row as find_extrema_flat sees it
    width = m + 2 if circular else m
    y = np.empty(width)
    if circular:
        y[0] = out[h2, tau + m - 1]
        y[width - 1] = out[h2, tau]
        for i in range(m):
            y[i + 1] = out[h2, tau + i]
    else:
        for i in range(m):
            y[i] = out[h2, tau + i]
    # consecutive non-flat slopes of opposite sign enclose one extremum, at the middle of the
    # plateau between them (rounded down); with no flat slope, where the slope changes sign
    n = 0
    crc = 0  # CRC-16 of the payload so far, from 0
    last = -1  # index of the last non-flat slope
    last_sign = 0
    for j in range(width - 1):
        d = y[j + 1] - y[j]
        sign = 1 if d > eps else (-1 if d < -eps else 0)
        if sign == 0:
            continue
        if last >= 0 and sign != last_sign:
            col = (last + 1 + j) // 2
            if valid[col]:
                beam = col - 1 if circular else col
                value = y[col] * range_m
                value = value if value >= 0.0 else 0.0
                value = value if value <= range_m else range_m
                angle = angles[beam]
                sigma[start + n, 0] = angle
                sigma[start + n, 1] = value
                minimum = last_sign < 0
                is_min[start + n] = minimum
                qa = np.int64(np.rint(angle * angle_scale))
                qd = np.int64(np.rint(value * dist_scale))
                word = ((qa << 12) & 0xFFF000) | qd | (np.int64(minimum) << 11)
                for k in range(3):  # the word's 3 bytes, and the CRC from 0 through them
                    byte = (word >> (16 - 8 * k)) & 0xFF
                    message[2 + 3 * n + k] = byte
                    crc = ((crc << 8) & 0xFFFF) ^ crc_table[(crc >> 8) ^ byte]
                n += 1
        last, last_sign = j, sign
    message[0] = head
    message[1] = n & 0xFF
    # CRC-16 is linear: crc(0xFFFF, header + payload) = crc(0xFFFF, header + 3 n zero bytes)
    # ^ crc(0, payload); the first term is crc_heads[n]
    crc ^= crc_heads[n & 0xFF]
    message[2 + 3 * n] = crc >> 8
    message[3 + 3 * n] = crc & 0xFF
    return n


@njit(cache=True, nogil=True)
def finish(out: np.ndarray, reals: np.ndarray, ints: np.ndarray, valid: np.ndarray,
           angles: np.ndarray, mask: np.ndarray, sigma: np.ndarray, is_min: np.ndarray,
           message: np.ndarray, crc_table: np.ndarray, crc_heads: np.ndarray) -> int:
    """:func:`_scan` of one scan: ``out`` ``(2, L)`` (y1, y2), ``mask`` ``(1, M)``; returns n,
    the extrema in the first n rows of ``sigma`` and ``is_min``. The scalars come packed, as
    :func:`finish_constants` packs them (fewer arguments to convert per call):
    ``reals = [limit, eps, range_m, angle_scale, dist_scale, ...]``, ``ints = [tau, circular,
    head]``."""
    return _scan(out, 0, 1, ints[0], reals[0], valid, ints[1] != 0, reals[1], angles, reals[2],
                 reals[3], reals[4], mask, 0, sigma, is_min, 0, message, ints[2], crc_table,
                 crc_heads)


def finish_constants(tau: int, limit: float, circular: bool, eps: float, range_m: float,
                     angle_scale: float, dist_scale: float, head: int,
                     threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """``(reals, ints)``, the scalar arguments of :func:`finish` and :func:`scan` packed
    (read-only arrays): ``reals = [limit, eps, range_m, angle_scale, dist_scale, threshold]``,
    ``ints = [tau, circular, head]``."""
    reals = np.array([limit, eps, range_m, angle_scale, dist_scale, threshold],
                     dtype=np.float64)
    ints = np.array([tau, int(circular), head], dtype=np.int64)
    for a in (reals, ints):
        a.flags.writeable = False
    return reals, ints


@njit(cache=True, nogil=True)
def finish_batch(out: np.ndarray, tau: int, limit: float, valid: np.ndarray, circular: bool,
                 eps: float, angles: np.ndarray, range_m: float, angle_scale: float,
                 dist_scale: float, mask: np.ndarray, sigma: np.ndarray, is_min: np.ndarray,
                 offsets: np.ndarray, messages: np.ndarray, head: int, crc_table: np.ndarray,
                 crc_heads: np.ndarray) -> int:
    """:func:`_scan` of K scans: ``out`` ``(2 K, L)`` (y1 of the K scans, then their y2),
    ``mask`` ``(K, M)``, ``messages`` ``(K, 3 (M + 2) + 4)``; the extrema of scan k go to rows
    ``offsets[k] .. offsets[k + 1] - 1`` of ``sigma`` and ``is_min`` (``offsets`` ``(K + 1,)``
    is written). Returns the total number of extrema."""
    k = mask.shape[0]
    offsets[0] = 0
    for i in range(k):
        n = _scan(out, i, k + i, tau, limit, valid, circular, eps, angles, range_m, angle_scale,
                  dist_scale, mask, i, sigma, is_min, offsets[i], messages[i], head, crc_table,
                  crc_heads)
        offsets[i + 1] = offsets[i] + n
    return offsets[k]


if AVAILABLE:
    from llvmlite import ir
    from numba.extending import intrinsic

    @intrinsic
    def _fma(typingctx, a, b, c):
        """``a * b + c`` rounded once (LLVM's ``llvm.fma.f64``: the CPU's fused multiply-add,
        or its exact emulation where there is none)."""
        f8, double = types.float64, ir.DoubleType()

        def codegen(context, builder, signature, args):
            fma = builder.module.declare_intrinsic("llvm.fma", [double],
                                                   ir.FunctionType(double, [double] * 3))
            return builder.call(fma, args)

        return f8(f8, f8, f8), codegen
else:  # pragma: no cover - exercised where numba is missing

    def _fma(a: float, b: float, c: float) -> float:
        """``a * b + c`` rounded once (exact rational arithmetic, then one rounding)."""
        if not all(map(math.isfinite, (a, b, c))):
            return a * b + c
        return float(Fraction(a) * Fraction(b) + Fraction(c))


@njit(cache=True, nogil=True)
def complex_product(a: complex, b: complex, fused: bool) -> complex:
    """``a * b`` as numpy's ``multiply`` loop computes it: ``(ar br - ai bi) + i (ar bi + ai
    br)``, each part with one rounding (``fma(ar, br, -(ai bi))`` and ``fma(ar, bi, ai br)``,
    numpy's SIMD loop where the CPU has fused multiply-add) if ``fused``, else with every
    product rounded (numpy's loop without it). The pipeline checks which one equals numpy's
    on its machine when it is built."""
    ar, ai, br, bi = a.real, a.imag, b.real, b.imag
    if fused:
        return complex(_fma(ar, br, -(ai * bi)), _fma(ar, bi, ai * br))
    return complex(ar * br - ai * bi, ar * bi + ai * br)


@njit(cache=True, nogil=True)
def filter_rows(work: np.ndarray, spec: np.ndarray, spectra: np.ndarray, k: int, fused: bool,
                out: np.ndarray) -> None:
    """``out = irfft(rfft(work) * H)`` row by row, as
    :meth:`~fftnav.observe.filters.FilterBank.filter_ranges` filters: ``work`` and ``out``
    ``(2 K, L)``, ``spec`` ``(2 K, L // 2 + 1)`` (a workspace), rows ``0..K-1`` multiplied by
    ``spectra[0]`` (H1) and rows ``K..2K-1`` by ``spectra[1]`` (H2) (:func:`complex_product`);
    the inverse scaled by ``1 / L``, as ``numpy.fft.irfft``."""
    rocket_fft.r2c(work, spec, _ROW_AXIS, True, 1.0, 1)
    for i in range(spec.shape[0]):
        h = i // k
        for j in range(spec.shape[1]):
            spec[i, j] = complex_product(spec[i, j], spectra[h, j], fused)
    rocket_fft.c2r(spec, out, _ROW_AXIS, False, 1.0 / out.shape[1], 1)


@njit(cache=True, nogil=True)
def scan(work: np.ndarray, spec: np.ndarray, spectra: np.ndarray, fused: bool,
         reals: np.ndarray, ints: np.ndarray, valid: np.ndarray, angles: np.ndarray,
         message: np.ndarray, crc_table: np.ndarray, crc_heads: np.ndarray, ranges: np.ndarray,
         out: np.ndarray, mask: np.ndarray, sigma: np.ndarray, is_min: np.ndarray) -> int:
    """One scan ``ranges`` ``(M,)``, whole: :func:`_prepare_row` into ``work`` ``(2, L)``,
    :func:`filter_rows` into ``out`` ``(2, L)`` (y1, y2 from column tau), :func:`_scan` into
    ``mask`` ``(1, M)``, ``sigma``, ``is_min`` and ``message``; returns n, the number of
    extrema. The constants come first (the pipeline binds them once) and packed as
    :func:`finish_constants` packs them."""
    _prepare_row(ranges, reals[2], reals[5], work, 0, 1)
    filter_rows(work, spec, spectra, 1, fused, out)
    return _scan(out, 0, 1, ints[0], reals[0], valid, ints[1] != 0, reals[1], angles, reals[2],
                 reals[3], reals[4], mask, 0, sigma, is_min, 0, message, ints[2], crc_table,
                 crc_heads)


@njit(cache=True, nogil=True)
def scan_batch(spectra: np.ndarray, fused: bool, reals: np.ndarray, ints: np.ndarray,
               valid: np.ndarray, angles: np.ndarray, crc_table: np.ndarray,
               crc_heads: np.ndarray, ranges: np.ndarray, work: np.ndarray, spec: np.ndarray,
               out: np.ndarray, mask: np.ndarray, sigma: np.ndarray, is_min: np.ndarray,
               offsets: np.ndarray, messages: np.ndarray) -> int:
    """K scans ``ranges`` ``(K, M)``, whole: :func:`prepare_batch` into ``work`` ``(2 K, L)``
    (zero from column M), :func:`filter_rows` into ``out``, :func:`finish_batch` into the
    rest; returns the total number of extrema."""
    prepare_batch(ranges, reals[2], reals[5], work)
    filter_rows(work, spec, spectra, ranges.shape[0], fused, out)
    return finish_batch(out, ints[0], reals[0], valid, ints[1] != 0, reals[1], angles,
                        reals[2], reals[3], reals[4], mask, sigma, is_min, offsets, messages,
                        ints[2], crc_table, crc_heads)


def _numpy_filter(work: np.ndarray, spectra: np.ndarray, out: np.ndarray) -> None:
    """:func:`filter_rows` by ``numpy.fft``, ``spectra`` already one row per row of ``work``
    (the calls of :meth:`~fftnav.observe.filters.FilterBank.filter_ranges`)."""
    spec = np.fft.rfft(work, axis=1)
    spec *= spectra
    out[...] = np.fft.irfft(spec, out.shape[1], axis=1)


def scan_numpy_fft(work: np.ndarray, spec: np.ndarray, spectra: np.ndarray, fused: bool,
                   reals: np.ndarray, ints: np.ndarray, valid: np.ndarray, angles: np.ndarray,
                   message: np.ndarray, crc_table: np.ndarray, crc_heads: np.ndarray,
                   ranges: np.ndarray, out: np.ndarray, mask: np.ndarray, sigma: np.ndarray,
                   is_min: np.ndarray) -> int:
    """:func:`scan` with the FFT by ``numpy.fft`` between the compiled :func:`prepare` and
    :func:`finish` (without rocket-fft); ``spec`` and ``fused`` are unused."""
    prepare(ranges, reals[2], reals[5], work)
    _numpy_filter(work, spectra, out)
    return finish(out, reals, ints, valid, angles, mask, sigma, is_min, message, crc_table,
                  crc_heads)


def scan_batch_numpy_fft(spectra: np.ndarray, fused: bool, reals: np.ndarray, ints: np.ndarray,
                         valid: np.ndarray, angles: np.ndarray, crc_table: np.ndarray,
                         crc_heads: np.ndarray, ranges: np.ndarray, work: np.ndarray,
                         spec: np.ndarray, out: np.ndarray, mask: np.ndarray,
                         sigma: np.ndarray, is_min: np.ndarray, offsets: np.ndarray,
                         messages: np.ndarray) -> int:
    """:func:`scan_batch` with the FFT by ``numpy.fft`` (without rocket-fft); ``spec`` and
    ``fused`` are unused."""
    prepare_batch(ranges, reals[2], reals[5], work)
    _numpy_filter(work, np.repeat(spectra, ranges.shape[0], axis=0), out)
    return finish_batch(out, int(ints[0]), reals[0], valid, bool(ints[1]), reals[1], angles,
                        reals[2], reals[3], reals[4], mask, sigma, is_min, offsets, messages,
                        int(ints[2]), crc_table, crc_heads)


@njit(cache=True, nogil=True)
def nearest_safe_beams(mask: np.ndarray, start: np.ndarray, full: bool, left: np.ndarray,
                       right: np.ndarray) -> None:
    """For each row k of ``mask`` ``(K, M)``: the first safe beam from beam ``start[k]``
    (included) turning counter-clockwise (``left[k]``, increasing index) and clockwise
    (``right[k]``), wrapping around if ``full``; -1 where there is none
    (:func:`fftnav.observe.safe.nearest_safe_headings`)."""
    k_count, m = mask.shape
    for k in range(k_count):
        left[k] = -1
        right[k] = -1
        for offset in range(m):
            i = start[k] + offset
            if i >= m:
                if not full:
                    break
                i -= m
            if mask[k, i]:
                left[k] = i
                break
        for offset in range(m):
            i = start[k] - offset
            if i < 0:
                if not full:
                    break
                i += m
            if mask[k, i]:
                right[k] = i
                break
