"""The results git keeps stay light: tracked files under results/ are at most 1 MB each, at most
20 MB and 500 files together (docs/experiments.md, "What a results folder keeps"). Read from
``git ls-files``, what a clone holds, not from the working tree (which also holds the ignored
regenerable files of local runs)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_FILE_BYTES = 1_000_000
MAX_TOTAL_BYTES = 20_000_000
MAX_FILES = 500


def _tracked_results() -> dict[str, int]:
    """Tracked path under results/ -> its size in bytes (of the committed blob, ``git ls-files
    -s`` then ``git cat-file --batch-check``)."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: nothing is tracked")
    staged = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-s", "-z", "--", "results"],
                            capture_output=True, text=True, check=True).stdout
    entries = [line.split("\t", 1) for line in staged.split("\0") if line]
    blobs = [meta.split()[1] for meta, _ in entries]
    sizes = subprocess.run(["git", "-C", str(ROOT), "cat-file", "--batch-check=%(objectsize)"],
                           input="\n".join(blobs) + "\n", capture_output=True, text=True,
                           check=True).stdout.split()
    return {path: int(size) for (_, path), size in zip(entries, sizes, strict=True)}


def test_no_tracked_result_is_over_1_mb():
    big = {path: size for path, size in _tracked_results().items() if size > MAX_FILE_BYTES}
    assert big == {}, f"tracked files under results/ over 1 MB: {big}"


def test_tracked_results_are_at_most_20_mb_and_500_files():
    tracked = _tracked_results()
    total = sum(tracked.values())
    assert len(tracked) <= MAX_FILES, f"{len(tracked)} tracked files under results/"
    assert total <= MAX_TOTAL_BYTES, f"tracked results/ hold {total / 1e6:.1f} MB"


def test_regenerable_files_are_ignored_at_any_depth():
    """Per-task files, reference lengths, recordings and trajectories, one level down or
    deeper (a sweep's cells), are ignored by git and none is tracked."""
    names = [f"results/{folder}/{kind}/x.{ext}" for folder in ("t", "collab/c", "a/b/c")
             for kind, ext in (("episodes", "csv"), ("reference", "npy"), ("records", "npz"),
                               ("trajectories", "npz"), ("timing", "json"))]
    ignored = subprocess.run(["git", "-C", str(ROOT), "check-ignore", "--no-index", *names],
                             capture_output=True, text=True).stdout.split()
    assert ignored == names
    kinds = ("/episodes/", "/reference/", "/records/", "/trajectories/", "/timing/")
    assert [p for p in _tracked_results() if any(k in p for k in kinds)] == []


def test_config_json_names_no_machines_paths():
    """A committed results folder's config.json names its files (plugins, trained networks,
    world files) relative to the folder, so a clone anywhere resumes it without --fresh."""
    import json

    found = 0
    for path in _tracked_results():
        if path.endswith("/config.json"):
            found += 1
            stored = json.loads((ROOT / path).read_text())
            files = [*stored.get("plugin_sha256", {}), *stored.get("world_sha256", {}),
                     *(p.split(":", 1)[1] for p in stored.get("policies", [])
                       if p.startswith(("learned:", "learned-decider:", "/")))]
            assert [f for f in files if Path(f).is_absolute()] == [], path
    assert found
