"""The paper's claims: the verdict rule, the measures, and every claim judged by name."""

import csv
import io
import math

import numpy as np
import pytest

from jaxnav.report import claims, stats
from jaxnav.report.claims import CLAIMS, claims_markdown, evaluate_claims, training_scores, verdict
from jaxnav.report.results import RESULT_COLUMNS

SEEDS = 6
NO_OBSTACLE_MAZES = ("square4", "square8", "square2", "triangle", "pentagon")
OBSTACLE_MAZES = ("square4_obstacles", "pentagon_obstacles")


def test_the_rule_reads_the_interval_against_one_half():
    assert verdict(stats.Interval(0.8, 0.6, 0.95)) == "supported"
    assert verdict(stats.Interval(0.2, 0.05, 0.4)) == "contradicted"
    assert verdict(stats.Interval(0.55, 0.4, 0.7)) == "inconclusive"
    assert verdict(stats.Interval(0.5, 0.5, 0.6)) == "inconclusive"  # touching 0.5
    assert verdict(stats.Interval(1.0, math.nan, math.nan)) == "inconclusive"  # one seed


def _metrics_rows(ebe_curve, eps_curve):
    rows = []
    for strategy, curve in (("ebe", ebe_curve), ("epsilon_greedy", eps_curve)):
        for seed in range(SEEDS):
            for e, ret in enumerate(curve(seed)):
                rows.append(
                    {"strategy": strategy, "seed": str(seed), "episode": str(e), "return": str(ret)}
                )
    return rows


