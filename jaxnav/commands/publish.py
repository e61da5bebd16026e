"""``jaxnav publish [NAME ...] [--check] [--root DIR]``

Rewrites the parts of the docs that are computed from committed data (whole pages and
blocks between ``<!-- NAME: begin/end -->`` markers; :data:`jaxnav.report.publish.PUBLISHED`
lists them) after a study or a campaign has committed new data. ``--check`` writes
nothing and exits 1 naming every page that differs from its data.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from jaxnav.core import cli
from jaxnav.core.errors import JaxnavError
from jaxnav.report.publish import PUBLISHED, publish, stale


def main(argv: Sequence[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav publish",
        description="Rewrite the docs' parts computed from committed data (every one, or "
        "those named: " + ", ".join(x.name for x in PUBLISHED) + ").",
    )
    p.add_argument("names", nargs="*", metavar="NAME", help="the parts to write (default: all)")
    p.add_argument("--root", default=".", help="the repository's root (default: here)")
    p.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 if a page differs from its data"
    )
    args = p.parse_args(argv)

    def work() -> int:
        root = Path(args.root)
        if not (root / "docs").is_dir():
            raise JaxnavError(f"publish: {root} has no docs/ folder (run from the repository)")
        if args.check:
            out = stale(root, tuple(args.names))
            for line in out:
                print(f"differs from its data: {line}")
            return 1 if out else 0
        for page in publish(root, tuple(args.names)):
            print(f"wrote {page}")
        return 0

    return cli.run(p.prog, work)


if __name__ == "__main__":
    sys.exit(main())
