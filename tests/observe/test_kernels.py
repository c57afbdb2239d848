"""The compiled single-scan path is bit-identical to the numpy path (the FFT reference).

The oracle is ``Pipeline(compiled=False)``: the batched numpy implementation, FFT filtering and
vectorised extrema search. Every output of one scan is compared exactly (``array_equal`` on
floats, equal bytes), on random scans (hypothesis) and on every scan of the four Radish logs;
deliberately broken kernels must be caught by the same comparison.
"""

from __future__ import annotations

import inspect
import math
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from fftnav.observe import kernels
from fftnav.observe.geometry import REAL_ROBOT, SIM_ROBOT
from fftnav.observe.pipeline import Pipeline
from fftnav.observe.scanio import read_scans
from fftnav.world.scenes import trunk_scans

pytestmark = pytest.mark.skipif(not kernels.AVAILABLE, reason="numba is not installed")

RADISH = sorted(Path("/work/shared/data/radish").glob("*.log.gz"))
FIELDS = ("safe_mask", "y1", "y2", "sigma_flat", "is_min_flat", "offsets", "x0", "p_s")


def differences(fast: Pipeline, slow: Pipeline, scans: np.ndarray) -> list[str]:
    """Names of the outputs that differ between the two pipelines, with the first scan."""
    found = []
    for i, scan in enumerate(scans):
        for with_p_s in (True, False):
            a, b = fast.process(scan, with_p_s=with_p_s), slow.process(scan, with_p_s=with_p_s)
            found += [f"{name} (scan {i})" for name in FIELDS
                      if not np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True)
                      or getattr(a, name).shape != getattr(b, name).shape]
            if a.messages != b.messages or a.sigma[0].tobytes() != b.sigma[0].tobytes():
                found.append(f"messages or sigma (scan {i})")
            if found:
                return found
    return found


def pair(geometry=SIM_ROBOT, **kwargs) -> tuple[Pipeline, Pipeline]:
    return Pipeline(geometry, compiled=True, **kwargs), Pipeline(geometry, compiled=False, **kwargs)


SIM = pair()
CIRCULAR = pair(mode="circular")
FLOAT32 = pair(layout="float32")
PARTIAL = pair(REAL_ROBOT, beams=181, fov_rad=math.pi, range_m=10.0)

# readings as a lidar gives them: open (inf, >= R), blocked (NaN, negative), exactly l_th,
# plateaus of equal readings, and arbitrary values
READING = st.one_of(
    st.floats(0.0, 4.0),
    st.sampled_from([math.inf, math.nan, -1.0, 0.0, 0.6, 3.0, 2.5]),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
)


def scans_of(beams: int):
    return hnp.arrays(np.float64, (3, beams), elements=READING)


@settings(max_examples=150, deadline=None)
@given(scans_of(360), st.integers(0, 3))
def test_random_scans_linear(scans, quantise):
    if quantise:  # plateaus: readings on a coarse grid
        scans = np.round(scans, quantise - 1)
    assert differences(*SIM, scans) == []


@settings(max_examples=60, deadline=None)
@given(scans_of(360))
def test_random_scans_circular_and_float32_layout(scans):
    assert differences(*CIRCULAR, scans) == []
    assert differences(*FLOAT32, scans) == []


@settings(max_examples=60, deadline=None)
@given(scans_of(181))
def test_random_scans_partial_field_of_view(scans):
    assert differences(*PARTIAL, scans) == []


def test_open_and_blocked_scans():
    scans = np.array([np.full(360, np.inf), np.zeros(360), np.full(360, np.nan),
                      np.full(360, 0.6), np.r_[np.full(180, 0.3), np.full(180, 3.0)]])
    assert differences(*SIM, scans) == []
    assert differences(*CIRCULAR, scans) == []


def test_radish_logs_are_all_there():
    assert len(RADISH) == 4


@pytest.mark.parametrize("log", RADISH, ids=lambda p: p.name.split("-")[0])
def test_every_radish_scan(log):
    ranges = read_scans(log).ranges
    fast, slow = pair(REAL_ROBOT, beams=ranges.shape[1], fov_rad=math.pi, range_m=10.0)
    assert differences(fast, slow, ranges) == []


def test_compiled_needs_numba(monkeypatch):
    monkeypatch.setattr(kernels, "AVAILABLE", False)
    with pytest.raises(ValueError, match="compiled must be False or None without numba"):
        Pipeline(SIM_ROBOT, compiled=True)
    assert Pipeline(SIM_ROBOT).compiled is False


# Mutation check: each mutant is one plausible slip in a kernel; the comparison above must see
# it on the first Radish log plus a few synthetic scans. The mutants run as plain Python.
MUTANTS = {
    "finish": [
        ("col = (last + 1 + j) // 2", "col = (last + 2 + j) // 2"),  # plateau middle rounded up
        ("minimum = last_sign < 0", "minimum = last_sign > 0"),  # maxima and minima swapped
        ("value = value if value <= range_m else range_m", "pass"),  # no clipping to R
        ("mask[i] = out[0, tau + i] >= limit", "mask[i] = out[0, tau + i] > limit + 1e-6"),
        ("if valid[col]:", "if True:"),  # extrema in the blind sector / at the ends
    ],
    "prepare": [
        ("d = 0.0", "d = range_m"),  # NaN read as open
        ("work[0, i] = s if s <= threshold else threshold", "work[0, i] = s"),  # h1 unclipped
    ],
}


def mutant(name: str, before: str, after: str):
    source = textwrap.dedent(inspect.getsource(getattr(kernels, name).py_func))
    assert source.count(before) == 1, before
    source = source.replace(before, after).split("\n", 1)[1]  # drop the @njit line
    namespace = {"np": np}
    exec(source, namespace)
    return namespace[name]


@pytest.mark.parametrize(("name", "before", "after"),
                         [(n, b, a) for n, ms in MUTANTS.items() for b, a in ms])
def test_a_broken_kernel_is_caught(monkeypatch, name, before, after):
    ranges = read_scans(RADISH[0]).ranges[::40]
    synthetic = np.full((2, ranges.shape[1]), 5.0)
    synthetic[0, 60:70] = np.nan
    synthetic[1, :] = 20.0
    real = pair(REAL_ROBOT, beams=ranges.shape[1], fov_rad=math.pi, range_m=10.0)
    cases = [(real, np.concatenate([synthetic, ranges])),
             (SIM, trunk_scans(np.random.default_rng(0), 5)),  # 360 deg, blind sector
             (SIM, np.random.default_rng(1).uniform(0.2, 3.0, (3, 360))),
             (CIRCULAR, np.r_[np.full(4, 3.0), np.full(353, 1.0), np.full(3, 3.0)][None])]
    assert all(differences(*p, scans) == [] for p, scans in cases)
    monkeypatch.setattr(kernels, name, mutant(name, before, after))
    assert any(differences(*p, scans) != [] for p, scans in cases)
