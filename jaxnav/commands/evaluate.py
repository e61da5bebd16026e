"""``jaxnav evaluate RUN_DIR [env.KEY=VALUE ...] [--mazes M ...] [--episodes N] [--out DIR]
[--robustness]``
or ``jaxnav evaluate --baseline oracle|dwa WORLD [key=value ...] [--seeds N]``

The paper's test protocol (Sec. 6, Tables 3 and 4) for every trained policy of a
run: N consecutive greedy test episodes on each test maze, tables with the mean ±
std of the episode return and statistics over seeds (:mod:`jaxnav.experiments.evaluation`),
with the oracle and DWA beside the policies on the same test keys
(:mod:`jaxnav.experiments.baselines`). ``--robustness`` plays the same test under
sensor perturbations instead (:mod:`jaxnav.experiments.robustness`). ``--baseline``
drives one reference driver through the test of any world instead of a run.
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

import csv
import io
import sys
from collections.abc import Sequence
from pathlib import Path

from jaxnav.core import baselines, cli, families, rundir
from jaxnav.core.errors import JaxnavError
from jaxnav.core.rundir import CsvLog
from jaxnav.experiments.baselines import evaluate_world, world_config
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.experiments.levels import levels_text, levels_to_dir
from jaxnav.experiments.robustness import PERTURBATIONS, robustness_to_dir
from jaxnav.report.barn import summary_text as barn_summary
from jaxnav.report.nav_tables import long_waits_text, navigation_text
from jaxnav.report.results import ordered_unique
from jaxnav.report.tables import outcome_text, setting_text, tables_markdown


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
        waits = long_waits_text(mine)
        if waits:
            print(waits)
    barn = barn_summary(rows)  # BARN's own metrics, where the test was BARN's
    if barn:
        print(barn)


def baseline(args) -> None:
    """``--baseline NAME WORLD``: the reference driver through the world's test, its
    tables printed (and written with --out)."""
    if args.mazes or args.robustness or args.no_baselines:
        raise JaxnavError(
            "--baseline tests its WORLD: --mazes, --robustness and --no-baselines do not apply"
        )
    if args.seeds < 1:
        raise JaxnavError("--seeds must be at least 1")
    cfg = world_config(args.run_dir, args.overrides)
    listed = any(o.split("=", 1)[0].strip() == "run.test_mazes" for o in args.overrides)
    gen = cfg.env.generator
    if listed and not (gen and families.get(gen).fixed_test):  # it would do nothing
        raise JaxnavError(
            "run.test_mazes: --baseline drives its WORLD's own test (its maze, or a drawn "
            "family's train and test layouts); name a maze as the WORLD to drive it there"
        )
    out = Path(args.out) if args.out else None
    if out is not None:
        check_outputs(out, ("results.csv", "tables.md"), args.overwrite)
    episodes = args.episodes if args.episodes is not None else cfg.run.test_episodes
    if episodes < 1:
        raise JaxnavError("--episodes must be at least 1")
    text = evaluate_world(args.baseline, cfg, args.seeds, episodes).text
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        rundir.atomic_write_text(out / "results.csv", text)
        title = f"The {args.baseline} in {args.run_dir}"
        tables = tables_markdown(text, args.run_dir, cfg.seed, title=title)
        rundir.atomic_write_text(out / "tables.md", tables)
        print(f"wrote {out / 'results.csv'} and {out / 'tables.md'}")
    print_summary(list(csv.DictReader(io.StringIO(text))))


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav evaluate",
        description="Test every trained policy of a run on the test mazes (the paper's "
        "protocol: N consecutive greedy episodes) and write eval/results.csv and eval/tables.md; "
        "with --robustness, test them under sensor perturbations instead.",
    )
    p.add_argument(
        "run_dir",
        metavar="RUN_DIR",
        help="a finished training run (with params.npz); with --baseline, the WORLD: a "
        "shipped config's name or a config file (its maze or drawn family and settings), "
        "or a maze (a built-in name or a maze file)",
    )
    p.add_argument(
        "overrides",
        nargs="*",
        metavar="key=value",
        help="with --baseline: settings of the world (env.max_steps=300, ...); for a run: "
        "environment settings to test its policies in instead of those they trained in "
        "(env.random_start=false tests a run trained from random poses from the start pose)",
    )
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
    p.add_argument(
        "--baseline",
        metavar="NAME",
        choices=baselines.names(),
        help="drive the reference driver NAME (oracle: the privileged planner; dwa: the "
        "dynamic window approach) through the test of WORLD instead of testing a run",
    )
    p.add_argument(
        "--seeds",
        type=int,
        default=8,
        metavar="N",
        help="with --baseline: test keys (seeds 0..N-1 of the world's config, as a run's)",
    )
    p.add_argument(
        "--levels",
        type=int,
        metavar="N",
        help="instead of the plain test: N layouts of the test split of a run trained on "
        "drawn mazes (levels), each played once by every policy and the oracle from its own "
        "start to its first goal; writes levels.csv and prints the mean success over the "
        "levels and over their worst tenth",
    )
    p.add_argument(
        "--no-baselines",
        action="store_true",
        help="test the run's policies only, without the oracle's and DWA's rows",
    )
    args = p.parse_intermixed_args(argv)

    def work() -> None:
        if args.baseline:
            baseline(args)
            return
        if args.overrides and args.robustness:
            raise JaxnavError(
                f"{args.overrides[0]}: --robustness sets the perturbed settings itself"
            )
        setting = next((m for m in args.mazes or () if "=" in m), None)
        if setting is not None:  # --mazes takes every word after it
            raise JaxnavError(
                f"--mazes: {setting!r} is a setting, not a maze: put settings after the run "
                "directory, before --mazes"
            )
        run_dir = rundir.existing(args.run_dir, finished=True)
        out = Path(args.out) if args.out else run_dir / "eval"

        def say(line: str) -> None:  # progress, where a person watches the terminal
            print(f"{line} ...", file=sys.stderr, flush=True)

        watched = say if sys.stderr.isatty() else None
        if args.levels is not None:
            if args.levels < 10 or args.robustness or args.mazes or args.overrides:
                raise JaxnavError(
                    "--levels N (at least 10) tests the run's own drawn worlds: no --mazes, "
                    "--robustness or settings"
                )
            check_outputs(out, ("levels.csv",), args.overwrite)
            refs = () if args.no_baselines else ("oracle",)
            path = levels_to_dir(run_dir, args.levels, out, refs, say=watched)
            rows = CsvLog(path, ()).read()
            print(f"wrote {path}; first goal of each level, share of the seeds that reach it:")
            print(levels_text(rows))
            return
        if args.robustness:
            written = ("robustness.csv", "robustness.md", "robustness.png")
            check_outputs(out, written, args.overwrite)
            out = robustness_to_dir(run_dir, args.mazes, args.episodes, out, say=watched)
        else:
            written = ("results.csv", "tables.md", "trajectories.npz", "failures.npz")
            check_outputs(out, written, args.overwrite)
            refs = () if args.no_baselines else baselines.names()
            out = evaluate_to_dir(
                run_dir,
                args.mazes,
                args.episodes,
                out,
                references=refs,
                say=watched,
                overrides=args.overrides,
            )
        print(f"wrote {out / written[0]}, {out / written[1]} and {out / written[2]}")
        if not args.robustness:
            print_summary(CsvLog(out / written[0], ()).read())

    return cli.run(p.prog, work)


if __name__ == "__main__":
    sys.exit(main())
