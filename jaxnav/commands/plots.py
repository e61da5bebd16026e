"""``jaxnav plots RUN_DIR [--mazes M ...] [--window W]``: figures of a run.

Draws every figure of a run from its files into RUN_DIR/plots/
(:func:`jaxnav.report.plots.make_plots`, which lists them) and prints their paths;
``--help`` lists the options.
"""

from __future__ import annotations

if __name__ == "__main__":  # first thing: Ctrl-C ends the command cleanly
    from jaxnav.core.startup import catch_interrupts_in_command

    catch_interrupts_in_command()

import sys

from jaxnav.core import cli
from jaxnav.core.errors import JaxnavError
from jaxnav.report.plots import make_plots


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav plots",
        description="Training curves, exploration, test-maze trajectories and an episode GIF "
        "of a run, written into RUN_DIR/plots/.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--mazes", nargs="+", metavar="M", help="test mazes (default run.test_mazes)")
    p.add_argument(
        "--window",
        type=int,
        metavar="W",
        help="moving-average window in episodes (default episodes/20)",
    )
    args = p.parse_args(argv)

    def work() -> None:
        if args.window is not None and args.window < 1:
            raise JaxnavError("--window must be at least 1")
        for path in make_plots(args.run_dir, args.mazes, args.window):
            print(path)

    return cli.run(p.prog, work)


if __name__ == "__main__":
    sys.exit(main())
