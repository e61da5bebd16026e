"""``jaxnav train CONFIG [key=value ...] [--out RUN_DIR] [--resume RUN_DIR]``

The command that trains every seed of every strategy of a config in one compiled
program (:mod:`jaxnav.run.training`) and writes a run directory (:mod:`jaxnav.core.rundir`
lists its files), ending with its training-curve figure. ``--resume`` continues a
killed run from its last checkpoint.
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

import sys
import time
from pathlib import Path
from typing import Any

from jaxnav.agent.sharding import initialize, is_writer
from jaxnav.core import cli
from jaxnav.core.config import load_config
from jaxnav.core.errors import RunError
from jaxnav.core.rundir import CONFIG, METRICS, CsvLog
from jaxnav.core.shipped import resolve_config_path
from jaxnav.run.launch import check_test_mazes, interrupted_text, resume, train_new
from jaxnav.run.memory import confirm_memory

LAST = 50  # training episodes per seed in the summary (summary.json's last50)


def default_out(config_path: str | None) -> Path:
    stem = Path(config_path).stem if config_path else "default"
    return Path("runs") / f"{stem}-{time.strftime('%Y%m%d-%H%M%S')}"


def print_summary(out: Path, summary: dict[str, Any]) -> None:
    print(f"results in {out}/ (metrics.csv, params.npz, summary.json)")
    print(
        f"trained {summary['env_steps']} env steps in {summary['wall_clock_s']} s "
        f"({summary['steps_per_s']:.0f} steps/s)"
    )
    if summary.get("startup_s") is not None:  # None: nothing was left to train
        print(
            f"training began {summary['startup_s']:.1f} s after the command started "
            f"(compilation {summary['compile_s']:.1f} s)"
        )
    if summary.get("lockstep_useful") is not None:
        print(
            f"{100 * summary['lockstep_useful']:.0f}% of the steps computed in lockstep were "
            "real steps (the rest: finished runs waiting for the others)"
        )
    from jaxnav.report.nav_tables import training_success_text  # statistics only when done
    from jaxnav.report.tables import outcome_text

    print(f"last {LAST} training episodes of each seed, mean over seeds [95% CI]:")
    rows = CsvLog(out / METRICS, ()).read()
    print(outcome_text(rows, last=LAST))
    max_steps = load_config(str(out / CONFIG)).env.max_steps
    print(
        f"goal attempts of the last {LAST} training episodes of each seed (exploration on; "
        "attempts cut by an episode's end left out), mean over seeds [95% CI]:"
    )
    print(training_success_text(rows, max_steps, LAST))
    for d in summary.get("diverged", []):
        print(f"  dropped: {d['strategy']} seed {d['seed']} diverged at step {d['step']}")


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav train",
        description="Train DQN with EBE, epsilon-greedy or Boltzmann exploration on a maze, "
        "many seeds at once.",
    )
    p.add_argument(
        "items",
        nargs="*",
        metavar="CONFIG [key=value ...]",
        help="a YAML config (path, or a name in configs/) then dotted overrides",
    )
    p.add_argument("--out", help="run directory (default runs/<config>-<time>)")
    p.add_argument(
        "--resume", metavar="RUN_DIR", help="continue a killed run from its last checkpoint"
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the run already in --out (refused while another command uses it)",
    )
    p.add_argument(
        "--keep-checkpoints",
        action="store_true",
        help="keep checkpoints/ once training has finished (removed otherwise: nothing reads them)",
    )
    p.add_argument(
        "--yes",
        action="store_true",
        help="start a run that needs over half of this machine's memory without asking",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    args = p.parse_intermixed_args(argv)  # overrides may follow the flags too

    def work() -> None:
        initialize()  # multi-host, when jax.distributed's variables are set
        if args.resume:
            if args.items or args.out or args.overwrite:
                raise RunError("--resume takes only the run directory (its config.yaml is used)")
            out = Path(args.resume)
            summary = resume(out, args.quiet, args.keep_checkpoints)
        else:
            config_path = None
            overrides = list(args.items)
            if overrides and "=" not in overrides[0]:
                config_path = resolve_config_path(overrides.pop(0))
            cfg = load_config(config_path, overrides)
            check_test_mazes(cfg)
            confirm_memory(cfg, args.yes, args.quiet)  # before anything is allocated
            out = Path(args.out) if args.out else default_out(config_path)
            summary = train_new(cfg, out, args.quiet, args.overwrite, args.keep_checkpoints)
        if is_writer():
            print_summary(out, summary)
            from jaxnav.report.plots import plot_training_curves  # matplotlib only when done

            (out / "plots").mkdir(exist_ok=True)
            curves = plot_training_curves(out, out / "plots" / "training_curves.png")
            print(f"training curves: {curves}")

    return cli.run(p.prog, work, interrupted=interrupted_text)


if __name__ == "__main__":
    sys.exit(main())
