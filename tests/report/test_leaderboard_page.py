"""The leaderboard page's text (fftnav.report.leaderboard_page): the data the page embeds, read
back from the page as a browser would find it (its script element's JSON, its title), against
values worked by hand from a small leaderboard table built here as the lead's CSV is.

The page in a browser (sorting, tabs, the highlight, the links) is tests/report/
test_leaderboard_browser.py.
"""

from __future__ import annotations

import fnmatch
import json
import math
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomllib

from fftnav.errors import FftnavError
from fftnav.metrics import FAILURE_CAUSES
from fftnav.report.leaderboard_page import (
    TEMPLATE,
    leaderboard_data,
    leaderboard_html,
    method_failures_link,
    suite_report_link,
    write_leaderboard_page,
)

ROOT = Path(__file__).resolve().parents[2]
NAN = math.nan
WEIRD = "my<ctrl>.py:Attr"
SUITES = {"paper-v2": "the paper's forest and rocky ruins", "walls-v1": "long walls",
          "traps-v1": "U-shaped traps"}
CAUSES = list(FAILURE_CAUSES)
#: (suite, method, rank, spl, spl_ci, ar, apl_m, bytes_per_robot, compute_ms,
#: {cause: robots}, p_holm, notes), in no particular order
ROWS = [
    ("paper-v2", "bug-left", 2, 0.9704, (0.9651, 0.9749), 0.99, 18.8312, 0.0, NAN,
     {"stuck": 1}, 0.0004, "compute time not measured"),
    ("paper-v2", "fusion", 1, 0.9944, (0.9911, 0.9962), 1.0, 18.157, 58.6, 0.0123456, {}, NAN,
     ""),
    ("paper-v2", "random", 4, 0.864, (0.851, 0.884), 0.98, 21.5, 0.0, 0.5,
     {"stuck": 2, "slow": 1}, 0.5, ""),
    ("paper-v2", WEIRD, 3, 0.5, (0.45, 0.55), 0.6, 20.5, 1234.4, 9.996,
     {"collision": 2, "detour": 4}, 0.031249, ""),
    ("walls-v1", "bug-left", 3, 0.7, (0.6, 0.8), 0.8, 25.0, 0.0, 0.2, {"loop": 3}, 0.001, ""),
    ("walls-v1", "collab", 1, 0.95, (0.9, 0.97), 0.99, 22.0, 40.0, 1.5, {}, NAN, ""),
    ("walls-v1", "fusion", 2, 0.85, (0.8, 0.9), 0.9, NAN, 58.0, 0.3, {"jam": 1}, 0.0312, ""),
]


def board(rows=ROWS, causes=CAUSES) -> pd.DataFrame:
    """The leaderboard table of ``rows`` in the contract's column order, one ``failures_<cause>``
    column per cause of ``causes``."""
    records = []
    for suite, method, rank, spl, ci, ar, apl, nbytes, ms, failed, p, notes in rows:
        record = {"suite": suite, "method": method, "rank": rank, "maps": 20, "robots": 300,
                  "spl": spl, "spl_ci_low": ci[0], "spl_ci_high": ci[1], "ar": ar,
                  "ar_ci_low": max(ar - 0.01, 0.0), "ar_ci_high": min(ar + 0.01, 1.0), "apl_m": apl,
                  "bytes_per_robot": nbytes, "compute_ms": ms}
        record |= {f"failures_{c}": failed.get(c, 0) for c in causes}
        records.append(record | {"p_holm": p, "notes": notes})
    return pd.DataFrame(records)


class Page(HTMLParser):
    """A page's title, its elements' attributes, and its scripts' texts."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.title, self.scripts, self.attrs, self._in = "", [], [], None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        self.attrs.append((tag, dict(attrs)))
        self._in = tag
        if tag == "script":
            self.scripts.append([dict(attrs).get("type"), ""])

    def handle_endtag(self, tag):
        self._in = None

    def handle_data(self, data):
        if self._in == "title":
            self.title += data
        elif self._in == "script":
            self.scripts[-1][1] += data

    def data(self) -> dict:
        (text,) = [t for kind, t in self.scripts if kind == "application/json"]
        return json.loads(text)


def _page(table=None, **options) -> tuple[str, dict]:
    text = leaderboard_html(board() if table is None else table,
                            **({"suites": SUITES} | options))
    return text, Page(text).data()


def _rows(data: dict, suite: str) -> dict[str, dict]:
    """The rows of a tab by method, each cell by its column's key."""
    (tab,) = [s for s in data["suites"] if s["name"] == suite]
    keys = [c["key"] for c in data["columns"]]
    return {r["method"]: r | {"by": dict(zip(keys, r["cells"], strict=True))}
            for r in tab["rows"]}


