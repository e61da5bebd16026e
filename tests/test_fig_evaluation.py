"""The greedy-evaluation figure reads eval.csv's attempt counts as shares of the
decided attempts, checked by hand."""

from __future__ import annotations

import numpy as np

from jaxnav.report.fig_evaluation import plot_greedy_evaluation, read_rates

HEAD = (
    "strategy,seed,env_step,wall_s,return,goals,collided,"
    "attempts,successes,success,collisions,timeouts,cut\n"
)


def test_rates_are_shares_of_the_decided_attempts_and_the_figure_is_drawn(tmp_path):
    rows = [
        # 10 attempts, 2 cut: 8 decided (6 successes, 1 collision, 1 time-out)
        "ebe,0,100,1.0,5.0,6,1,10,6,0.75,1,1,2",
        "ebe,1,100,1.0,5.0,4,0,4,4,1,0,0,0",
        "ebe,0,200,2.0,5.0,3,0,4,3,0.75,0,1,0",
        "ebe,1,200,2.0,5.0,0,0,1,0,,0,0,1",  # every attempt cut: no rate
        "ebe,0,300,3.0,5.0,3,0,3,3,1,0,0,0",  # seed 1 never got here: cut from the curve
    ]
    (tmp_path / "eval.csv").write_text(HEAD + "\n".join(rows) + "\n")
    curves = read_rates(tmp_path / "eval.csv")
    x, rates = curves["ebe"]
    np.testing.assert_array_equal(x, [100, 200])
    np.testing.assert_allclose(rates["success"], [[6 / 8, 3 / 4], [1.0, np.nan]])
    np.testing.assert_allclose(rates["collision"], [[1 / 8, 0.0], [0.0, np.nan]])
    np.testing.assert_allclose(rates["time-out"], [[1 / 8, 1 / 4], [0.0, np.nan]])
    total = rates["success"] + rates["collision"] + rates["time-out"]
    np.testing.assert_allclose(total[np.isfinite(total)], 1.0)
    out = plot_greedy_evaluation(tmp_path, tmp_path / "greedy_evaluation.png")
    assert out is not None and out.stat().st_size > 1000


def test_a_run_without_evaluations_or_attempt_counts_gets_no_figure(tmp_path):
    assert plot_greedy_evaluation(tmp_path, tmp_path / "g.png") is None
    (tmp_path / "eval.csv").write_text("strategy,seed,env_step,wall_s,return\nebe,0,1,1,1\n")
    assert plot_greedy_evaluation(tmp_path, tmp_path / "g.png") is None
    assert not (tmp_path / "g.png").exists()
