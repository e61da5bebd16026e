"""Navigation metrics per goal attempt on hand-made trajectories, computed by hand."""

from __future__ import annotations

import numpy as np
import pytest

from jaxnav.core.rundir import csv_text
from jaxnav.report.nav_tables import navigation_text
from jaxnav.report.navigation import (
    COLLISION,
    METRICS,
    SUCCESS,
    TIMEOUT,
    episode_counts,
    seed_metrics,
    split_attempts,
)
from jaxnav.report.results import RESULT_COLUMNS, read_results
from jaxnav.report.tables import tables_markdown

STEP_M, DT = 0.03, 0.2  # 0.15 m/s for 0.2 s


def steps(*episodes):
    """Per-step arrays of episodes given as lists of (x, y, goal x, goal y, flag), the
    flag "" (on), "reach" or "hit"; a last step after the test (episode 99)."""
    rows = [(e, *s) for e, ep in enumerate(episodes) for s in ep] + [(99, 0, 0, 0, 0, "")]
    episode = np.array([r[0] for r in rows])
    pos = np.array([r[1:3] for r in rows], float)
    goal = np.array([r[3:5] for r in rows], float)
    reached = np.array([r[5] == "reach" for r in rows])
    collided = np.array([r[5] == "hit" for r in rows])
    return pos, goal, reached, collided, episode


# Episode 0: the goal (1, 0) reached on the 3rd step, the next goal (0, 2) tried from
# (0.09, 0) and a collision on the 2nd step. Episode 1 restarts at (0, 0) with that goal
# and reaches it on its last (4th) step, which ends the episode: the goal drawn then
# has no step and no attempt.
EPISODES = (
    [(0, 0, 1, 0, ""), (0.03, 0, 1, 0, ""), (0.06, 0, 1, 0, "reach"),
     (0.09, 0, 0, 2, ""), (0.09, 0.03, 0, 2, "hit")],
    [(0, 0, 0, 2, ""), (0, 0.03, 0, 2, ""), (0, 0.06, 0, 2, ""), (0, 0.09, 0, 2, "reach")],
)  # fmt: skip


def test_attempts_start_at_each_goal_and_restart_and_end_at_goal_collision_or_limit():
    att = split_attempts(*steps(*EPISODES), n_episodes=2)
    np.testing.assert_array_equal(att.episode, [0, 0, 1])
    np.testing.assert_array_equal(att.start, [[0, 0], [0.09, 0], [0, 0]])
    np.testing.assert_array_equal(att.goal, [[1, 0], [0, 2], [0, 2]])
    np.testing.assert_array_equal(att.steps, [3, 2, 4])
    np.testing.assert_array_equal(att.outcome, [SUCCESS, COLLISION, SUCCESS])


def test_an_episode_at_the_step_limit_ends_its_attempt_in_a_timeout():
    ep = [(0, 0, 1, 0, ""), (0, 0.03, 1, 0, "")]
    att = split_attempts(*steps(ep, ep), n_episodes=2)
    np.testing.assert_array_equal(att.outcome, [TIMEOUT, TIMEOUT])
    np.testing.assert_array_equal(att.steps, [2, 2])


def test_rates_path_spl_and_time_by_hand():
    att = split_attempts(*steps(*EPISODES), n_episodes=2)
    # shortest paths 0.06 and 0.1 m for the successes (driven: 0.09 and 0.12 m), 2.1 m
    counts = episode_counts(att, np.array([0.06, 2.1, 0.1]), STEP_M, DT, n_episodes=2)
    np.testing.assert_allclose(counts["attempts"], [2, 1])
    np.testing.assert_allclose(counts["successes"], [1, 1])
    np.testing.assert_allclose(counts["timeouts"], [0, 0])
    np.testing.assert_allclose(counts["path_m"], [0.09 + 0.06, 0.12])
    np.testing.assert_allclose(counts["spl_sum"], [0.06 / 0.09, 0.1 / 0.12])
    np.testing.assert_allclose(counts["time_s"], [0.6, 0.8])
    m = seed_metrics(dict(counts, collided=np.array([1, 0])))
    assert m["success"] == pytest.approx(2 / 3)
    assert m["collision"] == pytest.approx(1 / 3)
    assert m["timeout"] == 0
    assert m["success"] + m["collision"] + m["timeout"] == pytest.approx(1)
    assert m["path_length_m"] == pytest.approx((0.09 + 0.06 + 0.12) / 3)
    assert m["spl"] == pytest.approx((0.06 / 0.09 + 0 + 0.1 / 0.12) / 3)
    assert m["time_to_goal_s"] == pytest.approx((0.6 + 0.8) / 2)


