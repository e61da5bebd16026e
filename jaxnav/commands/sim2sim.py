"""``jaxnav sim2sim RUN_DIR [--mazes M ...] [--episodes N] [--seeds K ...]``

A run's exported policies driving a TurtleBot3 burger in MuJoCo physics, beside
jaxnav's own test of the same policies: a per-seed CSV and a markdown table of the
gap, in RUN_DIR/sim2sim/ or at ``--out FILE`` (an existing FILE or its table is
refused unless ``--overwrite``). The work is :func:`jaxnav.experiments.sim2sim.sim2sim`;
``--help`` lists the options. Needs MuJoCo (optional extra ``sim``); without it, the
command says how to install it.
"""

import sys

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

from jaxnav.core import cli  # noqa: E402
from jaxnav.experiments.sim2sim import LIDAR_NOISE_STD, sim2sim  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav sim2sim",
        description="Test every trained policy of a run, exported as for the robot, on a "
        "TurtleBot3 burger in MuJoCo physics (wheel servos, contacts, ray-cast LiDAR), "
        "beside jaxnav's own test of the same policies; write a per-seed CSV and a "
        "markdown table of the gap.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a finished training run (with params.npz)")
    p.add_argument(
        "--mazes",
        nargs="+",
        metavar="M",
        help="test mazes (default the config's run.test_mazes): built-in names or maze YAML paths",
    )
    p.add_argument(
        "--episodes",
        type=int,
        metavar="N",
        help="consecutive MuJoCo test episodes per policy and maze (default run.test_episodes)",
    )
    p.add_argument(
        "--seeds", type=int, nargs="+", metavar="K", help="test only these seeds (default all)"
    )
    p.add_argument(
        "--out",
        metavar="FILE",
        help="the CSV (default RUN_DIR/sim2sim/sim2sim.csv); the table goes beside it as .md",
    )
    p.add_argument(
        "--lidar-noise",
        type=float,
        default=LIDAR_NOISE_STD,
        metavar="SIGMA",
        help=f"Gaussian range noise of the MuJoCo LiDAR in m (default {LIDAR_NOISE_STD})",
    )
    p.add_argument(
        "--wheel-limit",
        action="store_true",
        help="clip the MuJoCo burger's commands as its firmware does (each wheel at most "
        "0.21 m/s); jaxnav's test keeps the run's own settings",
    )
    cli.add_overwrite(p, "the --out FILE and its table")
    args = p.parse_args(argv)

    def work() -> None:
        say = lambda line: print(line, file=sys.stderr, flush=True)
        csv_path, md = sim2sim(
            args.run_dir,
            args.mazes,
            args.episodes,
            args.seeds,
            args.out,
            args.lidar_noise,
            say,
            overwrite=args.overwrite,
            wheel_limit=args.wheel_limit,
        )
        print(f"wrote {csv_path} and {md}")

    return cli.run(p.prog, work)


if __name__ == "__main__":
    sys.exit(main())
