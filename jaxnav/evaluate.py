"""``python -m jaxnav.evaluate RUN_DIR [--mazes M ...] [--episodes N] [--out DIR] [--robustness]``

The paper's test protocol (Sec. 6, Tables 3 and 4) for every trained policy of a
run: N consecutive greedy test episodes on each test maze, tables with the mean ±
std of the episode return and statistics over seeds (:mod:`jaxnav.experiments.evaluation`).
``--robustness`` plays the same test under sensor perturbations instead
(:mod:`jaxnav.experiments.robustness`).
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

import sys
from collections.abc import Sequence
from pathlib import Path

from jaxnav.core import cli, rundir
from jaxnav.core.rundir import CsvLog
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.experiments.robustness import PERTURBATIONS, robustness_to_dir
from jaxnav.report.nav_tables import navigation_text
from jaxnav.report.results import ordered_unique
from jaxnav.report.tables import outcome_text, setting_text


def check_outputs(out: Path, names: Sequence[str], overwrite: bool) -> None:
    """Refuse, before the test starts, an output folder that cannot be written or files
    in it that would be replaced without ``--overwrite``. The folder may exist already
    (it holds the run's other results)."""
    if out.is_dir():
        for name in names:
            cli.check_output(out / name, overwrite)
    else:  # absent (then its parent must exist) or not a folder (refused)
        cli.check_output(out, overwrite, is_dir=True)


def print_summary(rows: list[dict[str, str]]) -> None:
    """Per test mode, train's table of the test episodes: all of each seed's, all mazes."""
    for mode in ordered_unique(r["mode"] for r in rows):
        mine = [r for r in rows if r["mode"] == mode]
        mazes = ordered_unique(r["maze"] for r in mine)
        print(
            f"{mode} test on {', '.join(mazes)}, every test episode of each seed, "
            "mean over seeds [95% CI]:"
        )
        print(outcome_text(mine))
        nav = navigation_text(mine)
        if nav:
            print("per goal attempt, every attempt of each seed, mean over seeds [95% CI]:")
            print(nav)


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="python -m jaxnav.evaluate",
        description="Test every trained policy of a run on the test mazes (the paper's "
        "protocol: N consecutive greedy episodes) and write eval/results.csv and eval/tables.md; "
        "with --robustness, test them under sensor perturbations instead.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a finished training run (with params.npz)")
    p.add_argument(
        "--mazes",
        nargs="+",
        metavar="M",
        help="test mazes, replacing the config's run.test_mazes (with --robustness: the "
        "training maze): built-in names (square2, square4, ...) or maze YAML paths",
    )
    p.add_argument(
        "--episodes",
        type=int,
        metavar="N",
        help="consecutive test episodes per seed (default run.test_episodes)",
    )
    p.add_argument("--out", metavar="DIR", help="output directory (default RUN_DIR/eval)")
    cli.add_overwrite(p, "a result file in --out")
    sweep = "; ".join(
        f"{k} ({setting_text(v)})" if v else f"{k} (as trained)" for k, v in PERTURBATIONS.items()
    )
    p.add_argument(
        "--robustness",
        action="store_true",
        help="instead of the plain test, play it under each perturbation of the training "
        f"environment: {sweep}. Each replaces that setting only. Mazes default to the training "
        "maze. Writes robustness.csv, robustness.md (mean return over seeds with 95%% CI, its "
        "change from 'none', goals, collision rate) and robustness.png",
    )
    args = p.parse_args(argv)

    def work() -> None:
        run_dir = rundir.existing(args.run_dir, finished=True)
        out = Path(args.out) if args.out else run_dir / "eval"
        if args.robustness:
            written = ("robustness.csv", "robustness.md", "robustness.png")
            check_outputs(out, written, args.overwrite)
            out = robustness_to_dir(run_dir, args.mazes, args.episodes, out)
        else:
            written = ("results.csv", "tables.md", "trajectories.npz")
            check_outputs(out, written, args.overwrite)
            out = evaluate_to_dir(run_dir, args.mazes, args.episodes, out)
        print(f"wrote {out / written[0]}, {out / written[1]} and {out / written[2]}")
        if not args.robustness:
            print_summary(CsvLog(out / written[0], ()).read())

    return cli.run(p.prog, work)


if __name__ == "__main__":
    sys.exit(main())