def test_a_path_shorter_than_the_shortest_counts_one_and_a_failure_zero():
    """SPL's max(p, l): reaching within the goal radius can take fewer metres than the
    path to the goal's centre; the term is then 1, never more."""
    ep = [(0, 0, 0.2, 0, ""), (0.03, 0, 0.2, 0, "reach")]
    att = split_attempts(*steps(ep, [(0, 0, 5, 5, "hit")]), n_episodes=2)
    counts = episode_counts(att, np.array([0.2, 7.0]), STEP_M, DT, n_episodes=2)
    np.testing.assert_allclose(counts["spl_sum"], [1.0, 0.0])


def test_no_success_has_no_time_to_goal_and_rates_still_sum_to_one():
    ep = [(0, 0, 1, 0, ""), (0, 0.03, 1, 0, "hit")]
    att = split_attempts(*steps(ep, ep[:1]), n_episodes=2)
    m = seed_metrics(dict(episode_counts(att, np.ones(2), STEP_M, DT, 2), collided=[1, 0]))
    assert np.isnan(m["time_to_goal_s"]) and m["spl"] == 0
    assert (m["success"], m["collision"], m["timeout"]) == (0, 0.5, 0.5)


def results_text(per_seed_counts):
    """results.csv text of one maze, arm "ebe", one row per (seed, episode)."""
    rows = []
    for seed, episodes in enumerate(per_seed_counts):
        for e, (collided, att, succ, tout, path, spl, time) in enumerate(episodes):
            rows.append(
                ("ebe", seed, "greedy", "square4", e, "1.0", succ, collided, 10)
                + (att, succ, tout, path, spl, time)
            )
    return csv_text(RESULT_COLUMNS, rows)


def test_seed_rates_pool_attempts_and_tables_show_them_with_intervals():
    text = results_text(
        [
            [(1, 3, 2, 0, 1.2, 1.5, 4.0), (0, 1, 0, 1, 3.0, 0.0, 0.0)],  # 2 of 4 attempts
            [(0, 2, 1, 1, 2.0, 0.5, 2.0)],  # 1 of 2 attempts
        ]
    )
    res = read_results(text)
    seed0 = seed_metrics(res[("square4", "ebe", 0)])
    assert seed0 == pytest.approx(
        dict(
            success=2 / 4, collision=1 / 4, timeout=1 / 4, path_length_m=4.2 / 4, spl=1.5 / 4,
            time_to_goal_s=4.0 / 2,
        )
    )  # fmt: skip
    seed1 = seed_metrics(res[("square4", "ebe", 1)])
    tables = tables_markdown(text, "square4", 0)
    header = next(ln for ln in tables.splitlines() if ln.startswith("| maze | strategy | success"))
    assert header == "| maze | strategy | " + " | ".join(METRICS) + " |"
    row = tables.splitlines()[tables.splitlines().index(header) + 2]
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:2] == ["square4", "EBE"]
    for cell, m in zip(cells[2:], METRICS):
        mean = (seed0[m] + seed1[m]) / 2
        assert cell.startswith(f"{mean:.{1 if m == 'time_to_goal_s' else 2}f} ["), (m, cell)
    printed = navigation_text([dict(zip(RESULT_COLUMNS, r.split(","))) for r in text.split()[1:]])
    assert printed.splitlines()[1].split()[:3] == ["ebe", "2", f"{(0.5 + 0.5) / 2:.2f}"]


def test_results_written_before_the_counts_give_no_navigation_table():
    text = csv_text(RESULT_COLUMNS[:9], [("ebe", 0, "greedy", "square4", 0, "1.0", 1, 0, 10)])
    assert "Navigation" not in tables_markdown(text, "square4", 0)
    assert navigation_text([dict(zip(RESULT_COLUMNS[:9], text.split()[1].split(",")))]) == ""
