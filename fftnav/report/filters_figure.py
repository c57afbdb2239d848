"""The paper's Fig. 3 (safe directions) and Fig. 5 (dimension reduction) for an analytic scene.

The scene is a robot among circular trunks (:mod:`fftnav.world.scenes`), seen by the paper's
simulated lidar (M = 360, R = 3 m, 15 degree blind sector reading 0) with the simulated robot
(l_th = 0.6 m, alpha = 60 deg).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from matplotlib.patches import Circle

from fftnav.observe.compress import reconstruct
from fftnav.observe.geometry import SIM_ROBOT
from fftnav.observe.pipeline import Pipeline, PipelineResult
from fftnav.observe.safe import nearest_safe_headings
from fftnav.report import new_figure, save_figure
from fftnav.world.scenes import random_trunks, ray_cast_circles

__all__ = ["draw_filter_figures", "SCENE_SEED", "TARGET_RAD"]

#: Seed of the trunk scene drawn in the figures (26 random trunks plus one straight ahead).
SCENE_SEED = 12
#: Target bearing (rad) for the two candidate headings of Fig. 3c / 3f.
TARGET_RAD = 0.0


def _response(ax_t, ax_f, h, *, n0, cutoff, name, label_t):
    ax_t.plot(np.arange(len(h)), h, "C0.-", ms=3, lw=1)
    ax_t.set(title=f"({label_t}) {name}(n), N = {len(h)}", xlabel="n (samples)", ylabel=name)
    f = np.arange(n0 // 2 + 1) / n0
    mag = np.abs(np.fft.rfft(h, n0))
    db = 20 * np.log10(np.maximum(mag / mag[0], 1e-6))
    ax_f.plot(f, db, "C0-", lw=1)
    ax_f.axhline(-3, color="grey", ls=":", lw=0.8)
    ax_f.plot([cutoff], [-3], "ro")
    ax_f.annotate(
        f"-3 dB at f = {cutoff:.4f}",
        (cutoff, -3),
        (cutoff + 0.03, -12),
        arrowprops={"arrowstyle": "->"},
    )
    ax_f.set(
        xlim=(0, 0.15),
        ylim=(-80, 5),
        xlabel="digital frequency (cycles / beam)",
        ylabel="gain (dB)",
        title=f"({chr(ord(label_t) + 1)}) |{name.upper()}(k)|, N0 = {n0}",
    )


def _scene_axes(ax, centres, radii, xy, title):
    for c, r in zip(centres, radii, strict=True):
        ax.add_patch(Circle(c, r, color="0.6"))
    ax.add_patch(Circle((0, 0), SIM_ROBOT.r0_m, color="C1"))
    ax.plot(xy[:, 0], xy[:, 1], ".", ms=2, color="C0")
    ax.set(
        xlim=(-3.3, 3.3),
        ylim=(-3.3, 3.3),
        aspect="equal",
        title=title,
        xlabel="x (m, ahead)",
        ylabel="y (m, left)",
    )


def _arrows(ax, headings, length):
    for a, colour in zip(headings, ("C2", "C3"), strict=True):
        if np.isfinite(a):
            ax.annotate(
                "",
                (length * math.cos(a), length * math.sin(a)),
                (0, 0),
                arrowprops={"arrowstyle": "->", "color": colour, "lw": 2},
            )


class _Scene(NamedTuple):
    """The analytic scene seen by the paper's simulated lidar, and the pipeline's output."""

    pipe: Pipeline
    centres: np.ndarray
    radii: np.ndarray
    #: Distances of the scan, its normalised form ``d / R``, the processed result.
    d: np.ndarray
    s: np.ndarray
    res: PipelineResult
    #: Beam angles in degrees; the hits as points (x, y) and which beams hit.
    deg: np.ndarray
    xy: np.ndarray
    hit: np.ndarray
    #: The safe headings nearest to :data:`TARGET_RAD` on either side.
    headings: tuple[float, float]


def _scene() -> _Scene:
    """26 random trunks (:data:`SCENE_SEED`) and one ahead, scanned and processed."""
    pipe = Pipeline(SIM_ROBOT)
    b = pipe.bank
    centres, radii = random_trunks(
        np.random.default_rng(SCENE_SEED), n_trunks=26, extent_m=2.8, clearance_m=0.3
    )
    centres, radii = np.vstack([centres, [0.7, 0.05]]), np.append(radii, 0.2)
    d = ray_cast_circles(
        centres, radii, angles_rad=pipe.angles_rad, range_m=b.range_m, blind_rad=b.blind_rad
    )
    res = pipe.process(d)
    headings = nearest_safe_headings(res.safe_mask[0], TARGET_RAD, fov_rad=b.fov_rad)
    hit = np.isfinite(d) & (d > 0)
    a_hit = pipe.angles_rad[hit]
    xy = np.column_stack([d[hit] * np.cos(a_hit), d[hit] * np.sin(a_hit)])
    return _Scene(pipe, centres, radii, d, pipe.normalise(d)[0], res,
                  np.degrees(pipe.angles_rad), xy, hit, headings)


def draw_filter_figures(out_dir: Path) -> list[Path]:
    """Draw ``fig3_safe_directions.png`` and ``fig5_compression.png`` into ``out_dir``.

    Returns the paths written.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    scene = _scene()
    fig3 = _draw_fig3(scene, out_dir / "fig3_safe_directions.png")
    fig5 = _draw_fig5(scene, out_dir / "fig5_compression.png")
    return [fig3, fig5]


