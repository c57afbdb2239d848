"""The import rules of docs/architecture.md hold for every module of fftnav/: layers, third-party
imports, no import cycles (imports under ``if TYPE_CHECKING:`` included); pyproject.toml lists
every package and takes the version from fftnav/__init__.py; no function body outside a numba
kernel is over 60 lines."""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import pytest
import tomllib

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "fftnav"


def _rules() -> dict[str, tuple[int, frozenset[str]]]:
    """package -> (layer, allowed third-party top-level names), from the architecture table."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    rows = re.findall(r"^\| (\d+) \| `([\w.]+)` \| [^|]* \|\s*([^|]*?)\s*\|$", text, re.M)
    assert len(rows) >= 12, "docs/architecture.md lost its import-rules table"
    return {pkg: (int(layer), frozenset(n.strip() for n in allowed.split(",") if n.strip()))
            for layer, pkg, allowed in rows}


RULES = _rules()


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _package(module: str) -> str:
    """The architecture table's row of a module: its longest listed prefix."""
    best = max((p for p in RULES if module == p or module.startswith(p + ".")), key=len)
    return best


_FUNCTIONS = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)


def _outside_functions(tree: ast.Module) -> set[int]:
    """ids of the import statements outside every function: those that run when the module is
    imported (at the top, in ``try``, ``if`` and class bodies) and those a type checker reads
    under ``if TYPE_CHECKING:``. An import inside a function runs when the function does."""
    found, stack = set(), list(tree.body)
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found.add(id(node))
        elif not isinstance(node, _FUNCTIONS):
            stack.extend(ast.iter_child_nodes(node))
    return found


def _imports(source: str) -> tuple[set[str], set[str]]:
    """(fftnav modules a module's source imports outside functions, ``TYPE_CHECKING`` blocks
    included; top-level names of every import anywhere)."""
    tree = ast.parse(source)
    outside = _outside_functions(tree)
    module_level, anywhere = set(), set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            # `from fftnav import metrics` imports the module fftnav.metrics
            names = [f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in MODULES
                     else node.module for a in node.names]
        else:
            continue
        anywhere |= {n.split(".")[0] for n in names}
        if id(node) in outside:
            module_level |= {n for n in names if n.split(".")[0] == "fftnav"}
    return module_level, anywhere


GRAPH = {name: _imports(path.read_text()) for name, path in MODULES.items()}


def test_imports_under_type_checking_count_and_those_inside_functions_do_not():
    source = "\n".join([
        "from typing import TYPE_CHECKING",
        "import fftnav.validate",
        "try:",
        "    from fftnav import limits",
        "except ImportError:",
        "    pass",
        "if TYPE_CHECKING:",
        "    from fftnav.navigation.bugcontrol import BugController",
        "class Holder:",
        "    from fftnav.states import State",
        "def later():",
        "    from fftnav.report import frames",
    ])
    module_level, anywhere = _imports(source)
    assert module_level == {"fftnav.validate", "fftnav.limits", "fftnav.navigation.bugcontrol",
                            "fftnav.states"}
    assert anywhere == {"typing", "fftnav"}


def test_every_top_level_module_and_package_has_its_own_row():
    """A module directly under fftnav/, or a subpackage, is a room of its own: its row in
    docs/architecture.md gives its layer and third-party imports (it does not inherit the
    package root's)."""
    top = {name for name in MODULES if name.count(".") == 1}
    assert sorted(top - set(RULES)) == [], "docs/architecture.md has no row for these"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_module_imports_only_lower_layers_and_its_allowed_third_party(module):
    """Imports outside functions, those under TYPE_CHECKING included, name only the module's
    own package or lower layers: a lower layer does not even name a higher layer's types."""
    package = _package(module)
    layer, allowed = RULES[package]
    fftnav_imports, top_level = GRAPH[module]
    for target in fftnav_imports:
        other = _package(target)
        assert other == package or RULES[other][0] < layer, (
            f"{module} (layer {layer}) imports {target} ({other}, layer {RULES[other][0]})")
    third_party = top_level - set(sys.stdlib_module_names) - {"fftnav", "__future__"}
    assert third_party <= allowed, f"{module} imports {sorted(third_party - allowed)}"


def test_only_sim_imports_pybullet_and_only_report_imports_matplotlib():
    for module, (_, top_level) in GRAPH.items():
        if "pybullet" in top_level:
            assert module.startswith("fftnav.sim"), module
        if "matplotlib" in top_level:
            assert module.startswith("fftnav.report"), module
        if module.startswith("fftnav.observe"):
            assert top_level.isdisjoint({"pybullet", "matplotlib", "pandas"}), module


