"""The paper's claims, each with a verdict computed from the runs' files.

Every claim says that one strategy does better than the other on one measure; its
evidence is the probability of improvement P(claimed winner > other) over seeds
with a 95% bootstrap interval (:mod:`jaxnav.report.stats`). The rule, declared once
(:func:`verdict`):

* supported: the interval lies above 0.5;
* contradicted: the interval lies below 0.5;
* inconclusive: otherwise, with the seeds per strategy that an interval of the
  same relative width around the same effect would need to exclude 0.5
  (:func:`jaxnav.report.stats.seeds_to_resolve`, a rough extrapolation).

Measures, per seed:

* learning speed: the area under the training curve, i.e. the mean return over all
  training episodes (a run that learns sooner collects more return on the way);
* final training return: the mean return of the last 50 training episodes;
* test return on a maze: the mean return over the seed's test episodes, in each
  test mode (greedy and exploring, see :mod:`jaxnav.experiments.rollout`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from jaxnav.core.sweep import row_arm
from jaxnav.report import stats
from jaxnav.report.markdown import interval
from jaxnav.report.results import MODE_NAMES, display_name, per_seed_scores, read_results

FINAL_EPISODES = 50  # the "final training return" window, per seed
OTHER = {"ebe": "epsilon_greedy", "epsilon_greedy": "ebe"}


class Claim(NamedTuple):
    """One claim of the paper: ``winner`` does better on ``measure``."""

    source: str  # where the paper makes it
    statement: str
    experiment: str  # paper_no_obstacles or paper_obstacles
    measure: str  # "learning_speed", "final_training_return" or "test"
    mazes: tuple[str, ...]  # test mazes (several: averaged, seeds drawn jointly)
    winner: str


def _test_claims(source: str, experiment: str, table: dict[str, str]) -> list[Claim]:
    return [
        Claim(
            source,
            f"{display_name(w)} scores higher on {maze}",
            experiment,
            "test",
            (maze,),
            w,
        )
        for maze, w in table.items()
    ]


CLAIMS: tuple[Claim, ...] = (
    Claim(
        "Fig. 2(b)",
        "EBE learns faster (no obstacles)",
        "paper_no_obstacles",
        "learning_speed",
        (),
        "ebe",
    ),
    Claim(
        "Fig. 2(b)",
        "EBE settles at a higher training return; epsilon-greedy 'settles at much lower score'",
        "paper_no_obstacles",
        "final_training_return",
        (),
        "ebe",
    ),
    *_test_claims(
        "Table 3",
        "paper_no_obstacles",
        {
            "square4": "ebe",
            "square8": "ebe",
            "triangle": "ebe",
            "pentagon": "ebe",
        },
    ),
    Claim(
        "Table 3 text",
        "the exception: epsilon-greedy scores higher on square2",
        "paper_no_obstacles",
        "test",
        ("square2",),
        "epsilon_greedy",
    ),
    Claim(
        "Table 3",
        "EBE scores higher averaged over the five test mazes",
        "paper_no_obstacles",
        "test",
        ("square4", "square8", "square2", "triangle", "pentagon"),
        "ebe",
    ),
    Claim(
        "Fig. 4(c)",
        "EBE learns faster (obstacles)",
        "paper_obstacles",
        "learning_speed",
        (),
        "ebe",
    ),
    Claim(
        "Fig. 4(c)",
        "EBE learns a better policy: higher final training return (obstacles)",
        "paper_obstacles",
        "final_training_return",
        (),
        "ebe",
    ),
    *_test_claims(
        "Table 4",
        "paper_obstacles",
        {"square4_obstacles": "ebe", "pentagon_obstacles": "ebe"},
    ),
)


class Verdict(NamedTuple):
    claim: Claim
    mode: str  # test mode, "" for training claims
    n_seeds: int  # seeds per strategy
    p: stats.Interval  # P(claimed winner > other)
    verdict: str  # supported, contradicted or inconclusive
    seeds_needed: float  # for an inconclusive verdict, else NaN


def verdict(p: stats.Interval) -> str:
    """The declared rule: where the 95% interval of P(winner > other) lies."""
    return {1: "supported", -1: "contradicted", 0: "inconclusive"}[stats.side(p)]


def training_scores(metrics_rows: list[dict[str, str]], measure: str) -> dict[str, np.ndarray]:
    """Per-seed training scores {strategy: f[seeds]} (seeds in ascending order)."""
    by: dict[str, dict[int, list[tuple[int, float]]]] = {}
    for r in metrics_rows:
        by.setdefault(row_arm(r), {}).setdefault(int(r["seed"]), []).append(
            (int(r["episode"]), float(r["return"]))
        )
    out = {}
    for strategy, seeds in by.items():
        scores = []
        for seed in sorted(seeds):
            returns = [ret for _, ret in sorted(seeds[seed])]
            if measure == "final_training_return":
                returns = returns[-FINAL_EPISODES:]
            scores.append(np.mean(returns))
        out[strategy] = np.asarray(scores)
    return out


def judge(claim: Claim, mode: str, x: np.ndarray, y: np.ndarray) -> Verdict:
    """The verdict on ``claim`` from per-seed scores of the winner ``x`` and the other ``y``."""
    p = stats.probability_of_improvement_ci(x, y)
    v = verdict(p)
    needed = stats.seeds_to_resolve(p, len(x)) if v == "inconclusive" else math.nan
    return Verdict(claim, mode, len(x), p, v, needed)


def claim_scores(
    experiments: dict[str, tuple[list[dict[str, str]], str]],
) -> list[tuple[Claim, str, np.ndarray, np.ndarray]]:
    """(claim, test mode, winner's scores, other's scores) of every claim whose experiment
    is given; scores are f[seeds] (training) or f[seeds, mazes] (test).

    Args:
      experiments: name -> (metrics.csv rows, results.csv text) of each experiment.
    """
    out = []
    for claim in CLAIMS:
        if claim.experiment not in experiments:
            continue
        rows, results_csv = experiments[claim.experiment]
        w, o = claim.winner, OTHER[claim.winner]
        if claim.measure != "test":
            scores = training_scores(rows, claim.measure)
            out.append((claim, "", scores[w], scores[o]))
            continue
        for mode in MODE_NAMES:
            res = read_results(results_csv, mode)
            if not all((m, s) in {k[:2] for k in res} for m in claim.mazes for s in (w, o)):
                continue
            out.append((claim, mode, *(_test_scores(res, claim.mazes, s) for s in (w, o))))
    return out


def evaluate_claims(
    experiments: dict[str, tuple[list[dict[str, str]], str]],
) -> list[Verdict]:
    """A verdict for every claim whose experiment is given (see :func:`claim_scores`)."""
    return [judge(*c) for c in claim_scores(experiments)]


def _test_scores(results: dict, mazes: tuple[str, ...], strategy: str) -> np.ndarray:
    """f[seeds, mazes]: a row per seed, so a bootstrap draws a seed's mazes together."""
    seeds = sorted({k[2] for k in results if k[1] == strategy})
    return np.stack([per_seed_scores(results, m, strategy, seeds) for m in mazes], axis=1)


