"""Merge ablations (``python -m jaxnav.ablation --out DIR``) into docs/ablation.

Reads each DIR/ablation.csv (the per-seed scores) and the wall-clock section of
each DIR/ablation.md, and writes docs/ablation/ablation.csv and
docs/ablation/ablation.md: the tables recomputed from the merged scores
(``jaxnav.experiments.ablation.ablation_markdown``), then how each part was made. A variant may
come from one DIR only. Run from the repository root:
``python scripts/publish_ablation.py DIR [DIR ...]``.
"""

import csv
import sys
from pathlib import Path

from jaxnav.experiments.ablation import ablation_markdown, rows_to_csv


def main(*srcs: str, dst: str = "docs/ablation") -> int:
    rows, made, owner = [], [], {}
    for src in map(Path, srcs):
        part = list(csv.DictReader((src / "ablation.csv").open()))
        for v in sorted({r["variant"] for r in part}):
            if v in owner:
                print(f"variant {v} is in both {owner[v]} and {src}")
                return 2
            owner[v] = src
        rows += part
        md = (src / "ablation.md").read_text()
        made.append(md[md.index("## Wall-clock") :].replace("## Wall-clock", "### Wall-clock", 1))
    out = Path(dst)
    out.mkdir(parents=True, exist_ok=True)
    (out / "ablation.csv").write_text(rows_to_csv(rows))
    text = ablation_markdown(rows) + "\n## How it was made\n\n" + "\n".join(made)
    (out / "ablation.md").write_text(text)
    print(f"wrote {out}/ablation.md and ablation.csv from {len(srcs)} ablation(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