def test_only_ros_imports_rosbags_and_only_inside_functions():
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            if any(n.split(".")[0] == "rosbags" for n in names):
                assert module.startswith("fftnav.ros"), module
                assert node.col_offset > 0, f"{module}:{node.lineno} imports rosbags at top level"


def test_imports_have_no_cycle_type_checking_included():
    state: dict[str, int] = {}  # 1 on the stack, 2 done

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for target in sorted(GRAPH[node][0]):
            if target not in MODULES:
                continue
            if state.get(target) == 1:
                cycle = stack[stack.index(target):] + [target]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if target not in state:
                visit(target, [*stack, target])
        state[node] = 2

    for module in sorted(MODULES):
        if module not in state:
            visit(module, [module])


def test_pyproject_lists_every_package():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    listed = set(project["tool"]["setuptools"]["packages"])
    found = {_module_name(p) for p in PACKAGE.rglob("__init__.py")}
    data = {".".join(("fftnav", *d.relative_to(PACKAGE).parts)) for d in PACKAGE.rglob("*")
            if d.is_dir() and d.name != "__pycache__" and not (d / "__init__.py").exists()
            and d.name.isidentifier()}  # folders of data files (not paper-v2: not a name)
    assert data and listed == found | data | {"fftnav.world.presets"}
    assert project["tool"]["setuptools"]["package-dir"]["fftnav.world.presets"] == "worlds"


def test_the_version_has_one_source():
    """pyproject.toml reads the version from ``fftnav.__version__``, a string literal (which
    setuptools reads without importing the package); no other module states one."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "fftnav.__version__"}
    init = ast.parse((PACKAGE / "__init__.py").read_text())
    literals = [node.value.value for node in init.body if isinstance(node, ast.Assign)
                and [ast.unparse(t) for t in node.targets] == ["__version__"]
                and isinstance(node.value, ast.Constant)]
    assert len(literals) == 1 and re.fullmatch(r"\d+\.\d+\.\d+", literals[0])
    stated = [name for name, path in MODULES.items()
              if name != "fftnav" and re.search(r"^__version__\s*=", path.read_text(), re.M)]
    assert stated == []


#: Longest function body (lines from its first statement after the docstring to its last).
MAX_FUNCTION_LINES = 60


def _is_numba_kernel(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """A function compiled by numba: decorated with ``njit``, bare (``@njit``), called
    (``@njit(cache=True)``) or as an attribute (``@numba.njit(...)``)."""
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", None)
        if name == "njit":
            return True
    return False


def _long_functions(source: str) -> list[tuple[str, int, int]]:
    """(name, line, body lines) of every function, method or nested function whose body is
    over :data:`MAX_FUNCTION_LINES` lines and which is not a numba kernel."""
    long = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body[1:] if ast.get_docstring(node) else node.body
            lines = body[-1].end_lineno - body[0].lineno + 1 if body else 0
            if lines > MAX_FUNCTION_LINES and not _is_numba_kernel(node):
                long.append((node.name, node.lineno, lines))
    return long


def _function(header: str, lines: int, indent: str = "") -> str:
    statements = "".join(f"{indent}    x{i} = {i}\n" for i in range(lines))
    return f"{indent}{header}\n{indent}    '''A docstring: not counted.'''\n{statements}"


def test_the_function_length_rule_exempts_numba_kernels_alone():
    over, limit = MAX_FUNCTION_LINES + 1, MAX_FUNCTION_LINES
    source = "".join([
        _function("def long():", over),
        _function("def short():", limit),
        _function("@njit(cache=True, nogil=True)\ndef kernel():", over),
        _function("@njit\ndef bare_kernel():", over),
        _function("@numba.njit(cache=True)\ndef numba_kernel():", over),
        _function("@jit\ndef not_njit():", over),
        "class Holder:\n", _function("def method(self):", over, indent="    "),
        "def outer():\n", _function("def inner():", over, indent="    "),
    ])
    assert sorted((name, lines) for name, _, lines in _long_functions(source)) == [
        ("inner", over), ("long", over), ("method", over), ("not_njit", over),
        ("outer", over + 2)]


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_function_body_is_over_60_lines_outside_numba_kernels(module):
    long = _long_functions(MODULES[module].read_text())
    assert long == [], "; ".join(f"{name} (line {line}) has {lines} lines of code"
                                 for name, line, lines in long)
