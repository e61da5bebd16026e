"""``jaxnav render MAZE [--out maze.png] [--beams 24] [--seed 0] [--samples N]``

A picture of a maze (built-in name or YAML file): walls, obstacles, the robot at
its start pose, a goal drawn by ``reset``, and what its LiDAR beams see (cast by
the environment's own sensor). MAZE may also be a maze generator (``grid``,
``cylinders``, ``rooms``) or a config (``grid4``, a YAML file): then one maze of its
family, drawn by ``reset`` from ``--seed``. ``--samples N`` draws a sheet of N panels
instead: mazes of the family (or goals in a fixed maze), each with its start, goal and
shortest path (:func:`jaxnav.experiments.mazes.render_sheet`). ``--worlds DIR`` draws
every picture of docs/worlds.md (:data:`jaxnav.experiments.mazes.WORLD_PICTURES`). The
drawing itself is :mod:`jaxnav.report.drawing`.
"""

from __future__ import annotations

if __name__ == "__main__":  # first thing: Ctrl-C ends the command cleanly
    from jaxnav.core.startup import catch_interrupts_in_command

    catch_interrupts_in_command()

import sys
from collections.abc import Sequence
from pathlib import Path

from jaxnav.core import cli
from jaxnav.core.errors import JaxnavError
from jaxnav.experiments.mazes import (
    render_named,
    render_sheet,
    render_world_pictures,
    world_picture_paths,
)


def image_formats() -> list[str]:
    """The file extensions matplotlib writes a figure to by itself (pgf needs LaTeX)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return sorted(set(FigureCanvasBase.get_supported_filetypes()) - {"pgf"})


def check_picture_path(out: str, overwrite: bool) -> Path:
    """The picture's path, refused in one line before any drawing: a folder, a missing
    folder, an existing file (without ``--overwrite``), or an extension that names no
    format matplotlib writes (the extension picks the format; none is added)."""
    path = cli.check_output(out, overwrite)
    formats = image_formats()
    ext = path.suffix[1:].lower()
    if ext not in formats:
        what = f"'.{ext}' is not an image format" if ext else "it has no extension"
        raise JaxnavError(
            f"cannot write {path}: {what}; the extension picks the format, one of "
            f"{', '.join('.' + f for f in formats)}"
        )
    return path


def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.Parser(
        prog="jaxnav render",
        description="Draw a maze (built-in name or YAML file) with the robot, a goal and "
        "its LiDAR beams.",
    )
    parser.add_argument(
        "maze",
        nargs="?",
        help="built-in maze name (e.g. square4_obstacles), a maze .yaml file, a maze "
        "generator (grid, cylinders, rooms) or a config (e.g. grid4): a maze it draws",
    )
    parser.add_argument(
        "--out",
        default="maze.png",
        help="output picture, its format from its extension: .png, .svg, .pdf, ... "
        "(default: maze.png)",
    )
    cli.add_overwrite(parser, "the output picture")
    parser.add_argument("--beams", type=int, default=24, help="LiDAR beams to draw (default: 24)")
    parser.add_argument(
        "--seed", type=cli.seed, default=0, help="seed of the goal draw (default: 0)"
    )
    parser.add_argument(
        "--samples",
        type=int,
        metavar="N",
        help="instead, a sheet of N panels: mazes the family draws (or goals in a fixed "
        "maze), each with its start, goal and shortest path",
    )
    parser.add_argument(
        "--worlds",
        metavar="DIR",
        help="instead, draw every picture of docs/worlds.md into DIR (docs/worlds): the "
        "built-in stages, a maze of each family and a sheet of grid mazes",
    )
    args = parser.parse_args(argv)

    def work() -> None:
        if args.worlds is not None:
            if args.maze is not None or args.samples is not None:
                raise JaxnavError("--worlds draws its own pictures: give no MAZE or --samples")
            folder = Path(args.worlds)
            if not folder.is_dir():  # made: its parent must be there
                cli.check_output(folder, False, is_dir=True)
            else:
                for path in world_picture_paths(folder):
                    cli.check_output(path, args.overwrite)
            for path in render_world_pictures(folder):
                print(f"wrote {path}")
            return
        if args.maze is None:
            raise JaxnavError("give a MAZE to draw (or --worlds DIR)")
        if args.beams < 0:
            raise JaxnavError("--beams must be 0 or more")
        if args.samples is not None and args.samples < 1:
            raise JaxnavError(f"--samples must be at least 1 (got {args.samples})")
        out = check_picture_path(args.out, args.overwrite)
        if args.samples is not None:
            render_sheet(args.maze, str(out), args.samples, args.seed)
            print(f"wrote {out}")
            return
        render_named(args.maze, str(out), args.beams, args.seed)
        print(f"wrote {out}")

    return cli.run(parser.prog, work)


if __name__ == "__main__":
    sys.exit(main())
