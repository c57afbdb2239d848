"""The leaderboard page in a real browser: headless Chromium driven over the Chrome DevTools
Protocol, as tests/report/test_replay_browser.py drives the replay player (its DevTools session,
its Chromium lookup and its list of console errors and network requests are reused here). The
page, written from the small leaderboard of tests/report/test_leaderboard_page.py, must load
from file:// with no network request and no console error, sort its tables by a click on a
column's header both ways (NaN last), switch tabs by a click, the arrow keys and the URL's hash,
highlight the chosen method in every tab, and link each tab to its suite's report and each row
to its method's failures.

Skipped only when Chromium is missing on a developer's machine; with ``CI`` set, a missing
Chromium fails (as the replay player's test).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import pytest

from fftnav.report.leaderboard_page import method_failures_link, write_leaderboard_page
from tests.report.test_leaderboard_page import SUITES, WEIRD, board
from tests.report.test_replay_browser import DevTools, _browser, _errors

HIGHLIGHT = "fusion"


def _load(tools: DevTools, url: str) -> None:
    """Open ``url`` (a fresh document) and wait for the page's script to finish."""
    tools.call("Page.navigate", url="about:blank")
    tools.call("Page.navigate", url=url)
    _until(tools, "!!(window.fftnavLeaderboard && window.fftnavLeaderboard.ready)",
           "the page did not start")


def _until(tools: DevTools, expression: str, what: str, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not tools.evaluate(expression):
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def _session(browser: str, profile, html, *, width: int = 1400) -> DevTools:
    """A DevTools session on the leaderboard page ``html``, loaded (its URL in ``tools.url``)."""
    tools = DevTools(browser, str(profile))
    target = tools.call("Target.createTarget", url="about:blank")["targetId"]
    tools.session = tools.call("Target.attachToTarget", targetId=target,
                               flatten=True)["sessionId"]
    for domain in ("Runtime", "Log", "Page", "Network"):
        tools.call(f"{domain}.enable")
    tools.call("Emulation.setDeviceMetricsOverride", width=width, height=800,
               deviceScaleFactor=1, mobile=False)
    tools.url = html.as_uri()
    _load(tools, tools.url)
    return tools


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    """A DevTools session on the page of the small leaderboard, ``fusion`` highlighted."""
    browser = _browser()
    folder = tmp_path_factory.mktemp("leaderboard")
    html = write_leaderboard_page(folder / "index.html", board(), suites=SUITES,
                                  highlight=HIGHLIGHT, generated="made by the test")
    tools = _session(browser, folder / "profile", html)
    try:
        yield tools
    finally:
        tools.close()


def _js(text: str) -> str:
    return json.dumps(text)


def _click(tools: DevTools, selector: str) -> None:
    """A mouse click at the middle of the (visible) element ``selector``."""
    x, y = tools.evaluate(f"(() => {{ const r = document.querySelector({_js(selector)})"
                          f".getBoundingClientRect(); return [r.x + r.width / 2, "
                          f"r.y + r.height / 2]; }})()")
    for kind in ("mousePressed", "mouseReleased"):
        tools.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left",
                   clickCount=1)


def _key(tools: DevTools, key: str, code: int) -> None:
    for kind in ("rawKeyDown", "keyUp"):
        tools.call("Input.dispatchKeyEvent", type=kind, key=key, code=key,
                   windowsVirtualKeyCode=code)


def _order(tools: DevTools, suite: str) -> list[str]:
    return tools.evaluate(f"window.fftnavLeaderboard.order({_js(suite)})")


def _open_tab(tools: DevTools, suite: str) -> None:
    tools.evaluate(f"window.fftnavLeaderboard.show({_js(suite)})")
    assert tools.evaluate("window.fftnavLeaderboard.suite") == suite


def _sorted(suite: str, column: str, *, reverse: bool = False) -> list[str]:
    """The oracle: the suite's methods by ``column``, NaN last either way, ties in rank order."""
    rows = board().sort_values("rank")
    rows = rows[rows["suite"] == suite]
    known = [(v, m) for v, m in zip(rows[column], rows["method"], strict=True)
             if not (isinstance(v, float) and math.isnan(v))]
    nan = [m for v, m in zip(rows[column], rows["method"], strict=True) if (v, m) not in known]
    return [m for _, m in sorted(known, key=lambda vm: vm[0], reverse=reverse)] + nan


def _cells(tools: DevTools, panel: int, key: str) -> list[list[str]]:
    """The text and tooltip of a column's cells in a tab, in the rows' shown order."""
    return tools.evaluate(
        f"(() => {{ const heads = Array.from(document.querySelectorAll('#panel-{panel} thead th'));"
        f" const j = heads.findIndex((th) => th.getAttribute('data-key') === {_js(key)});"
        f" return Array.from(document.querySelectorAll('#panel-{panel} tbody tr'),"
        f" (tr) => [tr.cells[j].textContent, tr.cells[j].title]); }})()")


