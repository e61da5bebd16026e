"""``jaxnav ablation [--seeds N] [--out DIR] [--quick] [--resume] [--variants A,B]``
``jaxnav ablation --merge DIR [DIR ...] --out DIR``

Both experiments under each ROBOTIS-faithful switch, and ``DIR/ablation.md``: the
work is :func:`jaxnav.experiments.ablation.ablation` (its module says what it
writes); ``--help`` lists the options.
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
from jaxnav.experiments.ablation import DEFAULT_SEEDS, VARIANTS, ablation, merge
from jaxnav.experiments.reproduce import EXPERIMENTS, QUICK


def _parser() -> cli.Parser:
    p = cli.Parser(
        prog="jaxnav ablation",
        description="Train and test both experiments under each ROBOTIS-faithful switch, "
        "alone and together, and write DIR/ablation.md.",
    )
    cli.add_sizes(p, DEFAULT_SEEDS, QUICK)
    p.add_argument("--out", metavar="DIR", help="output directory (default runs/ablation-<time>)")
    p.add_argument(
        "--variants",
        metavar="A,B",
        help=f"comma-separated subset of {', '.join(VARIANTS)} (default all)",
    )
    p.add_argument(
        "--experiments",
        metavar="A,B",
        help=f"comma-separated subset of {', '.join(n for n, _ in EXPERIMENTS)} (default both)",
    )
    p.add_argument("--resume", action="store_true", help="reuse finished runs in --out")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument(
        "--baselines",
        action="store_true",
        help="also drive the oracle and DWA through every greedy test, beside the policies "
        "(their rows judge none of the paper's claims, which compare the strategies)",
    )
    p.add_argument(
        "--merge",
        nargs="+",
        metavar="DIR",
        help="merge finished ablations (each DIR an --out of this command) into --out "
        "instead of running one: their per-seed scores, the tables recomputed, each "
        "part's wall-clock",
    )
    return p


def main(argv: list[str] | None = None) -> int:
    p = _parser()
    args = p.parse_args(argv)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    out = Path(args.out) if args.out else Path("runs") / f"ablation-{stamp}"

    def work() -> None:
        if args.merge:
            if not args.out:
                raise JaxnavError("--merge needs --out DIR (where the merged ablation goes)")
            path = merge([Path(d) for d in args.merge], out)
            print(f"ablation: {path} (merged from {len(args.merge)})")
            return
        seeds, sizes = cli.chosen_sizes(args, DEFAULT_SEEDS, QUICK)
        variants = args.variants.split(",") if args.variants else list(VARIANTS)
        unknown = [v for v in variants if v not in VARIANTS]
        if unknown:
            raise JaxnavError(f"unknown variant '{unknown[0]}' (choose from {', '.join(VARIANTS)})")
        known = [n for n, _ in EXPERIMENTS]
        experiments = args.experiments.split(",") if args.experiments else known
        unknown = [e for e in experiments if e not in known]
        if unknown:
            raise JaxnavError(f"unknown experiment '{unknown[0]}' (choose from {', '.join(known)})")
        if args.resume and not args.out:
            raise JaxnavError("--resume needs --out DIR")
        command = "jaxnav ablation " + " ".join(argv if argv is not None else sys.argv[1:])
        path = ablation(
            out,
            seeds,
            variants,
            sizes,
            args.quick,
            args.resume,
            args.quiet,
            experiments,
            command.strip(),
            args.baselines,
        )
        print(f"ablation: {path}")

    given = list(argv if argv is not None else sys.argv[1:])
    return cli.run(p.prog, work, interrupted=cli.resume_advice("ablation", given, out))


if __name__ == "__main__":
    sys.exit(main())
