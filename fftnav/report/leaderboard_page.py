"""The leaderboard page: one static HTML file ranking methods on benchmark suites, offline.

:func:`leaderboard_html` turns a leaderboard table (one row per suite and method) into the page
text and :func:`write_leaderboard_page` writes it atomically. The page is the template
``leaderboard_page.html`` (package data of :mod:`fftnav.report`) with the title and one JSON
block put in; its inline script builds a tab per suite (in the order of ``suites``) holding the
suite's table. No script, style or data comes from elsewhere: the page makes no network request
(its content security policy forbids any).

The table's columns, in its order, become the page's columns (``suite`` is the tab, ``notes``
a tooltip on the method's name, ``<name>_ci_low`` and ``<name>_ci_high`` the bracket after
``<name>``). The columns of the leaderboard contract are shown so:

============================== =============================================================
column                         shown as
============================== =============================================================
``method``                     its name, a link to its failed robots (``failures_link``)
``rank``, ``maps``, ``robots`` an integer
``spl``, ``ar`` (fractions)    percent with one decimal, the 95 % interval as ``[lo, hi]``
``apl_m`` (m)                  two decimals
``bytes_per_robot``            rounded to an integer
``compute_ms`` (ms)            three significant digits
``failures_<cause>``           an integer count of robots, one column per cause, headed by it
``p_holm``                     three significant digits; ``<0.001`` below 0.001
any other column               numbers: integers or three significant digits; else its text
============================== =============================================================

NaN shows as ``-``, with a tooltip giving the reason when one is known: ``p_holm`` of the
rank-1 method (the reference of the tests), ``apl_m`` where no robot arrived, else the row's
``notes``. Rows start in ``rank`` order (NaN last, then in the table's order). A click on a
column's header sorts the tab's table by it (numbers numerically, text alphabetically, NaN
last in both directions), a second click reverses it; an arrow shows the direction. A tab opens
by a click, by the keys Left, Right, Home and End on the tabs (which are buttons), and by the
URL's hash ``#suite=NAME`` (opening the page with it opens that tab; the open tab is kept in it).
Each tab tells its suite's description, links its report (``report_link``; a suite without rows
says so instead) and ends with a line explaining the columns; each header's tooltip explains
its column (a failure cause's definition from :data:`fftnav.metrics.FAILURE_CAUSES`).

The page exposes ``window.fftnavLeaderboard`` (``ready``, ``data``, ``suite``: the open tab,
``show(name)``, ``order(name)``: the methods of a tab in their shown order) for scripting and
the browser test.
"""

from __future__ import annotations

import html
import json
import math
import re
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np
import pandas as pd

from fftnav.errors import FftnavError
from fftnav.files import write_atomic
from fftnav.metrics import FAILURE_CAUSES

__all__ = ["TEMPLATE", "leaderboard_data", "leaderboard_html", "method_failures_link",
           "suite_report_link", "write_leaderboard_page"]

#: The page's template, with ``/*FFTNAV_TITLE*/`` and ``/*FFTNAV_DATA*/`` to fill in.
TEMPLATE = "leaderboard_page.html"
_PLACEHOLDER = re.compile(r"/\*FFTNAV_(TITLE|DATA)\*/")
#: The columns that are not columns of the page.
_HIDDEN = ("suite", "notes")
_FAILURES = "failures_"


@dataclass(frozen=True)
class _Kind:
    """How a column's values are checked and shown: ``show(value) -> text``, the bounds of its
    numbers (None: text), its header and what it means."""

    label: str
    help: str
    show: Callable[[float], str] | None = None
    low: float = -math.inf
    high: float = math.inf
    cause: bool = False


def _sig3(value: float) -> str:
    """``value`` to three significant digits, without an exponent (``0.0523``, ``1230``)."""
    rounded = float(f"{value:.3g}")
    if rounded == 0:
        return "0"
    decimals = max(2 - math.floor(math.log10(abs(rounded))), 0)
    return f"{rounded:.{decimals}f}"


def _count(value: float) -> str:
    """An integer as such; a count with a fraction (a mean) to three significant digits."""
    return f"{value:.0f}" if float(value).is_integer() else _sig3(value)


def _percent(value: float) -> str:
    return f"{100 * value:.1f}"


def _p_value(value: float) -> str:
    return "<0.001" if value < 0.001 else _sig3(value)


