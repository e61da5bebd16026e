"""Navigation metrics per goal attempt: success, collision and time-out rates over the
attempts that were decided, the attempts cut off by an episode's end, the path
travelled, SPL, the time to the goal and goals per minute of driving.

An attempt starts when a goal is set: at an episode's start (a reset, or the restart
after a collision or the step limit, which keeps the goal unless
``env.restart_goal`` is "new") and after a goal is
reached (the next goal, from where the robot stands). It may take at most the
*attempt limit* in steps (``env.attempt_limit``; by default the episode's step limit,
so an attempt times out only if it spans a whole episode). It ends, in this order of
precedence:

* at its goal within the limit: a **success**;
* in a collision within the limit: a **collision**;
* having run its limit's worth of steps without either: a **time-out** (what it
  does after the limit does not change that);
* at the end of its episode (the step limit) before its own limit: **cut**. A cut
  attempt is neither a success nor a failure: the episode, not the attempt, ran out
  of time. In the paper's multi-goal episodes every episode that survives to its
  step limit ends with one, so counting it as a time-out would cap success near
  G / (G + 1) for G goals per episode, whatever the driver.

A goal reached on an episode's last step leaves no step for the next goal, so that
attempt is not counted.

results.csv keeps each test episode's sums over its attempts (:data:`COUNT_COLUMNS`).
A seed's metrics (:data:`METRICS`) are ratios of its sums over all its episodes, so
they are exact over its attempts:

* ``success``, ``collision``, ``timeout``: the share of the *decided* attempts (all
  but the cut ones) ending each way; they sum to 1;
* ``cut``: the cut attempts per test episode, reported on their own;
* ``path_length_m``: the mean distance travelled per decided attempt (m);
* ``spl``: success weighted by path length (Anderson et al., 2018), the mean over
  decided attempts of S_i l_i / max(p_i, l_i), with S_i the success, l_i the
  shortest path's length from the attempt's start to its goal
  (:mod:`jaxnav.world.paths`) and p_i the path travelled;
* ``time_to_goal_s``: the mean time of the successful attempts (steps times dt;
  NaN without one);
* ``goals_per_min``: successful attempts per minute of driving (every test step).

Smoothness (:func:`smoothness`, from the optional :data:`SMOOTH_COLUMNS`): the mean
absolute change of the driven command between consecutive steps of an attempt,
``dv_per_step`` (m/s) and ``dw_per_step`` (rad/s), over every attempt's step pairs:
what users of continuous control compare controllers by.

No JAX here: the per-step arrays come from the test rollout, the rest from files.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from jaxnav.core import sweep

# results.csv: each episode's sums over its attempts. The first six are the columns of
# files written before cut attempts were told apart (read by :func:`censored`).
FIRST_COUNT_COLUMNS = ("attempts", "successes", "timeouts", "path_m", "spl_sum", "time_s")
COUNT_COLUMNS = FIRST_COUNT_COLUMNS + ("collisions", "cut", "drive_s")
# A seed's metrics, as the tables name them.
METRICS = (
    "success",
    "collision",
    "timeout",
    "cut",
    "path_length_m",
    "spl",
    "time_to_goal_s",
    "goals_per_min",
)
# results.csv's smoothness sums per episode (absent in files written before them), and
# the metrics they give.
SMOOTH_COLUMNS = ("dv_sum", "dw_sum", "pairs")
SMOOTH_METRICS = ("dv_per_step", "dw_per_step")
RATES = ("success", "collision", "timeout")  # shares of the decided attempts: sum 1
SUCCESS, COLLISION, TIMEOUT, CUT = 0, 1, 2, 3  # how an attempt ends


class Attempts(NamedTuple):
    """A run's goal attempts in test order, [A] each."""

    episode: np.ndarray  # i[A] the test episode
    start: np.ndarray  # f[A, 2] where the robot stood when the goal was set
    goal: np.ndarray  # f[A, 2]
    steps: np.ndarray  # i[A] steps taken
    outcome: np.ndarray  # i[A] SUCCESS, COLLISION, TIMEOUT or CUT
    path: np.ndarray | None = None  # f[A] metres driven, where the steps' travel is known
    end: np.ndarray | None = None  # f[A, 2] where the robot stood at the attempt's last step
    # f[A] sums of |v_t+1 - v_t| and |w_t+1 - w_t| over the attempt's consecutive steps,
    # where the steps' commands are known
    dv: np.ndarray | None = None
    dw: np.ndarray | None = None


