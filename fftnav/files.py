"""File readers that turn any damage of a file's format into one ``ValueError`` naming the file.

numpy, ``json``, ``gzip``, ``zipfile`` and ``tomllib`` raise a zoo of exceptions on damaged
input (``EOFError``, ``UnicodeDecodeError``, ``BadZipFile``, ``zlib.error``, ``RecursionError``,
``_ArrayMemoryError``, ``AttributeError`` for an archive named ``.npy`` ...). Every fftnav reader
goes through these helpers, so that a bad file is always ``ValueError: PATH: what is wrong``
(with the line, key or array where known), checked against :mod:`fftnav.limits` before anything
large is allocated. ``OSError`` (missing file, permissions) passes through. numpy and the
standard library only.
"""

from __future__ import annotations

import gzip
import io
import json
import os
import re
import sys
import zipfile
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from fftnav.limits import MAX_INPUT_BYTES, MAX_JSON_DEPTH, check_limit

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["atomic_writer", "json_depth", "load_npy", "load_npz", "parse_json", "read_csv_floats",
           "read_json", "read_lines", "read_text", "read_toml", "remove_pending_temporaries",
           "write_atomic"]

#: Exceptions of damaged compressed streams.
_STREAM_ERRORS = (EOFError, zlib.error, gzip.BadGzipFile, zipfile.BadZipFile)
#: Temporary files being written by :func:`write_atomic` in this process.
_PENDING: set[Path] = set()
_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)


@contextmanager
def atomic_writer(path: str | Path) -> Iterator[BinaryIO]:
    """A binary file to write ``path`` through: a temporary file beside it, renamed over
    ``path`` when the block ends, removed if it raises (see :func:`write_atomic`)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    _PENDING.add(tmp)
    try:
        with open(tmp, "wb") as fh:
            yield fh
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    finally:
        _PENDING.discard(tmp)


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, then rename it over ``path``: readers
    see the old file or the whole new one, never a part. The temporary file is removed on every
    path (a full disk, an interrupt), so no ``.tmp`` is ever left behind by a live process."""
    with atomic_writer(path) as fh:
        fh.write(data.encode() if isinstance(data, str) else data)


def remove_pending_temporaries() -> None:
    """Delete the temporary files this process is writing right now (for an exit that skips
    the ``finally`` blocks, e.g. ``os._exit`` on a second Ctrl-C)."""
    for tmp in list(_PENDING):
        try:
            tmp.unlink()
        except OSError:
            pass


def read_text(path: str | Path, *, encoding: str = "utf-8") -> str:
    """The text of ``path`` (``.gz`` decompressed); ValueError naming the file on bad bytes."""
    return "".join(read_lines(path, encoding=encoding))


@contextmanager
def _damage(path: str | Path, what: str) -> Iterator[None]:
    """Turn the format errors of a block into ``ValueError: PATH: not a valid WHAT (...)``."""
    try:
        yield
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not {exc.encoding} text: byte 0x{exc.object[exc.start]:02x} "
                         f"at offset {exc.start}") from None
    except _STREAM_ERRORS as exc:
        raise ValueError(f"{path}: damaged {what}: {exc or type(exc).__name__}") from None


def read_lines(path: str | Path, *, encoding: str = "utf-8") -> Iterator[str]:
    """Yield the lines of a text file (``.gz`` files decompressed on the fly); a damaged gzip
    stream or bytes that are not ``encoding`` raise ValueError naming the file and line."""
    path = Path(path)
    gz = path.name.lower().endswith(".gz")
    opener = gzip.open if gz else open
    lineno = 0
    with _damage(path, "gzip stream" if gz else "text"), \
            opener(path, "rt", encoding=encoding) as fh:
        try:
            for lineno, line in enumerate(fh, 1):  # noqa: B007 - used in the message
                yield line
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path}:{lineno + 1}: not {exc.encoding} text: byte "
                             f"0x{exc.object[exc.start]:02x}") from None


def json_depth(text: str | bytes) -> int:
    """Nesting depth of a JSON document (brackets outside strings), without recursion."""
    data = text.encode() if isinstance(text, str) else text
    data = _STRING.sub(b'""', data)
    codes = np.frombuffer(data, dtype=np.uint8)
    step = (np.isin(codes, (ord("["), ord("{"))).astype(np.int64)
            - np.isin(codes, (ord("]"), ord("}"))))
    return int(np.cumsum(step).max(initial=0))


