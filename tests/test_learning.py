"""A study of learning (a ladder with ``eval_points``): each seed's steps to 90% of the
oracle's success and the area under its success curve, against hand-computed values and
rliable's own statistic, and its page from its data alone."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from rliable import metrics

from jaxnav.experiments import ladder
from jaxnav.report import heldout, learning, study_pages
from jaxnav.report import ladder as page
from tests.test_ladder import STUDY, _synthetic

STEPS = (100, 200, 300, 400)  # the evaluations along a budget of 400 env steps
CURVES = {  # rung a's greedy success at each evaluation, the same for every seed
    "ebe": (0.5, 0.95, 1.0, 1.0),  # reaches 90% of the oracle's 1.0 at 200 steps
    "epsilon_greedy": (0.2, 0.5, 0.92, 1.0),  # at 300
    "boltzmann": (0.1, 0.2, 0.3, 0.4),  # never
}


def _with_evals(folder: Path, n: int = 16) -> None:
    """:func:`tests.test_ladder._synthetic` with evaluations while training: on rung a
    :data:`CURVES`; on rung b, every strategy's seeds drawn from one distribution."""
    _synthetic(folder, n)
    rng = np.random.default_rng(1)
    with open(folder / "evals.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(ladder.EVAL_COLUMNS)
        for rung in ("a", "b"):
            for strategy, curve in CURVES.items():
                for seed in range(n):
                    for k, step in enumerate(STEPS):
                        s = curve[k] if rung == "a" else float(rng.uniform(0.0, 1.0))
                        w.writerow([rung, "dqn", strategy, seed, step, step / 10, s, 0.0])


def test_steps_to_90_percent_of_the_oracle_and_the_area_by_hand(tmp_path):
    _with_evals(tmp_path / "d")
    L = learning.Learning(page.Data(tmp_path / "d"))
    assert L.target("a") == pytest.approx(0.9)  # 90% of the oracle's 1.0
    steps, secs = L.reached("a", "dqn", "ebe")
    # the cell's 60 s of training ended at its last evaluation, 40 s on the evaluations'
    # clock: it began at -20 s, and 20 s on that clock is 40 s into training
    assert np.all(steps == 200) and np.all(secs == 40)
    assert np.all(L.reached("a", "dqn", "epsilon_greedy")[0] == 300)
    assert np.all(np.isinf(L.reached("a", "dqn", "boltzmann")[0]))
    # never ranks below every seed that reaches it: twice the budget, negated
    assert np.all(L.per_seed("a", "dqn", "boltzmann", "reach") == -800)
    for strategy, curve in CURVES.items():
        auc = L.per_seed("a", "dqn", strategy, "auc")
        assert auc == pytest.approx(np.full(16, sum(curve) / 4))
    # collisions: less is better, so the score is negated
    x = L.per_seed("a", "dqn", "ebe", "collision")
    assert np.all(x == -page.Data(tmp_path / "d").per_seed("a", "dqn", "own", "ebe", "collision"))


@pytest.mark.slow  # 4 s on 2 cores
def test_verdicts_are_rliables_probability_of_improvement_on_each_measure(tmp_path):
    _with_evals(tmp_path / "d")
    L = learning.Learning(page.Data(tmp_path / "d"))
    for other in ("epsilon_greedy", "boltzmann"):
        for measure in learning.MEASURES:
            x = L.per_seed("a", "dqn", "ebe", measure)
            y = L.per_seed("a", "dqn", other, measure)
            p, word = L.compare("a", "dqn", other, measure)
            want = float(metrics.probability_of_improvement(x[:, None], y[:, None]))
            assert p.value == pytest.approx(want)
        assert L.compare("a", "dqn", other, "reach")[1] == "EBE better"
        assert L.compare("a", "dqn", other, "auc")[1] == "EBE better"
    # every strategy's seeds from one distribution: no detectable difference
    p, word = L.compare("b", "dqn", "epsilon_greedy", "auc")
    assert word == "no detectable difference" and p.low < 0.5 < p.high


@pytest.mark.slow
def test_the_page_and_its_sentence_come_from_the_data(tmp_path):
    folder = tmp_path / "d"
    _with_evals(folder)
    data = page.Data(folder)
    sentence = study_pages.sentence(folder)
    assert sentence == learning.summary_sentence(data)
    assert sentence.startswith("On the 1 of 2 worlds that an arm drives within 0.02 of the oracle")
    assert "sooner than epsilon-greedy in 1 of 1 world and agent cell, later in 0" in sentence
    text = study_pages.page(folder, "x")
    assert text == learning.learning_markdown(folder, "x")
    for part in ("## How fast each arm learns", "## EBE against epsilon-greedy",
                 "## EBE against Boltzmann", "16 of 16", "x-success.png"):  # fmt: skip
        assert part in text
    # the trajectory figure's world: the hardest with a fixed maze that an arm solves
    assert page.trajectory_cell(data) == ("a", "dqn")
    assert study_pages.figure_names(folder) == learning.FIGURES
    written = study_pages.figures(folder, tmp_path, "x")
    assert [p.name for p in written] == ["x-success.png", "x-measures.png"]


def test_an_agent_may_train_on_some_rungs_only():
    two = "  dqn: {label: DQN}\n  two: {rungs: [grid4_dense]}"
    text = STUDY.replace("  dqn: {label: DQN}", two)
    study = ladder.parse_study(text, "x")
    assert [(r.name, a.name) for r, a in study.cells()] == [
        ("square4_dense", "dqn"),
        ("grid4_dense", "dqn"),
        ("grid4_dense", "two"),
    ]


def test_evaluations_along_the_budget_are_chunk_ends():
    study = ladder.parse_study(STUDY.replace("seeds: 2", "seeds: 2\neval_points: 2"), "x")
    cfg = ladder.cell_config(study, *study.cells()[0])
    assert cfg.run.eval_every == 256 == cfg.run.chunk_steps


def test_a_resumed_cells_seconds_are_not_given(tmp_path):
    folder = tmp_path / "d"
    _with_evals(folder)
    text = (folder / "evals.csv").read_text().splitlines()
    # the clock of rung a's last evaluation restarted (a resumed command)
    rows = [r.replace(",400,40.0,", ",400,3.0,") if r.startswith("a,") else r for r in text]
    (folder / "evals.csv").write_text("\n".join(rows) + "\n")
    L = learning.Learning(page.Data(folder))
    assert L.resumed("a", "dqn") and not L.resumed("b", "dqn")
    steps, secs = L.reached("a", "dqn", "ebe")
    assert np.all(steps == 200) and np.all(np.isnan(secs))
    assert "n/a (resumed)" in learning.learning_table(L)[2]


def test_the_held_out_sentence_counts_the_verdicts_and_means_by_hand(tmp_path):
    """Two tests on a kind of world no rung trained on: on rung a EBE reaches every goal
    and the others about half (EBE better than both), on rung b all three succeed alike."""
    folder = tmp_path / "d"
    _with_evals(folder)
    rng = np.random.default_rng(3)
    rows, want = [], {"ebe": [], "epsilon_greedy": [], "boltzmann": []}
    for rung in ("a", "b"):
        for strategy in want:
            x = np.ones(16) if rung == "a" and strategy == "ebe" else rng.uniform(0.3, 0.7, 16)
            want[strategy].append(x.mean())
            office = "configs/mazes/office.yaml"
            rows += [[rung, "dqn", strategy, seed, office, 2, 4, 0, s, s, 0, 0, s]
                     for seed, s in enumerate(x)]  # fmt: skip
        # the oracle drove the same test: every goal on rung a, 0.9 of them on rung b
        s = 1.0 if rung == "a" else 0.9
        rows += [
            [rung, "dqn", "oracle", seed, office, 2, 4, 0, s, s, 0, 0, s] for seed in range(16)
        ]
    with open(folder / "scores.csv", "a", newline="") as f:
        csv.writer(f, lineterminator="\n").writerows(rows)
    text = heldout.held_out_sentence(page.Data(folder))
    assert "(office; 2 tests, one per world and agent trained)" in text
    assert "than epsilon-greedy's in 1, a lower one in 0 and no detectable difference in 1" in text
    assert "than Boltzmann's in 1, a lower one in 0 and no detectable difference in 1" in text
    means = ", ".join(f"{page.NAMES[s]} {np.mean(v):.2f}" for s, v in want.items())
    # beside them the oracle's on the same tests (no DWA rows: no DWA figure)
    assert text.endswith(f"mean success over those tests: {means}, the oracle 0.95.")
    # a study without such a test says so
    _with_evals(tmp_path / "e")
    assert heldout.held_out_sentence(page.Data(tmp_path / "e")).startswith("No policy")
