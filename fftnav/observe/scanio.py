"""Scan readers: ``.npy``, ``.csv`` (one scan per row) and CARMEN logs (``FLASER`` lines).

Every reader returns ranges in metres as a ``(K, M)`` float array plus the field of view the
format implies (CARMEN front lasers: 180 degrees; npy / csv: unknown, ``None``). Pure numpy.
"""

from __future__ import annotations

import gzip
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fftnav.validate import check_choice

__all__ = ["FORMATS", "CARMEN_NO_RETURN_M", "ScanFile", "detect_format", "read_scans"]

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
    raise ValueError(
        f"cannot tell the format of {str(path)!r} from its name (.npy, .csv, .log, .log.gz); "
        "pass --format"
    )


def _read_carmen(path: Path) -> np.ndarray:
    opener = gzip.open if path.name.lower().endswith(".gz") else open
    rows: list[list[str]] = []
    no_return = CARMEN_NO_RETURN_M
    with opener(path, "rt", encoding="ascii", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            if line.startswith("FLASER "):
                parts = line.split()
                try:
                    n = int(parts[1])
                except (IndexError, ValueError):
                    raise ValueError(f"{path}:{lineno}: bad FLASER line (no beam count)") from None
                if n < 1 or len(parts) < n + 2:
                    raise ValueError(f"{path}:{lineno}: FLASER line with fewer than n={n} ranges")
                if rows and n != len(rows[0]):
                    raise ValueError(
                        f"{path}:{lineno}: FLASER with n={n} beams, "
                        f"earlier scans had {len(rows[0])}"
                    )
                rows.append(parts[2 : n + 2])
            elif line.startswith("PARAM robot_front_laser_max "):
                no_return = min(no_return, float(line.split()[2]))
    if not rows:
        raise ValueError(f"no FLASER scan in {str(path)!r}")
    try:
        ranges = np.array(rows, dtype=np.float64)
    except ValueError:
        raise ValueError(f"{path}: a FLASER line holds a non-numeric range") from None
    ranges[ranges >= no_return] = np.inf
    return ranges


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
        Unknown format, unreadable content, empty file, ragged rows.
    OSError
        The file cannot be opened.
    """
    check_choice("format", format, FORMATS)
    path = Path(path)
    fmt = detect_format(path) if format == "auto" else format
    if fmt == "carmen":
        return ScanFile(_read_carmen(path), math.pi, "carmen")
    try:
        if fmt == "npy":
            ranges = np.load(path, allow_pickle=False)
        else:
            ranges = np.loadtxt(path, delimiter=",", ndmin=2, dtype=np.float64)
    except (ValueError, EOFError) as exc:
        raise ValueError(f"cannot read {str(path)!r} as {fmt}: {exc}") from None
    if ranges.ndim not in (1, 2) or ranges.size == 0 or ranges.dtype.kind not in "biuf":
        raise ValueError(
            f"{str(path)!r} must hold a numeric (M,) or (K, M) array, got shape={ranges.shape} "
            f"dtype={ranges.dtype}"
        )
    return ScanFile(np.atleast_2d(ranges).astype(np.float64), None, fmt)
