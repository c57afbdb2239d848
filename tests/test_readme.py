"""The README and docs/results.md say what is: their examples run, their commands are the
Makefile's, their Table I figures are the committed CSV's, their links and code references
resolve."""

import importlib
import json
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
    """The `fftnav scan FILE ...` example on the real recording the repository ships, run from
    the repository's top folder as the README says."""
    text = " ".join(README.read_text().split())
    match = re.search(r"`fftnav scan ([^`]+)` prints (\d+) lines", text)
    assert match, "the README lost its fftnav scan example"
    args = match.group(1).split()
    assert (ROOT / args[0]).is_file() and not args[0].startswith("..")
    if args[0].endswith(".bag"):
        pytest.importorskip("rosbags", reason="the optional extra fftnav[ros] is not installed")
    proc = subprocess.run([sys.executable, "-m", "fftnav", "scan", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert len(proc.stdout.splitlines()) == int(match.group(2))


def test_the_benchmark_time_is_the_committed_run_s():
    """The README's time of `make benchmark` is the committed run's wall time, as written."""
    text = " ".join(README.read_text().split())
    minutes = re.search(r"`make benchmark` took ([\d.]+) minutes", text)
    assert minutes, "the README lost the time of make benchmark"
    info = json.loads((ROOT / "results" / "table1" / "run_info.json").read_text())
    assert same(minutes.group(1), info["wall_time_s"] / 60)
    assert f"with {info['workers']} workers" in text


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
    text = README.read_text()
    block = next(b for b in re.findall(r"```bash\n(.*?)```", text, re.S) if "make test" in b)
    commands = dict(re.findall(r"^make (\w+)\s+# (.*)$", block, re.M))
    assert list(commands) == ["test", "benchmark"]
    recipes = make_recipes()
    assert "pytest" in recipes["test"] and "--doctest-modules fftnav tests" in recipes["test"]
    config, out = re.search(r"(experiments/\S+\.toml) -> (\S+?)/?(\s|$)",
                            commands["benchmark"]).groups()[:2]
    assert f"fftnav run {config} --out {out}" in recipes["benchmark"]
    assert (ROOT / config).exists() and (ROOT / out / "summary.csv").exists()


def test_the_readme_holds_one_test_count_at_most_and_no_history():
    text = " ".join(README.read_text().split())
    assert len(re.findall(r"\d[\d,]* tests\b", text)) <= 1
    assert not re.search(r"\bissues? \d+", text, re.I)


def readme_table1() -> list[dict[str, str]]:
    """The rows of the README's results table, by header."""
    section = re.search(r"\n## Results[^\n]*\n(.*?)\n## ", README.read_text(), re.S)[1]
    lines = [line.strip().strip("|").split("|") for line in section.splitlines()
             if line.startswith("|")]
    header = [cell.strip() for cell in lines[0]]
    return [dict(zip(header, (cell.strip() for cell in row), strict=True))
            for row in lines[2:]]


def quoted(cell: str) -> tuple[str, ...]:
    """The numbers of a table cell (a value, or a value and its interval), as written."""
    return tuple(re.findall(r"-?\d+(?:\.\d+)?", cell))


def same(written: str, value: float) -> bool:
    """Whether ``written`` is ``value`` rounded to the decimals written."""
    decimals = len(written.partition(".")[2])
    return float(written) == round(value, decimals)


def test_the_readme_table_is_the_committed_summary_beside_the_papers():
    """Every figure of the README's Table I is the committed summary.csv's (in percent where
    the column says %) or the paper's Table I (PAPER_TABLE1), rounded as written."""
    rows = readme_table1()
    summary = pd.read_csv(ROOT / "results" / "table1" / "summary.csv")
    names = [(row["env"], re.search(r"`([\w-]+)`", row["policy"])[1]) for row in rows]
    assert names == list(zip(summary.env, summary.policy, strict=True))
    ours = {"AR %": ["ar"], "APL m": ["apl_m"], "SPL %": ["spl"],
            "SPL % [95% CI]": ["spl", "spl_ci_low", "spl_ci_high"],
            "SPL geodesic %": ["spl_geodesic"]}
    papers = {"paper AR %": 0, "paper APL m": 1, "paper SPL %": 2}
    assert {"AR %", "APL m"} <= set(rows[0]) and set(papers) <= set(rows[0])
    for row, (name, record) in zip(rows, zip(names, summary.itertuples(), strict=True),
                                   strict=True):
        for column, fields in ours.items():
            if column in row:
                scale = 100 if "%" in column else 1
                values = [scale * getattr(record, field) for field in fields]
                assert len(quoted(row[column])) == len(values), (name, column)
                assert all(map(same, quoted(row[column]), values)), (name, column, row[column])
        paper = PAPER_TABLE1.get(name)
        for column, index in papers.items():
            if paper is None:
                assert row[column] == "-", (name, column)
            else:
                assert same(row[column], paper[index]), (name, column, row[column])


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
    # in text and code, not an entry-point group's name
    dotted = set(re.findall(r"(?<!group `)(?<![\w/.-])(fftnav(?:\.\w+)+)", text))
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


def test_the_readme_leaderboard_is_the_committed_leaderboard():
    """The README's leaderboard lists every built-in on every suite with the committed
    results/leaderboard/leaderboard.csv's figures (SPL and AR in percent, as written), in the
    order of the pooled suite's ranking."""
    section = re.search(r"\n## Leaderboard[^\n]*\n(.*?)\n## ", README.read_text(), re.S)[1]
    lines = [line.strip().strip("|").split("|") for line in section.splitlines()
             if line.startswith("|")]
    header = [cell.strip() for cell in lines[0]]
    rows = [dict(zip(header, (cell.strip() for cell in row), strict=True)) for row in lines[2:]]
    board = pd.read_csv(ROOT / "results" / "leaderboard" / "leaderboard.csv")
    from fftnav.suites import builtin_methods, ordered_suites

    suites = [s.name for s in ordered_suites()]
    assert set(board["suite"]) == set(suites)
    pooled = next(s.name for s in ordered_suites() if s.includes)
    order = list(board[board["suite"] == pooled].sort_values("rank")["method"])
    assert [re.search(r"`([\w-]+)`", r["method"])[1] for r in rows] == order
    assert set(order) == set(builtin_methods())
    by = board.set_index(["suite", "method"])
    for row in rows:
        method = re.search(r"`([\w-]+)`", row["method"])[1]
        assert int(row["rank"]) == by.loc[(pooled, method), "rank"]
        for suite in suites:
            cell = row.get(f"{suite} SPL %") or row[f"{suite} SPL % [95% CI]"]
            record = by.loc[(suite, method)]
            values = [100 * record[c] for c in ("spl", "spl_ci_low", "spl_ci_high")]
            assert len(quoted(cell)) in (1, 3), (method, suite, cell)
            assert all(map(same, quoted(cell), values[:len(quoted(cell))])), (method, suite)
        record = by.loc[(pooled, method)]
        assert same(row[f"{pooled} AR %"], 100 * record["ar"])
        causes = [c for c in board.columns if c.startswith("failures_")]
        assert int(row["failed robots (all)"]) == sum(record[c] for c in causes)
        assert same(row["bytes/robot (all)"], record["bytes_per_robot"])


def test_the_evaluate_time_is_the_measured_one_and_within_a_third_of_the_benchmark():
    """The README's time of `fftnav evaluate ... --suite paper-v2` beside `make benchmark` is
    results/evaluate_time.csv's (`make evaluate-time`), and at most a third of it."""
    text = " ".join(README.read_text().split())
    found = re.search(r"Its (\d+) episodes took ([\d.]+) s, ([\d.]+) of the ([\d.]+) s of "
                      r"`make benchmark`'s (\d+)", text)
    assert found, "the README lost the time of fftnav evaluate"
    times = pd.read_csv(ROOT / "results" / "evaluate_time.csv")
    evaluate, benchmark = times.iloc[0], times.iloc[1]
    assert evaluate["command"].startswith("fftnav evaluate my_controller.py:SafeGreedy")
    assert int(found[1]) == evaluate["episodes"] and int(found[5]) == benchmark["episodes"]
    assert same(found[2], evaluate["wall_s"]) and same(found[4], benchmark["wall_s"])
    assert same(found[3], evaluate["wall_s"] / benchmark["wall_s"])
    assert evaluate["wall_s"] <= benchmark["wall_s"] / 3


def test_the_readme_learned_table_is_the_committed_rows():
    """The README's learned-methods table: each method's AR and SPL per world (percent) and
    failed robots by cause, recomputed from results/learned/table1 and results/table1 (the
    rows the learned report reads); the untrained row from the three untrained networks."""
    section = re.search(r"\n## Learned methods[^\n]*\n(.*?)\n## ", README.read_text(), re.S)[1]
    lines = [line.strip().strip("|").split("|") for line in section.splitlines()
             if line.startswith("|")]
    header = [cell.strip() for cell in lines[0]]
    rows = [dict(zip(header, (c.strip() for c in row), strict=True)) for row in lines[2:]]
    episodes = pd.concat([pd.read_csv(ROOT / "results" / d / "episodes.csv",
                                      keep_default_na=False)
                          for d in ("learned/table1", "table1")])

    def causes(table):
        failed = table.loc[~table["arrived"], "failure"].value_counts()
        return failed

    for row in rows:
        name = re.search(r"`([\w-]+)`", row["method"])
        policies = ([name[1]] if name else
                    sorted(p for p in episodes.policy.unique() if p.endswith("-untrained")))
        table = episodes[episodes.policy.isin(policies)]
        for env in ("forest", "rocky"):
            per = [table[(table.env == env) & (table.policy == p)] for p in policies]
            for measure, col in (("AR", "arrived"), ("SPL", "spl")):
                values = sorted(f"{100 * t[col].astype(float).mean():.1f}" for t in per)
                cell = row[f"{env} {measure} %"]
                expected = (values[0] if values[0] == values[-1]
                            else f"{values[0]}-{values[-1]}")
                assert cell == expected, (row["method"], env, measure, cell, expected)
        failed = causes(table)
        cell = row["failed robots by cause (both)"]
        if cell == "none":
            assert failed.empty, row["method"]
        for cause, count in re.findall(r"(\w+) ([\d,]+)", re.sub(r" of [\d,]+", "", cell)):
            assert int(count.replace(",", "")) == failed[cause], (row["method"], cause)
        if "of" in cell:
            assert re.search(rf"of {len(table):,}", cell), row["method"]
