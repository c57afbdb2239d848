import subprocess
import sys


def test_figure_filters_cli_writes_both_pngs(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "fftnav", "figure", "filters", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    paths = proc.stdout.split()
    assert [p.rsplit("/", 1)[1] for p in paths] == [
        "fig3_safe_directions.png",
        "fig5_compression.png",
    ]
    for p in paths:
        with open(p, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
