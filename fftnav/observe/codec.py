"""Binary messages carrying Sigma between robots (paper Sec. III-D, "about 16 f0 bytes").

Two layouts, both ``[layout/version byte][count n][payload][CRC-16]``; the CRC is
CRC-16/CCITT-FALSE (``binascii.crc_hqx``, init 0xFFFF) over everything before it, big-endian.

* ``"float32"`` (first byte 0xF1): per extremum two little-endian float32, angle (rad) and
  distance (m); a minimum is flagged by the distance's sign bit (``-d``, also for ``d = 0``).
  ``4 + 8 n`` bytes: 68 bytes for the paper's 8 extrema.
* ``"compact"`` (first byte 0xC1): per extremum 3 bytes (big-endian 24 bits): a 12-bit angle
  ``round(phi mod 2pi / 2pi * 4096)``, one minimum bit, an 11-bit distance ``round(d / R * 2047)``.
  ``4 + 3 n`` bytes: 28 bytes for 8 extrema. Quantisation error: at most ``pi / 4096`` rad
  (0.044 deg) in angle and ``R / 4094`` in distance (0.73 mm for R = 3 m).

Pure numpy + stdlib.
"""

from __future__ import annotations

import binascii
import math

import numpy as np

from fftnav.errors import FftnavError
from fftnav.validate import check_choice, check_number

__all__ = [
    "LAYOUTS",
    "MessageError",
    "encode_sigma",
    "encode_batch",
    "pack_messages",
    "packed_message",
    "codec_scales",
    "decode_sigma",
    "decode_message",
]

LAYOUTS = {"compact": 0xC1, "float32": 0xF1}
_LAYOUT_OF = {v: k for k, v in LAYOUTS.items()}
_ITEM_BYTES = {"compact": 3, "float32": 8}
_ANGLE_LEVELS, _DIST_MAX = 4096, 2047
_TWO_PI = 2.0 * math.pi
#: ``[layout/version byte][count n]`` of every possible message, per layout
_HEADS = {name: [bytes((head, n)) for n in range(256)] for name, head in LAYOUTS.items()}
#: ... and their CRC-16 states
_HEAD_CRCS = {name: [binascii.crc_hqx(h, 0xFFFF) for h in heads] for name, heads in _HEADS.items()}


class MessageError(FftnavError):
    """A message that is truncated, corrupted (bad CRC) or not an fftnav Sigma message."""


def _check_range(range_m: float) -> None:
    check_number("range_m", range_m, low=0, low_open=True)


def _crc(data: bytes) -> bytes:
    return binascii.crc_hqx(data, 0xFFFF).to_bytes(2, "big")


def encode_sigma(
    sigma: np.ndarray,
    *,
    is_min: np.ndarray | None = None,
    layout: str = "compact",
    range_m: float,
) -> bytes:
    """Encode Sigma (``(n, 2)``: angle rad, distance m) and its minimum flags as bytes.

    Parameters
    ----------
    sigma : ndarray, shape (n, 2)
        Extrema, ``n <= 255``, distances in ``[0, R]``.
    is_min : ndarray of bool, shape (n,), optional
        Which extrema are minima (default: none).
    layout : {"compact", "float32"}
        See the module docstring.
    range_m : float
        Maximum range R (m): the compact layout's distance scale.
    """
    n = len(np.asarray(sigma).reshape(-1)) // 2
    flags = np.zeros(n, bool) if is_min is None else is_min
    return encode_batch(sigma, flags, np.array([0, n]), layout=layout, range_m=range_m)[0]


def encode_batch(
    sigma: np.ndarray,
    is_min: np.ndarray,
    offsets: np.ndarray,
    *,
    layout: str = "compact",
    range_m: float,
) -> list[bytes]:
    """Encode the Sigmas of K scans stored flat (``sigma[offsets[k]:offsets[k+1]]`` is scan k,
    as returned by :func:`fftnav.observe.compress.find_extrema_flat`): one message per scan."""
    _check_range(range_m)
    check_choice("layout", layout, LAYOUTS)
    sig = np.asarray(sigma, dtype=np.float64)
    flags = np.asarray(is_min, dtype=bool)
    off = np.asarray(offsets)
    counts = np.diff(off)
    if sig.ndim != 2 or sig.shape[1] != 2 or np.any(counts > 255):
        raise FftnavError(
            f"sigma must have shape (n, 2) with n <= 255 per message, got shape={sig.shape}"
        )
    if flags.shape != (len(sig),):
        raise FftnavError(f"is_min must have shape ({len(sig)},), got shape={flags.shape}")
    if len(sig) and not (
        np.isfinite(sig[:, 0]).all() and sig[:, 1].min() >= 0 and sig[:, 1].max() <= range_m
    ):
        raise FftnavError(
            f"sigma must hold finite angles and distances in [0, range_m={range_m}], got {sig}"
        )
    rows = slice(off[0], off[-1]) if len(off) else slice(0, 0)
    return pack_messages(sig[rows], flags[rows], counts.tolist(), layout=layout, range_m=range_m)


