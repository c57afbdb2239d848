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
    """Names of the outputs that differ between the two pipelines: for the whole batch (if it
    has several scans), then scan by scan (naming the first scan that differs)."""
    found = []
    if len(scans) > 1:
        for with_p_s in (True, False):
            a, b = fast.process(scans, with_p_s=with_p_s), slow.process(scans, with_p_s=with_p_s)
            found += [f"{name} (batch)" for name in FIELDS
                      if not np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True)
                      or getattr(a, name).shape != getattr(b, name).shape]
            if a.messages != b.messages or a.offsets.dtype != b.offsets.dtype:
                found.append("messages or offsets (batch)")
            if found:
                return found
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
# it on the first Radish log plus a few synthetic scans. The mutants run as plain Python, called
# by the plain-Python versions of the kernels that wrap them.
MUTANTS = {
    "_scan": [
        ("col = (last + 1 + j) // 2", "col = (last + 2 + j) // 2"),  # plateau middle rounded up
        ("minimum = last_sign < 0", "minimum = last_sign > 0"),  # maxima and minima swapped
        ("value = value if value <= range_m else range_m", "pass"),  # no clipping to R
        ("mask[row, i] = out[h1, tau + i] >= limit",
         "mask[row, i] = out[h1, tau + i] > limit + 1e-6"),
        ("if valid[col]:", "if True:"),  # extrema in the blind sector / at the ends
        ("message[1] = n & 0xFF", "message[1] = (n + 1) & 0xFF"),  # count in the header
        ("crc ^= crc_heads[n & 0xFF]", "pass"),  # header not in the CRC
        ("crc = 0  # CRC-16", "crc = 0xFFFF  # CRC-16"),  # payload's CRC from the wrong state
        ("message[3 + 3 * n] = crc & 0xFF", "message[3 + 3 * n] = crc >> 8"),
        ("sigma[start + n, 0] = angle", "sigma[n, 0] = angle"),  # batch: rows of scan 0
    ],
    "_prepare_row": [
        ("d = 0.0", "d = range_m"),  # NaN read as open
        ("work[clipped, i] = s if s <= threshold else threshold", "work[clipped, i] = s"),
    ],
}
WRAPPERS = ("scan", "scan_batch", "prepare", "prepare_batch", "finish", "finish_batch")


def mutant(name: str, before: str, after: str):
    source = textwrap.dedent(inspect.getsource(getattr(kernels, name).py_func))
    assert source.count(before) == 1, before
    source = source.replace(before, after).split("\n", 1)[1]  # drop the @njit line
    namespace = {"np": np}
    exec(source, namespace)
    return namespace[name]


def mutation_cases() -> list[tuple[tuple[Pipeline, Pipeline], np.ndarray]]:
    """Pipelines built now (they take the kernels when they are built) and their scans."""
    ranges = read_scans(RADISH[0]).ranges[::40]
    synthetic = np.full((2, ranges.shape[1]), 5.0)
    synthetic[0, 60:70] = np.nan
    synthetic[1, :] = 20.0
    real = pair(REAL_ROBOT, beams=ranges.shape[1], fov_rad=math.pi, range_m=10.0)
    return [(real, np.concatenate([synthetic, ranges])),
            (pair(), trunk_scans(np.random.default_rng(0), 5)),  # 360 deg, blind sector
            (pair(), np.random.default_rng(1).uniform(0.2, 3.0, (3, 360))),
            (pair(mode="circular"),
             np.r_[np.full(4, 3.0), np.full(353, 1.0), np.full(3, 3.0)][None])]


@pytest.mark.parametrize(("name", "before", "after"),
                         [(n, b, a) for n, ms in MUTANTS.items() for b, a in ms])
def test_a_broken_kernel_is_caught(monkeypatch, name, before, after):
    assert all(differences(*p, scans) == [] for p, scans in mutation_cases())
    for wrapper in WRAPPERS:  # plain Python, calling the module's (mutated) helpers
        monkeypatch.setattr(kernels, wrapper, getattr(kernels, wrapper).py_func)
    monkeypatch.setattr(kernels, name, mutant(name, before, after))
    assert any(differences(*p, scans) != [] for p, scans in mutation_cases())


