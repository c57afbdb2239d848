"""Worlds from ROS ``map_server`` maps: a YAML file and its image (PGM, PNG, ...) -> a world.

The map is read as ROS ``map_server`` reads it (``map_server/src/image_loader.cpp``, mode
``trinary``, the default): a pixel's value ``c`` is the mean of its colour channels, its
occupancy probability is ``p = (255 - c) / 255`` (``p = c / 255`` with ``negate: 1``); the cell is
occupied if ``p > occupied_thresh``, free if ``p < free_thresh``, unknown otherwise. ``mode:
scale`` classifies cells the same way; ``mode: raw`` takes ``c`` as the occupancy in percent
(occupied if ``c > 100 occupied_thresh``, free if ``c < 100 free_thresh``, ``c > 100``
unknown). Unknown cells become obstacles by default (a robot must not plan through what was
never seen), or free space with ``unknown="free"``. The image's first row is the top of the map;
``origin`` is the pose of the lower-left pixel (its yaw must be 0) and ``resolution`` the cell
size in metres.

The occupied cells become axis-aligned rectangular prisms, exact to the cell: runs of occupied
cells in each row, merged with the identical runs of the rows above, so a wall is one obstacle
and rasterising the world at the map's resolution gives the map back. fftnav worlds start at
(0, 0): the world frame is the map frame shifted by ``-origin``; starts and goals are given in the
map frame (as read off RViz) and shifted too.

PGM (P2 and P5, 8 and 16 bit) is read with numpy; other image formats with Pillow. An image's
size is checked against the grid-cell limit (:data:`fftnav.limits.MAX_GRID_CELLS`) from its
header, before any pixel is read, and its pixels are classified ``BLOCK_ROWS`` rows at a time.
Numbers in the YAML are read as map_server's yaml-cpp reads them (``resolution: 5e-2`` too).
"""

from __future__ import annotations

import math
import re
import sys
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.files import check_input, read_text
from fftnav.limits import MAX_GRID_CELLS, MAX_INPUT_BYTES, MAX_MAP_SIDE_M, check_limit
from fftnav.validate import check_choice, check_number, check_vector
from fftnav.world.model import World
from fftnav.world.obstacles import Polygon

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["RosMap", "grid_rectangles", "import_ros_map", "read_pgm", "read_ros_map",
           "read_robots_toml"]

#: Height (m) of the imported obstacles' prisms.
HEIGHT_M = 1.0


class RosMap:
    """A map as ``map_server`` loads it: ``occupancy`` (+1 occupied, 0 free, -1 unknown) with
    row 0 at the **bottom** (the fftnav grid convention), ``resolution_m`` and ``origin_m``."""

    def __init__(self, occupancy: np.ndarray, resolution_m: float,
                 origin_m: tuple[float, float]) -> None:
        self.occupancy, self.resolution_m, self.origin_m = occupancy, resolution_m, origin_m

    def occupied(self, unknown: str = "occupied") -> np.ndarray:
        """Boolean grid of obstacle cells (row 0 at the bottom); unknown cells per ``unknown``."""
        check_choice("unknown", unknown, ("occupied", "free"))
        return (self.occupancy == 1) | ((self.occupancy == -1) & (unknown == "occupied"))


#: Rows of a map image classified at a time: memory stays a few bytes per pixel of the map.
BLOCK_ROWS = 1024
#: Bytes of a PGM header read before its pixels (comments included).
PGM_HEADER_BYTES = 65536
#: Smallest ``resolution`` (m per pixel) of a map: a tenth of a millimetre.
MIN_RESOLUTION_M = 1e-4
_PGM_TOKEN = re.compile(rb"\s*(?:#[^\n]*\n\s*)*(\S+)")
#: A number as YAML 1.2 (and map_server's yaml-cpp) reads it, e.g. ``5e-2``, ``.5``, ``+1``.
_YAML_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _pgm_header(path: Path) -> tuple[bytes, int, int, int, int]:
    """Magic, columns, rows, maxval and the pixels' offset of a PGM file, from its header
    alone; ValueError naming the file for anything that is not a grey PGM header."""
    with open(path, "rb") as fh:
        head = fh.read(PGM_HEADER_BYTES)
    tokens: list[bytes] = []
    pos = 0
    for _ in range(4):
        m = _PGM_TOKEN.match(head, pos)
        if m is None:
            raise FftnavError(f"{path}: not a PGM file (truncated header)")
        tokens.append(m.group(1))
        pos = m.end()
    magic = tokens[0]
    if magic not in (b"P5", b"P2") or not all(t.isdigit() for t in tokens[1:]):
        raise FftnavError(f"{path}: not a grey PGM (P2/P5 magic, then width, height and maxval), "
                          f"got {b' '.join(tokens)[:60]!r}")
    cols, rows, maxval = (int(t) for t in tokens[1:])
    if not 0 < maxval < 65536 or cols == 0 or rows == 0:
        raise FftnavError(f"{path}: not a grey PGM, got {cols} x {rows} pixels, maxval {maxval}")
    return magic, cols, rows, maxval, pos + 1


