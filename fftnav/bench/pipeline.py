"""Latency benchmarks of the observation pipeline, and a generic CSV recorder.

Timings run on one thread and, where the OS allows it, one CPU: the process is pinned to a
single core with ``os.sched_setaffinity`` for the duration of the run; numpy's FFT (the 2D
pipeline), ``numpy.convolve``, ``scipy.ndimage`` and ``scipy.fft`` (the 3D image, default one
worker) are single-threaded (no BLAS call is involved). The alternatives are timed in three
groups (one scan; batches of 15 scans; one 3D image), round-robin within each group, so a busy
machine slows the alternatives of a group alike; each timed call directly follows
:data:`WARM_CALLS` untimed calls of the same function (warm caches: the steady state of a robot
running the pipeline on every scan); each figure is the median over the repeats.
"""

from __future__ import annotations

import csv
import datetime
import io
import os
import platform
import socket
import time
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from fftnav.errors import FftnavError
from fftnav.files import write_atomic
from fftnav.observe.geometry import SIM_ROBOT
from fftnav.observe.pipeline import Pipeline
from fftnav.observe.safe import safe_mask, sliding_min_safe_mask
from fftnav.observe.spherical import DiscFilterBank, SphericalGrid
from fftnav.validate import check_integer
from fftnav.world.scenes import trunk_scans

__all__ = ["bench_pipeline", "format_pipeline", "record_csv"]

BATCH = 15
#: Untimed calls of an alternative right before each of its timed calls (see :func:`_median_us`).
WARM_CALLS = 3


@contextmanager
def _one_cpu():
    """Pin this process to one CPU while timing (no-op where unsupported)."""
    if not hasattr(os, "sched_setaffinity"):
        yield None
        return
    before = os.sched_getaffinity(0)
    cpu = max(before)
    os.sched_setaffinity(0, {cpu})
    try:
        yield cpu
    finally:
        os.sched_setaffinity(0, before)


def _read_all(result) -> tuple:
    """Every field of a result, so that the ones a one-scan result makes on first access
    (``y1``, ``y2``, ``sigma_flat``, ``is_min_flat``, ``offsets``) are made."""
    return (result.safe_mask, result.y1, result.y2, result.sigma_flat, result.is_min_flat,
            result.offsets, result.messages, result.x0, result.p_s)


def _median_us(fns: dict[str, Callable[[], object]], repeats: int) -> dict[str, float]:
    """Median time (us) of each function; round-robin, each timed call right after
    ``WARM_CALLS`` untimed ones of the same function, so every figure is the warm
    (steady-state) latency of a loop that runs this function alone, rather than the cost of
    reloading the caches and branch history the previous alternative replaced; a busy machine
    still slows every alternative alike."""
    times = {name: np.empty(repeats) for name in fns}
    for r in range(repeats):
        for name, fn in fns.items():
            for _ in range(WARM_CALLS):
                fn()
            t0 = time.perf_counter_ns()
            fn()
            times[name][r] = time.perf_counter_ns() - t0
    return {name: float(np.median(t)) / 1e3 for name, t in times.items()}


def bench_pipeline(*, repeats: int = 2000, seed: int = 0, runs: int = 1) -> dict:
    """Time the pipeline per scan, single and in a batch of 15, beside other mask methods.

    The scans are 15 analytic trunk scenes (:func:`fftnav.world.scenes.trunk_scans`) with the
    paper's simulated robot and lidar (M = 360, R = 3 m, 15 degree blind sector).

    Parameters
    ----------
    repeats : int
        Timed repetitions of each alternative, ``>= 1``.
    seed : int
        Seed of the scenes.
    runs : int
        Independent runs, ``>= 1``; each figure is the best (smallest) of their medians.

    Returns
    -------
    dict
        ``single_us`` (one scan: safe mask, extrema, compact message; by the compiled kernels
        of :mod:`fftnav.observe.kernels` when numba is installed, ``compiled``),
        ``single_numpy_us`` (the same by the numpy path, timed side by side),
        ``single_all_fields_us`` (one scan, then every field of the result read: a one-scan
        result makes y1, y2, Sigma, its minima and the offsets on first access),
        ``batch15_us_per_scan``
        (same, batch of 15), ``batch15_with_p_s_us_per_scan`` (plus quadrant areas and P_s),
        the safe mask alone per scan in a batch of 15 by FFT (``mask_fft_us_per_scan``), by
        ``numpy.convolve`` (``mask_convolve_us_per_scan``) and by a sliding-window minimum
        (``mask_sliding_min_us_per_scan``), ``masks_agree``, ``repeats``, ``runs``, ``cpu``,
        ``load_avg_1min`` (the machine's load average at the end).
    """
    check_integer("repeats", repeats, low=1)
    check_integer("runs", runs, low=1)
    pipe = Pipeline(SIM_ROBOT)
    scans = trunk_scans(np.random.default_rng(seed), BATCH)
    groups, masks_agree = _alternatives(pipe, scans, seed)
    with _one_cpu() as cpu:
        us: dict[str, float] = {}
        for _ in range(runs):
            run = {name: t for fns in groups for name, t in _median_us(fns, repeats).items()}
            us = {k: min(v, us.get(k, v)) for k, v in run.items()}
    per_scan = {"batch15_us_per_scan": "batch", "batch15_with_p_s_us_per_scan": "batch_p_s",
                "mask_fft_us_per_scan": "mask_fft", "mask_convolve_us_per_scan": "mask_convolve",
                "mask_sliding_min_us_per_scan": "mask_sliding_min"}
    return {
        "single_us": round(us["single"], 2),
        "single_numpy_us": round(us["single_numpy"], 2),
        "single_all_fields_us": round(us["single_all_fields"], 2),
        "compiled": pipe.compiled,
        **{key: round(us[name] / BATCH, 2) for key, name in per_scan.items()},
        "depth90x360_us": round(us["depth90x360"], 2),
        "masks_agree": masks_agree,
        "repeats": repeats,
        "runs": runs,
        "cpu": cpu,
        "load_avg_1min": round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None,
    }