def _head(tools: DevTools, panel: int, key: str) -> tuple[str, str]:
    """The arrow and ``aria-sort`` of a column's header."""
    th = f"document.querySelector('#panel-{panel} th[data-key=\"{key}\"]')"
    return (tools.evaluate(f"{th}.querySelector('.arrow').textContent"),
            tools.evaluate(f"{th}.getAttribute('aria-sort')"))


def test_the_page_opens_on_the_first_tab_in_rank_order(page):
    assert page.evaluate("window.fftnavLeaderboard.suite") == "paper-v2"
    assert page.evaluate("[0, 1, 2].map((i) => document.getElementById('panel-' + i).hidden)"
                         ) == [False, True, True]
    for suite in ("paper-v2", "walls-v1"):
        assert _order(page, suite) == _sorted(suite, "rank")
    assert _head(page, 0, "rank") == (" \u25b2", "ascending")
    assert page.evaluate("document.title") == "fftnav leaderboard"
    assert page.evaluate("document.getElementById('generated').textContent") == "made by the test"
    assert not _errors(page.events)


def test_a_numeric_column_with_a_nan_sorts_both_ways_nan_last(page):
    _open_tab(page, "paper-v2")
    _click(page, "#panel-0 th[data-key='compute_ms'] button")
    assert _order(page, "paper-v2") == _sorted("paper-v2", "compute_ms")
    assert _order(page, "paper-v2")[-1] == "bug-left"  # its compute_ms is NaN
    assert _head(page, 0, "compute_ms") == (" \u25b2", "ascending")
    assert _head(page, 0, "rank") == ("", "none")
    assert [t for t, _ in _cells(page, 0, "compute_ms")] == ["0.0123", "0.500", "10.0", "-"]
    _click(page, "#panel-0 th[data-key='compute_ms'] button")
    assert _order(page, "paper-v2") == _sorted("paper-v2", "compute_ms", reverse=True)
    assert _order(page, "paper-v2")[-1] == "bug-left"
    assert _head(page, 0, "compute_ms") == (" \u25bc", "descending")
    _click(page, "#panel-0 th[data-key='method'] button")  # text: alphabetically
    assert _order(page, "paper-v2") == sorted(_sorted("paper-v2", "rank"))
    assert _order(page, "walls-v1") == _sorted("walls-v1", "rank")  # another tab's table
    _click(page, "#panel-0 th[data-key='rank'] button")
    assert _order(page, "paper-v2") == _sorted("paper-v2", "rank")
    assert not _errors(page.events)


def test_tabs_switch_by_click_by_keys_and_by_the_hash(page):
    _open_tab(page, "paper-v2")
    _click(page, "#tab-1")
    assert page.evaluate("window.fftnavLeaderboard.suite") == "walls-v1"
    assert page.evaluate("location.hash") == "#suite=walls-v1"
    assert page.evaluate("[0, 1, 2].map((i) => document.getElementById('panel-' + i).hidden)"
                         ) == [True, False, True]
    assert page.evaluate("document.getElementById('tab-1').getAttribute('aria-selected')") == (
        "true")
    _key(page, "ArrowRight", 39)  # the focused tab's keys
    assert page.evaluate("window.fftnavLeaderboard.suite") == "traps-v1"
    assert page.evaluate("document.activeElement.id") == "tab-2"
    assert page.evaluate("document.querySelector('#panel-2 .empty').textContent") == (
        "No results on this suite yet.")
    _key(page, "Home", 36)
    assert page.evaluate("window.fftnavLeaderboard.suite") == "paper-v2"
    page.evaluate("location.hash = '#suite=walls-v1'")
    _until(page, "window.fftnavLeaderboard.suite === 'walls-v1'", "the hash opened no tab")
    page.evaluate("location.hash = '#suite=nowhere'")  # no such suite: the tab stays
    page.evaluate("location.hash = '#suite=%E0'")  # a malformed escape: the tab stays
    _until(page, "location.hash === '#suite=%E0'", "the hash did not change")
    assert page.evaluate("window.fftnavLeaderboard.suite") == "walls-v1"
    _load(page, page.url + "#suite=traps-v1")  # a link opens its tab
    assert page.evaluate("window.fftnavLeaderboard.suite") == "traps-v1"
    assert page.evaluate("document.getElementById('panel-2').hidden") is False
    assert not _errors(page.events)


