"""The two pieces every report table is made of: an estimate with its interval, and
a markdown table. One writer each, so every table in the reports reads alike."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

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