def test_a_method_name_of_any_text_is_data_never_markup():
    """Names with markup, a closing script tag and the template's placeholders come back
    from the page exactly, and add no element to it."""
    hostile = "</script><script>alert(1)</script><!--"
    rows = [("paper-v2", WEIRD, 1, *ROWS[1][3:]), ("paper-v2", hostile, 2, *ROWS[0][3:]),
            ("paper-v2", "/*FFTNAV_TITLE*/", 3, *ROWS[2][3:])]
    title = "Board <b>&amp; /*FFTNAV_DATA*/"
    text, data = _page(board(rows), title=title, highlight=hostile,
                       generated="made by <tool> & co")
    page = Page(text)
    assert page.title == title and data["title"] == title
    assert data["generated"] == "made by <tool> & co" and data["highlight"] == hostile
    assert [r["method"] for r in data["suites"][0]["rows"]] == [WEIRD, hostile,
                                                                 "/*FFTNAV_TITLE*/"]
    assert [s[0] for s in page.scripts] == ["application/json", None]  # no script added
    assert not set("<>&") & set(page.scripts[0][1])  # the data can close no element
    assert not any(tag in ("b", "ctrl") for tag, _ in page.attrs)
    assert "<ctrl>" not in text and "alert(1)</script>" not in text


def test_the_same_table_gives_the_same_bytes(tmp_path):
    first = leaderboard_html(board(), suites=SUITES, highlight="fusion", generated="g")
    again = leaderboard_html(board(), suites=dict(SUITES), highlight="fusion", generated="g")
    assert first == again
    assert Page(first).data() == leaderboard_data(board(), suites=SUITES, highlight="fusion",
                                                  generated="g")
    out = write_leaderboard_page(tmp_path / "index.html", board(), suites=SUITES,
                                 highlight="fusion", generated="g")
    assert out == tmp_path / "index.html" and out.read_bytes() == first.encode("utf-8")
    assert [p.name for p in tmp_path.iterdir()] == ["index.html"]  # no temporary file left


def test_the_columns_follow_the_table_and_a_new_failure_cause_gets_one():
    causes = [*CAUSES[:2], "wedged", *CAUSES[2:]]  # a cause the registry does not know yet
    rows = [(*r[:9], {"wedged": 5} if r[1] == "fusion" else r[9], *r[10:]) for r in ROWS]
    table = board(rows, causes)
    _, data = _page(table)
    keys = [c["key"] for c in data["columns"]]
    shown = [c for c in table.columns if c not in ("suite", "notes") and "_ci_" not in c]
    assert keys == shown  # the table's order; intervals go into their value's cell
    labels = {c["key"]: c["label"] for c in data["columns"]}
    assert [labels[f"failures_{c}"] for c in causes] == causes
    helps = {c["key"]: c["help"] for c in data["columns"]}
    assert FAILURE_CAUSES["stuck"].definition in helps["failures_stuck"]
    assert helps["failures_wedged"] == "robots that failed by wedged"
    assert _rows(data, "paper-v2")["fusion"]["by"]["failures_wedged"] == {"t": "5", "v": 5.0}
    assert _rows(data, "walls-v1")["fusion"]["by"]["failures_wedged"]["t"] == "5"
    assert f"{', '.join(causes)}: robots that failed by each cause" in data["legend"]


