"""fftnav.errors: one base for the library's refusals (a ValueError), and the missing optional
extra (an ImportError naming the pip line)."""

from __future__ import annotations

import math
import pickle
import sys
from dataclasses import dataclass

import numpy as np
import pytest

from fftnav import SIM_ROBOT, MessageError, Pipeline, decode_message
from fftnav.errors import FftnavError, MissingExtraError, import_extra
from fftnav.limits import MAX_GRID_CELLS, check_limit
from fftnav.optimal.astar import UnreachableGoalError, astar
from fftnav.validate import Checked, check_choice, check_integer, check_number, number_field


@dataclass(frozen=True)
class Probe(Checked):
    range_m: float = number_field(3.0, low=0, low_open=True)


@pytest.mark.parametrize(("call", "message"), [
    (lambda: check_number("range_m", -1.0, low=0, low_open=True),
     "range_m must be a finite number > 0, got range_m=-1.0"),
    (lambda: check_number("gain", math.nan), "gain must be a finite number, got gain=nan"),
    (lambda: check_integer("beams", 4, low=8), "beams must be an integer >= 8, got beams=4"),
    (lambda: check_integer("beams", 2.0, low=1, high=9),
     "beams must be an integer in [1, 9], got beams=2.0"),
    (lambda: check_choice("mode", "slow", ("fast",)),
     "mode must be one of ['fast'], got mode='slow'"),
    (lambda: check_limit("grid cells", 4e9, MAX_GRID_CELLS, hint="raise resolution_m"),
     "grid cells: 4,000,000,000 estimated, above the limit of 100,000,000; raise resolution_m"),
    (lambda: Pipeline(SIM_ROBOT, range_m=0.1),
     "range_m must be finite and >= l_th_m=0.6, got range_m=0.1"),
])
def test_the_library_refuses_with_fftnav_errors_that_are_value_errors(call, message):
    with pytest.raises(FftnavError) as caught:
        call()
    assert str(caught.value) == message
    assert isinstance(caught.value, ValueError) and type(caught.value) is FftnavError


def test_checked_dataclasses_and_their_tables_raise_fftnav_errors():
    with pytest.raises(FftnavError, match=r"^range_m must be a finite number > 0, got range_m=0$"):
        Probe(range_m=0)
    with pytest.raises(FftnavError, match=r"^sensor\.range_m must be a finite number > 0, "
                                          r"got sensor\.range_m=-2$"):
        Probe.from_table("sensor", {"range_m": -2})
    with pytest.raises(FftnavError, match=r"^unknown key sensor\.colour; expected one of "
                                          r"\['range_m'\]$"):
        Probe.from_table("sensor", {"colour": 1})


def test_the_library_s_error_classes_derive_from_fftnav_error():
    with pytest.raises(MessageError, match=r"^message truncated: 1 bytes") as caught:
        decode_message(b"\xc1", range_m=3.0)
    assert isinstance(caught.value, FftnavError)
    grid = np.zeros((3, 3), dtype=bool)
    grid[:, 1] = True  # a wall between the start and the goal
    with pytest.raises(UnreachableGoalError) as caught:
        astar(grid, (0, 0), (0, 2))
    assert isinstance(caught.value, FftnavError) and caught.value.goal == (0, 2)


def test_a_missing_extra_is_an_import_error_naming_the_pip_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "numba", None)  # as if it were not installed
    with pytest.raises(MissingExtraError) as caught:
        import_extra("numba", extra="fast", needed_for="compiled kernels")
    err = caught.value
    assert str(err) == "compiled kernels need the numba package: pip install 'fftnav[fast]'"
    assert isinstance(err, ImportError) and err.name == "numba" and err.extra == "fast"
    assert isinstance(err, FftnavError)  # the command line reports it in one line
    assert err.__cause__ is None and err.__suppress_context__


def test_an_installed_extra_is_imported():
    assert import_extra("numpy.linalg", extra="fast", needed_for="tests") is np.linalg


def test_errors_raised_in_a_worker_process_pickle_whole():
    for err in (FftnavError("range_m must be a finite number > 0, got range_m=0"),
                UnreachableGoalError((0, 0), (2, 3)),
                MissingExtraError("rosbags.highlevel", extra="ros", needed_for="ROS bags")):
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is type(err) and str(back) == str(err)
    assert (back.name, back.extra, back.needed_for) == ("rosbags.highlevel", "ros", "ROS bags")
    assert pickle.loads(pickle.dumps(UnreachableGoalError((0, 0), (2, 3)))).goal == (2, 3)


@pytest.mark.parametrize(("module", "extra", "code"), [
    ("pettingzoo", "marl", "import fftnav.envs"),
    ("imageio_ffmpeg", "video",
     "from fftnav.report.replay import write_video; write_video(None, 'x.mp4')"),
])
def test_features_of_an_optional_extra_name_its_pip_line_when_it_is_missing(module, extra, code):
    """Run in a fresh interpreter with the extra's module made unimportable."""
    import subprocess

    block = (f"import sys; sys.modules[{module!r}] = None\n"
             f"from fftnav.errors import MissingExtraError\n"
             f"try:\n    {code}\nexcept MissingExtraError as err:\n"
             f"    print(type(err).__name__, err.name, err)\n")
    done = subprocess.run([sys.executable, "-c", block], capture_output=True, text=True,
                          check=False, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"MissingExtraError {module} ")
    assert f"pip install 'fftnav[{extra}]'" in done.stdout


def _raised_builtin_value_errors() -> list[str]:
    import ast
    from pathlib import Path

    import fftnav

    found = []
    for path in sorted(Path(fftnav.__file__).parent.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Raise) and node.exc is not None:
                exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
                if isinstance(exc, ast.Name) and exc.id == "ValueError":
                    found.append(f"{path.name}:{node.lineno}")
    return found


def test_the_package_raises_no_bare_value_error():
    """Every refusal is an FftnavError (or a subclass), so ``except FftnavError`` catches the
    library's refusals and nothing else."""
    assert _raised_builtin_value_errors() == []


def test_every_error_class_of_the_package_is_an_fftnav_error():
    import importlib
    import inspect
    import pkgutil

    import fftnav

    optional = {"fftnav.envs", "fftnav.envs.swarm_env"}  # need the extra marl
    classes = set()
    for info in pkgutil.walk_packages(fftnav.__path__, "fftnav."):
        if info.name in optional or info.name == "fftnav.__main__":
            continue
        module = importlib.import_module(info.name)
        classes |= {obj for _, obj in inspect.getmembers(module, inspect.isclass)
                    if issubclass(obj, ValueError) and obj.__module__.startswith("fftnav")}
    assert len(classes) >= 5
    assert [c.__qualname__ for c in classes if not issubclass(c, FftnavError)] == []