#: What the bracket after a value with an interval is.
_INTERVAL = ", with its 95 % bootstrap interval over maps in brackets"
#: The leaderboard contract's columns.
_KNOWN = {
    "method": _Kind("method", "the method (a policy, a controller or a plugin); its link lists "
                    "its failed robots and the command that replays them"),
    "rank": _Kind("rank", "the method's rank on the suite (1: first)", _count, 1),
    "maps": _Kind("maps", "the suite's maps the method ran on", _count, 0),
    "robots": _Kind("robots", "robots over all maps", _count, 0),
    "spl": _Kind("SPL %", "success weighted by path length over all robots", _percent, 0, 1),
    "ar": _Kind("AR %", "arrival rate: the share of robots that arrived", _percent, 0, 1),
    "apl_m": _Kind("APL m", "average path length of the robots that arrived (m)",
                   lambda v: f"{v:.2f}", 0),
    "bytes_per_robot": _Kind("bytes/robot", "bytes sent per robot in an episode",
                             lambda v: f"{v:.0f}", 0),
    "compute_ms": _Kind("compute ms", "the controller's compute time per robot per tick (ms)",
                        _sig3, 0),
    "p_holm": _Kind("p (Holm)", "paired Wilcoxon p over maps against the suite's rank-1 "
                    "method, Holm-adjusted", _p_value, 0, 1),
}
#: Reasons for a NaN that follow from the row itself: column -> (test of the row, reason).
_NAN_REASONS: dict[str, tuple[Callable[[Mapping[str, Any]], bool], str]] = {
    "p_holm": (lambda row: row.get("rank") == 1,
               "the suite's rank-1 method: the others are tested against it"),
    "apl_m": (lambda row: row.get("ar") == 0, "no robot arrived"),
}


def suite_report_link(suite: str) -> str:
    """The default link of a suite's tab to its report: ``<suite>/report.md`` (URL-quoted).

    >>> suite_report_link("walls-v1")
    'walls-v1/report.md'
    """
    return f"{quote(suite, safe='')}/report.md"


def method_failures_link(suite: str, method: str) -> str:
    """The default link of a method's row to its failed robots: ``<suite>/failures.md#<method>``
    (both URL-quoted).

    >>> method_failures_link("traps-v1", "plugins/my.py:Ctrl")
    'traps-v1/failures.md#plugins%2Fmy.py%3ACtrl'
    """
    return f"{quote(suite, safe='')}/failures.md#{quote(method, safe='')}"


def _kind(table: pd.DataFrame, column: str) -> _Kind:
    """The kind of ``column``: the contract's, a failure cause's count, or one by its values."""
    if column in _KNOWN:
        return _KNOWN[column]
    if column.startswith(_FAILURES) and len(column) > len(_FAILURES):
        cause = column[len(_FAILURES):]
        known = FAILURE_CAUSES.get(cause)
        meaning = f": {known.definition}" if known is not None else ""
        return _Kind(cause, f"robots that failed by {cause}{meaning}", _count, 0, cause=True)
    values = table[column]
    if pd.api.types.is_bool_dtype(values) or not pd.api.types.is_numeric_dtype(values):
        return _Kind(column, column)
    numbers = values.to_numpy(dtype=float, na_value=np.nan)
    whole = bool(np.all(np.isnan(numbers) | (numbers == np.round(numbers))))
    return _Kind(column, column, _count if whole else _sig3)


def _interval_columns(columns: list[str], base: str) -> tuple[str, str] | None:
    """The interval columns of ``base``, if the table has both (``apl_m``'s may be
    ``apl_ci_*``, as in an experiment's summary)."""
    for prefix in (base, base.removesuffix("_m")):
        pair = (f"{prefix}_ci_low", f"{prefix}_ci_high")
        if all(c in columns for c in pair):
            return pair
    return None


def _layout(table: pd.DataFrame) -> list[tuple[str, _Kind, tuple[str, str] | None]]:
    """The page's columns in the table's order: (column, kind, its interval columns)."""
    columns = [str(c) for c in table.columns]
    shown, merged = [], set()
    for column in columns:
        kind = _kind(table, column)
        pair = _interval_columns(columns, column) if kind.show is not None else None
        if pair is not None:
            merged.update(pair)
            kind = replace(kind, help=kind.help + _INTERVAL)
        shown.append((column, kind, pair))
    return [c for c in shown if c[0] not in merged and c[0] not in _HIDDEN]