def test_values_are_shown_as_the_contract_says():
    _, data = _page()
    rows = _rows(data, "paper-v2")
    fusion, bug, weird, rand = (rows[m]["by"] for m in ("fusion", "bug-left", WEIRD, "random"))
    assert fusion["spl"] == {"t": "99.4", "v": 0.9944, "ci": "[99.1, 99.6]"}
    assert bug["spl"]["t"] == "97.0" and bug["spl"]["ci"] == "[96.5, 97.5]"
    assert bug["ar"]["t"] == "99.0" and bug["ar"]["ci"] == "[98.0, 100.0]"
    assert bug["apl_m"]["t"] == "18.83" and fusion["apl_m"]["t"] == "18.16"
    assert fusion["bytes_per_robot"]["t"] == "59" and weird["bytes_per_robot"]["t"] == "1234"
    # three significant digits, never an exponent
    assert [r["compute_ms"]["t"] for r in (fusion, weird, rand)] == ["0.0123", "10.0", "0.500"]
    assert [r["p_holm"]["t"] for r in (bug, weird, rand)] == ["<0.001", "0.0312", "0.500"]
    assert _rows(data, "walls-v1")["bug-left"]["by"]["p_holm"]["t"] == "0.00100"
    assert [fusion[k]["t"] for k in ("rank", "maps", "robots")] == ["1", "20", "300"]
    assert weird["failures_detour"] == {"t": "4", "v": 4.0}
    assert fusion["method"] == {"t": "fusion", "v": "fusion"}
    assert "95 % bootstrap interval over maps" in next(
        c["help"] for c in data["columns"] if c["key"] == "spl")


def test_no_value_is_a_dash_with_its_reason():
    _, data = _page()
    rows = _rows(data, "paper-v2")
    assert rows["fusion"]["by"]["p_holm"] == {
        "t": "-", "v": None, "title": "the suite's rank-1 method: the others are tested against it"}
    assert rows["bug-left"]["by"]["compute_ms"] == {"t": "-", "v": None,
                                                    "title": "compute time not measured"}
    assert rows["bug-left"]["note"] == "compute time not measured"
    walls = _rows(data, "walls-v1")
    assert walls["fusion"]["by"]["apl_m"] == {"t": "-", "v": None}  # no reason known
    table = board([("paper-v2", "stopped", 1, 0.0, (0.0, 0.0), 0.0, NAN, 0.0, 0.1, {}, NAN, "")])
    stopped = _rows(_page(table)[1], "paper-v2")["stopped"]["by"]
    assert stopped["apl_m"]["title"] == "no robot arrived"
    assert stopped["spl"] == {"t": "0.0", "v": 0.0, "ci": "[0.0, 0.0]"}


def test_rows_start_in_rank_order_and_every_suite_has_its_tab():
    table = board()
    table.loc[table["method"] == "random", "rank"] = NAN
    _, data = _page(table)
    assert [s["name"] for s in data["suites"]] == list(SUITES)
    assert data["sortedBy"] == "rank"
    ranks = {s: table[table["suite"] == s].sort_values("rank", na_position="last")["method"]
             for s in SUITES}
    for tab in data["suites"]:
        assert [r["method"] for r in tab["rows"]] == list(ranks[tab["name"]])
    assert list(ranks["paper-v2"]) == ["fusion", "bug-left", WEIRD, "random"]
    assert data["suites"][2]["rows"] == []  # traps-v1: a tab without results


def test_links_and_the_highlight():
    _, data = _page(highlight="fusion")
    tabs = {s["name"]: s for s in data["suites"]}
    assert tabs["walls-v1"]["report"] == "walls-v1/report.md"
    rows = _rows(data, "paper-v2")
    assert rows["fusion"]["link"] == "paper-v2/failures.md#fusion"
    assert rows[WEIRD]["link"] == "paper-v2/failures.md#my%3Cctrl%3E.py%3AAttr"
    highlighted = [(s["name"], r["method"]) for s in data["suites"] for r in s["rows"]
                   if r["highlight"]]
    assert highlighted == [("paper-v2", "fusion"), ("walls-v1", "fusion")]
    _, data = _page(report_link=lambda s: f"https://example.org/{s}",
                    failures_link=lambda s, m: f"{s}/{m}.html")
    assert data["suites"][1]["report"] == "https://example.org/walls-v1"
    assert _rows(data, "walls-v1")["collab"]["link"] == "walls-v1/collab.html"
    assert suite_report_link("a b") == "a%20b/report.md"
    assert method_failures_link("s", "a#b") == "s/failures.md#a%23b"


