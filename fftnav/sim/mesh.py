"""Static obstacle meshes within Bullet's limits: every obstacle's mesh made once, and tiles.

Bullet refuses a triangle mesh of more than :data:`MAX_MESH_VERTICES` vertices or
:data:`MAX_MESH_INDICES` triangle indices (``createCollisionShape failed``, or a
``SystemError`` from pybullet; measured with pybullet 3.2.7: 131,072 vertices and 524,288
indices build, one more fails). A trunk (a 64-gon prism) takes 128 vertices and 756 indices, so
one mesh holds at most 693 trunks.

:func:`obstacle_meshes` makes every obstacle's mesh once, the trunks all at once from one
unit 64-gon (bit for bit ``Obstacle.mesh()``, tested). :func:`static_tiles` keeps the whole
world one mesh when it fits (the fastest for the physics) and otherwise cuts it into square
tiles of :data:`TILE_M` (obstacles by their centre), each packed into meshes below the limits;
the simulator builds a tile in Bullet only when a robot comes near it. :func:`static_meshes`
gives the meshes themselves, tile by tile. Ray casts against a triangle are exact whichever
mesh holds it, so the lidar reads the same ranges, bit for bit, however the obstacles are tiled
(tested with a forced small mesh size). Contacts are resolved per mesh, so a robot touching
obstacles of two meshes at once may move differently in the last bits than with one mesh;
worlds that fit one mesh (every world of the paper's size) are one mesh. numpy only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fftnav.errors import FftnavError
from fftnav.world.obstacles import Circle, Obstacle

__all__ = ["MAX_MESH_INDICES", "MAX_MESH_VERTICES", "TILE_M", "Tile", "join_meshes",
           "obstacle_meshes", "static_meshes", "static_tiles"]

#: Largest mesh Bullet builds (pybullet's B3_MAX_NUM_VERTICES / B3_MAX_NUM_INDICES, measured).
MAX_MESH_VERTICES = 131_072
MAX_MESH_INDICES = 524_288
#: Side (m) of the square tiles that group obstacles when the world needs several meshes.
TILE_M = 10.0

Mesh = tuple[list[list[float]], list[int]]
Part = tuple[np.ndarray, np.ndarray]


def obstacle_meshes(obstacles: Sequence[Obstacle]) -> list[Part]:
    """Each obstacle's triangle mesh ``(vertices (V, 3), indices (3 T,))``, equal bit for bit to
    ``obstacle.mesh()``.

    Trunks (:class:`~fftnav.world.obstacles.Circle`) are made together: their outlines are
    ``centre + (radius / cos(pi / SIDES)) * unit`` over one shared unit polygon, as
    ``Circle.outline`` computes them, and they share one index array. Other shapes call their
    own ``mesh()``.
    """
    parts: list[Part | None] = [None] * len(obstacles)
    trunks = [k for k, o in enumerate(obstacles) if type(o) is Circle]
    for k, obstacle in enumerate(obstacles):
        if type(obstacle) is not Circle:
            parts[k] = obstacle.mesh()
    if trunks:
        sides = Circle.SIDES
        a = np.arange(sides) * (2.0 * math.pi / sides)
        unit = np.c_[np.cos(a), np.sin(a)]
        data = np.array([(*obstacles[k].center, obstacles[k].radius, obstacles[k].height)
                         for k in trunks])
        radius = data[:, 2] / math.cos(math.pi / sides)
        xy = data[:, None, :2] + radius[:, None, None] * unit  # (N, SIDES, 2)
        vertices = np.empty((len(trunks), sides, 2, 3))  # vertex 2 i at z = 0, 2 i + 1 on top
        vertices[:, :, :, :2] = xy[:, :, None, :]
        vertices[:, :, 0, 2] = 0.0
        vertices[:, :, 1, 2] = data[:, 3:4]
        vertices = vertices.reshape(len(trunks), 2 * sides, 3)
        indices = Circle((0.0, 0.0), 1.0, 1.0).mesh()[1]
        for row, k in enumerate(trunks):
            parts[k] = (vertices[row], indices)
    return parts  # type: ignore[return-value]


@dataclass(frozen=True)
class Tile:
    """A group of nearby obstacles built into Bullet together.

    Attributes
    ----------
    meshes : tuple of numpy.ndarray
        The obstacle indices of each of its meshes (each below Bullet's limits).
    box : tuple of float
        ``(xmin, ymin, xmax, ymax)`` (m): the smallest box holding the bounding circles of the
        tile's obstacles (which may reach past its 10 m square).
    """

    meshes: tuple[np.ndarray, ...]
    box: tuple[float, float, float, float]


def static_tiles(obstacles: Sequence[Obstacle], *, parts: Sequence[Part] | None = None,
                 max_vertices: int = MAX_MESH_VERTICES, max_indices: int = MAX_MESH_INDICES,
                 tile_m: float = TILE_M) -> list[Tile]:
    """The obstacles grouped into as few meshes as Bullet's limits allow.

    Parameters
    ----------
    obstacles : sequence of Obstacle
    parts : sequence of (vertices, indices), optional
        Their meshes (:func:`obstacle_meshes`, computed here when not given).
    max_vertices, max_indices : int
        Limits per mesh (Bullet's by default; tests force small ones).
    tile_m : float
        When everything does not fit one mesh, obstacles are grouped by the square tile of
        this side that holds their centre, tiles in row order, each tile packed (in the
        obstacles' order) into as few meshes as the limits allow.

    Returns
    -------
    list of Tile
        One tile of one mesh (in the obstacles' order) when everything fits, none for no
        obstacles.

    Raises
    ------
    ValueError
        If a single obstacle's mesh exceeds the limits (naming it).
    """
    parts = obstacle_meshes(obstacles) if parts is None else parts
    sizes = np.array([(len(v), np.size(i)) for v, i in parts], dtype=np.int64).reshape(-1, 2)
    too_big = np.flatnonzero((sizes[:, 0] > max_vertices) | (sizes[:, 1] > max_indices))
    if too_big.size:
        k = int(too_big[0])
        raise FftnavError(f"obstacles[{k}] has a mesh of {sizes[k, 0]} vertices and "
                          f"{sizes[k, 1]} indices, above Bullet's limit of {max_vertices} and "
                          f"{max_indices} per mesh")
    if not parts:
        return []
    circles = np.array([o.bounding_circle() for o in obstacles])
    boxes = np.c_[circles[:, :2] - circles[:, 2:], circles[:, :2] + circles[:, 2:]]
    total = sizes.sum(axis=0)
    if total[0] <= max_vertices and total[1] <= max_indices:
        groups = [np.arange(len(parts))]
    else:
        centres = np.array([np.add(*o.bounds()) / 2 for o in obstacles])
        cell = np.floor(centres / tile_m).astype(np.int64)
        order = np.lexsort((np.arange(len(parts)), cell[:, 0], cell[:, 1]))  # tile rows, then x
        key = cell[order]
        cuts = np.flatnonzero(np.any(key[1:] != key[:-1], axis=1)) + 1
        groups = np.split(order, cuts)
    tiles = []
    for group in groups:
        meshes, start, used = [], 0, np.zeros(2, dtype=np.int64)
        for n, k in enumerate(group):
            if n > start and np.any(used + sizes[k] > (max_vertices, max_indices)):
                meshes.append(group[start:n])
                start, used = n, np.zeros(2, dtype=np.int64)
            used += sizes[k]
        meshes.append(group[start:])
        box = boxes[group]
        tiles.append(Tile(tuple(meshes), (float(box[:, 0].min()), float(box[:, 1].min()),
                                          float(box[:, 2].max()), float(box[:, 3].max()))))
    return tiles


def static_meshes(obstacles: Sequence[Obstacle], *, max_vertices: int = MAX_MESH_VERTICES,
                  max_indices: int = MAX_MESH_INDICES, tile_m: float = TILE_M) -> list[Mesh]:
    """The meshes of :func:`static_tiles`, tile by tile, each as
    ``pybullet.createCollisionShape(GEOM_MESH, ...)`` takes it: one mesh (in the obstacles'
    order) when everything fits, none for no obstacles."""
    parts = obstacle_meshes(obstacles)
    return [join_meshes([parts[k] for k in mesh])
            for tile in static_tiles(obstacles, parts=parts, max_vertices=max_vertices,
                                     max_indices=max_indices, tile_m=tile_m)
            for mesh in tile.meshes]


def join_meshes(parts: Sequence[Part]) -> Mesh:
    """Concatenate obstacle meshes ``(vertices (V, 3), indices)`` into one, as
    :func:`fftnav.world.obstacles.combined_mesh` does (the same lists, tested)."""
    offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    vertices = np.concatenate([np.asarray(v, dtype=float).reshape(-1, 3) for v, _ in parts])
    indices = np.concatenate([np.asarray(i).ravel() + o for (_, i), o in zip(parts, offsets,
                                                                             strict=True)])
    return vertices.tolist(), indices.tolist()