def _draw_fig3(scene: _Scene, path: Path) -> Path:
    """Fig. 3: h1's response, the scan, the clipped and filtered scan, the safe directions."""
    pipe, b, res, deg, s, xy = scene.pipe, scene.pipe.bank, scene.res, scene.deg, scene.s, scene.xy
    fig = new_figure(figsize=(15, 8.5), layout="constrained")
    ax = fig.subplots(2, 3)
    _response(ax[0, 0], ax[0, 1], b.h1, n0=b.n0, cutoff=b.cutoff_3db_h1, name="h1", label_t="a")
    ax[0, 0].set_xlim(b.tau - 1.5 * b.window_beams, b.tau + 1.5 * b.window_beams)
    _scene_axes(ax[0, 2], scene.centres, scene.radii, xy,
                "(c) scan and the safe headings nearest to ahead")
    _arrows(ax[0, 2], scene.headings, 2.5)
    ax[1, 0].plot(deg, s, color="0.7", lw=1, label="s = d / R")
    ax[1, 0].plot(deg, np.minimum(s, b.threshold), "C0", lw=1.5, label="clipped at l_th / R")
    ax[1, 0].set(title=f"(d) clipped scan, l_th = {SIM_ROBOT.l_th_m:.2f} m")
    ax[1, 1].plot(deg, res.y1[0], "C0", label="y1 = h1 * clipped")
    ax[1, 1].axhline(b.threshold, color="r", ls="--", lw=1, label="l_th / R")
    ax[1, 1].fill_between(
        deg, 0, res.y1[0], where=res.safe_mask[0], color="C2", alpha=0.3, label="safe"
    )
    ax[1, 1].set(title="(e) filtered data against the threshold")
    for a in ax[1, :2]:
        a.set(
            xlabel="beam angle (deg, CCW from heading)",
            ylabel="normalised distance",
            xlim=(-180, 180),
            ylim=(0, 1.05),
        )
        a.legend(loc="upper right", fontsize=8)
    ax[1, 1].set_ylim(0, 1.3 * b.threshold)
    safe_xy = xy[res.safe_mask[0][scene.hit]]
    _scene_axes(ax[1, 2], scene.centres, scene.radii, xy, "(f) safe directions (green)")
    m = res.safe_mask[0]
    ax[1, 2].plot(
        2.8 * np.cos(pipe.angles_rad[m]), 2.8 * np.sin(pipe.angles_rad[m]), "s", ms=3, color="C2"
    )
    ax[1, 2].plot(safe_xy[:, 0], safe_xy[:, 1], ".", ms=3, color="C2")
    _arrows(ax[1, 2], scene.headings, 2.5)
    fig.suptitle(
        f"Fig. 3: safe directions (M = {b.beams}, Tc = {b.tc}, window = "
        f"{b.window_beams} beams, fc = 1/{1 / b.fc:.0f}, N0 = {b.n0})"
    )
    save_figure(fig, path, dpi=110)
    return path


def _draw_fig5(scene: _Scene, path: Path) -> Path:
    """Fig. 5: h2's response, the filtered scan's extrema (the message) and the reconstruction
    from them."""
    pipe, b, res, deg = scene.pipe, scene.pipe.bank, scene.res, scene.deg
    sig, mins = res.sigma[0], res.is_min[0]
    rec = reconstruct(sig, pipe.angles_rad, full_circle=True)
    fig = new_figure(figsize=(12, 8.5), layout="constrained")
    ax = fig.subplots(2, 2)
    _response(ax[0, 0], ax[0, 1], b.h2, n0=b.n0, cutoff=b.cutoff_3db_h2, name="h2", label_t="a")
    ax[1, 0].plot(deg, scene.s, color="0.7", lw=1, label="s = d / R")
    ax[1, 0].plot(deg, res.y2[0], "C0", label="y2 = h2 * s")
    sd = np.degrees(sig[:, 0])
    ax[1, 0].plot(sd[~mins], sig[~mins, 1] / b.range_m, "^", color="C2", label="maxima")
    ax[1, 0].plot(sd[mins], sig[mins, 1] / b.range_m, "v", color="C3", label="minima")
    ax[1, 0].axvspan(-180, -180 + 7.5, color="k", alpha=0.15, label="blind sector")
    ax[1, 0].axvspan(180 - 7.5, 180, color="k", alpha=0.15)
    ax[1, 0].set(
        xlim=(-180, 180),
        ylim=(0, 1.12),
        xlabel="beam angle (deg)",
        ylabel="normalised distance",
        title=f"(c) filtered data and its {len(sig)} extrema ({len(res.messages[0])}-byte message)",
    )
    ax[1, 0].legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=5, fontsize=8)
    _scene_axes(ax[1, 1], scene.centres, scene.radii, scene.xy,
                "(d) reconstruction from the extrema")
    ax[1, 1].plot(
        rec * np.cos(pipe.angles_rad),
        rec * np.sin(pipe.angles_rad),
        "C1-",
        lw=1.5,
        label="linear interpolation",
    )
    ax[1, 1].plot(
        sig[:, 1] * np.cos(sig[:, 0]), sig[:, 1] * np.sin(sig[:, 0]), "ko", ms=4, label="extrema"
    )
    ax[1, 1].legend(loc="upper right", fontsize=8)
    fig.suptitle(
        f"Fig. 5: dimension reduction (Blackman-windowed sinc, N2 = {b.n2}, "
        f"fc = 1/{1 / b.fc:.0f}); P_s = {res.p_s[0]:.3f}"
    )
    save_figure(fig, path, dpi=110)
    return path
