import subprocess
import sys

from fftnav.bench.compare import format_comparison, previous_row
from fftnav.bench.pipeline import record_csv


def test_previous_row_is_the_last_matching_one(tmp_path):
    path = tmp_path / "r.csv"
    assert previous_row(path, {}) is None
    record_csv({"env": "forest", "real_time_factor": 10.0}, path)
    record_csv({"env": "rocky", "real_time_factor": 12.0}, path, append=True)
    record_csv({"env": "forest", "real_time_factor": 20.0}, path, append=True)
    assert previous_row(path, {"env": "forest"})["real_time_factor"] == "20.0"
    assert previous_row(path, {"env": "rocky"})["real_time_factor"] == "12.0"
    assert previous_row(path, {"env": "desert"}) is None


def test_comparison_lines():
    text = format_comparison({"single_us": 26.0, "batch15_us_per_scan": 12.0, "other": 1},
                             {"single_us": "52.0"}, "old.csv")
    single = next(line for line in text.splitlines() if "1 scan" in line)
    assert "paper 13 (misses it)" in single and "52 in old.csv (new/old x0.50)" in single
    batch = next(line for line in text.splitlines() if "batch of 15" in line)
    assert "paper 13 (meets it)" in batch and batch.rstrip().endswith("-")
    sim = format_comparison({"real_time_factor": 45.0}, None)
    assert "target 30 (meets it)" in sim


def test_cli_prints_the_comparison_with_a_previous_record(tmp_path):
    old = tmp_path / "old.csv"
    record_csv({"single_us": 1000.0, "batch15_us_per_scan": 1000.0}, old)
    proc = subprocess.run([sys.executable, "-m", "fftnav", "bench", "pipeline", "--repeats", "2",
                           "--previous", str(old)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    line = next(x for x in proc.stdout.splitlines() if x.strip().startswith("1 scan"))
    new = float(line.split()[3])
    assert f"1000 in {old} (new/old x{new / 1000:.2f})" in line
