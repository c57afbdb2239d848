"""Measurements quoted in docs/3d.md: the disc footprints by elevation band, the 2D FFT against a
sliding minimum, and the cost of one PyBullet spherical scan (mesh against cylinder trunks).

Run from the repository root: ``.venv/bin/python experiments/3d_measurements.py``.
Timings are medians of repeated runs, the alternatives interleaved in one process; read their
ratios, not their absolute values, on a shared machine.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy import ndimage

from fftnav.observe.geometry import DRONE
from fftnav.observe.spherical import DiscFilterBank, SphericalGrid, disc_footprint
from fftnav.sim.drone import DroneSim, make_forest3d


def _median_s(fns: dict, repeats: int) -> dict[str, float]:
    times: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(repeats):
        for name, fn in fns.items():  # interleaved: the machine's load hits both alike
            t = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t)
    return {k: float(np.median(v)) for k, v in times.items()}


def band_table(grid: SphericalGrid, elevations_deg: list[float]) -> None:
    """Per elevation: pixels of the row's own disc, pixels tested by its band's footprint, and
    the share of the disc that the single horizon footprint (the former filter) tested."""
    bank = DiscFilterBank(grid)
    half = DRONE.alpha_rad / 2
    el = grid.elevations_rad()
    open_mask = bank.safe_mask(np.full((grid.rows, grid.cols), np.inf))
    highest = math.degrees(np.abs(el[open_mask.any(axis=1)]).max())
    horizon = disc_footprint(grid, 0.0, half_angle_rad=half)
    print(f"\n{grid.rows} x {grid.cols} image over {math.degrees(grid.fov_el_rad):g} x "
          f"{math.degrees(grid.fov_az_rad):g} deg, alpha = {DRONE.alpha_deg:.1f} deg: "
          f"{len(bank.bands)} bands; highest row that can be safe: {highest:.2f} deg")
    print("| elevation | band rows | disc pixels | tested pixels (band) | tested / disc "
          "| disc share tested by one horizon footprint |")
    print("|---|---|---|---|---|---|")
    for e_deg in [*elevations_deg, highest]:
        i = int(np.argmin(np.abs(el - math.radians(e_deg))))
        band = next(b for b in bank.bands if i in b.rows)
        own = disc_footprint(grid, el[i], half_angle_rad=half)
        w = max(own.shape[1], horizon.shape[1])
        pad = [np.pad(f, ((0, 0), ((w - f.shape[1]) // 2,) * 2)) for f in (own, horizon)]
        share = (pad[0] & pad[1]).sum() / own.sum()
        span = np.degrees(np.abs(el[band.rows]))
        print(f"| {math.degrees(el[i]):.2f} deg | |e| {span.min():.1f}-{span.max():.1f} deg | "
              f"{own.sum()} | {band.footprint.sum()} | {band.footprint.sum() / own.sum():.2f} | "
              f"{share:.0%} |")


def fft_vs_minimum_filter(repeats: int = 30) -> None:
    """One 90 x 360 safe mask: the banded 2D FFT against scipy's minimum_filter per band."""
    bank = DiscFilterBank(SphericalGrid(90, 360))
    depth = np.random.default_rng(0).uniform(0.5, 12.0, (90, 360))

    def sliding_min() -> np.ndarray:
        s = np.minimum(depth, bank.range_m) / bank.range_m
        mask = np.empty(s.shape, bool)
        for band in bank.bands:
            a, b = (n // 2 for n in band.footprint.shape)
            p = np.pad(np.pad(s, ((0, 0), (b, b)), mode="wrap"), ((a, a), (0, 0)))
            m = ndimage.minimum_filter(p, footprint=band.footprint, mode="constant")
            mask[band.rows] = m[a:-a, b:-b][band.rows] >= bank.threshold
        return mask

    assert np.array_equal(bank.safe_mask(depth), sliding_min())
    t = _median_s({"fft": lambda: bank.safe_mask(depth), "minimum_filter": sliding_min}, repeats)
    print(f"\n90 x 360 safe mask, median of {repeats}: 2D FFT ({len(bank.bands)} bands) "
          f"{t['fft'] * 1e6:,.0f} us, minimum_filter {t['minimum_filter'] * 1e6:,.0f} us, "
          f"ratio {t['minimum_filter'] / t['fft']:.1f}")


def scan_cost(positions: int = 10) -> None:
    """One 90 x 360 PyBullet scan in the seed-0 forest: trunks as one mesh vs as cylinders."""
    grid = SphericalGrid(90, 360)
    forest = make_forest3d(np.random.default_rng(0))
    points = [np.array([x, 0.5, 2.0]) for x in np.linspace(0.0, 30.0, positions)]
    with (DroneSim(forest, grid=grid, trunk_shape="mesh") as mesh,
          DroneSim(forest, grid=grid, trunk_shape="cylinder") as cyl):
        fns = {"mesh": lambda: [mesh.scan(q, 0.0) for q in points],
               "cylinder": lambda: [cyl.scan(q, 0.0) for q in points]}
        t = _median_s(fns, 3)
        diff = np.array([np.abs(mesh.scan(q, 0.0) - cyl.scan(q, 0.0)) for q in points])
    per = {k: v / positions for k, v in t.items()}
    print(f"\n90 x 360 scan of the seed-0 forest ({len(forest.trunks)} trees), median over 3 x "
          f"{positions} positions: mesh trunks {per['mesh']:.3f} s, cylinder trunks "
          f"{per['cylinder']:.3f} s, ratio {per['cylinder'] / per['mesh']:.1f}; readings differing "
          f"by more than 1 cm: {(diff > 0.01).mean():.2%}, median difference "
          f"{np.median(diff) * 1000:.2f} mm")


if __name__ == "__main__":
    band_table(SphericalGrid(90, 360), [0.0, 15.0, 25.0, 45.0])
    band_table(SphericalGrid(180, 360, math.pi), [0.0, 30.0, 45.0, 60.0, 75.0])
    fft_vs_minimum_filter()
    scan_cost()