def outcome_of(steps, reached, collided, limit: int) -> np.ndarray:
    """How attempts end (i[A]) from their steps taken and what their last step did
    (bool[A] each), under the attempt limit ``limit`` (steps): the rule of this
    module's docstring."""
    steps = np.asarray(steps)
    within = steps <= limit
    return np.select(
        [np.asarray(reached, bool) & within, np.asarray(collided, bool) & within, steps >= limit],
        [SUCCESS, COLLISION, TIMEOUT],
        CUT,
    ).astype(np.int32)


def attempt_first_steps(episode: np.ndarray, reached: np.ndarray) -> np.ndarray:
    """bool[T]: where a goal attempt starts among a run's steps (``episode`` each step's
    test episode, ``reached`` the goal reached in the step): at an episode's first step
    or at the step after a reach."""
    episode, reached = np.asarray(episode), np.asarray(reached, bool)
    first = np.ones(len(episode), bool)
    first[1:] = (episode[1:] != episode[:-1]) | reached[:-1]
    return first


def split_attempts(
    pos: np.ndarray,
    goal: np.ndarray,
    reached: np.ndarray,
    collided: np.ndarray,
    episode: np.ndarray,
    n_episodes: int,
    limit: int,
    travel: np.ndarray | None = None,
    command: np.ndarray | None = None,
) -> Attempts:
    """The goal attempts of one run's test from its steps, [T] each (``pos`` and
    ``goal`` [T, 2], before the step; ``reached`` and ``collided`` in the step;
    ``episode`` the step's test episode, ``n_episodes`` or more after the test;
    ``travel``, if known, the metres each step drove; ``command``, if known, [T, 2]
    the (v, omega) each step drove).
    ``limit``: the attempt limit in steps (the episode's step limit unless
    ``env.attempt_limit`` sets one). An attempt ends at a reach, or with its episode:
    by a collision or at the episode's step limit (then it is a time-out if it took
    ``limit`` steps, else cut)."""
    if limit < 1:
        raise ValueError(f"the attempt limit must be at least one step, not {limit}")
    episode = np.asarray(episode)
    keep = episode < n_episodes
    pos, goal = np.asarray(pos)[keep], np.asarray(goal)[keep]
    reached, collided = np.asarray(reached, bool)[keep], np.asarray(collided, bool)[keep]
    episode = episode[keep]
    n = len(episode)
    if n == 0:
        return Attempts(
            *(np.zeros(shape, dtype) for shape, dtype in _EMPTY), np.zeros(0), np.zeros((0, 2))
        )
    first = attempt_first_steps(episode, reached)
    starts = np.flatnonzero(first)
    ends = np.append(starts[1:] - 1, n - 1)  # attempts tile the steps
    taken = ends - starts + 1
    path = dv = dw = None
    if travel is not None:
        path = np.add.reduceat(np.asarray(travel, np.float64)[keep], starts)
    if command is not None:  # the change from each step to the next within its attempt
        change = np.abs(np.diff(np.asarray(command, np.float64)[keep], axis=0))
        inside = ~first[1:]
        which = (np.cumsum(first) - 1)[1:][inside]
        dv = np.bincount(which, weights=change[inside, 0], minlength=len(starts))
        dw = np.bincount(which, weights=change[inside, 1], minlength=len(starts))
    return Attempts(
        episode=episode[starts].astype(np.int32),
        start=pos[starts].astype(np.float64),
        goal=goal[starts].astype(np.float64),
        steps=taken.astype(np.int32),
        outcome=outcome_of(taken, reached[ends], collided[ends], limit),
        path=path,
        end=pos[ends].astype(np.float64),
        dv=dv,
        dw=dw,
    )