def _check_cells(path: Path, rows: int, cols: int) -> None:
    check_limit(f"{path}: map cells ({cols} x {rows} pixels)", float(rows) * cols,
                MAX_GRID_CELLS, hint="use a smaller map or a coarser image")


def _pgm_blocks(path: Path) -> tuple[tuple[int, int], Iterator[np.ndarray]]:
    """Shape of a PGM and its pixels (0..255, float64), ``BLOCK_ROWS`` rows at a time, top
    first; the cells are checked against the grid limit from the header, before any pixel is
    read, and a file shorter than its header claims is refused naming it."""
    magic, cols, rows, maxval, offset = _pgm_header(path)
    _check_cells(path, rows, cols)
    scale = 1.0 if maxval == 255 else 255.0 / maxval
    if magic == b"P2":  # text: small maps only in practice, read whole (within the limits)
        check_limit(f"{path}: bytes", float(path.stat().st_size), MAX_INPUT_BYTES)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # text that is not numbers
            raw = np.fromstring(path.read_bytes()[offset:], dtype=np.int64, sep=" ")
        if raw.size < rows * cols:
            raise FftnavError(f"{path}: PGM holds {raw.size} pixels, expected {rows} x {cols}")
        pixels = raw[: rows * cols].reshape(rows, cols) * scale
        return (rows, cols), iter([pixels[r:r + BLOCK_ROWS] for r in range(0, rows, BLOCK_ROWS)])
    dtype = np.dtype(np.uint8) if maxval < 256 else np.dtype(">u2")
    size = path.stat().st_size - offset
    if size < rows * cols * dtype.itemsize:
        raise FftnavError(f"{path}: PGM holds {max(size, 0) // dtype.itemsize} pixels, expected "
                          f"{rows} x {cols} (truncated)")

    def blocks() -> Iterator[np.ndarray]:
        with open(path, "rb") as fh:
            fh.seek(offset)
            for r in range(0, rows, BLOCK_ROWS):
                n = min(BLOCK_ROWS, rows - r)
                block = np.fromfile(fh, dtype=dtype, count=n * cols).reshape(n, cols)
                yield block * scale if scale != 1.0 else block.astype(np.float64)

    return (rows, cols), blocks()


def read_pgm(path: str | Path) -> np.ndarray:
    """A PGM image (``P5`` binary or ``P2`` text, maxval <= 65535) as ``(rows, cols)`` float64,
    first row = top of the image, values scaled to 0..255 if maxval is not 255. Its size is
    checked against :data:`fftnav.limits.MAX_GRID_CELLS` from the header first."""
    _, blocks = _pgm_blocks(check_input(path))
    return np.concatenate(list(blocks))


def _image_blocks(path: Path) -> tuple[tuple[int, int], Iterator[np.ndarray]]:
    """Shape of an image and its grey values (0..255, float64, colour channels averaged as
    map_server does, alpha ignored), ``BLOCK_ROWS`` rows at a time, top first; the size is
    checked against the grid limit from the header before the pixels are decoded."""
    check_input(path)
    if path.suffix.lower() == ".pgm":
        return _pgm_blocks(path)
    from PIL import Image  # only for non-PGM images

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # our limit applies
        try:
            img = Image.open(path)
        except Image.DecompressionBombError as exc:  # too many pixels to even open
            found = re.search(r"\((\d+) pixels\)", str(exc))
            check_limit(f"{path}: map cells (image pixels)",
                        float(found.group(1)) if found else math.inf, MAX_GRID_CELLS)
            raise  # pragma: no cover - the count is always above the grid limit
        except (OSError, SyntaxError, ValueError) as exc:
            raise FftnavError(f"{path}: not an image that can be read: {exc}") from None
        with img:
            cols, rows = img.size
            _check_cells(path, rows, cols)
            try:
                pixels = np.asarray(img.convert("RGBA") if img.mode in ("P", "LA", "PA")
                                    else img)
            except (OSError, SyntaxError, ValueError) as exc:
                raise FftnavError(f"{path}: damaged image: {exc}") from None

    def blocks() -> Iterator[np.ndarray]:
        for r in range(0, rows, BLOCK_ROWS):
            block = pixels[r:r + BLOCK_ROWS].astype(np.float64)
            if block.ndim == 3:  # map_server averages the colour channels, ignoring alpha
                block = block[..., :3 if block.shape[2] >= 3 else 1].mean(axis=2)
            yield block

    return (rows, cols), blocks()


