"""Markdown tables for the reports (no extra dependency)."""

from __future__ import annotations

import pandas as pd

__all__ = ["markdown_table"]


def markdown_table(table: pd.DataFrame) -> list[str]:
    """A DataFrame as Markdown table lines: a header, a rule, one line per row.

    >>> markdown_table(pd.DataFrame({"a": [1], "b": ["x"]}))
    ['| a | b |', '|---|---|', '| 1 | x |']
    """
    cells = [[str(c) for c in table.columns]] + [[str(v) for v in r] for r in table.to_numpy()]
    return ["| " + " | ".join(r) + " |" for r in cells[:1]] + [
        "|" + "---|" * len(table.columns)] + ["| " + " | ".join(r) + " |" for r in cells[1:]]
