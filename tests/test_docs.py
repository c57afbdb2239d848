"""The docs name only what is there: every repository path the README and docs/ name exists in
the repository (tracked, or a regenerable output that .gitignore keeps out), none points
outside it, and only docs/history.md tells history."""

from __future__ import annotations

import re
import subprocess
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
TOP = ("fftnav", "tests", "docs", "experiments", "results", "worlds", ".ci")
#: A path of the repository as the docs write it: a top-level folder, then path characters.
PATH = re.compile(rf"(?<![\w./:-])((?:{'|'.join(map(re.escape, TOP))})/[\w./=<>*{{}}+-]*"
                  r"|README\.md|Makefile|pyproject\.toml)")
#: A revision before a path (`git show 1845deca:results/...`) names the past, not the tree.
REVISION = re.compile(r"[0-9a-f]{7,40}:$")


@cache
def tracked() -> frozenset[str]:
    """The tracked files and every folder above them."""
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout.split()
    folders = {str(Path(f).parents[k]) for f in out for k in range(len(Path(f).parents) - 1)}
    return frozenset(out) | frozenset(folders)


def ignored(path: str) -> bool:
    """Whether .gitignore keeps ``path`` out (a regenerable output the docs may name)."""
    return any(subprocess.run(["git", "check-ignore", "-q", "--no-index", candidate], cwd=ROOT
                              ).returncode == 0
               for candidate in (path, path.rstrip("/") + "/"))  # a folder's pattern ends in /


def named_paths(text: str) -> set[str]:
    """The repository paths named in ``text``; a path with a placeholder or a wildcard is cut
    before it and ends in ``*`` (any tracked path that begins so will do)."""
    found = set()
    for match in PATH.finditer(text):
        if REVISION.search(text[max(0, match.start() - 41):match.start()]):
            continue
        head, *rest = re.split(r"[<*{]", match.group(1))
        path = head if rest else head.rstrip(".,:;/=-")
        if path:
            found.add(path + "*" if rest else path)
    return found


def exists(path: str) -> bool:
    """Whether ``path`` is tracked (a file or a folder of tracked files), or a regenerable
    output that .gitignore keeps out; ``prefix*``: whether a tracked path begins so."""
    if path.endswith("*"):
        return any(p.startswith(path[:-1]) for p in tracked()) or ignored(path[:-1])
    return path in tracked() or ignored(path)


def git_checkout() -> bool:
    return (ROOT / ".git").exists()


@pytest.mark.skipif(not git_checkout(), reason="needs the git checkout (CI clones it)")
@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_repository_path_named_exists(page):
    missing = sorted(p for p in named_paths(page.read_text()) if not exists(p))
    assert not missing, f"{page.relative_to(ROOT)} names paths that are not in the repository: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_no_path_points_outside_the_repository(page):
    """No relative path climbs out of the repository (``../shared/...`` from the README) or
    to a missing file, and no path names this machine's folders (``/work/...``)."""
    text = page.read_text()
    relative = re.findall(r"(?<![\w.])((?:\.\./)+[\w./-]+)", text)
    prose = re.sub(r"`[^`\n]*`", "", text)  # code spans hold no links
    links = [link for link in re.findall(r"\]\(([^)\s#]+)", prose) if not re.match(r"\w+:", link)]
    bad = [p for p in relative + links
           if not (page.parent / p).resolve().is_relative_to(ROOT)
           or not (page.parent / p).resolve().exists()]
    bad += re.findall(r"(?<![\w.])/work/[\w./-]+", text)
    assert not bad, f"{page.relative_to(ROOT)} points outside the repository: {bad}"


@pytest.mark.parametrize("page", [p for p in PAGES if p.name != "history.md"],
                         ids=lambda p: p.name)
def test_history_is_told_in_one_place(page):
    """Ticket numbers and tuning rounds belong to docs/history.md."""
    text = " ".join(page.read_text().split())
    found = re.findall(r"\b(?:issues? \d+|(?:first|second|third|fourth|fifth|sixth|seventh|"
                       r"eighth|ninth|tenth|eleventh|twelfth) round|round \d+)\b", text, re.I)
    assert not found, f"{page.relative_to(ROOT)} tells history: {found[:5]}"


def test_the_path_finder_finds_paths():
    text = ("see `results/table1/report.md`, results/collab/sweep/<key>=<value>/, "
            "`git show 1845deca:results/collab/drive_tuning/summary.csv` and ../shared/x")
    assert named_paths(text) == {"results/table1/report.md", "results/collab/sweep/*"}