def _yaml_number(value: Any) -> Any:
    """A YAML string that is a number (``5e-2``: PyYAML reads YAML 1.1, where it is a string;
    map_server's yaml-cpp reads it as a number) as a float; anything else unchanged."""
    if isinstance(value, str) and _YAML_NUMBER.fullmatch(value.strip()):
        return float(value)
    return value


@dataclass(frozen=True)
class _MapMeta:
    """The checked keys of a ``map_server`` YAML file."""

    image: str
    resolution: float
    origin: tuple[float, ...]
    negate: int
    occupied_thresh: float
    free_thresh: float
    mode: str

    @classmethod
    def checked(cls, meta: Mapping[str, Any]) -> _MapMeta:
        """The keys of ``meta`` (a YAML mapping holding ``image``, ``resolution`` and
        ``origin``) checked, the others defaulted as map_server does; FftnavError naming the
        key."""
        meta = {k: _yaml_number(v) for k, v in meta.items()}
        if isinstance(meta["origin"], list):
            meta["origin"] = [_yaml_number(v) for v in meta["origin"]]
        resolution = check_number("resolution", meta["resolution"], low=MIN_RESOLUTION_M,
                                  high=MAX_MAP_SIDE_M)
        origin = check_vector("origin", meta["origin"], 3)
        if origin[2] != 0:
            raise FftnavError(f"origin yaw must be 0 (rotated maps are not supported), got "
                              f"origin={list(meta['origin'])}")
        negate = check_choice("negate", meta.get("negate", 0), (0, 1))
        occ = check_number("occupied_thresh", meta.get("occupied_thresh", 0.65), low=0, high=1)
        free = check_number("free_thresh", meta.get("free_thresh", 0.196), low=0, high=occ)
        mode = check_choice("mode", meta.get("mode", "trinary"), ("trinary", "scale", "raw"))
        return cls(image=str(meta["image"]), resolution=resolution, origin=origin,
                   negate=negate, occupied_thresh=occ, free_thresh=free, mode=mode)

    def classify(self, grey: np.ndarray) -> np.ndarray:
        """Occupancy (+1 occupied, 0 free, -1 unknown, int8) of image pixels ``grey``, as
        map_server reads them in this file's ``mode``."""
        if self.mode == "raw":
            p = grey / 100.0
        else:
            p = grey / 255.0 if self.negate else (255.0 - grey) / 255.0
        block = np.where(p > self.occupied_thresh, 1,
                         np.where(p < self.free_thresh, 0, -1)).astype(np.int8)
        if self.mode == "raw":
            block[grey > 100] = -1
        return block


