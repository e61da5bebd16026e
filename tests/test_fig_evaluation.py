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


def test_one_evaluation_per_run_draws_no_figure_and_says_why(tmp_path):
    """run.eval_every as long as the budget left one point per panel, on an axis of a
    few thousand steps around it: no figure, and a line pointing at eval.csv."""
    from jaxnav.report.fig_evaluation import greedy_evaluation_note

    rows = ["ebe,0,81920,1.0,5.0,6,0,6,6,1,0,0,0", "ebe,1,81920,1.0,5.0,5,0,5,5,1,0,0,0"]
    (tmp_path / "eval.csv").write_text(HEAD + "\n".join(rows) + "\n")
    assert plot_greedy_evaluation(tmp_path, tmp_path / "g.png") is None
    assert not (tmp_path / "g.png").exists()
    note = greedy_evaluation_note(tmp_path)
    assert "1 greedy evaluation per run" in note and "eval.csv" in note


def test_failures_at_one_place_are_one_marker_with_their_count(tmp_path):
    """A failure map said "3 collisions" over one visible cross: a greedy policy that
    replays a failure ends it at the same pose every time."""
    from matplotlib.figure import Figure

    from jaxnav.report import fig_failures
    from jaxnav.world.maps import make_maze

    same = np.array([[0.5, 0.5], [0.5, 0.5], [0.505, 0.5], [-1.0, 0.2]])
    places, counts = fig_failures.stacked(same)
    np.testing.assert_allclose(places, [[0.5, 0.5], [-1.0, 0.2]])
    assert counts.tolist() == [3, 1]
    ax = Figure().add_subplot()
    fig_failures._mark(ax, same, "crimson", marker="x", s=28, color="crimson")
    assert [t.get_text() for t in ax.texts] == ["3"]  # the count beside the marker
    out = fig_failures.plot_failures(
        make_maze("square4"),
        "square4",
        {"ebe": {"collision": same, "timeout": np.zeros((0, 2))}},
        2,
        10,
        tmp_path / "f.png",
    )
    assert out.stat().st_size > 1000