def _refuse(column: str, requirement: str, value: Any, row: int) -> FftnavError:
    return FftnavError(f"table.{column} must be {requirement}, got table.{column}={value!r} "
                       f"(row {row})")


def _missing(value: Any) -> bool:
    """True for None, NaN and pandas' missing values."""
    return value is None or (pd.api.types.is_scalar(value) and not isinstance(value, str)
                             and bool(pd.isna(value)))


def _bounds(kind: _Kind) -> str:
    if math.isfinite(kind.low) and math.isfinite(kind.high):
        return f" in [{kind.low:g}, {kind.high:g}]"
    return f" >= {kind.low:g}" if math.isfinite(kind.low) else ""


def _numbers(table: pd.DataFrame, column: str, kind: _Kind) -> np.ndarray:
    """The column as floats (NaN: none), each checked against the kind's bounds."""
    values = table[column]
    numbers = pd.to_numeric(values, errors="coerce").to_numpy(dtype=float, na_value=np.nan)
    for row, (value, number) in enumerate(zip(values, numbers, strict=True)):
        if isinstance(value, (bool, np.bool_)) or (math.isnan(number) and not _missing(value)):
            raise _refuse(column, "numbers (NaN: none)", value, row)
        if not math.isnan(number) and not (math.isfinite(number)
                                           and kind.low <= number <= kind.high):
            raise _refuse(column, f"NaN or a finite number{_bounds(kind)}", value, row)
    return numbers


def _names(table: pd.DataFrame, column: str) -> list[str]:
    values = list(table[column])
    for row, value in enumerate(values):
        if not isinstance(value, str) or not value:
            raise _refuse(column, "a non-empty text", value, row)
    return values


def _check_table(table: Any, suites: Mapping[str, str]) -> None:
    """Refuse a table that is not a leaderboard of these suites."""
    if not isinstance(table, pd.DataFrame):
        raise FftnavError(f"table must be a pandas.DataFrame, got table of type "
                          f"{type(table).__name__}")
    columns = list(table.columns)
    if not all(isinstance(c, str) for c in columns) or len(set(columns)) != len(columns):
        raise FftnavError(f"table must have distinct text column names, got table columns "
                          f"{columns!r}")
    for needed in ("suite", "method"):
        if needed not in columns:
            raise FftnavError(f"table must have a {needed!r} column, got table columns "
                              f"{columns!r}")
    for row, suite in enumerate(_names(table, "suite")):
        if suite not in suites:
            raise _refuse("suite", f"one of the suites {list(suites)!r}", suite, row)
    pairs = Counter(zip(table["suite"], _names(table, "method"), strict=True))
    for (suite, method), n in pairs.items():
        if n > 1:
            raise FftnavError(f"table must have one row per (suite, method), got {n} rows "
                              f"with suite={suite!r}, method={method!r}")


def _check_options(suites: Any, title: Any, generated: Any, links: dict[str, Any]) -> None:
    if not isinstance(suites, Mapping) or not suites:
        raise FftnavError(f"suites must be a non-empty mapping of suite name to one-line "
                          f"description, got suites={suites!r}")
    for name, description in suites.items():
        if not isinstance(name, str) or not name or "\n" in name:
            raise FftnavError(f"suites must have non-empty one-line names, got suite "
                              f"name {name!r}")
        if not isinstance(description, str) or "\n" in description:
            raise FftnavError(f"suites[{name!r}] must be a one-line text, got "
                              f"suites[{name!r}]={description!r}")
    for name, value in (("title", title), ("generated", generated)):
        if not isinstance(value, str):
            raise FftnavError(f"{name} must be a text, got {name}={value!r}")
    for name, value in links.items():
        if not callable(value):
            raise FftnavError(f"{name} must be a function returning a link, got "
                              f"{name}={value!r}")


def _link(name: str, builder: Callable[..., Any], *args: str) -> str:
    link = builder(*args)
    if not isinstance(link, str):
        call = ", ".join(repr(a) for a in args)
        raise FftnavError(f"{name} must return a text, got {name}({call})={link!r}")
    return link


def _notes(table: pd.DataFrame) -> list[str]:
    if "notes" not in table.columns:
        return [""] * len(table)
    return ["" if _missing(v) else str(v) for v in table["notes"]]


