"""``jaxnav study CONFIG [key=value ...] --out DIR [--resume] [--doc PATH]``

A config's sweep trained, tested in both modes and written up in ``DIR/study.md``:
the work is :func:`jaxnav.experiments.study.study` (its module describes the
layout). A study file runs instead, of any kind (:mod:`jaxnav.experiments.studies`):
a ladder (one with ``rungs:``, as ``configs/studies/when_ebe_helps.yaml``) trains
every world and agent it names, ``kind: driving`` each ``drive_*`` config
(``configs/studies/driving.yaml``), ``kind: sim2sim`` a sim-to-sim campaign's arms
(``configs/studies/sim2sim_realism.yaml``); each writes its page from its data.
``--help`` lists the options.
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

import argparse
import shlex
import sys
from pathlib import Path

from jaxnav.core import cli
from jaxnav.core.config import load_config
from jaxnav.core.shipped import resolve_config_path, studies_text
from jaxnav.experiments import studies
from jaxnav.experiments.study import doc_files, study
from jaxnav.report import stats
from jaxnav.run.launch import check_test_mazes
from jaxnav.run.memory import confirm_memory


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav study",
        description="Train a config's sweep, test every arm in both test modes and write "
        "DIR/study.md with the sweep's tables, computed answers and figures; or run a study "
        "file (a ladder, the driving study, a sim-to-sim campaign) and write its page from "
        "its data.",
        epilog="shipped studies (jaxnav list studies):\n" + studies_text(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("items", nargs="*", metavar="CONFIG|STUDY [key=value ...]")
    p.add_argument("--out", metavar="DIR", help="output directory (required)")
    p.add_argument("--title", help="the study's title (default: the config's name)")
    p.add_argument("--doc", metavar="PATH", help="also write the study here, figures beside it")
    cli.add_overwrite(p, "a file --doc writes")
    p.add_argument("--resume", action="store_true", help="continue the study in --out")
    p.add_argument(
        "--yes",
        action="store_true",
        help="start a run that needs over half of this machine's memory without asking",
    )
    p.add_argument("--quiet", action="store_true", help="no progress output")
    args = p.parse_intermixed_args(argv)
    command = "jaxnav study " + shlex.join(argv if argv is not None else sys.argv[1:])

    if not args.items:
        p.error("name a config or a shipped study (jaxnav list studies lists them, with costs)")
    if not args.out:
        p.error("--out DIR is required: the folder the study writes")

    def work() -> None:
        items = list(args.items)
        config_path = None if "=" in items[0] else resolve_config_path(items.pop(0))
        if config_path is not None and studies.is_study(config_path):
            return study_file(config_path, items)
        cfg = load_config(config_path, items)
        check_test_mazes(cfg)  # before the study's folder is made
        confirm_memory(cfg, args.yes, args.quiet)  # before anything is allocated
        title = args.title or f"Sweep study: {Path(config_path or 'defaults').stem}"
        doc = Path(args.doc) if args.doc else None
        for path in doc_files(doc) if doc else []:
            cli.check_output(path, args.overwrite)
        path = study(cfg, Path(args.out), title, command.strip(), args.resume, args.quiet, doc)
        print(f"study: {path}" + (f" (and {doc})" if doc else ""))
        if not stats.enough_seeds(cfg.seeds):
            print(
                f"{cfg.seeds} seeds per arm, fewer than the {stats.MIN_SEEDS} a verdict needs: "
                f"its verdicts say {stats.TOO_FEW_SEEDS}"
            )

    def study_file(path: str, items: list[str]) -> None:
        spec = studies.load(path, items)
        page = Path(args.doc) if args.doc else Path(args.out) / "study.md"
        if args.doc:
            cli.check_output(page, args.overwrite)
        out = Path(args.out)
        written = studies.run(spec, out, page, args.resume, args.quiet, command.strip())
        print(f"study: {written[0]} (data in {written[-1]})")

    given = list(argv if argv is not None else sys.argv[1:])
    return cli.run(p.prog, work, interrupted=cli.resume_advice("study", given, args.out))


if __name__ == "__main__":
    sys.exit(main())