def parse_json(text: str, *, where: str) -> Any:
    """Parse JSON text; ValueError naming ``where`` for bad JSON or nesting deeper than
    :data:`fftnav.limits.MAX_JSON_DEPTH`."""
    depth = json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise ValueError(f"{where}: JSON nested {depth} levels deep, above the limit of "
                         f"{MAX_JSON_DEPTH}")
    try:
        return json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise ValueError(f"{where}: not valid JSON: {exc}") from None


def read_json(path: str | Path) -> Any:
    """Parse a JSON file (see :func:`parse_json`)."""
    return parse_json(read_text(path), where=str(path))


def read_toml(path: str | Path) -> tuple[dict[str, Any], str]:
    """Parse a TOML file; return the document and its text. ValueError names the file."""
    text = read_text(path)
    try:
        return tomllib.loads(text), text
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        raise ValueError(f"{path}: invalid TOML: {exc}") from None


def _check_array_header(fh: Any, where: str) -> tuple[tuple[int, ...], np.dtype]:
    """Read a ``.npy`` header, refuse object arrays and sizes above MAX_INPUT_BYTES."""
    try:
        major, _minor = np.lib.format.read_magic(fh)
        if major == 1:
            shape, _fortran, dtype = np.lib.format.read_array_header_1_0(fh)
        else:
            shape, _fortran, dtype = np.lib.format.read_array_header_2_0(fh)
    except (ValueError, EOFError, OSError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ValueError(f"{where}: not a .npy array: {reason}") from None
    if dtype.hasobject:
        raise ValueError(f"{where}: holds Python objects (dtype={dtype}); only numbers are read")
    nbytes = float(np.prod([float(s) for s in shape])) * dtype.itemsize
    check_limit(f"{where}: array of shape {shape} and dtype {dtype}: bytes", nbytes,
                MAX_INPUT_BYTES)
    return shape, dtype


def load_npy(path: str | Path) -> np.ndarray:
    """One array from a ``.npy`` file, its header checked first; an ``.npz`` archive, a
    truncated file or a header claiming a huge shape raise ValueError naming the file."""
    path = Path(path)
    with open(path, "rb") as fh:
        head = fh.read(4)
        if head.startswith(b"PK"):
            raise ValueError(f"{path}: is a .npz archive, not one .npy array")
        fh.seek(0)
        _check_array_header(fh, str(path))
        fh.seek(0)
        with _damage(path, ".npy array"):
            try:
                return np.load(fh, allow_pickle=False)
            except ValueError as exc:
                raise ValueError(f"{path}: damaged .npy array: {exc}") from None


def load_npz(path: str | Path) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` archive, each header checked first; ValueError naming the
    file (and the member) for any damage."""
    path = Path(path)
    out: dict[str, np.ndarray] = {}
    with _damage(path, ".npz archive"), zipfile.ZipFile(path) as archive:
        for member in archive.namelist():
            where = f"{path}[{member}]"
            data = archive.read(member)
            fh = io.BytesIO(data)
            _check_array_header(fh, where)
            fh.seek(0)
            try:
                out[member.removesuffix(".npy")] = np.load(fh, allow_pickle=False)
            except (ValueError, EOFError) as exc:
                raise ValueError(f"{where}: damaged array: {exc}") from None
    return out


def read_csv_floats(path: str | Path) -> np.ndarray:
    """A ``(K, M)`` float array from a CSV of numbers, one row per line (blank lines and lines
    starting with ``#`` skipped); ValueError naming the file, line and column of a bad cell or
    a row of another length."""
    path = Path(path)
    check_limit(f"{path}: bytes", float(path.stat().st_size), MAX_INPUT_BYTES)
    rows: list[list[float]] = []
    for lineno, line in enumerate(read_lines(path), 1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        cells = text.split(",")
        try:
            row = [float(c) for c in cells]
        except ValueError:
            col = next(i for i, c in enumerate(cells) if not _is_float(c))
            raise ValueError(f"{path}:{lineno}: column {col + 1} is not a number, got "
                             f"{cells[col].strip()[:40]!r}") from None
        if rows and len(row) != len(rows[0]):
            raise ValueError(f"{path}:{lineno}: {len(row)} values, earlier rows have "
                             f"{len(rows[0])}")
        rows.append(row)
    if not rows:
        raise ValueError(f"{path}: holds no numbers")
    return np.array(rows, dtype=np.float64)


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
