"""Markdown tables for the reports (no extra dependency), and the reasons of their missing numbers.

A missing number is never a bare ``-``: the code that knows why it is missing writes
``dashes.dash(reason)`` (:class:`Dashes`), a ``-`` with a superscript number, and puts
``dashes.legend()`` under the table, one line giving each number's reason.
"""

from __future__ import annotations

import pandas as pd

__all__ = ["Dashes", "markdown_table"]

_SUPERSCRIPTS = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


def markdown_table(table: pd.DataFrame) -> list[str]:
    """A DataFrame as Markdown table lines: a header, a rule, one line per row.

    >>> markdown_table(pd.DataFrame({"a": [1], "b": ["x"]}))
    ['| a | b |', '|---|---|', '| 1 | x |']
    """
    cells = [[str(c) for c in table.columns]] + [[str(v) for v in r] for r in table.to_numpy()]
    return ["| " + " | ".join(r) + " |" for r in cells[:1]] + [
        "|" + "---|" * len(table.columns)] + ["| " + " | ".join(r) + " |" for r in cells[1:]]


class Dashes:
    """The reasons of the missing numbers of one table: each distinct reason gets a number, in
    the order first asked for, shown as a superscript after the table's ``-``.

    >>> dashes = Dashes()
    >>> dashes.dash("no robot arrived"), dashes.dash("one map"), dashes.dash("no robot arrived")
    ('-¹', '-²', '-¹')
    >>> dashes.legend()
    ['`-¹` no robot arrived; `-²` one map.']
    >>> Dashes().legend()
    []
    """

    def __init__(self) -> None:
        self._marks: dict[str, str] = {}

    def dash(self, reason: str) -> str:
        """The cell of a number missing for ``reason``: ``-`` and the reason's number."""
        if reason not in self._marks:
            self._marks[reason] = "-" + str(len(self._marks) + 1).translate(_SUPERSCRIPTS)
        return self._marks[reason]

    def legend(self) -> list[str]:
        """The line that gives each number's reason, or no line when nothing is missing."""
        if not self._marks:
            return []
        return ["; ".join(f"`{mark}` {reason}" for reason, mark in self._marks.items()) + "."]
