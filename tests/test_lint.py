"""The code base is ruff clean (the project's style standard, with its complexity and argument
limits), checked as part of `make test`: the package, the tests and the experiments' scripts."""

import shutil
import subprocess
import sys
from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parent.parent
#: What is linted (the Makefile's `lint` target checks the same).
LINTED = ("fftnav", "tests", "experiments")
#: ruff's complexity and argument-count rules, exempted for numba kernel files alone.
SIZE_RULES = {"C901", "PLR0911", "PLR0912", "PLR0913", "PLR0915", "PLR0917"}


def test_ruff_check_is_clean():
    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    assert ruff, "ruff is a test dependency (pip install -e '.[test]')"
    run = subprocess.run([ruff, "check", *LINTED], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


def test_complexity_and_argument_limits_are_on_and_only_kernel_files_are_exempt():
    lint = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]["lint"]
    assert SIZE_RULES <= set(lint["select"])
    assert lint["mccabe"]["max-complexity"] == 10
    assert (lint["pylint"]["max-args"], lint["pylint"]["max-positional-args"]) == (8, 5)
    exempt = {pattern for pattern, rules in lint["per-file-ignores"].items()
              if SIZE_RULES & set(rules)}
    assert exempt, "the numba kernel files are exempt from the size rules"
    for pattern in exempt:
        # one named file of numba kernels (a kernel file not written yet is allowed)
        assert pattern.startswith("fftnav/") and pattern.endswith(".py"), pattern
        assert not any(c in pattern for c in "*?["), pattern
        path = ROOT / pattern
        assert not path.exists() or "@njit" in path.read_text(), f"{pattern} holds no kernel"