def test_the_highlighted_method_shows_in_every_tab(page):
    assert page.evaluate("document.getElementById('highlighted').hidden") is False
    assert page.evaluate("document.getElementById('highlighted-method').textContent") == (
        HIGHLIGHT)
    background = "(tr) => getComputedStyle(tr).backgroundColor"
    for i, suite in enumerate(("paper-v2", "walls-v1")):
        _open_tab(page, suite)
        rows = f"document.querySelectorAll('#panel-{i} tbody tr')"
        marked = page.evaluate(f"Array.from({rows}).filter((tr) => tr.classList.contains("
                               f"'highlight')).map((tr) => tr.getAttribute('data-method'))")
        assert marked == [HIGHLIGHT]
        colours = dict(zip(_order(page, suite), page.evaluate(f"Array.from({rows}, "
                                                              f"{background})"), strict=True))
        others = {c for m, c in colours.items() if m != HIGHLIGHT}
        assert len(others) == 1 and colours[HIGHLIGHT] not in others, colours
        height = page.evaluate(f"document.querySelector('#panel-{i} tr.highlight')"
                               f".getBoundingClientRect().height")
        assert height > 0
    assert not _errors(page.events)


def test_links_point_to_the_reports_and_the_failures(page):
    folder = page.url.rsplit("/", 1)[0]
    for i, suite in enumerate(("paper-v2", "walls-v1")):
        _open_tab(page, suite)
        report = f"document.querySelector('#panel-{i} a.report')"
        assert page.evaluate(f"{report}.getAttribute('href')") == f"{suite}/report.md"
        assert page.evaluate(f"{report}.href") == f"{folder}/{suite}/report.md"
        links = page.evaluate(f"Array.from(document.querySelectorAll('#panel-{i} tbody th a'), "
                              f"(a) => [a.textContent, a.getAttribute('href'), a.href])")
        assert [t for t, _, _ in links] == _order(page, suite)
        for method, href, resolved in links:
            assert href == method_failures_link(suite, method)
            assert resolved == f"{folder}/{href}"
            assert resolved.split("#")[0] == f"{folder}/{suite}/failures.md"
    assert page.evaluate("document.querySelector('#panel-2 a')") is None  # no results: no report
    _open_tab(page, "paper-v2")
    links = dict(zip(_order(page, "paper-v2"), page.evaluate(
        "Array.from(document.querySelectorAll('#panel-0 tbody th a'), "
        "(a) => [a.textContent, a.getAttribute('href'), a.title])"), strict=True))
    assert links[WEIRD] == [WEIRD, "paper-v2/failures.md#my%3Cctrl%3E.py%3AAttr", ""]
    assert page.evaluate("document.getElementsByTagName('ctrl').length") == 0
    assert links["bug-left"][2] == "compute time not measured"  # the notes, on the name
    p_holm = dict(zip(_order(page, "paper-v2"), _cells(page, 0, "p_holm"), strict=True))
    assert p_holm["fusion"] == ["-", "the suite's rank-1 method: the others are tested against it"]
    assert p_holm["bug-left"] == ["<0.001", ""]
    assert not _errors(page.events)


def test_the_committed_leaderboard_page_loads_sorts_and_switches_tabs(tmp_path):
    """results/leaderboard/index.html itself: no console error or request, a tab per suite
    in reading order, the SPL column sorts both ways as leaderboard.csv does, the tabs switch
    by a click."""
    import pandas as pd

    from fftnav.suites import ordered_suites

    root = Path(__file__).resolve().parents[2] / "results" / "leaderboard"
    board_csv = pd.read_csv(root / "leaderboard.csv")
    tools = _session(_browser(), tmp_path / "profile", root / "index.html", width=1600)
    try:
        names = [s.name for s in ordered_suites()]
        assert tools.evaluate("Array.from(document.querySelectorAll('[role=tab]'),"
                              " (b) => b.textContent)") == names
        for panel, suite in enumerate(names):
            rows = board_csv[board_csv["suite"] == suite]
            _click(tools, f"#tab-{panel}")
            assert tools.evaluate("window.fftnavLeaderboard.suite") == suite
            assert _order(tools, suite) == list(rows.sort_values(["rank", "method"])["method"])
            _click(tools, f"#panel-{panel} th[data-key='spl'] button")
            first = _order(tools, suite)
            _click(tools, f"#panel-{panel} th[data-key='spl'] button")
            second = _order(tools, suite)
            by_spl = sorted(rows["spl"])
            spl = rows.set_index("method")["spl"]
            assert [spl[m] for m in first] in (by_spl, by_spl[::-1]), (suite, first, by_spl)
            assert [spl[m] for m in second] == [spl[m] for m in first][::-1], (suite, first, second)
        assert not _errors(tools.events)
    finally:
        tools.close()
