"""The documented resource limits, and estimate-then-refuse checks for them.

Every stage that allocates or loops in proportion to an input estimates the amount first and
refuses (:class:`~fftnav.errors.FftnavError`, a ``ValueError``, naming the estimate, the limit
and what to change) before allocating anything, so that a typo such as ``--resolution 1e-6`` or
``maps = 1000000000`` is a one-line refusal instead of an hour of swapping:

>>> check_limit("grid cells", 4_000_000_000, MAX_GRID_CELLS, hint="raise resolution_m")
Traceback (most recent call last):
...
fftnav.errors.FftnavError: grid cells: 4,000,000,000 estimated, above the limit of \
100,000,000; raise resolution_m

The limits (``docs/experiments.md`` lists them) are far above anything the paper's setup needs
and below what a 2-core, 8 GB machine survives. Pure Python.
"""

from __future__ import annotations

import math

from fftnav.errors import FftnavError

__all__ = [
    "MAX_BEAMS", "MAX_DEPTH_PIXELS", "MAX_EPISODE_PHYSICS_STEPS", "MAX_GRID_CELLS",
    "MAX_INPUT_BYTES", "MAX_JSON_DEPTH", "MAX_MAP_SIDE_M", "MAX_OBSTACLES", "MAX_RAYS_PER_TICK",
    "MAX_REFERENCE_CELLS", "MAX_TASKS", "check_limit", "grid_cells",
]

#: Cells of one occupancy grid (bool; labelling needs 4 bytes per cell more): 100 million.
MAX_GRID_CELLS = 100_000_000
#: Cells of the grid the A* / geodesic reference (SPL) searches: its 32-connected graph costs
#: about 2 kB per cell (measured: 2.9 GB peak for a 60 m x 60 m map at 0.05 m, 1.44 million
#: cells). Larger maps get a coarser reference grid
#: (:func:`fftnav.optimal.reference.reference_resolution`).
MAX_REFERENCE_CELLS = 1_500_000
#: Lidar rays cast in one control tick (robots x beams).
MAX_RAYS_PER_TICK = 2_000_000
#: Beams of one scan.
MAX_BEAMS = 100_000
#: Physics steps of one episode (time_limit_s x physics_hz): 3 million, 3.5 h of simulated time
#: at the default 240 Hz, and about 2.5 min of physics alone for 15 robots on a 2-core machine
#: (49 us per step: results/sim_speed.csv, physics_ms_per_s / physics_hz).
MAX_EPISODE_PHYSICS_STEPS = 3_000_000
#: Episodes (envs x maps x policies) of one experiment.
MAX_TASKS = 10_000_000
#: Side of a world (m).
MAX_MAP_SIDE_M = 1000.0
#: Obstacles of one world.
MAX_OBSTACLES = 50_000
#: Pixels of one spherical depth image (rows x cols), and its filter's FFT grid.
MAX_DEPTH_PIXELS = 20_000_000
#: Bytes of one array read from a file (npy, npz member, csv, CARMEN log).
MAX_INPUT_BYTES = 2 * 1024**3
#: Nesting depth of a JSON document (a world file needs 4).
MAX_JSON_DEPTH = 64


def check_limit(what: str, estimate: float, limit: float, *, hint: str = "") -> float:
    """Return ``estimate`` if it is finite and at most ``limit``; else FftnavError with both.

    Parameters
    ----------
    what : str
        What is counted, e.g. ``"grid cells"`` (with the file or key it comes from).
    estimate : float
        The amount the input asks for, computed before allocating anything.
    limit : float
        The documented limit.
    hint : str, optional
        What to change, appended to the message.
    """
    if not math.isfinite(estimate) or estimate > limit:
        small = math.isfinite(estimate) and estimate < 1e18
        shown = f"{estimate:,.0f}" if small else f"{estimate:.3g}"
        raise FftnavError(f"{what}: {shown} estimated, above the limit of {limit:,}"
                          + (f"; {hint}" if hint else ""))
    return estimate


def grid_cells(width_m: float, height_m: float, resolution_m: float) -> float:
    """Cells of a grid covering ``width_m x height_m`` at ``resolution_m`` (a float, so that
    absurd inputs give ``inf`` or ``1e600``-like values instead of overflowing)."""
    try:
        return math.ceil(width_m / resolution_m) * float(math.ceil(height_m / resolution_m))
    except (OverflowError, ValueError, ZeroDivisionError):
        return math.inf
