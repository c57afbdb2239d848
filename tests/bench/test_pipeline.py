import csv
import json
import subprocess
import sys

import pytest

from fftnav.bench.pipeline import bench_pipeline, format_pipeline, record_csv

KEYS = {
    "single_us",
    "single_all_fields_us",
    "batch15_us_per_scan",
    "batch15_with_p_s_us_per_scan",
    "mask_fft_us_per_scan",
    "mask_convolve_us_per_scan",
    "mask_sliding_min_us_per_scan",
}


def test_bench_pipeline_quick():
    res = bench_pipeline(repeats=3)
    assert KEYS <= res.keys() and res["masks_agree"] is True and res["repeats"] == 3
    assert all(res[k] > 0 for k in KEYS)
    text = format_pipeline(res)
    assert f"{res['batch15_us_per_scan']:.2f} us/scan" in text and "masks agree: True" in text


def test_record_csv_appends_rows_and_checks_columns(tmp_path):
    path = tmp_path / "out" / "r.csv"
    record_csv({"a": 1, "b": 2.5}, path)
    record_csv({"a": 3, "b": 4.5}, path, append=True)
    rows = list(csv.DictReader(path.open()))
    assert [(r["a"], r["b"]) for r in rows] == [("1", "2.5"), ("3", "4.5")]
    assert {"timestamp", "host", "python", "numpy"} <= rows[0].keys()
    record_csv({"a": 5, "b": 0}, path)  # without append: replaced
    assert len(list(csv.DictReader(path.open()))) == 1
    with pytest.raises(ValueError, match=r"cannot append to .*r.csv.: its columns"):
        record_csv({"c": 1}, path, append=True)


def test_bench_errors_and_cli():
    with pytest.raises(ValueError, match="repeats must be an integer >= 1, got repeats=0"):
        bench_pipeline(repeats=0)
    proc = subprocess.run(
        [sys.executable, "-m", "fftnav", "bench", "pipeline", "--repeats", "2", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert KEYS <= json.loads(proc.stdout).keys()
    proc = subprocess.run(
        [sys.executable, "-m", "fftnav", "bench", "pipeline", "--repeats", "0"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1
    assert "repeats must be an integer >= 1, got repeats=0" in proc.stderr
