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

import errno
import glob
import gzip
import io
import json
import os
import re
import shutil
import stat
import sys
import zipfile
import zlib
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from fftnav.errors import FftnavError
from fftnav.limits import MAX_BEAMS, MAX_INPUT_BYTES, MAX_JSON_DEPTH, check_limit

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["atomic_path", "atomic_writer", "cannot_write", "check_distinct", "check_input",
           "check_target", "iter_csv_rows", "iter_npy_rows", "json_depth", "load_npy",
           "load_npz", "parse_json", "read_csv_floats", "read_json", "read_lines", "read_text",
           "read_toml", "is_temporary", "remove_pending_temporaries",
           "remove_stale_temporaries_of", "track_temporary", "write_atomic"]

#: Exceptions of damaged compressed streams.
_STREAM_ERRORS = (EOFError, zlib.error, gzip.BadGzipFile, zipfile.BadZipFile)
#: Temporary files being written by :func:`write_atomic` in this process.
_PENDING: set[Path] = set()
_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)


#: Readings (scans x beams) of one chunk of a streamed scan file: 4,096 scans of 360 beams.
CHUNK_VALUES = 4096 * 360
#: Bytes of one line of a CSV scan file: 64 per beam at most (the longest float text is 24).
MAX_CSV_LINE_BYTES = 64 * MAX_BEAMS


def _file_kind(mode: int) -> str:
    """What a ``stat`` mode that is not a regular file is, in words."""
    for test, kind in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return kind
    return "not a regular file"


def check_input(path: str | os.PathLike[str]) -> Path:
    """``path`` if it is a regular file (symbolic links followed); ValueError naming it if it
    is a folder, a FIFO, a device or a socket. Decided by ``stat`` alone: a FIFO is never
    opened, so a reader never blocks on one. A missing file raises FileNotFoundError."""
    path = Path(path)
    mode = os.stat(path).st_mode
    if not stat.S_ISREG(mode):
        raise FftnavError(f"{path}: is {_file_kind(mode)}, not a file; give a regular file")
    return path


def check_target(path: str | os.PathLike[str], *, flag: str | None = None,
                 make_folder: bool = False, image: bool = False, sweep: bool = True) -> Path:
    """Refuse, before anything is computed, an output path that cannot be written: a folder,
    a FIFO, device or socket (a symbolic link is followed: its target is checked and written),
    a file in a folder that does not exist (made with ``make_folder``) or is not writable, and
    with ``image`` a name without a suffix (the image's type, which plotting libraries would
    otherwise append to the name). With ``sweep``, the temporary files of this path that a
    killed writer left beside it are removed (:func:`remove_stale_temporaries_of`).

    The message names the path as the user gave it (``--out='x'`` with ``flag="--out"``, else
    ``path='x'``).
    Returns the path to write: the final target of a symbolic link, else ``path``.
    """
    name = flag or "path"
    given = f"{name}={str(path)!r}"
    target = Path(os.path.realpath(path)) if os.path.islink(path) else Path(path)
    try:  # the link itself followed: /proc/self/fd/1 may name a pipe that has no path
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):  # checked as the folder below
        mode = None
    except OSError as exc:
        raise FftnavError(f"{name} cannot be written, got {given} ({exc.strerror})") from None
    if mode is not None and not stat.S_ISREG(mode):
        raise FftnavError(f"{name} must be a file path, not {_file_kind(mode)}, got {given}")
    if image and not target.suffix:
        raise FftnavError(f"{name} must end in the image's type, e.g. .png or .svg, got {given}")
    folder = target.parent
    if make_folder:
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise FftnavError(f"{name} must be in a folder that can be made, got {given} "
                              f"({exc.strerror})") from None
    if not folder.is_dir():
        raise FftnavError(f"{name} must be in an existing folder, got {given} (no folder "
                          f"{str(folder)!r})")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise FftnavError(f"{name} must be in a writable folder, got {given}")
    if sweep:
        remove_stale_temporaries_of(target)
    return target


def check_distinct(outputs: Mapping[str, str | os.PathLike[str] | None], *,
                   inputs: Mapping[str, str | os.PathLike[str] | None] | None = None) -> None:
    """Refuse, before any work, two options naming the same file (the later write would replace
    the earlier output, or an output its own input): paths compared after resolving links and
    ``..``; options given None or ``""`` are not used.

    >>> check_distinct({"--out": "e.csv", "--record": "./e.csv"})
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: --out and --record name the same file, got --record='./e.csv': \
give each its own path
    >>> check_distinct({"--out": "e.csv"}, inputs={"--world": "w.json"})
    """
    seen: dict[str, str] = {}
    for flag, path in [*(inputs or {}).items(), *outputs.items()]:
        if not path:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise FftnavError(f"{seen[key]} and {flag} name the same file, got "
                              f"{flag}={str(path)!r}: give each its own path")
        seen[key] = flag


