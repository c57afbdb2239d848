"""Top-down pictures of worlds (obstacles, starts, goals, scale bar)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.patches import Polygon as PolygonPatch

from fftnav.report import new_figure, save_figure
from fftnav.world import World

__all__ = ["draw_world", "render_world"]


def draw_world(world: World, ax: Any, *, starts: bool = True, scale_bar: bool = True) -> None:
    """Draw ``world`` on a matplotlib axes: obstacles (grey), starts (blue arrows along the start
    yaw; ``starts``), goals (green stars), the world border (thick for boundary walls) and a 1 m
    scale bar (``scale_bar``).
    Axes are in metres, equal aspect, x right and y up."""
    for obstacle in world.obstacles:
        patch = PolygonPatch(obstacle.outline(), closed=True)  # trunks: their 64-gon
        patch.set(facecolor="0.45", edgecolor="0.2", linewidth=0.5)
        ax.add_patch(patch)
    w, h = world.size_m
    walls = world.boundary == "walls"  # a boundary wall is drawn as a thick border
    ax.plot([0, w, w, 0, 0], [0, 0, h, h, 0], color="k", lw=3.0 if walls else 0.8)
    if starts:
        sx, sy, yaw = world.starts.T
        ax.quiver(sx, sy, 0.5 * np.cos(yaw), 0.5 * np.sin(yaw), color="tab:blue", angles="xy",
                  scale_units="xy", scale=1, width=0.004)
        ax.plot(sx, sy, "o", color="tab:blue", ms=3, label="starts")
    ax.plot(world.goals[:, 0], world.goals[:, 1], "*", color="tab:green", ms=7, label="goals")
    if scale_bar:
        bar_y = -0.04 * h
        ax.plot([0, 1], [bar_y, bar_y], color="k", lw=2)
        ax.text(0.5, bar_y * 1.8, "1 m", ha="center", va="top", fontsize=8)
    ax.set_xlim(-0.02 * w, 1.02 * w)
    ax.set_ylim(-0.1 * h if scale_bar else -0.02 * h, 1.02 * h)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def render_world(world: World, path: str | Path) -> Path:
    """Draw ``world`` (see :func:`draw_world`) into an image file; return its path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = new_figure(figsize=(6, 6.4), dpi=120)
    ax = fig.subplots()
    draw_world(world, ax)
    ax.set_title(f"{world.env} world, seed {world.seed}: {len(world.obstacles)} obstacles, "
                 f"{len(world.starts)} robots", fontsize=9)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.9)
    fig.tight_layout()
    save_figure(fig, path)
    return path
