"""The README's Python examples run as written."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_blocks_run():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert blocks, "the README has no Python example"
    for i, code in enumerate(blocks):
        exec(compile(code, f"README.md python block {i}", "exec"), {})


def test_readme_scan_example_runs_from_the_repository():
    """The `fftnav scan ../shared/...` example, run from the repository's top folder as the
    README says (skipped where the shared Radish logs are not beside the repository)."""
    text = " ".join(README.read_text().split())
    match = re.search(r"`fftnav scan (\S+)` prints (\d+) lines", text)
    assert match, "the README lost its fftnav scan example"
    root = README.parent
    if not (root / match.group(1)).exists():
        pytest.skip(f"{match.group(1)} is not beside this repository")
    proc = subprocess.run([sys.executable, "-m", "fftnav", "scan", match.group(1)], cwd=root,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert len(proc.stdout.splitlines()) == int(match.group(2))