def _results_csv(score):
    """results.csv text; score(mode, maze, strategy, seed) -> each episode's return."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(RESULT_COLUMNS)
    mazes = NO_OBSTACLE_MAZES + OBSTACLE_MAZES
    for mode in ("greedy", "exploring"):
        for maze in mazes:
            for strategy in ("ebe", "epsilon_greedy"):
                for seed in range(SEEDS):
                    for e in range(3):
                        ret = score(mode, maze, strategy, seed) + e
                        w.writerow([strategy, seed, mode, maze, e, ret, 1, 0, 100])
    return buf.getvalue()


def test_training_measures_are_the_whole_curve_and_its_last_50_episodes():
    # EBE: 0 for 100 episodes then 10; epsilon-greedy: 5 throughout
    rows = _metrics_rows(lambda s: [0.0] * 100 + [10.0] * 100, lambda s: [5.0 + s] * 200)
    auc = training_scores(rows, "learning_speed")
    final = training_scores(rows, "final_training_return")
    np.testing.assert_allclose(auc["ebe"], 5.0)
    np.testing.assert_allclose(final["ebe"], 10.0)
    np.testing.assert_allclose(auc["epsilon_greedy"], 5.0 + np.arange(SEEDS))


@pytest.mark.slow  # 4 s on 2 cores
def test_every_claim_is_judged_by_name_in_both_test_modes():
    """EBE learns faster but ends lower in training; it wins every test in the greedy
    mode and loses every test while exploring; square2 is a tie."""
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 1, size=(2, 7, 2, SEEDS))
    mazes = NO_OBSTACLE_MAZES + OBSTACLE_MAZES

    def score(mode, maze, strategy, seed):
        if maze == "square2":
            return 100.0 + noise[0, 0, 0, seed]  # both strategies alike, same draws
        sign = 1.0 if (strategy == "ebe") == (mode == "greedy") else -1.0
        m = 0 if mode == "greedy" else 1
        return 100.0 + 50.0 * sign + noise[m, mazes.index(maze), 0, seed]

    rows = _metrics_rows(
        lambda s: [10.0] * 150 + [20.0] * 50, lambda s: [0.0] * 150 + [30.0 + s] * 50
    )
    text = _results_csv(score)
    got = evaluate_claims({"paper_no_obstacles": (rows, text), "paper_obstacles": (rows, text)})
    by = {(v.claim.source, v.claim.statement, v.mode): v for v in got}
    training = [c for c in CLAIMS if c.measure != "test"]
    tests = [c for c in CLAIMS if c.measure == "test"]
    assert len(got) == len(training) + 2 * len(tests)
    for c in training:
        v = by[(c.source, c.statement, "")]
        want = "supported" if c.measure == "learning_speed" else "contradicted"
        assert v.verdict == want, c
        assert v.n_seeds == SEEDS
    for c in tests:
        greedy, exploring = (
            by[(c.source, c.statement, "greedy")],
            by[(c.source, c.statement, "exploring")],
        )
        if "square2" in c.mazes and len(c.mazes) == 1:
            assert greedy.verdict == exploring.verdict == "inconclusive"
            assert greedy.p.value == 0.5 and math.isinf(greedy.seeds_needed)
        elif len(c.mazes) > 1:  # averaged over the five mazes, square2's tie included
            assert greedy.p.value == pytest.approx(0.9)
        else:
            assert (greedy.verdict, exploring.verdict) == ("supported", "contradicted"), c
    md = claims_markdown(got)
    assert md.count("\n| ") == 1 + len(got)  # header + one row per verdict
    assert (
        "| Table 3 text | the exception: epsilon-greedy scores higher on square2 | greedy |" in md
    )
    assert "not conclusive" in claims_markdown(got, quick=True)


@pytest.mark.slow  # 4 s on 2 cores
def test_the_pooled_claim_draws_each_seed_over_all_mazes():
    """The Table 3 average is P over f[seeds, mazes] rows, as jaxnav.report.stats resamples it."""

    def score(mode, maze, strategy, seed):
        return 100.0 + seed * (1 if strategy == "ebe" else -1) * (
            NO_OBSTACLE_MAZES.index(maze) - 2 if maze in NO_OBSTACLE_MAZES else 1
        )

    text = _results_csv(score)
    rows = _metrics_rows(lambda s: [1.0] * 60, lambda s: [1.0] * 60)
    got = evaluate_claims({"paper_no_obstacles": (rows, text)})
    pooled = next(v for v in got if len(v.claim.mazes) == 5 and v.mode == "greedy")
    x = np.array(
        [[score("greedy", m, "ebe", k) + 1 for m in NO_OBSTACLE_MAZES] for k in range(SEEDS)]
    )
    y = np.array(
        [
            [score("greedy", m, "epsilon_greedy", k) + 1 for m in NO_OBSTACLE_MAZES]
            for k in range(SEEDS)
        ]
    )
    assert pooled.p == stats.probability_of_improvement_ci(x, y)
    assert {v.claim.experiment for v in got} == {"paper_no_obstacles"}  # only what is given
    assert claims.OTHER["ebe"] == "epsilon_greedy"


def test_training_table_is_computed_from_metrics_rows():
    from jaxnav.report.tables import training_markdown

    rows = []
    for seed, (early, late) in enumerate([(0.0, 100.0), (0.0, 300.0)]):
        for e in range(60):
            ret = early if e < 10 else late
            rows.append(
                {
                    "strategy": "ebe",
                    "seed": str(seed),
                    "episode": str(e),
                    "return": str(ret),
                    "goals": "2",
                    "collided": str(int(e % 2 == 0)),
                }
            )
    md = training_markdown(rows, last=50)
    cells = [c.strip() for c in md.splitlines()[-1].strip("|").split("|")]
    # last 50: 100 and 300 -> 200; all 60: (50*100)/60 and (50*300)/60 -> 166.7
    assert cells[:2] == ["EBE", "2"]
    assert cells[2].startswith("200 [100, 300]")
    assert cells[3].startswith("2.00 [2.00, 2.00]") and cells[4].startswith("0.50 [")
    assert cells[5].startswith(f"{(50 * 100 / 60 + 50 * 300 / 60) / 2:.0f} [")
