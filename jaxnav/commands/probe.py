"""``jaxnav probe WHAT ...``: diagnostics of runs, tests and worlds, each one line a
finding.

- ``jaxnav probe collisions RUN_DIR [--maze M] [--episodes N]``: what a run's policies
  collide with in their greedy test, and how (:mod:`jaxnav.experiments.collisions`);
- ``jaxnav probe cut-attempts PATH ... [--over S]``: how long the attempts an
  episode's end cut off had lasted, per driver and maze of results files
  (:mod:`jaxnav.report.cut_attempts`);
- ``jaxnav probe reach STAGE ... [--speed S]``: a bound on where any robot at up to
  that speed can get in a stage whose cylinders spin about the origin
  (:mod:`jaxnav.world.reach`);
- ``jaxnav probe search CONFIG [key=value ...]``: which first goals of a world with
  moving cylinders a search proves reachable, each replayed through the environment
  (:mod:`jaxnav.experiments.reachability`).

Each subcommand imports only what it needs: ``cut-attempts`` runs no JAX.
"""

from __future__ import annotations

import sys

from jaxnav.core import cli
from jaxnav.core.errors import JaxnavError
from jaxnav.world.reach import BURGER_SPEED


def collisions(args) -> None:
    from jaxnav.experiments.collisions import run_causes, summary_line

    if args.episodes < 1:
        raise JaxnavError(f"--episodes must be at least 1, got {args.episodes}")
    for name, (causes, base) in run_causes(args.run_dir, args.maze, args.episodes).items():
        print(summary_line(name, causes, base))


def cut_attempts(args) -> None:
    from jaxnav.report.cut_attempts import cut_attempts_table

    print(cut_attempts_table(args.paths, args.over))


def reach(args) -> None:
    from jaxnav.world.maps import make_maze
    from jaxnav.world.reach import farthest_reach, spinning, verdict_line

    if not args.speed >= 0:
        raise JaxnavError(f"--speed must be 0 or more, got {args.speed}")
    for what in ("cell", "dt", "horizon"):
        if not getattr(args, what) > 0:
            raise JaxnavError(f"--{what} must be positive, got {getattr(args, what)}")
    stages = {name: spinning(make_maze(name), name) for name in args.stages}  # all checked
    for name, stage in stages.items():
        bound = farthest_reach(stage, args.speed, args.cell, args.dt, args.horizon)
        print(verdict_line(name, args.speed, bound))


def search(args) -> None:
    from jaxnav.experiments.reachability import found_line
    from jaxnav.experiments.reachability import search as search_world

    if not args.cell > 0 or args.headings < 1 or args.horizon < 0 or args.replay < 0:
        raise JaxnavError(
            "--cell must be positive, --headings at least 1, --horizon and --replay 0 or more"
        )
    found = search_world(
        args.config, args.overrides, args.cell, args.headings, args.horizon, args.replay
    )
    print(found_line(found, args.cell, args.headings, args.replay))


def parser() -> cli.Parser:
    p = cli.Parser(
        prog="jaxnav probe",
        description="Diagnostics of runs, tests and worlds: what collisions hit, the waits "
        "cut attempts hide, and whether a world with moving cylinders can be driven.",
    )
    sub = p.add_subparsers(dest="what", metavar="WHAT", required=True)

    c = sub.add_parser(
        "collisions",
        help="what a run's policies collide with in their greedy test, and how",
        description="For every collision of a run's greedy test: the surface nearest the "
        "robot, and for a moving cylinder who closed the gap, where it stood and when.",
    )
    c.add_argument("run_dir", metavar="RUN_DIR", help="a finished training run")
    c.add_argument("--maze", help="one test maze (default: the run's test mazes)")
    c.add_argument("--episodes", type=int, default=10, help="greedy test episodes per seed")
    c.set_defaults(func=collisions, parser=c)

    a = sub.add_parser(
        "cut-attempts",
        help="how long the attempts an episode's end cut off had lasted",
        description="How many greedy test episodes ended on a cut attempt, per driver and "
        "maze, and how many of those had lasted longer than --over seconds.",
    )
    a.add_argument("paths", nargs="+", metavar="PATH", help="results.csv files or folders of them")
    a.add_argument("--over", type=float, default=60.0, help="seconds (default 60)")
    a.set_defaults(func=cut_attempts, parser=a)

    r = sub.add_parser(
        "reach",
        help="could any robot this fast get past a spinning stage's ring? a bound",
        description="A bound on where any robot at up to --speed m/s in any direction can "
        "get in a stage whose cylinders spin about the origin, beside the ring they sweep.",
    )
    r.add_argument("stages", nargs="+", metavar="STAGE", help="stages whose cylinders spin")
    r.add_argument("--speed", type=float, default=BURGER_SPEED, help="m/s, in any direction")
    r.add_argument("--cell", type=float, default=0.005, help="raster cell, m")
    r.add_argument("--dt", type=float, default=0.2, help="time step, s")
    r.add_argument("--horizon", type=float, default=120.0, help="s")
    r.set_defaults(func=reach, parser=r)

    s = sub.add_parser(
        "search",
        help="which first goals of a moving world a search proves reachable",
        description="Search a world with moving cylinders from its start at time 0 for "
        "every first goal, and replay each sequence found through the environment.",
    )
    s.add_argument("config", metavar="CONFIG", help="a shipped config or config file")
    s.add_argument("overrides", nargs="*", metavar="key=value", help="settings (env.actions=vw)")
    s.add_argument("--cell", type=float, default=0.04, help="raster cell, m")
    s.add_argument("--headings", type=int, default=24, help="yaw bins of the raster")
    s.add_argument("--horizon", type=int, default=0, help="steps (0: env.max_steps)")
    s.add_argument("--replay", type=int, default=0, help="replay at most this many (0: all)")
    s.set_defaults(func=search, parser=s)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    return cli.run(args.parser.prog, lambda: args.func(args))


if __name__ == "__main__":
    sys.exit(main())
