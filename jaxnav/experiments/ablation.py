"""``jaxnav ablation [--seeds N] [--out DIR] [--quick] [--resume] [--variants A,B]``

Why are jaxnav's test returns two to three times the paper's? ROBOTIS' simulation,
which the paper ran on, differs from jaxnav's environment in four ways, each a
switch of :class:`jaxnav.env.NavEnv` (off by default): collision from the smallest
LiDAR reading, ROBOTIS' goal sampler, Gazebo's inclusive beam layout and actions
applied one step late. This command trains and tests both of the paper's
experiments (as ``jaxnav.experiments.reproduce`` does, without figures and perturbations) once
with every switch off, once with each switch alone and once with all four, and
writes ``DIR/ablation.md``:

* the mean test return per strategy beside the paper's, per experiment and test
  mode, with 95% intervals over seeds: which switches bring the returns to the
  paper's magnitude;
* every claim's verdict (:mod:`jaxnav.report.claims`) under each variant;

and ``DIR/ablation.csv``, the per-seed scores behind both tables (the tables are
recomputed from it by :func:`ablation_markdown`).

Layout: ``DIR/<variant>/<experiment>/``, each a training run with ``eval/``: a cell of
the study runner (:mod:`jaxnav.experiments.runner`, :func:`variant_cells`), trained,
reused or resumed and tested by the same rule as every study's cells.
"""

from __future__ import annotations

import csv
import io
import time
from pathlib import Path

import numpy as np

from jaxnav.core import strategies as registry
from jaxnav.core.config import PAPER_STRATEGIES
from jaxnav.core.errors import JaxnavError
from jaxnav.core.rundir import atomic_write_text
from jaxnav.experiments import runner
from jaxnav.experiments.reproduce import (
    EXPERIMENTS,
    experiment_config,
    experiment_files,
    references,
)
from jaxnav.report import stats
from jaxnav.report.claims import CLAIMS, OTHER, Claim, claim_scores, judge
from jaxnav.report.markdown import interval
from jaxnav.report.paper import PAPER_TABLES
from jaxnav.report.results import MODE_NAMES

# name -> (what it changes, config overrides). The first is the reference.
VARIANTS: dict[str, tuple[str, tuple[str, ...]]] = {
    "jaxnav": ("every switch off (jaxnav's environment)", ()),
    "lidar_collision": (
        "collision when the smallest of the 24 beams reads below 0.13 m",
        ("env.collision=lidar",),
    ),
    "robotis_goals": (
        "ROBOTIS' goal grid, boxes and 1 m rule; first goal (0.6, 0)",
        ("env.goal_sampler=robotis",),
    ),
    "gazebo_beams": ("24 beams over [0, 2 pi] inclusive", ("env.beam_layout=gazebo",)),
    "late_actions": ("each action applied one step late", ("env.action_delay=true",)),
    "all_four": (
        "all four switches on",
        (
            "env.collision=lidar",
            "env.goal_sampler=robotis",
            "env.beam_layout=gazebo",
            "env.action_delay=true",
        ),
    ),
}
DEFAULT_SEEDS = 32
TRAIN_MAZE = {"paper_no_obstacles": "square4", "paper_obstacles": "square4_obstacles"}
CSV_COLUMNS = ("variant", "source", "statement", "mode", "strategy", "seed", "task", "score")


def variant_cells(
    variant: str, out: Path, sizes: dict, experiments: list[str]
) -> list[runner.Cell]:
    """The runner's cells of one variant: each experiment with the variant's switches,
    in ``DIR/<variant>/<experiment>/``."""
    return [
        runner.Cell(
            f"{variant}/{name}",
            experiment_config(name, **sizes, extra=VARIANTS[variant][1]),
            out / variant / name,
        )
        for name in experiments
    ]


def run_variant(
    variant: str,
    out: Path,
    sizes: dict,
    experiments: list[str],
    quiet: bool,
    say,
    baselines: bool = False,
) -> float:
    """Train and test the experiments of one variant; seconds taken. ``baselines``: the
    oracle and DWA take the greedy test beside the policies."""
    t0 = time.perf_counter()
    for cell in variant_cells(variant, out, sizes, experiments):
        runner.train(cell, quiet, say)
        say(f"{cell.name}: testing on {', '.join(cell.cfg.run.test_mazes)}")
        runner.test(cell, references=references(baselines))
    return time.perf_counter() - t0