def _needed_text(v: Verdict) -> str:
    if v.verdict != "inconclusive":
        return ""
    if math.isinf(v.seeds_needed):
        return "no effect seen"
    if math.isnan(v.seeds_needed):
        return "n/a"
    return f"~{int(v.seeds_needed)}"


def claims_markdown(verdicts: list[Verdict], quick: bool = False) -> str:
    """The claims table, with its rule."""
    n = sorted({v.n_seeds for v in verdicts})
    L = [
        "# The paper's claims, judged",
        "",
        f"Each claim is judged on {'/'.join(map(str, n))} seeds per strategy by "
        "P(claimed winner > other), the probability of improvement over seeds with a 95% "
        "bootstrap interval. Rule: **supported** when the interval lies above 0.5, "
        "**contradicted** when it lies below 0.5, **inconclusive** otherwise; for an "
        "inconclusive claim, the seeds per strategy an interval of the same relative width "
        "would need to exclude 0.5 (a rough extrapolation; 'no effect seen' when P = 0.5). "
        "Learning speed is the mean return over all training episodes (area under the "
        f"training curve); final training return is the mean of the last {FINAL_EPISODES} "
        "training episodes; test claims are judged in both test modes.",
        "",
    ]
    if quick:
        L += [
            "**A quick run on few seeds: these verdicts are not conclusive.**",
            "",
        ]
    L += [
        "| source | claim | test mode | P(winner > other) [95% CI] | verdict | seeds to resolve |",
        "|---|---|---|---|---|---|",
    ]
    for v in verdicts:
        ci = interval(v.p, 2, missing="")
        L.append(
            f"| {v.claim.source} | {v.claim.statement} | {v.mode or 'training'} | {ci} "
            f"| {v.verdict} | {_needed_text(v)} |"
        )
    return "\n".join(L) + "\n"
