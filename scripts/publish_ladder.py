"""Write the committed ladder study's one-sentence summary, computed from its verdict
table, into README.md and docs/studies.md (between their ``when-ebe-helps`` markers).

    python scripts/publish_ladder.py

Run it after ``jaxnav study when_ebe_helps --out DIR --doc docs/studies/when-ebe-helps.md``
has written the page and its data; tests/test_published.py checks both places.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jaxnav.report import ladder  # noqa: E402

DATA = ROOT / "docs" / "studies" / "when-ebe-helps"
PAGES = (ROOT / "README.md", ROOT / "docs" / "studies.md")
BEGIN, END = "<!-- when-ebe-helps: begin -->", "<!-- when-ebe-helps: end -->"


def main() -> int:
    sentence = ladder.summary_sentence(ladder.Data(DATA))
    for page in PAGES:
        text = page.read_text()
        head, rest = text.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        page.write_text(f"{head}{BEGIN}\n{sentence}\n{END}{tail}")
        print(f"wrote {page.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
