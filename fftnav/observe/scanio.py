"""Scan readers: ``.npy``, ``.csv`` (one scan per row) and CARMEN logs (``FLASER`` lines).

Every reader returns ranges in metres as a ``(K, M)`` float array plus the field of view the
format implies (CARMEN front lasers: 180 degrees; npy / csv: unknown, ``None``). Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fftnav.errors import FftnavError
from fftnav.files import iter_csv_rows, iter_npy_rows, load_npy, read_csv_floats, read_lines
from fftnav.limits import MAX_BEAMS, MAX_INPUT_BYTES, check_limit
from fftnav.validate import check_choice, check_number

__all__ = ["FORMATS", "CARMEN_NO_RETURN_M", "ScanFile", "ScanStream", "detect_format",
           "iter_scans", "read_scans"]

FORMATS = ("auto", "npy", "csv", "carmen")
#: CARMEN logs write "no return" as ~80-82 m (or the ``robot_front_laser_max`` PARAM): readings
#: at or above the smaller of the two become ``+inf`` (open space at the model's range R).
CARMEN_NO_RETURN_M = 80.0


@dataclass(frozen=True)
class ScanFile:
    """Scans read from a file.

    Attributes
    ----------
    ranges : ndarray, shape (K, M)
        Range readings in metres (``+inf`` for CARMEN "no return").
    fov_rad : float or None
        Field of view implied by the format (CARMEN: pi), else None.
    format : str
        ``"npy"``, ``"csv"`` or ``"carmen"``.
    """

    ranges: np.ndarray
    fov_rad: float | None
    format: str


@dataclass(frozen=True)
class ScanStream:
    """Scans of a file, read a chunk at a time (:func:`iter_scans`).

    Attributes
    ----------
    chunks : iterator of ndarray, shape (k, M)
        Consecutive scans, float64, every chunk with the same M.
    fov_rad : float or None
        Field of view implied by the format (CARMEN: pi), else None.
    format : str
        ``"npy"``, ``"csv"`` or ``"carmen"``.
    """

    chunks: Iterator[np.ndarray]
    fov_rad: float | None
    format: str


def detect_format(path: Path) -> str:
    """Format from the file name: ``.npy``, ``.csv``, ``.log`` / ``.log.gz`` (CARMEN)."""
    name = path.name.lower()
    for suffix, fmt in (
        (".npy", "npy"),
        (".csv", "csv"),
        (".log", "carmen"),
        (".log.gz", "carmen"),
    ):
        if name.endswith(suffix):
            return fmt
    raise FftnavError(
        f"cannot tell the format of {str(path)!r} from its name (.npy, .csv, .log, .log.gz); "
        "pass --format"
    )


#: Characters of one CARMEN log line: a FLASER line of MAX_BEAMS readings of up to 16
#: characters each, with room to spare.
MAX_LOG_LINE = 20 * MAX_BEAMS


def _read_carmen(path: Path) -> np.ndarray:
    """Every FLASER scan of a CARMEN log, ``(K, M)``."""
    chunks, size = [], 0
    for chunk in _iter_carmen(path, rows=4096):
        size += chunk.size
        check_limit(f"{path}: ranges (bytes)", 8.0 * size, MAX_INPUT_BYTES)
        chunks.append(chunk)
    return np.concatenate(chunks)


def _iter_carmen(path: Path, *, rows: int) -> Iterator[np.ndarray]:
    """The FLASER scans of a CARMEN log, ``rows`` at a time, read line by line (lines longer
    than :data:`MAX_LOG_LINE` refused). Readings at or beyond the laser's maximum range (the
    ``PARAM robot_front_laser_max`` lines before them, at most 81.91 m) read ``inf``."""
    chunk: list[np.ndarray] = []
    width = None
    no_return = CARMEN_NO_RETURN_M
    for lineno, line in enumerate(read_lines(path, encoding="latin-1",
                                             max_chars=MAX_LOG_LINE), 1):
        if line.startswith("FLASER "):
            row = _flaser(line, f"{path}:{lineno}")
            if width is not None and len(row) != width:
                raise FftnavError(
                    f"{path}:{lineno}: FLASER with n={len(row)} beams, "
                    f"earlier scans had {width}"
                )
            width = len(row)
            row[row >= no_return] = np.inf
            chunk.append(row)
            if len(chunk) == rows:
                yield np.array(chunk)
                chunk = []
        elif line.startswith("PARAM robot_front_laser_max"):
            no_return = min(no_return, _laser_max(line, f"{path}:{lineno}"))
    if chunk:
        yield np.array(chunk)
    elif width is None:
        raise FftnavError(f"no FLASER scan in {str(path)!r}")


def _flaser(line: str, where: str) -> np.ndarray:
    """The ranges of one FLASER line."""
    parts = line.split()
    try:
        n = int(parts[1])
    except (IndexError, ValueError):
        raise FftnavError(f"{where}: bad FLASER line (no beam count)") from None
    if n < 1 or len(parts) < n + 2:
        raise FftnavError(f"{where}: FLASER line with fewer than n={n} ranges")
    check_limit(f"{where}: FLASER beams", n, MAX_BEAMS)
    try:
        return np.array(parts[2 : n + 2], dtype=np.float64)
    except ValueError:
        bad = next(v for v in parts[2 : n + 2] if not _is_number(v))
        raise FftnavError(f"{where}: FLASER range is not a number, got {bad[:40]!r}") from None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _laser_max(line: str, where: str) -> float:
    """The value of a ``PARAM robot_front_laser_max VALUE`` line: a finite number > 0 (a
    maximum range of 0 would turn every reading into "no return")."""
    parts = line.split()
    if parts[0] != "PARAM" or parts[1] != "robot_front_laser_max" or len(parts) < 3:
        raise FftnavError(f"{where}: robot_front_laser_max must be a number > 0 (the laser's "
                          f"maximum range, m), got {line.strip()[:80]!r}")
    value = float(parts[2]) if _is_number(parts[2]) else parts[2]
    try:
        return check_number("robot_front_laser_max", value, low=0, low_open=True)
    except ValueError as exc:
        raise FftnavError(f"{where}: {exc}") from None


def read_scans(path: str | Path, *, format: str = "auto") -> ScanFile:
    """Read every scan of a file.

    Parameters
    ----------
    path : str or Path
        ``.npy`` (shape ``(M,)`` or ``(K, M)``), ``.csv`` (one scan per row, comma separated;
        ``inf`` / ``nan`` allowed) or a CARMEN log (``.log`` or ``.log.gz``).
    format : {"auto", "npy", "csv", "carmen"}
        ``"auto"`` picks the format from the file name.

    Raises
    ------
    ValueError
        Unknown format, damaged or unreadable content (named with the file and, where known,
        the line), empty file, ragged rows, an impossible sensor parameter, a size above
        :mod:`fftnav.limits`.
    OSError
        The file cannot be opened.
    """
    check_choice("format", format, FORMATS)
    path = Path(path)
    fmt = detect_format(path) if format == "auto" else format
    if fmt == "carmen":
        return ScanFile(_read_carmen(path), math.pi, "carmen")
    ranges = load_npy(path) if fmt == "npy" else read_csv_floats(path)
    if ranges.ndim not in (1, 2) or ranges.size == 0 or ranges.dtype.kind not in "biuf":
        raise FftnavError(
            f"{str(path)!r} must hold a numeric (M,) or (K, M) array, got shape={ranges.shape} "
            f"dtype={ranges.dtype}"
        )
    return ScanFile(np.atleast_2d(ranges).astype(np.float64), None, fmt)


def iter_scans(path: str | Path, *, format: str = "auto", rows: int = 4096) -> ScanStream:
    """Read the scans of a file a chunk at a time: at most ``rows`` scans and 4096 x 360
    readings per chunk (so very wide scans come fewer per chunk, at least one), so that memory
    stays bounded whatever the file's size: every format is streamed from the file. The same
    checks and messages as :func:`read_scans`, raised when the chunk that holds the damage is
    read."""
    check_choice("format", format, FORMATS)
    path = Path(path)
    fmt = detect_format(path) if format == "auto" else format
    if fmt == "carmen":
        return ScanStream(_iter_carmen(path, rows=rows), math.pi, fmt)
    reader = iter_npy_rows if fmt == "npy" else iter_csv_rows
    return ScanStream(reader(path, rows=rows), None, fmt)