#: A temporary file of :func:`atomic_path`: ``.NAME.PID.tmp``, or ``.NAME.PID.tmp.SUFFIX``.
_TEMPORARY = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.tmp(\.[^./]+)?$")


def is_temporary(path: Path) -> bool:
    """Whether ``path`` is named as :func:`atomic_path`'s temporary files are."""
    return _TEMPORARY.match(path.name) is not None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return pid > 0
    return True


def remove_stale_temporaries_of(target: Path) -> int:
    """Delete the temporary files of ``target`` that a killed writer left beside it (named
    ``.NAME.PID.tmp...`` with NAME ``target``'s and a PID no process has); return how many."""
    count = 0
    try:
        siblings = list(target.parent.glob(f".{glob.escape(target.name)}.*.tmp*"))
    except OSError:
        return 0
    for path in siblings:
        match = _TEMPORARY.match(path.name)
        if match and match["name"] == target.name and int(match["pid"]) != os.getpid() \
                and not _alive(int(match["pid"])):
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path, ignore_errors=True)
            else:
                path.unlink(missing_ok=True)
            count += 1
    return count


def cannot_write(path: str | os.PathLike[str], exc: OSError, *,
                 folder: str | os.PathLike[str]) -> FftnavError:
    """The error of a temporary file or folder that could not be made in ``folder`` to write
    ``path`` through: ``PATH: cannot write here (why)``, naming the user's path, never the
    temporary's, and the cause in words (a folder that is not writable, a read-only file
    system, a full disk). ``folder`` is named as its nearest existing folder, absolute.

    >>> print(cannot_write("out.csv", PermissionError(13, "Permission denied", "/x/.out.csv.7.tmp"),
    ...                    folder="/"))
    out.csv: cannot write here (permission denied: the folder / is not writable)
    """
    where = Path(os.path.abspath(folder))
    while not where.is_dir() and where != where.parent:
        where = where.parent
    reasons = {errno.EACCES: f"permission denied: the folder {where} is not writable",
               errno.EPERM: f"permission denied: the folder {where} is not writable",
               errno.EROFS: f"read-only file system: the folder {where} cannot be written",
               errno.ENOSPC: f"no space left on the device of the folder {where}",
               getattr(errno, "EDQUOT", -1): f"disk quota exceeded in the folder {where}"}
    text = exc.strerror or str(exc) or type(exc).__name__
    why = reasons.get(exc.errno, text[:1].lower() + text[1:])  # type: ignore[arg-type]
    return FftnavError(f"{path}: cannot write here ({why})")


@contextmanager
def atomic_path(path: str | os.PathLike[str], *, keep_suffix: bool = False) -> Iterator[Path]:
    """A temporary path beside ``path`` (``.NAME.PID.tmp``, ending in ``path``'s suffix too with
    ``keep_suffix``, for writers that choose the format by it) to write ``path`` through: made
    (empty) before the block runs, renamed over ``path`` when the block ends, removed if the
    block raises. A symbolic link is written through (its target is replaced, the link kept); a
    FIFO, device, socket or folder is refused, naming ``path`` (:func:`check_target`). A
    temporary file that cannot be made (a folder that is not writable, a read-only file system)
    is one ValueError naming ``path`` and why (:func:`cannot_write`); an OSError while writing
    (a full disk), and a ValueError of the block whose message names the temporary file (a
    writer's own "could not be written"), name ``path`` instead."""
    # no sweep of the folder per write (a run writes thousands into one folder): the command
    # that names the output checks it first (check_target), a run sweeps when it resumes
    target = check_target(path, sweep=False)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp"
                           + (target.suffix if keep_suffix else ""))
    _PENDING.add(tmp)  # before the file exists: a second Ctrl-C's exit removes it too
    try:
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666))
        except OSError as exc:
            raise cannot_write(path, exc, folder=target.parent) from None
        yield tmp
        os.replace(tmp, target)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        named = None if exc.filename is None else os.fspath(exc.filename)
        if exc.errno is None or named not in (None, str(tmp), str(target)):
            raise  # not the write: e.g. an input the block read
        raise OSError(exc.errno, f"cannot write {str(path)!r}: {exc.strerror}") from None
    except ValueError as exc:  # a writer's own message, e.g. a video that does not decode
        tmp.unlink(missing_ok=True)
        if exc.args and isinstance(exc.args[0], str) and str(tmp) in exc.args[0]:
            exc.args = (exc.args[0].replace(str(tmp), str(path)), *exc.args[1:])
        raise
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    finally:
        _PENDING.discard(tmp)