def score_rows(variant: str, variant_dir: Path) -> list[dict[str, str]]:
    """ablation.csv rows of one variant: every claim's per-seed scores."""
    rows = []
    names = [name for name, _ in EXPERIMENTS if (variant_dir / name / "eval").is_dir()]
    for claim, mode, x, y in claim_scores(experiment_files(variant_dir, names)):
        for strategy, scores in ((claim.winner, x), (OTHER[claim.winner], y)):
            scores = scores.reshape(len(scores), -1)
            for seed, per_task in enumerate(scores):
                for task, value in enumerate(per_task):
                    rows.append(
                        {
                            "variant": variant,
                            "source": claim.source,
                            "statement": claim.statement,
                            "mode": mode,
                            "strategy": strategy,
                            "seed": str(seed),
                            "task": str(task),
                            "score": repr(float(value)),
                        }
                    )
    return rows


def rows_to_csv(rows: list[dict[str, str]]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, CSV_COLUMNS, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def _scores(rows: list[dict[str, str]]) -> dict[tuple, np.ndarray]:
    """(variant, source, statement, mode, strategy) -> f[seeds, tasks]."""
    acc: dict[tuple, dict[tuple[int, int], float]] = {}
    for r in rows:
        key = (r["variant"], r["source"], r["statement"], r["mode"], r["strategy"])
        acc.setdefault(key, {})[(int(r["seed"]), int(r["task"]))] = float(r["score"])
    out = {}
    for key, cells in acc.items():
        n_seeds = 1 + max(s for s, _ in cells)
        n_tasks = 1 + max(t for _, t in cells)
        a = np.full((n_seeds, n_tasks), np.nan)
        for (s, t), v in cells.items():
            a[s, t] = v
        out[key] = a
    return out


def _table_claims(experiment: str) -> list[Claim]:
    """The one-maze test claims of an experiment's paper table (Table 3 or 4 rows)."""
    return [
        c
        for c in CLAIMS
        if c.experiment == experiment and c.measure == "test" and len(c.mazes) == 1
    ]


def magnitude_rows(scores: dict, variants: list[str]):
    """(variant, experiment, mode, strategy, our mean test return [CI], paper's, ratio),
    averaged over the paper table's mazes, seeds drawn jointly over them."""
    out = []
    for experiment, _ in EXPERIMENTS:
        table = PAPER_TABLES[TRAIN_MAZE[experiment]][1]
        claims = _table_claims(experiment)
        for mode in MODE_NAMES:
            for strategy in PAPER_STRATEGIES:
                paper = np.mean([table[c.mazes[0]][1][strategy][0] for c in claims])
                for v in variants:
                    cols = [scores.get((v, c.source, c.statement, mode, strategy)) for c in claims]
                    if any(c is None for c in cols):
                        continue
                    iv = stats.mean_ci(np.concatenate(cols, axis=1))
                    out.append((v, experiment, mode, strategy, iv, paper, iv.value / paper))
    return out


def ablation_markdown(rows: list[dict[str, str]], quick: bool = False) -> str:
    """The ablation's two tables, computed from ablation.csv rows."""
    scores = _scores(rows)
    variants = [v for v in VARIANTS if any(k[0] == v for k in scores)]
    seeds = sorted({a.shape[0] for a in scores.values()})
    L = [
        "# Why our returns exceed the paper's: the ROBOTIS switches",
        "",
        f"{'/'.join(map(str, seeds))} seeds per strategy and variant; every variant trains "
        "and tests both of the paper's experiments with the paper's config plus its "
        'switches (docs/paper.md, "ROBOTIS\' code in detail"; `jaxnav.env.NavEnv`).',
        "",
    ]
    if quick:
        L += ["**A quick run on few seeds: these numbers are not conclusive.**", ""]
    n_seeds = {v: max(a.shape[0] for k, a in scores.items() if k[0] == v) for v in variants}
    L += ["| variant | seeds | what it changes |", "|---|---|---|"]
    L += [f"| {v} | {n_seeds[v]} | {VARIANTS[v][0]} |" for v in variants]
    L += [
        "",
        "## Test return beside the paper's",
        "",
        "Mean test return per seed, averaged over the paper table's mazes (Table 3: the "
        "five mazes; Table 4: the two), with a 95% bootstrap interval over seeds; the "
        "paper's figure is the mean of its table's means over the same mazes; ratio = "
        "ours / paper's.",
        "",
    ]
    mag = magnitude_rows(scores, variants)
    for experiment, _ in EXPERIMENTS:
        for mode in MODE_NAMES:
            sel = [r for r in mag if r[1] == experiment and r[2] == mode]
            if not sel:
                continue
            L += [
                f"### {experiment}, {mode} test",
                "",
                "| variant | "
                + " | ".join(
                    f"{registry.label(s)} (paper {sel[[r[3] for r in sel].index(s)][5]:.0f})"
                    for s in PAPER_STRATEGIES
                )
                + " | ratio EBE | ratio epsilon-greedy |",
                "|---|---|---|---|---|",
            ]
            for v in variants:
                by = {r[3]: r for r in sel if r[0] == v}
                if len(by) < len(PAPER_STRATEGIES):
                    continue
                cells = [interval(by[s][4], 0, missing="") for s in PAPER_STRATEGIES]
                ratios = [f"{by[s][6]:.2f}" for s in PAPER_STRATEGIES]
                L.append(f"| {v} | " + " | ".join(cells + ratios) + " |")
            L.append("")
    L += [
        "## Verdicts under each variant",
        "",
        "P(claimed winner > other) [95% CI] and the verdict by the claims table's rule "
        "(S supported, C contradicted, I inconclusive).",
        "",
        "| claim | test mode | " + " | ".join(variants) + " |",
        "|---|---|" + "---|" * len(variants),
    ]
    letter = {"supported": "S", "contradicted": "C", "inconclusive": "I"}
    keys = []
    for k in scores:
        if k[1:4] not in keys:
            keys.append(k[1:4])
    by_claim = {(c.source, c.statement): c for c in CLAIMS}
    for source, statement, mode in keys:
        claim = by_claim[(source, statement)]
        cells = []
        for v in variants:
            x = scores.get((v, source, statement, mode, claim.winner))
            y = scores.get((v, source, statement, mode, OTHER[claim.winner]))
            if x is None or y is None:
                cells.append("")
                continue
            if x.shape[1] == 1:
                x, y = x[:, 0], y[:, 0]
            res = judge(claim, mode, x, y)
            cells.append(f"{interval(res.p, 2, missing='')} {letter[res.verdict]}")
        L.append(f"| {source}: {statement} | {mode or 'training'} | " + " | ".join(cells) + " |")
    return "\n".join(L) + "\n"


def ablation(
    out: Path,
    seeds: int,
    variants: list[str],
    sizes: dict,
    quick: bool,
    resume_ok: bool,
    quiet: bool,
    experiments: list[str] | None = None,
    command: str = "",
    baselines: bool = False,
) -> Path:
    experiments = experiments or [name for name, _ in EXPERIMENTS]
    runner.check_request(out, seeds, {}, resume_ok)
    out.mkdir(parents=True, exist_ok=True)
    say = runner.sayer("ablation", quiet)

    times = {}
    rows: list[dict[str, str]] = []
    for v in variants:
        times[v] = run_variant(v, out, dict(sizes, seeds=seeds), experiments, quiet, say, baselines)
        rows += score_rows(v, out / v)
    atomic_write_text(out / "ablation.csv", rows_to_csv(rows))
    md = ablation_markdown(rows, quick=quick)
    info = runner.machine_info()
    md += f"\n## Wall-clock\n\n| variant | train and test: {', '.join(experiments)} |\n|---|---|\n"
    md += "".join(f"| {v} | {t:.0f} s |\n" for v, t in times.items())
    md += f"\nMachine: {info['CPU']}; {info['cores']}; JAX {info['JAX']}.\n"
    if command:
        md += f"\nCommand: `{command}`\n"
    path = out / "ablation.md"
    atomic_write_text(path, md)
    return path


def merge(sources: list[Path], dst: Path) -> Path:
    """Ablations run apart (``jaxnav ablation --out DIR`` on several machines or days)
    merged into ``dst``: ``ablation.csv`` with every per-seed score, and ``ablation.md``
    with the tables recomputed from them, then each part's wall-clock section. A
    variant may come from one part only; a part without its files is a one-line error."""
    rows: list[dict[str, str]] = []
    made: list[str] = []
    owner: dict[str, Path] = {}
    for src in sources:
        try:
            part = list(csv.DictReader(io.StringIO((src / "ablation.csv").read_text())))
            md = (src / "ablation.md").read_text()
        except FileNotFoundError as e:
            raise JaxnavError(f"ablation --merge: {src} has no {Path(e.filename).name}") from None
        for v in sorted({r["variant"] for r in part}):
            if v in owner:
                raise JaxnavError(f"ablation --merge: variant {v} is in both {owner[v]} and {src}")
            owner[v] = src
        rows += part
        if "## Wall-clock" in md:
            made.append(
                md[md.index("## Wall-clock") :].replace("## Wall-clock", "### Wall-clock", 1)
            )
    dst.mkdir(parents=True, exist_ok=True)
    atomic_write_text(dst / "ablation.csv", rows_to_csv(rows))
    text = ablation_markdown(rows) + "\n## How it was made\n\n" + "\n".join(made)
    atomic_write_text(dst / "ablation.md", text)
    return dst / "ablation.md"
