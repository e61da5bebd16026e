"""The pieces every report table is made of: an estimate with its interval, a
markdown table, and the aligned plain-text table the commands print. One writer
each, so every table in the reports reads alike."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from jaxnav.core.values import flatten
from jaxnav.report.stats import Interval


def interval(iv: Interval, digits: int = 1, sign: str = "", missing: str = " [n/a]") -> str:
    """``1.23 [0.98, 1.40]``: the estimate and its interval at ``digits`` decimals;
    ``sign="+"`` signs them; where the interval is undefined (NaN), ``missing``
    follows the estimate instead."""
    text = f"{iv.value:{sign}.{digits}f}"
    if math.isnan(iv.low):
        return text + missing
    return f"{text} [{iv.low:{sign}.{digits}f}, {iv.high:{sign}.{digits}f}]"


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    """A markdown table's lines: the header, the rule, one line per row."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return lines + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]


def aligned_table(table: Sequence[Sequence[str]]) -> str:
    """A plain-text table for a terminal: the first column left-aligned, the others
    right-aligned, each line indented by two spaces."""
    widths = [max(len(row[i]) for row in table) for i in range(len(table[0]))]
    return "\n".join(
        "  "
        + "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths))
        )
        for row in table
    )


def page_head(doc: dict, run: dict, total_s: float, more: str = "") -> list[str]:
    """A study page's opening: the study's title (``doc``, its study.yaml), the command
    that produced it with its minutes and machine (``run``, its run.json; ``more`` ends
    that paragraph), and the heading of its one sentence."""
    return [
        f"# {doc['title']}",
        "",
        f"Produced by `{run['command']}` in {total_s / 60:.0f} minutes on {run['machine']}. "
        "Every table and sentence below is computed from the data in the folder beside this "
        "page; `tests/test_published.py` checks that the data gives this page byte for "
        "byte." + more,
        "",
        "## In one sentence",
        "",
    ]


def settings_text(doc: dict) -> str:
    """A study entry's ``settings:`` as `` `key=value` `` items (``none`` without)."""
    s = doc.get("settings") or {}
    flat = flatten(s)
    return ", ".join(f"`{k}={_value(v)}`" for k, v in flat.items()) or "none"


def _value(v) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, list):
        return "[" + ",".join(_value(x) for x in v) + "]"
    return str(v)