@contextmanager
def atomic_writer(path: str | os.PathLike[str]) -> Iterator[BinaryIO]:
    """A binary file to write ``path`` through (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        yield fh


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, then rename it over ``path``: readers
    see the old file or the whole new one, never a part. The temporary file is removed on every
    path (a full disk, an interrupt), so no ``.tmp`` is ever left behind by a live process."""
    with atomic_writer(path) as fh:
        fh.write(data.encode() if isinstance(data, str) else data)


def track_temporary(path: Path, *, done: bool = False) -> None:
    """Count ``path`` (a temporary file or folder being written) among those
    :func:`remove_pending_temporaries` deletes, or, with ``done``, no longer."""
    if done:
        _PENDING.discard(path)
    else:
        _PENDING.add(path)


def remove_pending_temporaries() -> None:
    """Delete the temporary files this process is writing right now (for an exit that skips
    the ``finally`` blocks, e.g. ``os._exit`` on a second Ctrl-C); a folder (a bag being
    written) with what it holds."""
    for tmp in list(_PENDING):
        if tmp.is_dir() and not tmp.is_symlink():
            shutil.rmtree(tmp, ignore_errors=True)
            continue
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
        raise FftnavError(f"{path}: not {exc.encoding} text: byte 0x{exc.object[exc.start]:02x} "
                          f"at offset {exc.start}") from None
    except _STREAM_ERRORS as exc:
        raise FftnavError(f"{path}: damaged {what}: {exc or type(exc).__name__}") from None


def read_lines(path: str | Path, *, encoding: str = "utf-8",
               max_chars: int | None = None) -> Iterator[str]:
    """Yield the lines of a text file (``.gz`` files decompressed on the fly); a damaged gzip
    stream or bytes that are not ``encoding`` raise ValueError naming the file and line, and so
    does, with ``max_chars``, a line longer than that (read no further: memory stays bounded
    for a file that is not the text it is named as)."""
    path = check_input(path)
    gz = path.name.lower().endswith(".gz")
    opener = gzip.open if gz else open
    lineno = 0
    limit = -1 if max_chars is None else max_chars + 1
    with _damage(path, "gzip stream" if gz else "text"), \
            opener(path, "rt", encoding=encoding) as fh:
        try:
            while line := fh.readline(limit):
                lineno += 1
                if max_chars is not None and len(line) > max_chars:
                    raise FftnavError(f"{path}:{lineno}: a line longer than {max_chars:,} "
                                      f"characters: not a line-oriented text file")
                yield line
        except UnicodeDecodeError as exc:
            raise FftnavError(f"{path}:{lineno + 1}: not {exc.encoding} text: byte "
                              f"0x{exc.object[exc.start]:02x}") from None


def json_depth(text: str | bytes) -> int:
    """Nesting depth of a JSON document (brackets outside strings), without recursion, counted
    1 MiB at a time (a few bytes of memory per byte of a 1 MiB piece, whatever the size).

    >>> json_depth('{"a": [1, {"b": "[[["}]}')
    3
    """
    data = text.encode() if isinstance(text, str) else text
    data = _STRING.sub(b'""', data)
    depth = deepest = 0
    piece = 1 << 20
    for start in range(0, len(data), piece):
        codes = np.frombuffer(data, dtype=np.uint8, count=min(piece, len(data) - start),
                              offset=start)
        step = (np.isin(codes, (ord("["), ord("{"))).astype(np.int32)
                - np.isin(codes, (ord("]"), ord("}"))))
        levels = np.cumsum(step, dtype=np.int64) + depth
        deepest = max(deepest, int(levels.max(initial=depth)))
        depth = int(levels[-1]) if len(levels) else depth
    return deepest