def _alternatives(pipe: Pipeline, scans: np.ndarray,
                  seed: int) -> tuple[list[dict[str, Callable[[], object]]], bool]:
    """The timed alternatives of :func:`bench_pipeline` in their three groups, and whether
    the three ways to the safe mask agree on ``scans``.

    Each group is timed round-robin within itself: one scan, batches of 15 scans, one 3D
    image. A member of one group is not an alternative to a member of another, and its larger
    working set (a batch's arrays and temporaries, the 3D image's megabytes of FFT work) would
    evict the other's caches between two of its calls.
    """
    reference = Pipeline(SIM_ROBOT, compiled=False)
    bank = pipe.bank
    box = bank.h1[bank.h1 > 0]  # the centred window of h1

    def mask_convolve() -> np.ndarray:
        s = np.minimum(pipe.normalise(scans), bank.threshold)
        y1 = np.array([np.convolve(row, box, mode="same") for row in s])
        return safe_mask(y1, threshold=bank.threshold)

    def mask_sliding_min() -> np.ndarray:
        return sliding_min_safe_mask(
            pipe.normalise(scans), window_beams=bank.window_beams, threshold=bank.threshold
        )

    masks = [pipe.safe_mask(scans), mask_convolve(), mask_sliding_min()]
    bank3d = DiscFilterBank(SphericalGrid(90, 360))  # the paper's drone, 90 x 360 deg, R = 10 m
    depth3d = np.random.default_rng(seed).uniform(0.5, 12.0, (90, 360))
    groups = [
        {
            "single": lambda: pipe.process(scans[0], with_p_s=False),
            "single_all_fields": lambda: _read_all(pipe.process(scans[0], with_p_s=False)),
            "single_numpy": lambda: reference.process(scans[0], with_p_s=False),
        },
        {
            "batch": lambda: pipe.process(scans, with_p_s=False),
            "batch_p_s": lambda: pipe.process(scans),
            "mask_fft": lambda: pipe.safe_mask(scans),
            "mask_convolve": mask_convolve,
            "mask_sliding_min": mask_sliding_min,
        },
        {"depth90x360": lambda: bank3d.safe_mask(depth3d)},
    ]
    return groups, all(np.array_equal(masks[0], m) for m in masks[1:])


def format_pipeline(result: dict) -> str:
    """Human-readable table of :func:`bench_pipeline`'s result (microseconds)."""
    rows = [
        ("pipeline, 1 scan (mask + extrema + message)", result["single_us"], "us"),
        ("same, numpy path (no compiled kernels)", result["single_numpy_us"], "us"),
        ("same, then every field read (y1, y2, Sigma, ...)", result["single_all_fields_us"],
         "us"),
        ("pipeline, batch of 15", result["batch15_us_per_scan"], "us/scan"),
        ("pipeline + P_s, batch of 15", result["batch15_with_p_s_us_per_scan"], "us/scan"),
        ("safe mask by FFT, batch of 15", result["mask_fft_us_per_scan"], "us/scan"),
        (
            "safe mask by numpy.convolve, batch of 15",
            result["mask_convolve_us_per_scan"],
            "us/scan",
        ),
        (
            "safe mask by sliding minimum, batch of 15",
            result["mask_sliding_min_us_per_scan"],
            "us/scan",
        ),
        ("3D safe mask, one 90 x 360 image (2D FFT)", result["depth90x360_us"], "us"),
    ]
    lines = [f"{name:<46} {value:>9.2f} {unit}" for name, value, unit in rows]
    lines.append(
        f"masks agree: {result['masks_agree']}; compiled kernels: {result['compiled']}; "
        f"best of {result['runs']} run(s) of the median of {result['repeats']} repeats, "
        f"pinned to CPU {result['cpu']}, load average {result['load_avg_1min']}"
    )
    return "\n".join(lines)


def record_csv(result: dict, path: str | Path, *, append: bool = False) -> None:
    """Write one row: the result's keys as columns plus ``timestamp``, ``host``, ``python``,
    ``numpy``. With ``append`` the row is added to an existing file, whose header must match."""
    row = {
        **result,
        "timestamp": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "host": socket.gethostname(),
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    path = Path(path)
    exists = append and path.exists() and path.stat().st_size > 0
    if exists:
        with path.open(newline="") as fh:
            header = next(csv.reader(fh), [])
        if header != list(row):
            raise FftnavError(
                f"cannot append to {str(path)!r}: its columns {header} differ from {list(row)}"
            )
    path.parent.mkdir(parents=True, exist_ok=True)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(row))
    if not exists:
        writer.writeheader()
    writer.writerow(row)
    earlier = path.read_bytes() if exists else b""
    write_atomic(path, earlier + text.getvalue().encode())  # the old file or the whole new one
