"""``jaxnav imitate CONFIG [key=value ...] --out RUN_DIR [--dagger K] ...``

Policies fit to the oracle's actions in a config's world (behaviour cloning, then
``--dagger`` rounds in which the policies drive and the oracle labels where they go),
written as a finished run directory (:mod:`jaxnav.experiments.imitation`) that
``jaxnav evaluate`` tests and ``run.init_from`` starts training from. The directory is
written whole or not at all.
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

import sys
from pathlib import Path

from jaxnav.core import cli
from jaxnav.core.config import load_config
from jaxnav.core.errors import JaxnavError
from jaxnav.core.shipped import resolve_config_path
from jaxnav.experiments.imitation import imitate


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav imitate",
        description="Fit each run's Q-network of a config to the oracle's actions in its "
        "world, and write them as a finished run directory.",
    )
    p.add_argument(
        "items",
        nargs="+",
        metavar="CONFIG [key=value ...]",
        help="a Q-learner's config (path, or a name in configs/) then dotted overrides",
    )
    p.add_argument(
        "--out", required=True, help="the run directory to write (new, or a run with --overwrite)"
    )
    cli.add_overwrite(p, "the run directory in --out")
    p.add_argument("--envs", type=int, default=64, help="environments the oracle drives")
    p.add_argument("--steps", type=int, default=1500, help="steps of each environment")
    p.add_argument("--epochs", type=int, default=20, help="passes over the demonstrations")
    p.add_argument(
        "--dagger",
        type=int,
        default=0,
        help="rounds in which the policies drive and the oracle labels where they go",
    )
    p.add_argument(
        "--seed", type=cli.seed, default=0, help="of the demonstrations' resets and the fit"
    )
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    args = p.parse_intermixed_args(argv)  # overrides may follow the flags too

    def work() -> None:
        if args.envs < 1 or args.steps < 1 or args.epochs < 1 or args.dagger < 0:
            raise JaxnavError("--envs, --steps and --epochs must be at least 1, --dagger 0 or more")
        cfg = load_config(resolve_config_path(args.items[0]), args.items[1:])
        out = Path(args.out)
        summary, agree = imitate(
            cfg,
            out,
            envs=args.envs,
            steps=args.steps,
            epochs=args.epochs,
            dagger=args.dagger,
            seed=args.seed,
            quiet=args.quiet,
            overwrite=args.overwrite,
        )
        print(
            f"{summary['demonstration_steps']:,} oracle steps ({summary['oracle_goals']} goals, "
            f"{summary['oracle_collisions']} collisions); agreement with the oracle "
            f"{agree.mean():.2f} (runs {agree.min():.2f}-{agree.max():.2f}); "
            f"{out}/ in {summary['wall_s']:.0f} s"
        )

    return cli.run(p.prog, work, interrupted="interrupted; nothing written")


if __name__ == "__main__":
    sys.exit(main())
