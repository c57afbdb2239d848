"""The README and docs/results.md say what is: their examples run, their commands are the
Makefile's, their Table I figures are the committed CSV's, their links and code references
resolve."""

import importlib
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from fftnav.report.experiment import PAPER_TABLE1

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
RESULTS = ROOT / "docs" / "results.md"


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
    if not (ROOT / match.group(1)).exists():
        pytest.skip(f"{match.group(1)} is not beside this repository")
    proc = subprocess.run([sys.executable, "-m", "fftnav", "scan", match.group(1)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert len(proc.stdout.splitlines()) == int(match.group(2))


def make_recipes() -> dict[str, str]:
    """The Makefile's targets and their recipes (the lines after ``target:``)."""
    recipes, target = {}, None
    for line in (ROOT / "Makefile").read_text().splitlines():
        if line.startswith("\t") and target:
            recipes[target] += line.strip() + "\n"
        elif match := re.match(r"([\w-]+):", line):
            target = match.group(1)
            recipes[target] = ""
        else:
            target = None
    return recipes


def test_the_two_commands_are_the_makefiles():
    block = re.search(r"## Install and run\n.*?```bash\n(.*?)```", README.read_text(), re.S)[1]
    commands = dict(re.findall(r"^make (\w+)\s+# (.*)$", block, re.M))
    assert list(commands) == ["test", "benchmark"]
    recipes = make_recipes()
    assert "pytest" in recipes["test"] and "--doctest-modules fftnav tests" in recipes["test"]
    config, out = re.search(r"(experiments/\S+\.toml) -> (\S+?)/?$", commands["benchmark"]).groups()
    assert f"fftnav run {config} --out {out}" in recipes["benchmark"]
    assert (ROOT / config).exists() and (ROOT / out / "summary.csv").exists()


def test_the_readme_holds_no_test_count_and_no_history():
    text = " ".join(README.read_text().split())
    assert not re.search(r"\d[\d,]* tests\b", text)
    assert not re.search(r"\bissues? \d+", text, re.I)


def readme_table1() -> pd.DataFrame:
    section = re.search(r"## Results: Table I\n(.*?)\n## ", README.read_text(), re.S)[1]
    rows = [line.strip("|").split("|") for line in section.splitlines()
            if re.match(r"\| (forest|rocky) \|", line)]
    columns = ["env", "policy", "ar", "apl_m", "spl", "paper_ar", "paper_apl_m", "paper_spl"]
    table = pd.DataFrame([[cell.strip().strip("`") for cell in row] for row in rows],
                         columns=columns)
    return table


def test_the_readme_table_is_the_committed_summary_beside_the_papers():
    table = readme_table1()
    summary = pd.read_csv(ROOT / "results" / "table1" / "summary.csv")
    assert list(zip(table.env, table.policy, strict=True)) == list(
        zip(summary.env, summary.policy, strict=True))
    for row, ours in zip(table.itertuples(), summary.itertuples(), strict=True):
        assert row.ar == f"{100 * ours.ar:.1f}"
        assert row.apl_m == f"{ours.apl_m:.3f}"
        assert row.spl == f"{100 * ours.spl:.1f}"
        paper = PAPER_TABLE1.get((row.env, row.policy))
        expected = ("-", "-", "-") if paper is None else (
            f"{paper[0]:.1f}", f"{paper[1]:.3f}", f"{paper[2]:.1f}")
        assert (row.paper_ar, row.paper_apl_m, row.paper_spl) == expected


def anchor(heading: str) -> str:
    """GitHub's anchor of a Markdown heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


@pytest.mark.parametrize("page", [README, RESULTS], ids=lambda p: p.name)
def test_links_and_anchors_resolve(page):
    text = re.sub(r"`[^`\n]*`", "", page.read_text())  # code spans hold no links
    links = re.findall(r"\]\(([^)\s]+)\)", text)
    assert links
    for link in links:
        target, _, fragment = link.partition("#")
        path = (page.parent / target).resolve() if target else page
        assert path.exists(), f"{page.name} links to {link}, which does not exist"
        if fragment:
            headings = re.findall(r"^#+ (.*)$", path.read_text(), re.M)
            assert fragment in {anchor(h) for h in headings}, f"{page.name}: no #{fragment}"


@pytest.mark.parametrize("page", [README, RESULTS], ids=lambda p: p.name)
def test_code_references_resolve(page):
    """Every `fftnav.module.name` names a module or an attribute of one (the modules' new
    homes, e.g. `fftnav.navigation`, are checked here), every `fftnav/...py` a file."""
    text = page.read_text()
    dotted = set(re.findall(r"(?<!group )`(fftnav(?:\.\w+)+)", text))  # not entry-point groups
    files = set(re.findall(r"`(fftnav/[\w/]+\.\w+)`", text))
    assert dotted or files
    for reference in dotted:
        parts = reference.split(".")
        for cut in range(len(parts), 0, -1):
            try:
                obj = importlib.import_module(".".join(parts[:cut]))
            except ModuleNotFoundError:
                continue
            for name in parts[cut:]:
                assert hasattr(obj, name), f"{page.name}: `{reference}` does not resolve"
                obj = getattr(obj, name)
            break
    for file in files:
        assert (ROOT / file).exists(), f"{page.name}: `{file}` does not exist"
