"""The import rules of docs/architecture.md hold for every module of fftnav/: layers, third-party
imports, no import cycles; pyproject.toml lists every package; no episode-loop function is long."""

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


def _imports(path: Path) -> tuple[set[str], set[str]]:
    """(fftnav modules imported at module level, top-level names of every import anywhere)."""
    tree = ast.parse(path.read_text())
    module_level, anywhere = set(), set()
    guarded = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
               and "TYPE_CHECKING" in ast.unparse(node.test) for n in ast.walk(node)}
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
        if node.col_offset == 0 and id(node) not in guarded:
            module_level |= {n for n in names if n.split(".")[0] == "fftnav"}
    return module_level, anywhere


GRAPH = {name: _imports(path) for name, path in MODULES.items()}


@pytest.mark.parametrize("module", sorted(MODULES))
def test_module_imports_only_lower_layers_and_its_allowed_third_party(module):
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


def test_module_level_imports_have_no_cycle():
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
    assert listed == found | {"fftnav.world.presets"}
    assert project["tool"]["setuptools"]["package-dir"]["fftnav.world.presets"] == "worlds"


def test_episode_loop_functions_are_short():
    tree = ast.parse((PACKAGE / "episode" / "loop.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body[1:] if ast.get_docstring(node) else node.body
            lines = body[-1].end_lineno - body[0].lineno + 1
            assert lines <= 60, f"{node.name} has {lines} lines of code"