def _cell(record: Mapping[str, Any], column: str, kind: _Kind,
          pair: tuple[str, str] | None, note: str) -> dict[str, Any]:
    """One cell: its text ``t``, sort value ``v`` (None: NaN), and where known the interval
    text ``ci`` and the tooltip ``title`` of a NaN."""
    value = record[column]
    if kind.show is None:
        if _missing(value):
            return {"t": "-", "v": None}
        return {"t": str(value), "v": str(value)}
    if math.isnan(value):
        test, reason = _NAN_REASONS.get(column, (lambda row: False, ""))
        why = reason if test(record) else note
        return {"t": "-", "v": None, **({"title": why} if why else {})}
    cell: dict[str, Any] = {"t": kind.show(value), "v": float(value)}
    if pair is not None:
        low, high = (record[c] for c in pair)
        if not (math.isnan(low) and math.isnan(high)):
            shown = ["-" if math.isnan(b) else kind.show(b) for b in (low, high)]
            cell["ci"] = f"[{shown[0]}, {shown[1]}]"
    return cell


def _records(table: pd.DataFrame,
             layout: list[tuple[str, _Kind, tuple[str, str] | None]]) -> list[dict[str, Any]]:
    """The table's rows as mappings of checked values: numbers as floats (NaN: none)."""
    columns: dict[str, Any] = {c: list(table[c]) for c in table.columns}
    numeric = {c: k for c, k, _ in layout if k.show is not None}
    for _, kind, pair in layout:
        for extra in pair or ():
            numeric[extra] = kind
    for column, kind in numeric.items():
        columns[column] = list(_numbers(table, column, kind))
    return [dict(zip(columns, values, strict=True)) for values in zip(*columns.values(),
                                                                       strict=True)]


def _legend(layout: list[tuple[str, _Kind, tuple[str, str] | None]]) -> str:
    """The line that explains the columns: the contract's, then the failure causes."""
    parts = [f"{k.label}: {k.help}" for c, k, _ in layout if c in _KNOWN and c != "method"]
    causes = [k.label for _, k, _ in layout if k.cause]
    if causes:
        parts.append(f"{', '.join(causes)}: robots that failed by each cause (a header's "
                     f"tooltip defines it)")
    parts.append("-: no value (its tooltip tells why, where known)")
    return "; ".join(parts) + "."


def _ranked(records: list[dict[str, Any]]) -> list[int]:
    """Row positions in ``rank`` order, NaN last, ties in the table's order."""
    def key(i: int) -> tuple[bool, float, int]:
        rank = records[i].get("rank", math.nan)
        return (math.isnan(rank), 0.0 if math.isnan(rank) else rank, i)

    return sorted(range(len(records)), key=key)


def leaderboard_data(table: pd.DataFrame, *, suites: Mapping[str, str],
                     title: str = "fftnav leaderboard", highlight: str | None = None,
                     report_link: Callable[[str], str] = suite_report_link,
                     failures_link: Callable[[str, str], str] = method_failures_link,
                     generated: str = "") -> dict[str, Any]:
    """The page's JSON data (parameters as in :func:`leaderboard_html`): ``columns`` (``key``,
    ``label``, ``help``, ``numeric``), ``suites`` (``name``, ``description``, ``report`` and
    ``rows``: ``method``, ``link``, ``note``, ``highlight`` and ``cells``, one per column:
    text ``t``, sort value ``v``, interval ``ci``, tooltip ``title``), ``sortedBy``,
    ``legend`` (the line explaining the columns), ``highlight``, ``title`` and
    ``generated``."""
    _check_options(suites, title, generated,
                   {"report_link": report_link, "failures_link": failures_link})
    _check_table(table, suites)
    methods = list(dict.fromkeys(table["method"]))
    if highlight is not None and highlight not in methods:
        raise FftnavError(f"highlight must be None or a method of the table {methods!r}, got "
                          f"highlight={highlight!r}")
    layout = _layout(table)
    records, notes = _records(table, layout), _notes(table)
    rows: dict[str, list[dict[str, Any]]] = {name: [] for name in suites}
    for i in _ranked(records):
        record = records[i]
        suite, method = record["suite"], record["method"]
        rows[suite].append({
            "method": method, "link": _link("failures_link", failures_link, suite, method),
            "note": notes[i], "highlight": method == highlight,
            "cells": [_cell(record, c, k, p, notes[i]) for c, k, p in layout]})
    return {
        "title": title, "generated": generated, "highlight": highlight,
        "sortedBy": "rank" if "rank" in table.columns else None, "legend": _legend(layout),
        "columns": [{"key": c, "label": k.label, "help": k.help, "numeric": k.show is not None}
                    for c, k, _ in layout],
        "suites": [{"name": name, "description": description,
                    "report": _link("report_link", report_link, name), "rows": rows[name]}
                   for name, description in suites.items()],
    }