def test_the_pipeline_calls_compiled_entry_points():
    """The single-scan path calls the kernels without numba's type dispatch (entry points
    compiled for one signature, held by the pipeline's workspaces), and takes strided scans
    too."""
    for name in WRAPPERS:
        assert type(kernels.entry(name)).__name__ == "builtin_function_or_method"
    fast = Pipeline(SIM_ROBOT, compiled=True)
    for run in (fast._local.w.run, fast._local.w.run_batch):
        assert type(run.func).__name__ == "builtin_function_or_method"
    assert fast.fft_in_kernel is kernels.FFT_IN_KERNEL
    scans = trunk_scans(np.random.default_rng(2), 3)
    strided = np.asfortranarray(scans)[1]  # a non-contiguous row
    assert not strided.flags.c_contiguous
    assert differences(fast, SIM[1], strided[None]) == []


@pytest.mark.skipif(not kernels.FFT_IN_KERNEL, reason="rocket-fft is not installed")
def test_the_fft_runs_inside_the_kernels_for_every_tested_configuration():
    for fast, _ in (SIM, CIRCULAR, FLOAT32, PARTIAL):
        assert fast.fft_in_kernel


@pytest.mark.skipif(not kernels.FFT_IN_KERNEL, reason="rocket-fft is not installed")
def test_complex_product_is_numpys_and_the_pipeline_picks_numpys_rounding():
    """numpy's complex multiply rounds each part once (fused multiply-add) on some CPUs and
    every product on others: the kernel's product equals numpy's for the variant the
    pipeline picked, and the other variant differs somewhere."""
    rng = np.random.default_rng(4)
    a = rng.normal(size=(2, 271)) + 1j * rng.normal(size=(2, 271))
    b = rng.normal(size=(2, 271)) + 1j * rng.normal(size=(2, 271))
    expected = a.copy()
    np.multiply(expected, b, expected)  # in place, as the numpy path multiplies
    fused = Pipeline(SIM_ROBOT, compiled=True)._local.w.run.args[3]
    product = np.vectorize(kernels.complex_product, otypes=[complex])
    assert np.array_equal(product(a, b, fused), expected)
    assert not np.array_equal(product(a, b, not fused), expected)


def test_without_rocket_fft_the_fft_runs_by_numpy_between_the_kernels(monkeypatch):
    monkeypatch.setattr(kernels, "FFT_IN_KERNEL", False)
    for kwargs in ({}, {"mode": "circular"}):
        fast = Pipeline(SIM_ROBOT, compiled=True, **kwargs)
        assert fast.compiled and not fast.fft_in_kernel
        scans = trunk_scans(np.random.default_rng(6), 4)
        assert differences(fast, Pipeline(SIM_ROBOT, compiled=False, **kwargs), scans) == []


def test_fft_lengths_with_large_prime_factors_give_numpys_results():
    """274 = 2 x 137 beams in circular mode: an FFT length whose transforms may take another
    route in rocket-fft than in numpy; whichever route the pipeline takes, its results are
    numpy's."""
    fast, slow = pair(mode="circular", beams=274)
    assert fast.bank.fft_size == 274
    assert differences(fast, slow, np.random.default_rng(9).uniform(0.1, 3.5, (3, 274))) == []


@pytest.mark.skipif(not kernels.FFT_IN_KERNEL, reason="rocket-fft is not installed")
def test_a_kernel_fft_that_differs_from_numpy_is_not_used(monkeypatch):
    """The pipeline checks its in-kernel FFT against the numpy path when it is built: an FFT
    that differs in the last bit sends it to the numpy.fft route, with numpy's results."""
    real = kernels.filter_rows

    def off_by_one_ulp(*args):  # filter_rows's arguments as the kernels pass them, out last
        real(*args)
        args[-1][:] = np.nextafter(args[-1], np.inf)

    monkeypatch.setattr(kernels, "filter_rows", off_by_one_ulp)
    monkeypatch.setattr(kernels, "scan", kernels.scan.py_func)
    monkeypatch.setattr(kernels, "scan_batch", kernels.scan_batch.py_func)
    fast = Pipeline(SIM_ROBOT, compiled=True)
    assert fast.compiled and not fast.fft_in_kernel
    assert differences(fast, SIM[1], trunk_scans(np.random.default_rng(7), 3)) == []


