"""``jaxnav study CONFIG [key=value ...] --out DIR [--resume] [--doc PATH]``

A sweep study end to end: train a config's sweep (every strategy, point and seed in
one program), test every arm in both test modes (``jaxnav evaluate``) and write
``DIR/study.md``: the sweep's tables and the answers they give, computed from the
results (:func:`jaxnav.report.tables.sweep_markdown`), its figures, the wall-clock of each
stage and the machine. ``--doc PATH`` writes the same study to PATH, its figures and
its test results beside it (``<name>-sweep.png``, ``<name>-training_curves.png``,
``<name>-results.csv.gz``), for committing.

``configs/temperature.yaml`` is EBE's and Boltzmann's softmax temperature against
epsilon-greedy (``docs/studies/temperature.md``).

Layout::

    DIR/study.md, DIR/sweep.png, DIR/training_curves.png
    DIR/run/        the training run (see jaxnav train) + eval/
"""

from __future__ import annotations

import gzip
import shutil
import time
from pathlib import Path

from jaxnav.core.config import Config
from jaxnav.core.errors import JaxnavError
from jaxnav.core.rundir import METRICS, CsvLog, atomic_write_bytes, atomic_write_text
from jaxnav.core.sweep import short_names, value_text
from jaxnav.experiments import runner
from jaxnav.report import plots, stats
from jaxnav.report.tables import sweep_markdown, training_markdown


def study_markdown(
    cfg: Config,
    title: str,
    results_csv: str,
    metrics_rows: list[dict[str, str]],
    timings: list[tuple[str, float, str]],
    command: str,
    figures: dict[str, str],
) -> str:
    """The study's text: setup, results per test mode with their answers, training
    (from metrics.csv rows), figures (``figures``: caption -> file name), time and
    machine."""
    n_arms = len(cfg.arms())
    sweep = "; ".join(
        f"`{k}` in {{{', '.join(value_text(v) for v in vals)}}}" for k, vals in cfg.sweep
    )
    total = sum(t for _, t, _ in timings)
    L = [
        f"# {title}",
        "",
        f"Produced by `{command}` in {total / 60:.1f} minutes on the machine below; "
        f"every number and sentence under Results is computed from the run's "
        f"`eval/results.csv`.",
        "",
        "## Setup",
        "",
        f"- Trained on `{cfg.env.maze}`, preset `{cfg.preset}`, {cfg.episodes} episodes of at "
        f"most {cfg.env.max_steps} steps per seed; the paper's network, replay and RMSprop.",
        f"- Strategies {', '.join(f'`{s}`' for s in cfg.strategies)}; sweep {sweep}. A strategy "
        f"varies only the keys it reads: {n_arms} arms x {cfg.seeds} seeds = {cfg.n_runs} runs, "
        "all in one compiled program; every arm of a seed shares its initial network and goals.",
        f"- Test: {cfg.run.test_episodes} consecutive episodes per seed on "
        f"{', '.join(f'`{m}`' for m in cfg.run.test_mazes)}, in both test modes: greedy "
        "(argmax Q, as the paper most plausibly tested) and exploring (each strategy's own "
        "exploration at the end of training).",
        "- A seed's score is its mean test return; intervals are 95% percentile bootstraps "
        "over seeds (rliable). A verdict names the better arm when the interval of P(X > Y) "
        "excludes 0.5, else there is no detectable difference. The best point of a strategy "
        "is chosen on the same seeds that score it, which flatters it, and with "
        f"{max(n_arms - 1, 1)} arms compared with epsilon-greedy one verdict in twenty "
        "names a winner by chance: a verdict at one point of several is a hypothesis "
        "until a fresh set of seeds confirms it (`seed=` another range)."
        + (
            f" With {cfg.seeds} seeds per arm, fewer than the {stats.MIN_SEEDS} a verdict needs, "
            f"every verdict below says {stats.TOO_FEW_SEEDS}."
            if not stats.enough_seeds(cfg.seeds)
            else ""
        ),
        "",
        "## Results",
    ]
    L += sweep_markdown(results_csv, cfg.seed)
    L += ["", "## Training", "", training_markdown(metrics_rows).rstrip()]
    L += ["", "## Figures", ""]
    for caption, name in figures.items():
        L += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    L += ["## Time and machine", "", "| stage | seconds | what |", "|---|---|---|"]
    L += [f"| {stage} | {t:.0f} | {note} |" for stage, t, note in timings]
    L += [f"| total | {total:.0f} | |", ""]
    L += [f"- {k}: {v}" for k, v in runner.machine_info().items()]
    return "\n".join(L) + "\n"


FIGURES = ("sweep.png", "training_curves.png")  # in DIR, and beside --doc PATH
RESULTS = "results.csv.gz"  # beside --doc PATH


def doc_files(doc: Path) -> list[Path]:
    """What ``--doc PATH`` writes: PATH, and its figures and results beside it."""
    return [doc] + [doc.parent / f"{doc.stem}-{name}" for name in (*FIGURES, RESULTS)]


def study(
    cfg: Config, out: Path, title: str, command: str, resume_ok: bool, quiet: bool, doc: Path | None
) -> Path:
    """Train, test and write the study; returns DIR/study.md."""
    if not cfg.sweep:
        raise JaxnavError("the config has no sweep: a study compares the points of one")
    runner.check_request(out, cfg.seeds, {}, resume_ok)
    out.mkdir(parents=True, exist_ok=True)
    say = runner.sayer("study", quiet)
    cell = runner.Cell("sweep", cfg, out / "run")
    run_dir = cell.run
    timings = [("train", *runner.train(cell, quiet, say))]
    say(f"testing {cfg.n_runs} runs on {', '.join(cfg.run.test_mazes)}, both test modes")
    t0 = time.perf_counter()
    eval_dir = runner.test(cell)
    n_tests = f"{cfg.run.test_episodes} episodes x {cfg.n_runs} runs x 2 modes"
    timings.append(("test", time.perf_counter() - t0, n_tests))
    results = (eval_dir / "results.csv").read_text()
    t0 = time.perf_counter()
    names = short_names([k for k, _ in cfg.sweep])
    figures = {
        "sweep": plots.plot_sweep(results, out / FIGURES[0], ", ".join(names.values())),
        "training_curves": plots.plot_training_curves(run_dir, out / FIGURES[1]),
    }
    timings.append(("figures", time.perf_counter() - t0, ", ".join(FIGURES)))
    captions = {
        "sweep": "Test return against the swept values, both test modes: mean over seeds "
        "with 95% bootstrap intervals (strategies that do not read the key: a band).",
        "training_curves": "Training return per arm: mean over seeds with 95% bootstrap band.",
    }
    metrics = CsvLog(run_dir / METRICS, ()).read()
    figure_names = {captions[k]: p.name for k, p in figures.items()}
    text = study_markdown(cfg, title, results, metrics, timings, command, figure_names)
    path = out / "study.md"
    atomic_write_text(path, text)
    if doc is not None:
        doc.parent.mkdir(parents=True, exist_ok=True)
        for p in figures.values():
            shutil.copyfile(p, doc.parent / f"{doc.stem}-{p.name}")
            text = text.replace(f"]({p.name})", f"]({doc.stem}-{p.name})")
        # The data behind every number: results.csv, gzipped (mtime 0: same bytes, same file).
        packed = gzip.compress(results.encode(), mtime=0)
        atomic_write_bytes(doc.parent / f"{doc.stem}-{RESULTS}", packed)
        text += f"\nThe test results behind every number above: `{doc.stem}-{RESULTS}`.\n"
        atomic_write_text(doc, text)
    return path
