"""``jaxnav reproduce [--seeds N] [--out DIR] [--quick] [--resume]``
``jaxnav reproduce --out DIR --publish docs/report``

The paper's two experiments end to end, and ``DIR/report.md``: the work is
:func:`jaxnav.experiments.reproduce.reproduce` (its module says what it does and how
long it takes); ``--help`` lists the options.
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

import sys
import time
from pathlib import Path

from jaxnav.core import cli
from jaxnav.core.errors import JaxnavError
from jaxnav.experiments.reproduce import (
    DEFAULT_SEEDS,
    EXPERIMENTS,
    QUICK,
    experiment_config,
    publish_report,
    reproduce,
)


def _parser() -> cli.Parser:
    p = cli.Parser(
        prog="jaxnav reproduce",
        description="Train, test and plot both of the paper's experiments (no obstacles and "
        "obstacles, EBE and epsilon-greedy) and write DIR/report.md.",
    )
    cli.add_sizes(p, DEFAULT_SEEDS, QUICK)
    p.add_argument("--out", metavar="DIR", help="output directory (default runs/reproduce-<time>)")
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted reproduction in --out: reuse finished trainings, "
        "resume the rest",
    )
    p.add_argument(
        "--sim2sim",
        type=int,
        default=0,
        metavar="K",
        help="also test the first K seeds of each experiment in MuJoCo physics "
        "(jaxnav sim2sim; needs the extra 'sim'; about 6 s per policy and maze "
        "at 10 test episodes of 500 steps) and add the sim-to-sim gap to the report",
    )
    p.add_argument(
        "--baselines",
        action="store_true",
        help="also drive the oracle and DWA through every greedy test, beside the policies "
        "(their rows judge none of the paper's claims, which compare the strategies)",
    )
    p.add_argument(
        "--yes",
        action="store_true",
        help="start a run that needs over half of this machine's memory without asking",
    )
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument(
        "--publish",
        metavar="PATH",
        help="copy the finished reproduction in --out to PATH (docs/report), replacing it: "
        "its report, claims, figures and the data behind them; trains nothing",
    )
    return p


def main(argv: list[str] | None = None) -> int:
    p = _parser()
    args = p.parse_args(argv)
    out = (
        Path(args.out) if args.out else Path("runs") / f"reproduce-{time.strftime('%Y%m%d-%H%M%S')}"
    )
    command = "jaxnav reproduce " + " ".join(argv if argv is not None else sys.argv[1:])

    def work() -> None:
        if args.publish:
            if not args.out:
                raise JaxnavError("--publish needs --out DIR (the finished reproduction)")
            files = publish_report(out, Path(args.publish))
            print(f"copied {len(files)} files from {out} to {args.publish}")
            return
        if args.resume and not args.out:
            raise JaxnavError("--resume needs --out DIR")
        seeds, chosen = cli.chosen_sizes(args, DEFAULT_SEEDS, QUICK)
        sizes = (seeds, chosen["episodes"], chosen["max_steps"], chosen["test_episodes"])
        # the experiments train one after the other: the larger one's memory is the need
        need = max(experiment_config(name, *sizes).memory_estimate() for name, _ in EXPERIMENTS)
        cli.confirm_memory(need, args.yes)
        report = reproduce(
            out,
            *sizes,
            args.quick,
            args.resume,
            args.quiet,
            command.strip(),
            args.sim2sim,
            args.baselines,
        )
        print(f"report: {report}")

    given = list(argv if argv is not None else sys.argv[1:])
    return cli.run(p.prog, work, interrupted=cli.resume_advice("reproduce", given, out))


if __name__ == "__main__":
    sys.exit(main())