def parse_json(text: str, *, where: str) -> Any:
    """Parse JSON text; ValueError naming ``where`` for bad JSON or nesting deeper than
    :data:`fftnav.limits.MAX_JSON_DEPTH`."""
    depth = json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise FftnavError(f"{where}: JSON nested {depth} levels deep, above the limit of "
                          f"{MAX_JSON_DEPTH}")
    try:
        return json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise FftnavError(f"{where}: not valid JSON: {exc}") from None


def read_json(path: str | Path) -> Any:
    """Parse a JSON file (see :func:`parse_json`)."""
    return parse_json(read_text(path), where=str(path))


def read_toml(path: str | Path) -> tuple[dict[str, Any], str]:
    """Parse a TOML file; return the document and its text. ValueError names the file."""
    text = read_text(path)
    try:
        return tomllib.loads(text), text
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        raise FftnavError(f"{path}: invalid TOML: {exc}") from None


def _check_array_header(fh: Any, where: str) -> tuple[tuple[int, ...], np.dtype]:
    """Read a ``.npy`` header, refuse object arrays and sizes above MAX_INPUT_BYTES."""
    return _read_array_header(fh, where)[:2]


def _read_array_header(fh: Any, where: str) -> tuple[tuple[int, ...], np.dtype, bool]:
    """Shape, dtype and Fortran order of a ``.npy`` header (``fh`` left at the data), checked
    as in :func:`_check_array_header`."""
    try:
        major, _minor = np.lib.format.read_magic(fh)
        if major == 1:
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
        else:
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
    except (ValueError, EOFError, OSError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise FftnavError(f"{where}: not a .npy array: {reason}") from None
    if dtype.hasobject:
        raise FftnavError(f"{where}: holds Python objects (dtype={dtype}); only numbers are read")
    nbytes = float(np.prod([float(s) for s in shape])) * dtype.itemsize
    check_limit(f"{where}: array of shape {shape} and dtype {dtype}: bytes", nbytes,
                MAX_INPUT_BYTES)
    return shape, dtype, fortran


def load_npy(path: str | Path) -> np.ndarray:
    """One array from a ``.npy`` file, its header checked first; an ``.npz`` archive, a
    truncated file or a header claiming a huge shape raise ValueError naming the file."""
    path = check_input(path)
    with open(path, "rb") as fh:
        head = fh.read(4)
        if head.startswith(b"PK"):
            raise FftnavError(f"{path}: is a .npz archive, not one .npy array")
        fh.seek(0)
        _check_array_header(fh, str(path))
        fh.seek(0)
        with _damage(path, ".npy array"):
            try:
                return np.load(fh, allow_pickle=False)
            except ValueError as exc:
                raise FftnavError(f"{path}: damaged .npy array: {exc}") from None


def load_npz(path: str | Path) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` archive, each header checked first; ValueError naming the
    file (and the member) for any damage."""
    path = check_input(path)
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
                raise FftnavError(f"{where}: damaged array: {exc}") from None
    return out


def iter_npy_rows(path: str | Path, *, rows: int = 4096, values: int = CHUNK_VALUES,
                  max_width: int = MAX_BEAMS) -> Iterator[np.ndarray]:
    """The rows of a numeric ``.npy`` array (shape ``(M,)``: one row; ``(K, M)``), as float64
    arrays of at most ``rows`` rows and ``values`` numbers (at least one row), read a chunk at
    a time: memory stays bounded whatever the file's size. Rows longer than ``max_width`` are
    refused from the header. The same checks and messages as
    :func:`load_npy`; a file shorter than its header claims raises ValueError naming it."""
    path = check_input(path)
    with open(path, "rb") as fh:
        if fh.read(4).startswith(b"PK"):
            raise FftnavError(f"{path}: is a .npz archive, not one .npy array")
        fh.seek(0)
        shape, dtype, fortran = _read_array_header(fh, str(path))
        if len(shape) not in (1, 2) or 0 in shape or dtype.kind not in "biuf":
            raise FftnavError(f"{str(path)!r} must hold a numeric (M,) or (K, M) array, got "
                              f"shape={shape} dtype={dtype}")
        k, m = (1, shape[0]) if len(shape) == 1 else shape
        check_limit(f"{path}: values per row (beams)", m, max_width)
        step = max(1, min(rows, values // m))
        if fortran and k > 1:  # columns are contiguous: a row is m reads far apart
            data = np.load(path, mmap_mode="r", allow_pickle=False)
            for i in range(0, k, step):
                with np.errstate(invalid="ignore"):
                    yield np.array(data[i:i + step], dtype=np.float64, order="C")
            return
        for i in range(0, k, step):
            n = min(step, k - i)
            chunk = fh.read(n * m * dtype.itemsize)
            if len(chunk) < n * m * dtype.itemsize:
                end = i + len(chunk) // (m * dtype.itemsize)
                raise FftnavError(f"{path}: damaged .npy array: the file ends at row {end} of "
                                  f"the {k} its header claims")
            with np.errstate(invalid="ignore"):  # a signalling NaN reads as NaN, quietly
                yield np.frombuffer(chunk, dtype=dtype).reshape(n, m).astype(np.float64)


def iter_csv_rows(path: str | Path, *, rows: int = 4096, values: int = CHUNK_VALUES,
                  max_width: int = MAX_BEAMS) -> Iterator[np.ndarray]:
    """The rows of a CSV of numbers (one row per line; blank lines and lines starting with
    ``#`` skipped; ``.gz`` decompressed), as float64 arrays of at most ``rows`` rows and
    ``values`` numbers, parsed a chunk at a time: memory stays bounded whatever the file's
    size. A line is read at most :data:`MAX_CSV_LINE_BYTES` at a time and its number of values
    checked against ``max_width`` before it is parsed. ValueError naming the file, line and
    column of a bad cell, a row of another length, a line too long or too wide."""
    path = check_input(path)
    check_limit(f"{path}: bytes", float(path.stat().st_size), MAX_INPUT_BYTES)
    gz = path.name.lower().endswith(".gz")
    width = 0
    lineno = 0
    with _damage(path, "gzip stream" if gz else "text"), \
            (gzip.open if gz else open)(path, "rb") as fh:
        while True:
            chunk: list[tuple[int, bytes]] = []
            size = 0
            while size < 16 * values and len(chunk) < (
                    max(1, min(rows, values // width)) if width else 1):
                line = fh.readline(MAX_CSV_LINE_BYTES + 1)
                if not line:
                    break
                lineno += 1
                beams = f"{path}:{lineno}: values on one line (beams)"
                if len(line) > MAX_CSV_LINE_BYTES:  # its first bytes only: refused unparsed
                    check_limit(beams, line.count(b",") + 1, max_width)
                    raise FftnavError(f"{path}:{lineno}: line longer than "
                                      f"{MAX_CSV_LINE_BYTES:,} bytes")
                text = line.strip()
                if not text or text.startswith(b"#"):
                    continue
                cells = check_limit(beams, text.count(b",") + 1, max_width)
                chunk.append((lineno, text))
                size += len(text)
                width = width or cells
            if not chunk:
                if not width:
                    raise FftnavError(f"{path}: holds no numbers")
                return
            block = _parse_csv_block(path, chunk)
            if block.shape[1] != width:
                raise FftnavError(f"{path}:{chunk[0][0]}: {block.shape[1]} values, earlier rows "
                                  f"have {width}")
            yield block


def _parse_csv_block(path: Path, chunk: list[tuple[int, bytes]]) -> np.ndarray:
    """Parse numbered CSV lines into a 2-D float64 array: numpy's C parser, and on any error
    the lines one by one with ``float``, for the message naming the line and column."""
    try:
        text = b"\n".join(line for _, line in chunk).decode("utf-8")
        return np.loadtxt(io.StringIO(text), delimiter=",", dtype=np.float64, ndmin=2,
                          comments=None)
    except ValueError:
        pass
    rows: list[list[float]] = []
    for lineno, line in chunk:
        try:
            cells = line.decode("utf-8").split(",")
        except UnicodeDecodeError as exc:
            raise FftnavError(f"{path}:{lineno}: not utf-8 text: byte "
                              f"0x{exc.object[exc.start]:02x}") from None
        try:
            row = [float(c) for c in cells]
        except ValueError:
            col = next(i for i, c in enumerate(cells) if not _is_float(c))
            raise FftnavError(f"{path}:{lineno}: column {col + 1} is not a number, got "
                              f"{cells[col].strip()[:40]!r}") from None
        if rows and len(row) != len(rows[0]):
            raise FftnavError(f"{path}:{lineno}: {len(row)} values, earlier rows have "
                              f"{len(rows[0])}")
        rows.append(row)
    return np.array(rows, dtype=np.float64)


def read_csv_floats(path: str | Path) -> np.ndarray:
    """A ``(K, M)`` float array from a CSV of numbers, one row per line (the rows of
    :func:`iter_csv_rows`, whose checks and messages it shares)."""
    return np.concatenate(list(iter_csv_rows(path)))


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