def test_one_scan_result_behaves_as_a_pipeline_result():
    """The compiled path's result makes y1 and y2 on first access; it still compares, copies,
    replaces and pickles as a PipelineResult."""
    import dataclasses
    import pickle

    fast, slow = SIM
    scan = trunk_scans(np.random.default_rng(3), 1)[0]
    a, b = fast.process(scan, with_p_s=False), slow.process(scan, with_p_s=False)
    assert isinstance(a, type(b)) and a.y1.shape == b.y1.shape == (1, 360)
    assert np.array_equal(a.y2, b.y2) and a.y1.base is a.y2.base
    copy = pickle.loads(pickle.dumps(a))
    assert np.array_equal(copy.y1, a.y1) and copy.messages == a.messages
    replaced = dataclasses.replace(a, y1=np.zeros((1, 360)))
    assert not replaced.y1.any() and np.array_equal(replaced.y2, a.y2)
    assert dataclasses.asdict(a).keys() == dataclasses.asdict(b).keys()
    # Sigma, its minima and the offsets are made on first access too: pickled before that,
    # they still arrive (the kernel's buffers travel), equal to the numpy path's
    fresh = fast.process(scan, with_p_s=False)
    assert {"sigma_flat", "is_min_flat", "offsets", "y1"}.isdisjoint(vars(fresh))
    arrived = pickle.loads(pickle.dumps(fresh))
    for result in (fresh, arrived):
        for name in ("sigma_flat", "is_min_flat", "offsets", "x0", "p_s"):
            assert np.array_equal(getattr(result, name), getattr(b, name), equal_nan=True), name
            assert getattr(result, name).dtype == getattr(b, name).dtype, name
        assert [s.tobytes() for s in result.sigma] == [s.tobytes() for s in b.sigma]


def test_a_pipeline_pickles_and_copies_with_workspaces_of_its_own():
    """The compiled paths write into per-pipeline workspaces: a pickled or copied pipeline
    rebuilds its own (same results; the original's buffers are not shared)."""
    import copy
    import pickle

    fast = Pipeline(SIM_ROBOT, compiled=True)
    scans = trunk_scans(np.random.default_rng(5), 3)

    def workspaces(w) -> set[int]:  # what a scan writes: the message, the FFT's buffers
        work, spec = w.run.args[:2]
        assert work.shape == (2, 540) and spec.dtype == complex
        return {id(w.message), id(work), id(spec)}

    for other in (pickle.loads(pickle.dumps(fast)), copy.copy(fast), copy.deepcopy(fast)):
        assert other._local.w is not fast._local.w and "_local" in vars(other)
        assert differences(other, SIM[1], scans) == []
        assert not workspaces(fast._local.w) & workspaces(other._local.w)


def test_a_compiled_pipelines_process_pickles_and_a_subclass_keeps_its_own():
    """``pipe.process`` of a compiled pipeline pickles with the pipeline, by pickle and
    cloudpickle (dask); a subclass that overrides ``process`` is not bypassed."""
    import inspect
    import pickle

    fast, slow = SIM
    scan = trunk_scans(np.random.default_rng(8), 1)[0]
    expected = slow.process(scan, with_p_s=False).messages
    dumps = [pickle.dumps]
    cloudpickle = pytest.importorskip("cloudpickle")
    dumps.append(cloudpickle.dumps)
    for dump in dumps:
        process = pickle.loads(dump(fast.process))
        assert process(scan, with_p_s=False).messages == expected
    assert list(inspect.signature(fast.process).parameters) == ["ranges", "with_p_s"]

    class Counted(Pipeline):
        calls = 0

        def process(self, ranges, *, with_p_s=True):
            Counted.calls += 1
            return super().process(ranges, with_p_s=with_p_s)

    counted = Counted(SIM_ROBOT, compiled=True)
    assert counted.process(scan, with_p_s=False).messages == expected
    assert Counted.calls == 1


def test_one_compiled_pipeline_is_safe_from_four_threads_at_once():
    """Four real threads share one compiled pipeline (its kernels release the GIL), each with
    scans of its own, started together: every result equals the numpy path's, and each thread
    wrote into workspaces of its own."""
    import threading

    fast, slow = Pipeline(SIM_ROBOT, compiled=True), SIM[1]
    scans = [trunk_scans(np.random.default_rng(100 + t), 40) for t in range(4)]
    expected = [[slow.process(s, with_p_s=False) for s in chunk] for chunk in scans]
    start, found, used = threading.Barrier(4), [[] for _ in range(4)], [None] * 4

    def work(t: int) -> None:
        start.wait()
        for _ in range(25):
            for scan, want in zip(scans[t], expected[t], strict=True):
                got = fast.process(scan, with_p_s=False)
                if (got.messages != want.messages
                        or not np.array_equal(got.safe_mask, want.safe_mask)
                        or not np.array_equal(got.y1, want.y1)):
                    found[t].append(scan)
        used[t] = id(fast._local.w)

    threads = [threading.Thread(target=work, args=(t,)) for t in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert [len(f) for f in found] == [0, 0, 0, 0]
    assert len(set(used)) == 4 and id(fast._local.w) not in used
