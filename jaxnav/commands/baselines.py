"""``jaxnav baselines [WORLD ...] [--seeds N] [--episodes N] [--out DIR] [--doc PAGE]``

Both reference drivers, the oracle and DWA (:mod:`jaxnav.experiments.baselines`),
through the test of each world (default: every shipped world): the data file
``DIR/baselines.csv`` (results.csv's columns after a ``world`` column) and the page
written from it (:mod:`jaxnav.report.baselines_page`). ``--publish-only`` writes the
page again from the data file without driving.
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

import json
import sys
from pathlib import Path

from jaxnav.core import cli, rundir
from jaxnav.core.errors import JaxnavError

DATA, NOTES = "baselines.csv", "notes.json"


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav baselines",
        description="Drive the oracle and DWA through the test of each world and write "
        "their page: success, collision, time-out, cut attempts, SPL and goals per minute.",
    )
    p.add_argument(
        "worlds",
        nargs="*",
        metavar="WORLD",
        help="configs or mazes, as for jaxnav evaluate --baseline (default: every shipped world)",
    )
    p.add_argument("--seeds", type=int, default=8, metavar="N", help="test keys per world")
    p.add_argument("--episodes", type=int, default=10, metavar="N", help="episodes per seed")
    p.add_argument("--out", metavar="DIR", default="docs/baselines", help="the data folder")
    p.add_argument("--doc", metavar="PAGE", default="docs/baselines.md", help="the page")
    p.add_argument(
        "--publish-only", action="store_true", help="write the page from DIR's data file only"
    )
    cli.add_overwrite(p, "the data file in --out")
    args = p.parse_args(argv)

    def work() -> None:
        from jaxnav.experiments.baselines import SHIPPED_WORLDS, drive_worlds
        from jaxnav.experiments.runner import machine_line
        from jaxnav.report.baselines_page import baselines_markdown

        out = Path(args.out)
        if args.publish_only:
            try:
                text = (out / DATA).read_text()
                meta = json.loads((out / NOTES).read_text())
            except (OSError, ValueError) as e:
                raise JaxnavError(f"{out}: no data to publish ({e})") from e
        else:
            if args.seeds < 1 or args.episodes < 1:
                raise JaxnavError("--seeds and --episodes must be at least 1")
            out.mkdir(parents=True, exist_ok=True)
            cli.check_output(out / DATA, args.overwrite)
            worlds = args.worlds or list(SHIPPED_WORLDS)
            text, notes = drive_worlds(worlds, args.seeds, args.episodes, log=_log)
            command = " ".join(
                ["jaxnav baselines", *args.worlds, f"--seeds {args.seeds}"]
                + [f"--episodes {args.episodes}", f"--out {args.out}", f"--doc {args.doc}"]
            )
            meta = {"command": command, "machine": machine_line(), "notes": notes}
            rundir.atomic_write_text(out / DATA, text)
            rundir.atomic_write_text(out / NOTES, json.dumps(meta, indent=1) + "\n")
        page = baselines_markdown(text, meta["command"], meta["machine"], meta["notes"])
        rundir.atomic_write_text(Path(args.doc), page)
        print(f"wrote {args.doc} from {out / DATA}")

    return cli.run(p.prog, work)


def _log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


if __name__ == "__main__":
    sys.exit(main())