def test_the_page_loads_nothing_from_elsewhere_and_ships_in_the_wheel():
    text, _ = _page()
    page = Page(text)
    for tag, attrs in page.attrs:
        for name in ("src", "href"):
            assert attrs.get(name, "data:").startswith("data:"), (tag, attrs)
    assert "http://" not in text and "https://" not in text
    (policy,) = [a["content"] for t, a in page.attrs
                 if a.get("http-equiv") == "Content-Security-Policy"]
    assert policy.startswith("default-src 'none';")
    shipped = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["fftnav.report"]
    assert any(fnmatch.fnmatch(TEMPLATE, pattern) for pattern in shipped)


def _refused(match: str, table=None, **options) -> None:
    with pytest.raises(FftnavError, match=match):
        leaderboard_html(board() if table is None else table, **({"suites": SUITES} | options))


def test_bad_tables_are_refused_naming_the_column_and_value():
    _refused(r"^table must be a pandas.DataFrame, got table of type list$", table=[1])
    _refused(r"^table must have a 'suite' column, got table columns \['method', 'rank'",
             table=board().drop(columns="suite"))
    _refused(r"^table must have a 'method' column", table=board().drop(columns="method"))
    stray = board()
    stray.loc[4, "suite"] = "walls-v2"
    _refused(r"^table.suite must be one of the suites \['paper-v2', 'walls-v1', 'traps-v1'\], "
             r"got table.suite='walls-v2' \(row 4\)$", table=stray)
    twice = pd.concat([board(), board().iloc[[5]]], ignore_index=True)
    _refused(r"^table must have one row per \(suite, method\), got 2 rows with "
             r"suite='walls-v1', method='collab'$", table=twice)
    nameless = board()
    nameless.loc[2, "method"] = ""
    _refused(r"^table.method must be a non-empty text, got table.method='' \(row 2\)$",
             table=nameless)
    text = board().astype({"spl": object})
    text.loc[1, "spl"] = "high"
    _refused(r"^table.spl must be numbers \(NaN: none\), got table.spl='high' \(row 1\)$",
             table=text)
    percent = board()
    percent.loc[3, "spl_ci_high"] = 55.0
    _refused(r"^table.spl_ci_high must be NaN or a finite number in \[0, 1\], got "
             r"table.spl_ci_high=55.0 \(row 3\)$", table=percent)
    endless = board()
    endless.loc[0, "compute_ms"] = np.inf
    _refused(r"^table.compute_ms must be NaN or a finite number >= 0, got "
             r"table.compute_ms=inf \(row 0\)$", table=endless)
    negative = board()
    negative.loc[6, "failures_stuck"] = -1
    _refused(r"table.failures_stuck must be NaN or a finite number >= 0, got "
             r"table.failures_stuck=-1 \(row 6\)", table=negative)


def test_bad_options_are_refused_naming_the_parameter_and_value():
    _refused(r"^suites must be a non-empty mapping of suite name to one-line description, "
             r"got suites=\{\}$", suites={})
    _refused(r"^suites\['walls-v1'\] must be a one-line text, got "
             r"suites\['walls-v1'\]='long\\nwalls'$", suites=SUITES | {"walls-v1": "long\nwalls"})
    _refused(r"^highlight must be None or a method of the table \['bug-left', 'fusion', "
             r"'random', 'my<ctrl>.py:Attr', 'collab'\], got highlight='fusoin'$",
             highlight="fusoin")
    _refused(r"^title must be a text, got title=None$", title=None)
    _refused(r"^report_link must return a text, got report_link\('paper-v2'\)=None$",
             report_link=lambda suite: None)
    _refused(r"^failures_link must be a function returning a link, got "
             r"failures_link='x.md'$", failures_link="x.md")


def test_a_refused_table_leaves_the_page_as_it_was(tmp_path):
    out = write_leaderboard_page(tmp_path / "index.html", board(), suites=SUITES)
    before = out.read_bytes()
    with pytest.raises(FftnavError, match=r"^table.suite must be one of the suites \['x'\]"):
        write_leaderboard_page(out, board(), suites={"x": "y"})
    assert out.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["index.html"]
