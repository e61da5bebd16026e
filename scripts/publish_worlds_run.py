"""Puts the greedy test's navigation, generalisation-gap and probability-of-improvement
tables of docs/worlds/grid4/tables.md into docs/worlds.md between its markers.

    python scripts/publish_worlds_run.py
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TABLES = ROOT / "docs" / "worlds" / "grid4" / "tables.md"
PAGE = ROOT / "docs" / "worlds.md"
BEGIN, END = "<!-- worlds_run: begin -->", "<!-- worlds_run: end -->"
SECTIONS = (
    "### Navigation: per goal attempt",
    "### Generalisation gap: train layouts minus test layouts",
    "### Probability of improvement",
)


def greedy_sections(text: str) -> str:
    """The SECTIONS of the greedy test mode, each up to the next heading, as ####."""
    greedy = text.split("## Test mode: greedy", 1)[1].split("\n## Test mode:", 1)[0]
    out = []
    for title in SECTIONS:
        body = greedy.split(title, 1)[1].split("\n#", 1)[0].strip()
        out.append(f"#{title}\n\n{body}\n")
    return "\n".join(out)


def main() -> int:
    page = PAGE.read_text()
    head, rest = page.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    PAGE.write_text(f"{head}{BEGIN}\n{greedy_sections(TABLES.read_text())}{END}{tail}")
    print(f"wrote {PAGE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