def run_attempts(steps, r: int, n_episodes: int, limit: int) -> Attempts:
    """Run ``r``'s goal attempts from a navigation rollout's per-step arrays (``steps``: a
    test rollout's or the greedy evaluation's ``Steps``, [runs, T] each), under the
    attempt limit ``limit`` (steps)."""
    return split_attempts(
        steps.pos[r],
        steps.goal[r],
        steps.reached[r],
        steps.collided[r],
        steps.episode[r],
        n_episodes,
        limit,
        steps.travel[r],
        None if getattr(steps, "command", None) is None else steps.command[r],
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
    length); ``step_m``: the distance a step travels where the attempts do not know
    their paths (``att.path`` None: the paper's robot drives at a constant speed, so v
    dt, the arc's length). Path and SPL sum the decided attempts; ``drive_s`` is the
    episode's driving time (its attempts tile its steps)."""
    success = att.outcome == SUCCESS
    decided = att.outcome != CUT
    path = att.steps * float(step_m) if att.path is None else np.asarray(att.path, np.float64)
    shortest = np.asarray(shortest, np.float64)
    straight = np.linalg.norm(att.goal - att.start, axis=1)
    shortest = np.where(np.isfinite(shortest), shortest, straight)
    with np.errstate(invalid="ignore", divide="ignore"):
        spl = np.where(success, shortest / np.maximum(path, shortest), 0.0)
    spl = np.where(np.isfinite(spl), spl, 0.0)

    def per_episode(values) -> np.ndarray:
        return np.bincount(att.episode, weights=values, minlength=n_episodes)[:n_episodes]

    smooth = {}
    if att.dv is not None:
        smooth = {
            "dv_sum": per_episode(att.dv),
            "dw_sum": per_episode(att.dw),
            "pairs": per_episode(att.steps - 1),
        }
    return smooth | {
        "attempts": per_episode(np.ones(len(att.episode))),
        "successes": per_episode(success),
        "timeouts": per_episode(att.outcome == TIMEOUT),
        "path_m": per_episode(np.where(decided, path, 0.0)),
        "spl_sum": per_episode(spl),
        "time_s": per_episode(np.where(success, att.steps * float(dt), 0.0)),
        "collisions": per_episode(att.outcome == COLLISION),
        "cut": per_episode(att.outcome == CUT),
        "drive_s": per_episode(att.steps * float(dt)),
    }


def censored(episodes: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """An episode table ({column: per-episode array}) with every :data:`COUNT_COLUMNS`
    column. Files written before cut attempts were told apart have only the first six
    and the episode's ``collided``; their attempt limit was the episode's, so an
    episode's one attempt left at its step limit was a time-out only if it spanned the
    whole episode (no goal reached before it) and was cut otherwise. Their path sums
    include the cut attempts' part; their driving time is unknown (NaN)."""
    if all(c in episodes for c in COUNT_COLUMNS):
        return episodes
    out = dict(episodes)
    left = np.asarray(episodes["timeouts"], np.float64)  # 0 or 1 an episode
    reached = np.asarray(episodes["successes"], np.float64) > 0
    out["cut"] = np.where(reached, left, 0.0)
    out["timeouts"] = np.where(reached, 0.0, left)
    out["collisions"] = np.asarray(episodes["collided"], np.float64)
    out["drive_s"] = np.full(len(left), np.nan)
    return out


def seed_metrics(episodes: dict[str, np.ndarray]) -> dict[str, float]:
    """A seed's :data:`METRICS` from its episodes' columns ({column: per-episode
    array} with :data:`COUNT_COLUMNS`, or the first six and ``collided``: see
    :func:`censored`): ratios of sums."""
    e = censored(episodes)
    total = {c: float(np.sum(e[c])) for c in COUNT_COLUMNS}
    n_episodes = len(np.asarray(e["attempts"]))
    decided = total["attempts"] - total["cut"]
    successes = total["successes"]
    drive_min = total["drive_s"] / 60.0
    out = {
        "cut": total["cut"] / n_episodes if n_episodes else float("nan"),
        "time_to_goal_s": total["time_s"] / successes if successes else float("nan"),
        "goals_per_min": successes / drive_min if drive_min > 0 else float("nan"),
    }
    if decided == 0:
        out |= {m: float("nan") for m in ("success", "collision", "timeout", "spl")}
        out["path_length_m"] = float("nan")
    else:
        out |= {
            "success": successes / decided,
            "collision": total["collisions"] / decided,
            "timeout": total["timeouts"] / decided,
            "path_length_m": total["path_m"] / decided,
            "spl": total["spl_sum"] / decided,
        }
    return {m: out[m] for m in METRICS}


def smoothness(episodes: dict[str, np.ndarray]) -> dict[str, float]:
    """A seed's :data:`SMOOTH_METRICS` from its episodes' :data:`SMOOTH_COLUMNS`: the
    sums of the command's absolute changes over the sum of step pairs; NaN where the
    columns are absent (files written before them) or there is no step pair."""
    if not all(c in episodes for c in SMOOTH_COLUMNS):
        return {m: float("nan") for m in SMOOTH_METRICS}
    pairs = float(np.sum(episodes["pairs"]))
    if pairs <= 0:
        return {m: float("nan") for m in SMOOTH_METRICS}
    return {
        "dv_per_step": float(np.sum(episodes["dv_sum"])) / pairs,
        "dw_per_step": float(np.sum(episodes["dw_sum"])) / pairs,
    }


# A world is solved by a policy whose mean success is within this of the oracle's, on
# the same test (the same test keys, episodes and counting): the one rule wherever
# "solved" appears.
SOLVED_TOLERANCE = 0.02


def solved(success: float, oracle_success: float) -> bool:
    """Whether a mean success solves a world whose oracle scores ``oracle_success``:
    within :data:`SOLVED_TOLERANCE` of it (NaN never solves)."""
    return bool(success >= oracle_success - SOLVED_TOLERANCE)


def training_outcomes(row: dict[str, str], max_steps: int) -> tuple[int, int, int, int]:
    """How one training episode's goal attempts ended, (successes, collisions,
    time-outs, cut), from its metrics.csv row: the counts themselves where an attempt
    limit wrote them, else from its goals, collision and length with the episode's
    step limit ``max_steps`` as the attempt limit (the episode's last attempt is a
    collision, a time-out if it spanned the whole episode, or cut). A row cannot tell
    a goal reached on the episode's last step, which opens no attempt: such an episode
    counts one cut attempt too many, which no rate reads."""
    if row.get("cut") not in (None, ""):
        return tuple(int(row[c]) for c in ("successes", "collisions", "timeouts", "cut"))
    goals, collided = int(row["goals"]), int(row["collided"])
    truncated = not collided and int(row["length"]) >= max_steps
    return goals, collided, int(truncated and goals == 0), int(truncated and goals > 0)


def last_episodes(rows: list[dict[str, str]], arms, n: int = 50) -> dict[str, dict[str, float]]:
    """Mean over seeds of each seed's last ``n`` training episodes (metrics.csv's rows),
    per arm (strategy, or strategy at a sweep point: :func:`jaxnav.core.sweep.row_arm`);
    summary.json's ``last50``."""
    out = {}
    for s in arms:
        per_seed: dict[int, list[tuple[int, float, float]]] = {}
        for r in rows:
            if sweep.row_arm(r) == s:
                per_seed.setdefault(int(r["seed"]), []).append(
                    (int(r["episode"]), float(r["return"]), float(r["goals"]))
                )
        ret, goals = [], []
        for eps in per_seed.values():
            tail = sorted(eps)[-n:]
            ret.append(np.mean([x[1] for x in tail]))
            goals.append(np.mean([x[2] for x in tail]))
        out[s] = {
            "return_mean": round(float(np.mean(ret)), 2),
            "return_std_over_seeds": round(float(np.std(ret)), 2),
            "goals_per_episode": round(float(np.mean(goals)), 3),
        }
    return out
