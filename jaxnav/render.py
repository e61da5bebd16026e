"""``python -m jaxnav.render MAZE [--out maze.png] [--beams 24] [--seed 0]``

A picture of a maze (built-in name or YAML file): walls, obstacles, the robot at
its start pose, a goal drawn by ``reset``, and what its LiDAR beams see (cast by
the environment's own sensor). The drawing itself is :mod:`jaxnav.report.drawing`.
"""

from __future__ import annotations

if __name__ == "__main__":  # first thing: Ctrl-C ends the command cleanly
    from jaxnav.core.startup import catch_interrupts_in_command

    catch_interrupts_in_command()

import sys
from collections.abc import Sequence

from jaxnav.core import cli
from jaxnav.core.errors import JaxnavError
from jaxnav.experiments.scene import render_maze


def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.Parser(
        prog="python -m jaxnav.render",
        description="Draw a maze (built-in name or YAML file) with the robot, a goal and "
        "its LiDAR beams.",
    )
    parser.add_argument(
        "maze", help="built-in maze name (e.g. square4_obstacles) or a maze .yaml file"
    )
    parser.add_argument("--out", default="maze.png", help="output PNG (default: maze.png)")
    parser.add_argument("--beams", type=int, default=24, help="LiDAR beams to draw (default: 24)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the goal draw (default: 0)")
    args = parser.parse_args(argv)

    def work() -> None:
        if args.beams < 0:
            raise JaxnavError("--beams must be 0 or more")
        render_maze(args.maze, args.out, args.beams, args.seed)
        print(f"wrote {args.out}")

    return cli.run(parser.prog, work)


if __name__ == "__main__":
    sys.exit(main())
