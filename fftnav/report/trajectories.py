"""Trajectories of one episode drawn over its map (the paper's Fig. 7 style)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure

from fftnav.config import SwarmConfig
from fftnav.episode.record import EpisodeRow
from fftnav.report import new_figure, save_figure
from fftnav.report.frames import KINDS, SwarmFrame, draw_frame
from fftnav.report.world_plot import draw_world
from fftnav.world.model import World

__all__ = ["draw_trajectories", "episode_frame", "plot_episode", "plot_failures"]


def draw_trajectories(
    ax: Any, world: World, trajectories: Sequence[np.ndarray],
    arrived: Sequence[bool] | None = None,
) -> None:
    """Draw the map (obstacles, starts, goals) and every robot's path on ``ax``.

    Arrived robots (``arrived[i]``; all when None) are solid lines, failed ones dashed with a
    cross where they stopped.
    """
    draw_world(world, ax)
    colors = colormaps["viridis"](np.linspace(0.0, 0.95, max(len(trajectories), 1)))
    for i, path in enumerate(trajectories):
        ok = True if arrived is None else bool(arrived[i])
        ax.plot(path[:, 0], path[:, 1], color=colors[i], lw=1.2, ls="-" if ok else "--")
        if not ok:
            ax.plot(path[-1, 0], path[-1, 1], "x", color="crimson", ms=8, mew=2)


def episode_frame(trajectories: Sequence[np.ndarray], rows: Sequence[EpisodeRow]) -> SwarmFrame:
    """The last frame of an episode from its trajectories and rows: every robot where it
    stopped, arrived or failed (with its cause), its whole path as its trail."""
    poses = np.array([np.asarray(t)[-1, :3] for t in trajectories]).reshape(-1, 3)
    kinds = np.array([KINDS.index("arrived" if r.arrived else "failed") for r in rows])
    return SwarmFrame(poses=poses, kinds=kinds, trails=[np.asarray(t)[:, :2]
                                                        for t in trajectories],
                      causes=[getattr(r, "failure", "") or "" for r in rows])


def plot_episode(
    world: World,
    trajectories: Sequence[np.ndarray],
    rows: Sequence[EpisodeRow],
    path: str | Path,
    *,
    title: str = "",
    r0_m: float | None = None,
) -> Path:
    """Write a PNG of one episode's end over its map (:func:`episode_frame`, drawn as a replay
    frame by :mod:`fftnav.report.frames`): headings, trails, a cross for each failed robot;
    robots of radius ``r0_m`` (default: the default configuration's); returns the path."""
    fig = new_figure(figsize=(6.5, 6.5), dpi=120)
    ax = fig.subplots()
    r0_m = SwarmConfig().robot.r0_m if r0_m is None else r0_m
    draw_frame(ax, world, episode_frame(trajectories, rows), r0_m)
    arrived = sum(r.arrived for r in rows)
    ax.set_title(title or f"{rows[0].policy}: {arrived}/{len(rows)} arrived")
    return _save(fig, path)


def _save(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` to ``path`` (its folder created); returns the path."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, out, bbox_inches="tight")
    return out


def plot_failures(
    world: World,
    trajectories: Sequence[np.ndarray],
    rows: Sequence[EpisodeRow],
    path: str | Path,
    *,
    title: str = "",
    control_hz: float = 10.0,
) -> Path:
    """Write a PNG of the robots of one episode that did not arrive: each path dashed, dotted
    once a second in a colour that goes from dark (start) to yellow (end), so that loops and
    back-and-forth show, with the robot's index at its start (docs/planner.md)."""
    fig = new_figure(figsize=(6.5, 6.5), dpi=120)
    ax = fig.subplots()
    failed = [i for i, r in enumerate(rows) if not r.arrived]
    draw_trajectories(ax, world, [trajectories[i] for i in failed], [False] * len(failed))
    step = max(int(round(control_hz)), 1)
    for i in failed:
        t = trajectories[i][::step]
        ax.scatter(t[:, 0], t[:, 1], c=np.arange(len(t)), cmap="plasma", s=4, zorder=3)
        ax.annotate(str(i), trajectories[i][0, :2], xytext=(0, -10),
                    textcoords="offset points", ha="center", fontsize=7)
    ax.set_title(title or f"{rows[0].policy}: the {len(failed)} of {len(rows)} robots that "
                 "did not arrive")
    return _save(fig, path)

