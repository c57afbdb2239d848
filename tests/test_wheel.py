"""The wheel works outside the repository: built from a copy of the sources, installed into a
fresh virtualenv, and run from another directory (world presets, URDF, a whole experiment).

The fresh virtualenv gets fftnav from the wheel alone; its dependencies (numpy, pybullet, ...)
come from the test environment's site-packages through a ``.pth`` line, so that the test needs
no download. ``.pth`` files of that directory are not processed, so the editable install of the
repository stays invisible: the test checks that ``fftnav`` is imported from the new venv.
"""

from __future__ import annotations

import shutil
import site
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


def _run(*args: str | Path, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    run = subprocess.run([str(a) for a in args], cwd=cwd, capture_output=True, text=True,
                         timeout=timeout)
    assert run.returncode == 0, f"{args}: {run.stdout[-2000:]}\n{run.stderr[-2000:]}"
    return run


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> tuple[Path, Path]:
    """(bin directory of a fresh venv with the fftnav wheel installed, a working directory)."""
    base = tmp_path_factory.mktemp("wheel")
    source = base / "source"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("fftnav", "worlds"):
        shutil.copytree(ROOT / name, source / name, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, source / name)
    _run(sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", base / "dist",
         source, cwd=base)
    wheel = next((base / "dist").glob("fftnav-*.whl"))
    env = base / "venv"
    venv.EnvBuilder(with_pip=True).create(env)
    python = env / "bin" / "python"
    _run(python, "-m", "pip", "install", "--no-deps", "--quiet", wheel, cwd=base)
    purelib = _run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])",
                   cwd=base).stdout.strip()
    deps = [p for p in site.getsitepackages() if Path(p).is_dir()]
    (Path(purelib) / "zz_test_dependencies.pth").write_text("\n".join(deps) + "\n")
    work = base / "elsewhere"
    work.mkdir()
    return env / "bin", work


def test_the_wheel_ships_presets_and_urdf_and_no_tests(installed):
    wheel = next((installed[0].parents[1] / "dist").glob("fftnav-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert "fftnav/world/presets/forest.toml" in names
    assert "fftnav/world/presets/rocky.toml" in names
    assert "fftnav/sim/wheeled.urdf" in names
    assert "fftnav/report/replay_player.html" in names
    assert not any(n.startswith(("tests/", "worlds/")) for n in names)


def test_the_wheel_s_version_is_fftnav_s_version(installed):
    """The one source of the version: the wheel's metadata and ``run_info.json`` agree with
    ``fftnav.__version__``."""
    import fftnav

    wheel = next((installed[0].parents[1] / "dist").glob("fftnav-*.whl"))
    assert wheel.name.startswith(f"fftnav-{fftnav.__version__}-")
    shown = _run(installed[0] / "python", "-c", "import importlib.metadata as m, fftnav; "
                 "print(m.version('fftnav'), fftnav.__version__)", cwd=installed[1])
    assert shown.stdout.split() == [fftnav.__version__] * 2


def test_installed_wheel_generates_runs_an_episode_and_an_experiment(installed):
    bin_dir, work = installed
    where = _run(bin_dir / "python", "-c", "import fftnav; print(fftnav.__file__)", cwd=work)
    assert str(bin_dir.parent) in where.stdout and str(ROOT) not in where.stdout
    fftnav = bin_dir / "fftnav"
    _run(fftnav, "world", "generate", "--env", "rocky", "--seed", "2", "--size", "8", "8",
         "--robots", "3", "--out", "w.json", cwd=work)
    _run(fftnav, "episode", "--world", "w.json", "--policy", "fusion", "--set",
         "time_limit_s=30", "--out", "e.csv", "--record", "r.npz", cwd=work)
    assert len((work / "e.csv").read_text().splitlines()) == 4
    _run(fftnav, "replay", "r.npz", "--out", "r.html", cwd=work)  # the player's template
    assert "window.fftnavPlayer" in (work / "r.html").read_text()
    shutil.copy2(ROOT / "experiments" / "smoke.toml", work / "smoke.toml")
    _run(fftnav, "run", "smoke.toml", "--out", "smoke", "--workers", "1", "--quiet", cwd=work)
    assert len((work / "smoke" / "episodes.csv").read_text().splitlines()) == 1 + 2 * 2 * 3
    info = (work / "smoke" / "run_info.json").read_text()
    assert '"git_revision": "unknown"' in info
    import fftnav

    assert f'"fftnav_version": "{fftnav.__version__}"' in info


def test_the_wheel_ships_the_suites_and_evaluates_a_plugin(installed, tmp_path):
    """The suites' definitions, pins and reference rows ship (``fftnav suites`` reads and
    checks them from the installed package), and ``fftnav evaluate`` ranks a plugin written
    outside the repository beside the references of a suite (the tiny test suite, through
    ``$FFTNAV_SUITES_HOME``: a shipped suite's 40 or more episodes would take minutes)."""
    import os
    import re

    from tests.suites.conftest import make_home

    bin_dir, work = installed
    wheel = next((bin_dir.parents[1] / "dist").glob("fftnav-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    for suite in ("paper-v2", "walls-v1", "traps-v1"):
        assert f"fftnav/suites/defs/{suite}.toml" in names
        assert f"fftnav/suites/pins/{suite}.json" in names
        assert f"fftnav/suites/references/{suite}/SHA256SUMS" in names
        assert f"fftnav/suites/references/{suite}/fusion.csv" in names
    listed = _run(bin_dir / "fftnav", "suites", cwd=work).stdout
    assert re.search(r"paper-v2 .*\n.*\n.*\n    references: 10 built-ins x 40 maps", listed)
    home = tmp_path / "home"
    make_home(home)
    section = re.search(r"## Benchmark your own method\n(.*?)\n## ",
                        (ROOT / "README.md").read_text(), re.S).group(1)
    (work / "my_controller.py").write_text(re.search(r"```python\n(.*?)```", section, re.S)[1])
    run = subprocess.run([str(bin_dir / "fftnav"), "evaluate", "my_controller.py:SafeGreedy",
                          "--suite", "tiny", "--out", "ev", "--workers", "1", "--quiet"],
                         cwd=work, capture_output=True, text=True, timeout=600,
                         env={**os.environ, "FFTNAV_SUITES_HOME": str(home)})
    assert run.returncode == 0, run.stderr
    assert re.search(r"^>\s+\d+\s+safe-greedy\s", run.stdout, re.M), run.stdout
    assert (work / "ev" / "report.md").exists()
