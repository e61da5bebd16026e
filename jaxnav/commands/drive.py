"""``jaxnav drive WORLD [--policy NAME|FILE] [--episodes N] [--out DIR] [key=value ...]``

Plays a pretrained policy (a shipped one by name, ``jaxnav list`` names them, or any
``jaxnav export`` file) in a world, without training: greedy episodes beside the
oracle through the same test, its success printed beside the oracle's, the
trajectories and a GIF of an episode drawn (:mod:`jaxnav.experiments.drive`).
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

import csv
import io
import sys
from pathlib import Path

from jaxnav.core import cli
from jaxnav.core.errors import JaxnavError
from jaxnav.experiments.drive import drive
from jaxnav.report.nav_tables import navigation_text
from jaxnav.robot.shipped import policy_path, shipped_policies

DEFAULT_POLICY = "drive_anywhere"


def main(argv: list[str] | None = None) -> int:
    shipped = ", ".join(shipped_policies()) or "none yet"
    p = cli.Parser(
        prog="jaxnav drive",
        description="Play a pretrained policy in a world without training: greedy episodes "
        "beside the oracle, its success printed beside the oracle's, the trajectories and "
        f"a GIF of an episode drawn. Shipped policies: {shipped}.",
    )
    p.add_argument("world", metavar="WORLD", help="a built-in maze, a maze file or a map")
    p.add_argument("overrides", nargs="*", metavar="env.KEY=VALUE", help="world settings")
    p.add_argument(
        "--policy",
        default=DEFAULT_POLICY,
        metavar="NAME|FILE",
        help=f"a shipped policy's name or a policy file (default {DEFAULT_POLICY})",
    )
    p.add_argument("--episodes", type=int, default=10, help="greedy episodes (default 10)")
    p.add_argument("--out", metavar="DIR", help="output folder (default drive-WORLD)")
    cli.add_overwrite(p, "DIR")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    args = p.parse_intermixed_args(argv)

    def work() -> None:
        if args.episodes < 1:
            raise JaxnavError("--episodes must be at least 1")
        path = policy_path(args.policy)
        out = Path(args.out or f"drive-{Path(args.world).stem}")
        cli.check_output(out, args.overwrite, is_dir=True)
        say = None if args.quiet else (lambda line: print(line, file=sys.stderr))
        tested, drawn = drive(path, args.world, out, args.episodes, args.overrides, say=say)
        rows = list(csv.DictReader(io.StringIO((tested / "results.csv").read_text())))
        print(f"{path.stem} in {args.world}, {args.episodes} greedy episodes, beside the oracle:")
        print(navigation_text(rows))
        for figure in drawn:
            print(f"wrote {figure}")
        print(f"results in {tested}")

    return cli.run(p.prog, work)


if __name__ == "__main__":
    sys.exit(main())