def codec_scales(range_m: float) -> tuple[float, float]:
    """Factors of the compact layout's quantisation: angle (rad) and distance (m) to levels."""
    return _ANGLE_LEVELS / _TWO_PI, _DIST_MAX / range_m


def packed_message(part: bytes, n: int, layout: str = "compact") -> bytes:
    """One message from its packed payload ``part`` of ``n`` extrema: header, payload, CRC."""
    # the CRC runs on from the header's: crc(header + part) without building that body
    return (_HEADS[layout][n] + part
            + binascii.crc_hqx(part, _HEAD_CRCS[layout][n]).to_bytes(2, "big"))


def pack_messages(
    sigma: np.ndarray, is_min: np.ndarray, counts: list[int], *, layout: str, range_m: float
) -> list[bytes]:
    """:func:`encode_batch` without its input checks, for Sigmas known to be valid (finite
    angles, distances in ``[0, R]``, as :func:`fftnav.observe.compress.find_extrema_flat` returns
    them): scan k's extrema are the next ``counts[k]`` rows of ``sigma``. Only the count limit is
    checked."""
    if max(counts, default=0) > 255:
        raise FftnavError(f"a message holds n <= 255 extrema, got n={max(counts)}")
    if layout == "float32":
        dist = np.where(is_min, -sigma[:, 1], sigma[:, 1])
        payload = np.column_stack([sigma[:, 0], dist]).astype("<f4").tobytes()
    else:
        q = np.rint(sigma * codec_scales(range_m)).astype(np.int64)
        word = q[:, 0] << 12
        word &= 0xFFF000  # the angle modulo 4096 (two's complement), in bits 23..12
        word |= q[:, 1]
        word |= is_min << 11  # the minimum bit
        payload = word.astype(">u4").view(np.uint8).reshape(-1, 4)[:, 1:].tobytes()
    size = _ITEM_BYTES[layout]
    out, a = [], 0
    for n in counts:
        z = a + n * size
        out.append(packed_message(payload[a:z], n, layout))
        a = z
    return out


def decode_message(data: bytes, *, range_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Decode a message into ``(sigma, is_min)``; see :func:`encode_sigma`.

    Raises
    ------
    MessageError
        Truncated or overlong data, an unknown first byte (foreign message or unsupported
        version), or a CRC mismatch (corruption).
    """
    _check_range(range_m)
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise MessageError(f"message must be bytes, got {type(data).__name__}")
    data = bytes(data)
    if len(data) < 4:
        raise MessageError(f"message truncated: {len(data)} bytes, a message has at least 4")
    layout = _LAYOUT_OF.get(data[0])
    if layout is None:
        raise MessageError(
            f"not an fftnav Sigma message or unsupported version: first byte 0x{data[0]:02x}"
        )
    n = data[1]
    expected = 4 + _ITEM_BYTES[layout] * n
    if len(data) != expected:
        raise MessageError(
            f"message length {len(data)} does not match {expected} bytes for n={n} extrema"
        )
    if _crc(data[:-2]) != data[-2:]:
        raise MessageError("message corrupted: CRC-16 mismatch")
    payload = data[2:-2]
    if layout == "float32":
        v = np.frombuffer(payload, dtype="<f4").reshape(n, 2).astype(np.float64)
        return np.column_stack([v[:, 0], np.abs(v[:, 1])]), np.signbit(v[:, 1])
    b = np.frombuffer(payload, dtype=np.uint8).reshape(n, 3).astype(np.uint32)
    word = b[:, 0] << 16 | b[:, 1] << 8 | b[:, 2]
    angle = (word >> 12) * (_TWO_PI / _ANGLE_LEVELS)
    angle = np.where(angle > math.pi, angle - _TWO_PI, angle)
    dist = (word & 0x7FF) * (range_m / _DIST_MAX)
    return np.column_stack([angle, dist]), (word >> 11 & 1).astype(bool)


def decode_sigma(data: bytes, *, range_m: float) -> np.ndarray:
    """Decode a message into Sigma only (``(n, 2)``: angle rad, distance m)."""
    return decode_message(data, range_m=range_m)[0]