def leaderboard_html(table: pd.DataFrame, *, suites: Mapping[str, str],
                     title: str = "fftnav leaderboard", highlight: str | None = None,
                     report_link: Callable[[str], str] = suite_report_link,
                     failures_link: Callable[[str, str], str] = method_failures_link,
                     generated: str = "") -> str:
    """The leaderboard page of ``table``: one self-contained HTML text (module docstring).

    Parameters
    ----------
    table : pandas.DataFrame
        One row per (suite, method): the columns ``suite`` and ``method`` and any of the
        leaderboard's (``rank``, ``maps``, ``robots``, ``spl`` and ``ar`` as fractions with
        their ``_ci_low``/``_ci_high``, ``apl_m`` in m, ``bytes_per_robot``, ``compute_ms`` in
        ms per robot per tick, ``failures_<cause>``, ``p_holm``, ``notes``), shown in its
        column order.
    suites : mapping of str to str
        Every suite of the table (more may be given, shown as tabs without results) and its
        one-line description, in tab order.
    title : str
        The page's title.
    highlight : str, optional
        A method of the table whose rows are highlighted in every tab.
    report_link : callable
        ``report_link(suite) -> str``, the link of a suite's report
        (:func:`suite_report_link`).
    failures_link : callable
        ``failures_link(suite, method) -> str``, the link of a method's failed robots on a
        suite (:func:`method_failures_link`).
    generated : str
        A provenance line shown in the footer (what made the table, and when).

    Returns
    -------
    str
        The page: the same inputs give the same text.

    Raises
    ------
    FftnavError
        A table without ``suite`` or ``method``, a suite of the table that ``suites`` lacks,
        two rows of one (suite, method), a value that is not a number in a numeric column (or
        out of its range: fractions and p in [0, 1], counts >= 0), a ``highlight`` that is
        not a method of the table, a link builder that returns no text.

    Examples
    --------
    >>> import pandas as pd
    >>> table = pd.DataFrame({"suite": ["s"], "method": ["fusion"], "spl": [0.5]})
    >>> page = leaderboard_html(table, suites={"s": "a suite"})
    >>> page.startswith("<!DOCTYPE html>") and '"t":"50.0"' in page
    True
    >>> leaderboard_html(table, suites={"t": "another"})
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: table.suite must be one of the suites ['t'], got table.suite='s' \
(row 0)
    """
    data = leaderboard_data(table, suites=suites, title=title, highlight=highlight,
                            report_link=report_link, failures_link=failures_link,
                            generated=generated)
    text = json.dumps(data, ensure_ascii=True, separators=(",", ":"), allow_nan=False)
    # no "<" (no "</script>"), ">" or "&" in the script element: any text of the table is safe
    text = text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    parts = {"TITLE": html.escape(title), "DATA": text}
    page = resources.files("fftnav.report").joinpath(TEMPLATE).read_text(encoding="utf-8")
    # one pass: a text put in is never searched for the other placeholder
    return _PLACEHOLDER.sub(lambda m: parts[m.group(1)], page)


def write_leaderboard_page(path: str | Path, table: pd.DataFrame, *,
                           suites: Mapping[str, str], title: str = "fftnav leaderboard",
                           highlight: str | None = None,
                           report_link: Callable[[str], str] = suite_report_link,
                           failures_link: Callable[[str, str], str] = method_failures_link,
                           generated: str = "") -> Path:
    """Write :func:`leaderboard_html` of the arguments to ``path`` (in an existing folder)
    atomically (:func:`fftnav.files.write_atomic`); returns ``path``. The page is made before
    the file is touched, so a refused table leaves an older page as it was."""
    page = leaderboard_html(table, suites=suites, title=title, highlight=highlight,
                            report_link=report_link, failures_link=failures_link,
                            generated=generated)
    write_atomic(path, page)
    return Path(path)
