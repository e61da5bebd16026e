"""``jaxnav mazes SPEC --n N [--split test] [--seed S] --out DIR [--overwrite]``

Keeps drawn mazes: N mazes of a family (SPEC: a maze generator such as ``grid``, or a
config that sets ``env.generator``, such as ``grid4`` or a YAML file), each drawn by
the environment's ``reset`` from ``split(PRNGKey(S), N)``, written as maze files
``DIR/maze_000.yaml``, ... with their start, goal and shortest path's length
(:mod:`jaxnav.experiments.mazes`). ``env.maze: DIR/maze_000.yaml`` then plays that
very maze from that start to that goal.
"""

from __future__ import annotations

if __name__ == "__main__":  # first thing: Ctrl-C ends the command cleanly
    from jaxnav.core.startup import catch_interrupts_in_command

    catch_interrupts_in_command()

import sys
from collections.abc import Sequence
from pathlib import Path

from jaxnav.core import cli, families
from jaxnav.experiments.mazes import write_mazes
from jaxnav.world.generators import SPLITS


def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.Parser(
        prog="jaxnav mazes",
        description="Write drawn mazes of a family as maze files, each with its start, goal "
        "and shortest path's length.",
    )
    parser.add_argument(
        "spec",
        metavar="SPEC",
        help=f"a maze generator ({', '.join(families.names())}) or a config that "
        "sets env.generator (e.g. grid4, or a YAML file)",
    )
    parser.add_argument("--n", type=int, required=True, help="mazes to write, at least 1")
    parser.add_argument(
        "--split", choices=SPLITS, default="test", help="the layouts drawn (default: test)"
    )
    parser.add_argument("--seed", type=cli.seed, default=0, help="seed of the draws (default: 0)")
    parser.add_argument("--out", required=True, metavar="DIR", help="the folder to write")
    cli.add_overwrite(parser, "a non-empty --out folder")
    args = parser.parse_args(argv)

    def work() -> None:
        out = write_mazes(args.spec, args.n, args.split, args.seed, Path(args.out), args.overwrite)
        names = sorted(p.name for p in out.iterdir())
        span = names[0] if len(names) == 1 else f"{names[0]} to {names[-1]}"
        print(f"wrote {len(names)} maze file{'s' if len(names) > 1 else ''} to {out}: {span}")

    return cli.run(parser.prog, work)


if __name__ == "__main__":
    sys.exit(main())
