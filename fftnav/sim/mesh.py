"""Static obstacle meshes within Bullet's limits: tiles of nearby obstacles.

Bullet refuses a triangle mesh of more than :data:`MAX_MESH_VERTICES` vertices or
:data:`MAX_MESH_INDICES` triangle indices (``createCollisionShape failed``, or a
``SystemError`` from pybullet; measured with pybullet 3.2.7: 131,072 vertices and 524,288
indices build, one more fails). A trunk (a 64-gon prism) takes 128 vertices and 756 indices, so
one mesh holds at most 693 trunks. :func:`static_meshes` keeps the whole world one mesh when it
fits (the fastest for the physics) and otherwise
splits it into square tiles of nearby obstacles, each packed into meshes below the limits. Ray
casts against a triangle are exact whichever mesh holds it, so the lidar reads the same ranges,
bit for bit, however the obstacles are tiled (tested with a forced small mesh size). Contacts
are resolved per mesh, so a robot touching obstacles of two meshes at once may move differently
in the last bits than with one mesh; worlds that fit one mesh (every world of the paper's size)
are one mesh. numpy only.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fftnav.world.obstacles import Obstacle

__all__ = ["MAX_MESH_INDICES", "MAX_MESH_VERTICES", "TILE_M", "static_meshes"]

#: Largest mesh Bullet builds (pybullet's B3_MAX_NUM_VERTICES / B3_MAX_NUM_INDICES, measured).
MAX_MESH_VERTICES = 131_072
MAX_MESH_INDICES = 524_288
#: Side (m) of the square tiles that group obstacles when the world needs several meshes.
TILE_M = 10.0

Mesh = tuple[list[list[float]], list[int]]


def static_meshes(obstacles: Sequence[Obstacle], *, max_vertices: int = MAX_MESH_VERTICES,
                  max_indices: int = MAX_MESH_INDICES, tile_m: float = TILE_M) -> list[Mesh]:
    """The obstacles as few triangle meshes as Bullet's limits allow.

    Parameters
    ----------
    obstacles : sequence of Obstacle
    max_vertices, max_indices : int
        Limits per mesh (Bullet's by default; tests force small ones).
    tile_m : float
        Obstacles are grouped by the square tile of this side that holds their centre, tiles
        in row order, so that each mesh covers a compact area (small bounding boxes).

    Returns
    -------
    list of (vertices, indices)
        Each as ``pybullet.createCollisionShape(GEOM_MESH, ...)`` takes it; one mesh (in the
        obstacles' order) when everything fits, none for no obstacles.

    Raises
    ------
    ValueError
        If a single obstacle's mesh exceeds the limits (naming it).
    """
    parts = [o.mesh() for o in obstacles]
    sizes = np.array([(len(v), i.size) for v, i in parts], dtype=np.int64).reshape(-1, 2)
    for k, (nv, ni) in enumerate(sizes):
        if nv > max_vertices or ni > max_indices:
            raise ValueError(f"obstacles[{k}] has a mesh of {nv} vertices and {ni} indices, above "
                             f"Bullet's limit of {max_vertices} and {max_indices} per mesh")
    if not parts:
        return []
    total = sizes.sum(axis=0)
    if total[0] <= max_vertices and total[1] <= max_indices:
        return [_join(parts)]
    centres = np.array([np.add(*o.bounds()) / 2 for o in obstacles])
    tiles = np.floor(centres / tile_m).astype(np.int64)
    order = np.lexsort((centres[:, 0], tiles[:, 0], tiles[:, 1]))  # tile rows, then x
    meshes: list[Mesh] = []
    group: list[tuple[np.ndarray, np.ndarray]] = []
    used = np.zeros(2, dtype=np.int64)
    for k in order:
        if group and (used[0] + sizes[k, 0] > max_vertices or used[1] + sizes[k, 1] > max_indices):
            meshes.append(_join(group))
            group, used = [], np.zeros(2, dtype=np.int64)
        group.append(parts[k])
        used += sizes[k]
    meshes.append(_join(group))
    return meshes


def _join(parts: Sequence[tuple[np.ndarray, np.ndarray]]) -> Mesh:
    """Concatenate obstacle meshes ``(vertices (V, 3), indices)`` into one, as
    :func:`fftnav.world.obstacles.combined_mesh` does (the same lists, tested)."""
    offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    vertices = np.concatenate([np.asarray(v, dtype=float).reshape(-1, 3) for v, _ in parts])
    indices = np.concatenate([np.asarray(i).ravel() + o for (_, i), o in zip(parts, offsets,
                                                                             strict=True)])
    return vertices.tolist(), indices.tolist()
