"""A study of exploring (a ladder whose runs recorded what they explored): each seed's
steps to its first goal, its coverage, its steps to 90% of the oracle and its area under
the success curve, against hand-computed values and rliable's own statistic; where EBE
ranks; and the page and its one sentence from the data alone."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from rliable import metrics

from jaxnav.experiments import ladder
from jaxnav.report import exploring, study_pages
from jaxnav.report.ladder import Data

METHODS = ("ebe", "epsilon_greedy", "boltzmann", "rnd", "noisy", "count")
STEPS = (100, 200, 300, 400)  # the evaluations along a budget of 400 env steps
# world a: each method's greedy success at each evaluation (every seed alike), the env
# step of its first goal ("" never) and its coverage at the last evaluation
CURVES = {
    "ebe": ((0.5, 0.95, 1.0, 1.0), "60", 0.5),  # reaches 90% of the oracle at 200
    "epsilon_greedy": ((0.0, 0.0, 0.0, 0.0), "", 0.2),  # never
    "boltzmann": ((0.0, 0.2, 0.5, 0.92), "150", 0.3),  # at 400
    "rnd": ((0.9, 1.0, 1.0, 1.0), "40", 0.7),  # at 100
    "noisy": ((0.0, 0.0, 0.3, 0.5), "250", 0.4),  # never
    "count": ((0.95, 1.0, 1.0, 1.0), "20", 0.9),  # at 100, the best area
}
STUDY = """\
title: Tiny exploring
seeds: 16
total_steps: 400
test_episodes: 2
eval_points: 4
strategies: [ebe, epsilon_greedy, boltzmann, rnd, noisy, count]
settings: {run: {coverage: true, eval_episodes: 2}}
agents:
  recipe: {label: PQN}
rungs:
  a:
    label: world a
    config: explore
    settings: {env: {maze: configs/mazes/uturn.yaml, max_steps: 300}}
  b: {label: world b, config: explore, settings: {env: {maze: configs/mazes/serpentine3.yaml}}}
"""


def _synthetic(folder: Path, n: int = 16) -> None:
    """World a as :data:`CURVES` says; on world b every method's seeds drawn alike."""
    rng = np.random.default_rng(0)
    folder.mkdir()
    (folder / "study.yaml").write_text(STUDY)
    scores, evals = [], []
    for rung in ("a", "b"):
        for m in METHODS:
            curve, first, cover = CURVES[m]
            for seed in range(n):
                final = curve[-1] if rung == "a" else float(rng.uniform(0.3, 0.7))
                scores.append([rung, "recipe", m, seed, "own", 2, 4, 0, final, final, 0, 0, 1])
                for k, step in enumerate(STEPS):
                    s = curve[k] if rung == "a" else float(rng.uniform(0.0, 1.0))
                    f = first if rung == "a" else str(int(rng.integers(10, 400)))
                    c = cover * (k + 1) / 4 if rung == "a" else float(rng.uniform(0.1, 0.9))
                    evals.append([rung, "recipe", m, seed, step, step / 10, s, 0.0, f, c])
        for seed in range(n):
            scores.append([rung, "recipe", "oracle", seed, "own", 2, 4, 0, 1.0, 1.0, 0, 0, 1])
    for name, head, rows in (
        ("scores.csv", ladder.SCORE_COLUMNS, scores),
        ("evals.csv", ladder.EVAL_COLUMNS + ladder.EXPLORED_COLUMNS, evals),
    ):
        with open(folder / name, "w", newline="") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(head)
            w.writerows(rows)
    (folder / "curves.csv").write_text("rung,agent,strategy,share,goals,low,high\n")
    (folder / "cells.csv").write_text(
        "rung,agent,runs,env_steps,train_s,test_s,transitions_per_s,compile_s\n"
        "a,recipe,96,1,60,6,1000,1\nb,recipe,96,1,54,0,1000,1\n"
    )
    (folder / "run.json").write_text(json.dumps({"command": "c", "machine": "m"}))


def test_the_measures_of_exploring_by_hand(tmp_path):
    _synthetic(tmp_path / "d")
    E = exploring.Exploring(Data(tmp_path / "d"))
    for m, (curve, first, cover) in CURVES.items():
        got = E.per_seed("a", "recipe", m, "first_goal")
        # fewer is better: negated; never ranks below all (twice the budget)
        assert np.all(got == -(float(first) if first else 800.0))
        assert E.per_seed("a", "recipe", m, "coverage") == pytest.approx(np.full(16, cover))
        assert E.per_seed("a", "recipe", m, "auc") == pytest.approx(np.full(16, np.mean(curve)))
    reach = {m: E.reached("a", "recipe", m)[0][0] for m in METHODS}
    assert reach == {"ebe": 200, "epsilon_greedy": np.inf, "boltzmann": 400, "rnd": 100,
                     "noisy": np.inf, "count": 100}  # fmt: skip
    reaching = [m for m in METHODS if E.reaches("a", "recipe", m)]
    assert reaching == ["ebe", "boltzmann", "rnd", "count"]
    # best area first: count (0.9875) over rnd (0.975), then EBE (0.8625): third
    assert E.ranking("a", "recipe")[:3] == ["count", "rnd", "ebe"]


@pytest.mark.slow  # 7 s on 2 cores
def test_verdicts_are_rliables_probability_of_improvement(tmp_path):
    _synthetic(tmp_path / "d")
    E = exploring.Exploring(Data(tmp_path / "d"))
    for other in E.others():
        for measure in exploring.MEASURES:
            x = E.per_seed("a", "recipe", "ebe", measure)
            y = E.per_seed("a", "recipe", other, measure)
            p, _ = E.compare_with("a", "recipe", other, measure)
            want = float(metrics.probability_of_improvement(x[:, None], y[:, None]))
            assert p.value == pytest.approx(want)
    assert E.compare_with("a", "recipe", "epsilon_greedy", "first_goal")[1] == "EBE better"
    assert E.compare_with("a", "recipe", "count", "coverage")[1] == "EBE worse"
    assert E.compare_with("b", "recipe", "rnd", "auc")[1] == "no detectable difference"


@pytest.mark.slow  # 52 s on 2 cores
def test_the_page_and_its_sentence_come_from_the_data(tmp_path):
    folder = tmp_path / "d"
    _synthetic(folder)
    assert study_pages.of_exploring(folder) and study_pages.of_learning(folder)
    sentence = study_pages.sentence(folder)
    assert sentence.startswith("On 2 worlds whose goal lies behind walls, with the sparse")
    assert (
        "Boltzmann on 1, RND on 1, count bonus on 1, epsilon-greedy on 0, NoisyNets on 0 of 2 "
        "(epsilon-greedy not on world a, world b)" in sentence
    )
    assert "EBE ranks 3rd and " in sentence
    text = study_pages.page(folder, "x")
    assert text == exploring.exploring_markdown(folder, "x")
    for part in ("## Which methods reach the oracle, and how soon", "## Where EBE ranks",
                 "| world a | 3 of 6 |", "x-coverage.png", "sooner to the first goal"):  # fmt: skip
        assert part in text
    written = study_pages.figures(folder, tmp_path, "x")
    assert [p.name for p in written] == ["x-success.png", "x-coverage.png"]


def test_a_study_of_learning_without_coverage_keeps_its_own_page(tmp_path):
    from tests.test_learning import _with_evals

    _with_evals(tmp_path / "d")
    assert not study_pages.of_exploring(tmp_path / "d")
    assert study_pages.figure_names(tmp_path / "d") == ("success.png", "measures.png",
                                                        "trajectories.png")  # fmt: skip