def _read_map_yaml(yaml_path: Path) -> _MapMeta:
    """The checked keys of a ``map_server`` YAML file (errors name the file)."""
    import yaml  # pyyaml, only for ROS maps

    try:
        meta = yaml.safe_load(read_text(yaml_path))
    except yaml.YAMLError as exc:
        raise FftnavError(f"{yaml_path}: invalid YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(meta, Mapping):
        raise FftnavError(f"{yaml_path}: a map YAML must be a mapping, got {meta!r:.80}")
    for key in ("image", "resolution", "origin"):
        if key not in meta:
            raise FftnavError(f"{yaml_path}: missing key {key!r}")
    try:  # each key's message names the file
        return _MapMeta.checked(meta)
    except ValueError as exc:
        raise FftnavError(f"{yaml_path}: {exc}") from None


def read_ros_map(yaml_path: str | Path) -> RosMap:
    """Read a ``map_server`` YAML file and its image.

    Raises
    ------
    FftnavError
        A missing or invalid key (named), a rotated origin, an unreadable image.
    """
    yaml_path = Path(yaml_path)
    meta = _read_map_yaml(yaml_path)
    image = Path(meta.image)
    image = image if image.is_absolute() else yaml_path.parent / image
    (rows, cols), blocks = _image_blocks(image)
    check_limit(f"{image}: map side ({max(rows, cols)} pixels x resolution {meta.resolution:g} m)",
                max(rows, cols) * meta.resolution, MAX_MAP_SIDE_M)
    occupancy = np.empty((rows, cols), dtype=np.int8)
    top = rows  # image row 0 is the top of the map: stored last (row 0 = bottom)
    for grey in blocks:
        occupancy[top - len(grey):top] = meta.classify(grey)[::-1]
        top -= len(grey)
    origin = meta.origin
    return RosMap(occupancy, float(meta.resolution), (float(origin[0]), float(origin[1])))


def grid_rectangles(grid: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Occupied cells of a boolean grid as disjoint rectangles ``(row0, row1, col0, col1)``
    (half-open): runs of each row merged with identical runs of the next rows.

    >>> g = np.array([[1, 1, 0], [1, 1, 0], [0, 0, 1]], dtype=bool)
    >>> grid_rectangles(g)
    [(0, 2, 0, 2), (2, 3, 2, 3)]
    """
    grid = np.asarray(grid, dtype=bool)
    done: list[tuple[int, int, int, int]] = []
    open_runs: dict[tuple[int, int], int] = {}  # (col0, col1) -> first row
    for r in range(grid.shape[0] + 1):
        runs: set[tuple[int, int]] = set()
        if r < grid.shape[0]:
            row = np.concatenate(([False], grid[r], [False])).astype(np.int8)
            edges = np.flatnonzero(np.diff(row))
            runs = {(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)}
        for run in [k for k in open_runs if k not in runs]:
            done.append((open_runs.pop(run), r, *run))
        for run in runs:
            open_runs.setdefault(run, r)
    return sorted(done)


def read_robots_toml(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Starts and goals from a small TOML file, in the map frame::

        [[robot]]
        start = [1.0, 2.0, 90.0]   # x m, y m, yaw degrees
        goal = [8.0, 2.0]          # x m, y m
    """
    try:
        data = tomllib.loads(read_text(path))
    except tomllib.TOMLDecodeError as exc:
        raise FftnavError(f"{path}: invalid TOML: {exc}") from None
    unknown = [k for k in data if k != "robot"]
    if unknown or not isinstance(data.get("robot"), list) or not data["robot"]:
        raise FftnavError(f"{path}: expected one or more [[robot]] tables with start and goal, "
                          f"got keys {sorted(data)}")
    starts, goals = [], []
    for i, robot in enumerate(data["robot"]):
        if not isinstance(robot, dict) or set(robot) != {"start", "goal"}:
            raise FftnavError(f"{path}: robot[{i}] must have exactly start and goal, got "
                              f"{robot!r:.80}")
        starts.append(check_vector(f"robot[{i}].start", robot["start"], 3))
        goals.append(check_vector(f"robot[{i}].goal", robot["goal"], 2))
    return np.array(starts, dtype=float), np.array(goals, dtype=float)


def import_ros_map(yaml_path: str | Path, starts: Sequence[Sequence[float]],
                   goals: Sequence[Sequence[float]], *, unknown: str = "occupied",
                   name: str = "rosmap") -> World:
    """A world from a ROS map, with robots.

    Parameters
    ----------
    yaml_path : str or Path
        The map's YAML file (its ``image`` relative to it).
    starts : sequence of (x_m, y_m, yaw_deg)
        Start poses in the map frame (yaw in degrees, as in configs).
    goals : sequence of (x_m, y_m)
        Goals in the map frame.
    unknown : {"occupied", "free"}
        What unknown cells become.
    name : str
        The world's ``env`` field.

    Returns
    -------
    World
        Size ``(cols res, rows res)``, one rectangular prism per merged block of occupied cells,
        starts and goals shifted into the world frame; validated like a world file (a start or
        goal outside the map or inside an obstacle is refused, naming it).
    """
    ros = read_ros_map(yaml_path)
    grid = ros.occupied(unknown)
    res = ros.resolution_m
    obstacles = tuple(
        Polygon(((c0 * res, r0 * res), (c1 * res, r0 * res), (c1 * res, r1 * res),
                 (c0 * res, r1 * res)), HEIGHT_M)
        for r0, r1, c0, c1 in grid_rectangles(grid))
    s = np.array(starts, dtype=float).reshape(-1, 3)
    g = np.array(goals, dtype=float).reshape(-1, 2)
    if len(s) == 0:
        raise FftnavError("starts must be at least one start pose (x, y, yaw_deg), got none")
    shift = np.asarray(ros.origin_m)
    s = np.c_[s[:, :2] - shift, np.radians(s[:, 2])]
    g = g - shift
    rows, cols = grid.shape
    world = World(name, 0, (cols * res, rows * res), obstacles, s, g)
    return World.from_json(world.to_json())  # the world file's checks, with its messages


def map_extent_text(world: World) -> str:
    """One line describing an imported world."""
    w, h = world.size_m
    return (f"{w:g} m x {h:g} m, {len(world.obstacles)} rectangular obstacles, "
            f"{len(world.starts)} robots")
