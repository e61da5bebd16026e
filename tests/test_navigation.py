"""Navigation metrics per goal attempt on hand-made trajectories, computed by hand."""

from __future__ import annotations

import numpy as np
import pytest

from jaxnav.core.rundir import csv_text
from jaxnav.report.nav_tables import navigation_text
from jaxnav.report.navigation import (
    COLLISION,
    CUT,
    METRICS,
    SMOOTH_METRICS,
    SUCCESS,
    TIMEOUT,
    episode_counts,
    seed_metrics,
    smoothness,
    split_attempts,
    training_outcomes,
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


LIMIT = 5  # the attempt limit of the hand-made episodes above: none reaches it


def test_attempts_start_at_each_goal_and_restart_and_end_at_goal_collision_or_limit():
    att = split_attempts(*steps(*EPISODES), n_episodes=2, limit=LIMIT)
    np.testing.assert_array_equal(att.episode, [0, 0, 1])
    np.testing.assert_array_equal(att.start, [[0, 0], [0.09, 0], [0, 0]])
    np.testing.assert_array_equal(att.goal, [[1, 0], [0, 2], [0, 2]])
    np.testing.assert_array_equal(att.steps, [3, 2, 4])
    np.testing.assert_array_equal(att.outcome, [SUCCESS, COLLISION, SUCCESS])
    # where each ended: the position before its last step (the collision's: (0.09, 0.03))
    np.testing.assert_array_equal(att.end, [[0.06, 0], [0.09, 0.03], [0, 0.09]])


def test_an_attempt_cut_by_the_episode_end_before_its_limit_is_cut_not_a_timeout():
    ep = [(0, 0, 1, 0, ""), (0, 0.03, 1, 0, "")]
    att = split_attempts(*steps(ep, ep), n_episodes=2, limit=3)
    np.testing.assert_array_equal(att.outcome, [CUT, CUT])
    np.testing.assert_array_equal(att.steps, [2, 2])


def test_an_attempt_that_uses_its_whole_limit_is_a_timeout():
    """The default limit is the episode's step limit: an attempt spanning a whole
    episode (2 steps here) is a real time-out."""
    ep = [(0, 0, 1, 0, ""), (0, 0.03, 1, 0, "")]
    att = split_attempts(*steps(ep, ep), n_episodes=2, limit=2)
    np.testing.assert_array_equal(att.outcome, [TIMEOUT, TIMEOUT])


def test_a_goal_reached_on_the_last_step_of_the_limit_is_a_success_and_opens_no_attempt():
    ep = [(0, 0, 1, 0, ""), (0, 0.03, 1, 0, ""), (0, 0.06, 1, 0, "reach")]
    att = split_attempts(*steps(ep), n_episodes=1, limit=3)
    np.testing.assert_array_equal(att.outcome, [SUCCESS])
    np.testing.assert_array_equal(att.steps, [3])


def test_a_collision_on_the_last_step_of_the_limit_is_a_collision():
    ep = [(0, 0, 1, 0, ""), (0, 0.03, 1, 0, ""), (0, 0.06, 1, 0, "hit")]
    att = split_attempts(*steps(ep), n_episodes=1, limit=3)
    np.testing.assert_array_equal(att.outcome, [COLLISION])


def test_a_goal_or_collision_after_the_limit_is_a_timeout_and_the_next_attempt_goes_on():
    ep = [(0, 0, 1, 0, ""), (0, 0.03, 1, 0, ""), (0, 0.06, 1, 0, "reach"),
          (0, 0.06, 2, 0, ""), (0, 0.06, 2, 0, "hit")]  # fmt: skip
    att = split_attempts(*steps(ep), n_episodes=1, limit=2)
    np.testing.assert_array_equal(att.outcome, [TIMEOUT, COLLISION])
    att = split_attempts(*steps(ep), n_episodes=1, limit=1)
    np.testing.assert_array_equal(att.outcome, [TIMEOUT, TIMEOUT])


def test_several_goals_per_episode_and_the_last_cut_give_success_one():
    """Three goals reached in an episode, the fourth chased when the step limit comes:
    success is 3 of 3 decided attempts, not 3 of 4 (the cap near G / (G + 1) that the
    old count put on every driver), and the cut attempt is counted on its own."""
    ep = [(0, 0, 1, 0, "reach"), (0, 0, 2, 0, "reach"), (0, 0, 3, 0, "reach"),
          (0, 0, 4, 0, ""), (0, 0, 4, 0, "")]  # fmt: skip
    att = split_attempts(*steps(ep), n_episodes=1, limit=5)
    np.testing.assert_array_equal(att.outcome, [SUCCESS, SUCCESS, SUCCESS, CUT])
    counts = episode_counts(att, np.full(4, 0.01), STEP_M, DT, n_episodes=1)
    m = seed_metrics(dict(counts, collided=np.array([0])))
    assert (m["success"], m["collision"], m["timeout"], m["cut"]) == (1, 0, 0, 1)
    assert m["goals_per_min"] == pytest.approx(3 / (5 * DT / 60))


def test_an_attempts_path_is_what_its_steps_drove_when_they_say():
    """With a stop in the action set a step may drive 0 m: the path is the steps'
    travel, not the steps times 0.15 m/s x 0.2 s."""
    travel = np.array([0.03, 0.0, 0.0, 0.044, 0.0])  # the last: after the test
    att = split_attempts(*steps(*EPISODES[1:]), n_episodes=1, limit=LIMIT, travel=travel)
    np.testing.assert_allclose(att.path, [0.074])
    counts = episode_counts(att, np.array([0.05]), STEP_M, DT, n_episodes=1)
    np.testing.assert_allclose(counts["path_m"], [0.074])
    np.testing.assert_allclose(counts["spl_sum"], [0.05 / 0.074])


def test_smoothness_sums_the_command_changes_within_each_attempt_by_hand():
    """Episode 0 of EPISODES has two attempts (3 steps, then 2); the change from the
    reach step to the next goal's first step lies between attempts and is left out, as
    is the change into the step after the test."""
    command = np.array([[0.1, 0.5], [0.2, 0.5], [0.2, -1.0], [0.0, 2.0], [0.05, 2.0], [0.3, 0.3]])
    att = split_attempts(*steps(*EPISODES[:1]), n_episodes=1, limit=LIMIT, command=command)
    np.testing.assert_allclose(att.dv, [0.1 + 0.0, 0.05])
    np.testing.assert_allclose(att.dw, [0.0 + 1.5, 0.0])
    counts = episode_counts(att, np.array([1.0, 2.0]), STEP_M, DT, n_episodes=1)
    assert counts["pairs"].tolist() == [3]  # (3 - 1) + (2 - 1)
    got = smoothness(counts)
    assert got["dv_per_step"] == pytest.approx(0.15 / 3)
    assert got["dw_per_step"] == pytest.approx(1.5 / 3)
    # files without the columns (or runs without commands) have no smoothness
    assert np.isnan(smoothness({"attempts": np.ones(1)})["dv_per_step"])


def test_smoothness_travels_through_results_csv_into_the_tables():
    att = split_attempts(*steps(*EPISODES[:1]), n_episodes=1, limit=LIMIT, command=np.ones((6, 2)))
    counts = episode_counts(att, np.array([1.0, 2.0]), STEP_M, DT, n_episodes=1)
    row = {"strategy": "ebe", "seed": 0, "mode": "greedy", "maze": "square4", "episode": 0}
    row |= {"return": 1.0, "goals": 1, "collided": 1, "length": 5}
    row |= {c: float(counts[c][0]) for c in RESULT_COLUMNS[9:]}
    text = csv_text(RESULT_COLUMNS, [tuple(row[c] for c in RESULT_COLUMNS)])
    back = read_results(text)[("square4", "ebe", 0)]
    assert back["pairs"].tolist() == [3] and back["dv_sum"].tolist() == [0.0]
    tables = tables_markdown(text, "square4", 0)
    header = next(ln for ln in tables.splitlines() if ln.startswith("| maze | strategy | success"))
    cells = tables.splitlines()[tables.splitlines().index(header) + 2].split("|")
    assert header.endswith("| dv_per_step | dw_per_step |")
    assert cells[-3].strip().startswith("0.000 [") and cells[-2].strip().startswith("0.00 [")


def test_rates_path_spl_and_time_by_hand():
    att = split_attempts(*steps(*EPISODES), n_episodes=2, limit=LIMIT)
    # shortest paths 0.06 and 0.1 m for the successes (driven: 0.09 and 0.12 m), 2.1 m
    counts = episode_counts(att, np.array([0.06, 2.1, 0.1]), STEP_M, DT, n_episodes=2)
    np.testing.assert_allclose(counts["attempts"], [2, 1])
    np.testing.assert_allclose(counts["successes"], [1, 1])
    np.testing.assert_allclose(counts["timeouts"], [0, 0])
    np.testing.assert_allclose(counts["collisions"], [1, 0])
    np.testing.assert_allclose(counts["cut"], [0, 0])
    np.testing.assert_allclose(counts["path_m"], [0.09 + 0.06, 0.12])
    np.testing.assert_allclose(counts["spl_sum"], [0.06 / 0.09, 0.1 / 0.12])
    np.testing.assert_allclose(counts["time_s"], [0.6, 0.8])
    np.testing.assert_allclose(counts["drive_s"], [1.0, 0.8])
    m = seed_metrics(dict(counts, collided=np.array([1, 0])))
    assert m["success"] == pytest.approx(2 / 3)
    assert m["collision"] == pytest.approx(1 / 3)
    assert m["timeout"] == 0
    assert m["success"] + m["collision"] + m["timeout"] == pytest.approx(1)
    assert m["path_length_m"] == pytest.approx((0.09 + 0.06 + 0.12) / 3)
    assert m["spl"] == pytest.approx((0.06 / 0.09 + 0 + 0.1 / 0.12) / 3)
    assert m["time_to_goal_s"] == pytest.approx((0.6 + 0.8) / 2)
    assert m["goals_per_min"] == pytest.approx(2 / (1.8 / 60))


def test_a_path_shorter_than_the_shortest_counts_one_and_a_failure_zero():
    """SPL's max(p, l): reaching within the goal radius can take fewer metres than the
    path to the goal's centre; the term is then 1, never more."""
    ep = [(0, 0, 0.2, 0, ""), (0.03, 0, 0.2, 0, "reach")]
    att = split_attempts(*steps(ep, [(0, 0, 5, 5, "hit")]), n_episodes=2, limit=LIMIT)
    counts = episode_counts(att, np.array([0.2, 7.0]), STEP_M, DT, n_episodes=2)
    np.testing.assert_allclose(counts["spl_sum"], [1.0, 0.0])


def test_no_success_has_no_time_to_goal_and_rates_still_sum_to_one():
    ep = [(0, 0, 1, 0, ""), (0, 0.03, 1, 0, "hit")]
    att = split_attempts(*steps(ep, ep[:1]), n_episodes=2, limit=1)
    m = seed_metrics(dict(episode_counts(att, np.ones(2), STEP_M, DT, 2), collided=[1, 0]))
    assert np.isnan(m["time_to_goal_s"]) and m["spl"] == 0
    # the collision came at step 2, past the 1-step limit: a time-out, as is the other
    assert (m["success"], m["collision"], m["timeout"]) == (0, 0, 1)


def test_only_cut_attempts_leave_the_rates_undefined():
    ep = [(0, 0, 1, 0, "")]
    att = split_attempts(*steps(ep), n_episodes=1, limit=5)
    m = seed_metrics(dict(episode_counts(att, np.ones(1), STEP_M, DT, 1), collided=[0]))
    assert np.isnan(m["success"]) and m["cut"] == 1


def test_files_written_before_cut_attempts_are_recounted_with_the_episodes_limit():
    """Old results.csv rows have one time-out per episode that reached its step limit:
    cut where the episode reached a goal before it, a time-out where it reached none."""
    old = {
        "attempts": np.array([4, 1, 2]),
        "successes": np.array([3, 0, 1]),
        "timeouts": np.array([1, 1, 0]),
        "path_m": np.array([1.0, 1.0, 1.0]),
        "spl_sum": np.array([2.4, 0.0, 0.9]),
        "time_s": np.array([9.0, 0.0, 3.0]),
        "collided": np.array([0, 0, 1]),
    }
    m = seed_metrics(old)
    assert m["success"] == pytest.approx(4 / 6)  # 7 attempts, 1 cut
    assert m["timeout"] == pytest.approx(1 / 6) and m["collision"] == pytest.approx(1 / 6)
    assert m["cut"] == pytest.approx(1 / 3) and np.isnan(m["goals_per_min"])


@pytest.mark.parametrize("limit", [1, 2, 3, 7])
def test_training_counts_of_episodes_equal_the_attempts_of_split_attempts(limit):
    """jaxnav.agent.episodes counts each episode's attempts step by step inside the
    trainer; split_attempts reads them off the whole record. Random step sequences
    (episodes of at most 7 steps, collisions ending them) must agree."""
    import jax.numpy as jnp

    from jaxnav.agent.episodes import Episodes

    rng = np.random.default_rng(limit)
    max_steps, n_eps = 7, 40
    reached, collided, episode = [], [], []
    for e in range(n_eps):
        for _ in range(max_steps):
            hit = rng.random() < 0.08
            collided.append(hit)
            reached.append(not hit and rng.random() < 0.25)
            episode.append(e)
            if hit:
                break
    reached, collided, episode = map(np.asarray, (reached, collided, episode))
    done = np.append(episode[1:] != episode[:-1], True)
    eps = Episodes.zeros(n_eps, attempts=True)
    for k in range(len(episode)):
        eps = eps.record(
            jnp.int32(episode[k]), 1.0, jnp.bool_(reached[k]), jnp.bool_(collided[k]),
            jnp.bool_(done[k]), limit=limit,
        )  # fmt: skip
    pos = np.zeros((len(episode), 2))
    att = split_attempts(pos, pos, reached, collided, episode, n_eps, limit)
    counts = episode_counts(att, np.zeros(len(att.episode)), STEP_M, DT, n_eps)
    np.testing.assert_array_equal(eps.ep_successes, counts["successes"])
    np.testing.assert_array_equal(eps.ep_collisions, counts["collisions"])
    np.testing.assert_array_equal(eps.ep_timeouts, counts["timeouts"])
    np.testing.assert_array_equal(eps.ep_cut, counts["cut"])
    if limit == max_steps:  # the default: the counts follow from each episode's row
        for e in range(n_eps):
            mine = episode == e
            row = {
                "goals": str(int(np.sum(reached[mine]))),
                "collided": str(int(np.any(collided[mine]))),
                "length": str(int(np.sum(mine))),
            }
            expected = [int(counts[c][e]) for c in ("successes", "collisions", "timeouts", "cut")]
            # a goal reached on the episode's last step opens no attempt; a row cannot
            # tell, so it counts one cut (the rates never read the cut attempts)
            expected[3] += int(row["length"] == str(max_steps) and reached[mine][-1])
            assert training_outcomes(row, max_steps) == tuple(expected)


def results_text(per_seed_counts):
    """results.csv text of one maze, arm "ebe", one row per (seed, episode): each
    episode (collided, attempts, successes, timeouts, path, spl, time, cut), 10 steps
    of 0.2 s."""
    rows = []
    for seed, episodes in enumerate(per_seed_counts):
        for e, (collided, att, succ, tout, path, spl, time, cut) in enumerate(episodes):
            rows.append(
                ("ebe", seed, "greedy", "square4", e, "1.0", succ, collided, 10)
                + (att, succ, tout, path, spl, time, collided, cut, 2.0, "", "", "")
            )
    return csv_text(RESULT_COLUMNS, rows)


def test_seed_rates_pool_attempts_and_tables_show_them_with_intervals():
    text = results_text(
        [
            # 2 of 4 decided attempts, a fifth cut
            [(1, 3, 2, 0, 1.2, 1.5, 4.0, 0), (0, 2, 0, 1, 3.0, 0.0, 0.0, 1)],
            [(0, 2, 1, 1, 2.0, 0.5, 2.0, 0)],  # 1 of 2 attempts
        ]
    )
    res = read_results(text)
    seed0 = seed_metrics(res[("square4", "ebe", 0)])
    assert seed0 == pytest.approx(
        dict(
            success=2 / 4, collision=1 / 4, timeout=1 / 4, cut=1 / 2, path_length_m=4.2 / 4,
            spl=1.5 / 4, time_to_goal_s=4.0 / 2, goals_per_min=2 / (4.0 / 60),
        )
    )  # fmt: skip
    seed1 = seed_metrics(res[("square4", "ebe", 1)])
    tables = tables_markdown(text, "square4", 0)
    header = next(ln for ln in tables.splitlines() if ln.startswith("| maze | strategy | success"))
    assert header == "| maze | strategy | " + " | ".join(METRICS + SMOOTH_METRICS) + " |"
    row = tables.splitlines()[tables.splitlines().index(header) + 2]
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:2] == ["square4", "EBE"]
    for cell, m in zip(cells[2:], METRICS):
        mean = (seed0[m] + seed1[m]) / 2
        digits = 1 if m in ("time_to_goal_s", "goals_per_min") else 2
        assert cell.startswith(f"{mean:.{digits}f} ["), (m, cell)
    printed = navigation_text([dict(zip(RESULT_COLUMNS, r.split(","))) for r in text.split()[1:]])
    assert printed.splitlines()[1].split()[:3] == ["ebe", "2", f"{(0.5 + 0.5) / 2:.2f}"]


def test_results_written_before_the_counts_give_no_navigation_table():
    text = csv_text(RESULT_COLUMNS[:9], [("ebe", 0, "greedy", "square4", 0, "1.0", 1, 0, 10)])
    assert "Navigation" not in tables_markdown(text, "square4", 0)
    assert navigation_text([dict(zip(RESULT_COLUMNS[:9], text.split()[1].split(",")))]) == ""
