"""Copy a reproduction (``python -m jaxnav.reproduce --out DIR``) into docs/report.

Copies report.md, claims.md, every file report.md links to, and the data behind the
claims and tables (each experiment's config.yaml, summary.json, metrics.csv and
eval/results.csv, eval/robustness.csv), replacing docs/report. Run from the
repository root: ``python scripts/publish_report.py DIR``.
"""

import re
import shutil
import sys
from pathlib import Path

DATA = ("config.yaml", "summary.json", "metrics.csv", "eval/results.csv", "eval/robustness.csv")


def main(src: str, dst: str = "docs/report") -> int:
    src_dir, dst_dir = Path(src), Path(dst)
    report = (src_dir / "report.md").read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", report)
    experiments = sorted({Path(link).parts[0] for link in links if "/" in link})
    files = ["report.md", "claims.md", *links]
    files += [f"{e}/{name}" for e in experiments for name in DATA]
    if dst_dir.exists():
        shutil.rmtree(dst_dir)
    for name in files:
        (dst_dir / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(src_dir / name, dst_dir / name)
    print(f"copied {len(files)} files from {src_dir} to {dst_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
