"""Navigation metrics per goal attempt: success, collision and time-out rates, the path
travelled, SPL and the time to the goal.

An attempt starts when a goal is set: at an episode's start (a reset, or the restart
after a collision or the step limit, which keeps the goal) and after a goal is
reached (the next goal, from where the robot stands). It ends at its goal (a
success), in a collision, or at the step limit (a time-out). A goal reached on an
episode's last step leaves no step for the next goal, so that attempt is not
counted.

results.csv keeps each test episode's sums over its attempts (:data:`COUNT_COLUMNS`);
its ``collided`` column is its collisions (an episode ends at its first). A seed's
metrics (:data:`METRICS`) are ratios of its sums over all its episodes, so they are
exact over its attempts:

* ``success``, ``collision``, ``timeout``: the share of attempts ending each way
  (they sum to 1);
* ``path_length_m``: the mean distance travelled per attempt (m);
* ``spl``: success weighted by path length (Anderson et al., 2018), the mean over
  attempts of S_i l_i / max(p_i, l_i), with S_i the success, l_i the shortest
  path's length from the attempt's start to its goal (:mod:`jaxnav.world.paths`)
  and p_i the path travelled;
* ``time_to_goal_s``: the mean time of the successful attempts (steps times dt;
  NaN without one).

No JAX here: the per-step arrays come from the test rollout, the rest from files.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# results.csv: each episode's sums over its attempts.
COUNT_COLUMNS = ("attempts", "successes", "timeouts", "path_m", "spl_sum", "time_s")
# A seed's metrics, as the tables name them.
METRICS = ("success", "collision", "timeout", "path_length_m", "spl", "time_to_goal_s")
SUCCESS, COLLISION, TIMEOUT = 0, 1, 2  # how an attempt ends


class Attempts(NamedTuple):
    """A run's goal attempts in test order, [A] each."""

    episode: np.ndarray  # i[A] the test episode
    start: np.ndarray  # f[A, 2] where the robot stood when the goal was set
    goal: np.ndarray  # f[A, 2]
    steps: np.ndarray  # i[A] steps taken
    outcome: np.ndarray  # i[A] SUCCESS, COLLISION or TIMEOUT


def split_attempts(
    pos: np.ndarray,
    goal: np.ndarray,
    reached: np.ndarray,
    collided: np.ndarray,
    episode: np.ndarray,
    n_episodes: int,
) -> Attempts:
    """The goal attempts of one run's test from its steps, [T] each (``pos`` and
    ``goal`` [T, 2], before the step; ``reached`` and ``collided`` in the step;
    ``episode`` the step's test episode, ``n_episodes`` or more after the test).
    The test's last step ends its episode: an attempt still going there is a
    time-out, as the rollout's last episode always ends by the scan's last step."""
    episode = np.asarray(episode)
    keep = episode < n_episodes
    pos, goal = np.asarray(pos)[keep], np.asarray(goal)[keep]
    reached, collided = np.asarray(reached, bool)[keep], np.asarray(collided, bool)[keep]
    episode = episode[keep]
    n = len(episode)
    if n == 0:
        return Attempts(*(np.zeros(shape, dtype) for shape, dtype in _EMPTY))
    first = np.ones(n, bool)  # an attempt starts at an episode's first step ...
    first[1:] = (episode[1:] != episode[:-1]) | reached[:-1]  # ... or after a reach
    starts = np.flatnonzero(first)
    ends = np.append(starts[1:] - 1, n - 1)  # attempts tile the steps
    outcome = np.where(reached[ends], SUCCESS, np.where(collided[ends], COLLISION, TIMEOUT))
    return Attempts(
        episode=episode[starts].astype(np.int32),
        start=pos[starts].astype(np.float64),
        goal=goal[starts].astype(np.float64),
        steps=(ends - starts + 1).astype(np.int32),
        outcome=outcome.astype(np.int32),
    )


_EMPTY = (
    ((0,), np.int32),
    ((0, 2), np.float64),
    ((0, 2), np.float64),
    ((0,), np.int32),
    ((0,), np.int32),
)


def episode_counts(
    att: Attempts,
    shortest: np.ndarray,
    step_m: float,
    dt: float,
    n_episodes: int,
) -> dict[str, np.ndarray]:
    """Each episode's sums over its attempts, {column: f[n_episodes]} for
    :data:`COUNT_COLUMNS`. ``shortest``: l_i per attempt (m; where it is not finite,
    a gap the raster of :mod:`jaxnav.world.paths` cannot pass, the straight line's
    length); ``step_m``: the distance a step travels (the robot drives at a
    constant speed: v dt, the arc's length)."""
    success = att.outcome == SUCCESS
    path = att.steps * float(step_m)
    shortest = np.asarray(shortest, np.float64)
    straight = np.linalg.norm(att.goal - att.start, axis=1)
    shortest = np.where(np.isfinite(shortest), shortest, straight)
    with np.errstate(invalid="ignore", divide="ignore"):
        spl = np.where(success, shortest / np.maximum(path, shortest), 0.0)
    spl = np.where(np.isfinite(spl), spl, 0.0)

    def per_episode(values) -> np.ndarray:
        return np.bincount(att.episode, weights=values, minlength=n_episodes)[:n_episodes]

    return {
        "attempts": per_episode(np.ones(len(att.episode))),
        "successes": per_episode(success),
        "timeouts": per_episode(att.outcome == TIMEOUT),
        "path_m": per_episode(path),
        "spl_sum": per_episode(spl),
        "time_s": per_episode(np.where(success, att.steps * float(dt), 0.0)),
    }


def seed_metrics(episodes: dict[str, np.ndarray]) -> dict[str, float]:
    """A seed's :data:`METRICS` from its episodes' columns ({column: per-episode
    array} with :data:`COUNT_COLUMNS` and ``collided``): ratios of sums."""
    total = {c: float(np.sum(episodes[c])) for c in (*COUNT_COLUMNS, "collided")}
    n = total["attempts"]
    if n == 0:
        return {m: float("nan") for m in METRICS}
    successes = total["successes"]
    return {
        "success": successes / n,
        "collision": total["collided"] / n,
        "timeout": total["timeouts"] / n,
        "path_length_m": total["path_m"] / n,
        "spl": total["spl_sum"] / n,
        "time_to_goal_s": total["time_s"] / successes if successes else float("nan"),
    }
