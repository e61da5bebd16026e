"""The navigation metrics' tables (:mod:`jaxnav.report.navigation`): in tables.md, per
maze and arm; in ``jaxnav evaluate``'s output, per arm over every test maze. Each
cell is the mean over seeds of the seed's metric with a 95% bootstrap CI, as the
other tables' cells are. Pure functions of results.csv's rows."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from jaxnav.core.sweep import row_arm
from jaxnav.report import stats
from jaxnav.report.markdown import aligned_table, interval, markdown_table
from jaxnav.report.navigation import (
    COUNT_COLUMNS,
    FIRST_COUNT_COLUMNS,
    METRICS,
    SMOOTH_METRICS,
    seed_metrics,
    smoothness,
    training_outcomes,
)
from jaxnav.report.results import arms_in, display_name

# Decimals each metric is shown with.
DIGITS = {
    "success": 2,
    "collision": 2,
    "timeout": 2,
    "cut": 2,
    "path_length_m": 2,
    "spl": 2,
    "time_to_goal_s": 1,
    "goals_per_min": 1,
    "dv_per_step": 3,
    "dw_per_step": 2,
}


def metric_cells(
    per_seed: Sequence[dict[str, float]], metrics: Sequence[str] = METRICS
) -> list[str]:
    """One arm's cells, metric by metric: the mean over its seeds [95% CI]. A seed
    without a successful attempt has no time to the goal: that column averages the
    seeds that have one and says how many when some have not."""
    cells = []
    for m in metrics:
        x = np.asarray([s[m] for s in per_seed], np.float64)
        have = x[np.isfinite(x)]
        if not len(have):
            cells.append("n/a")
            continue
        text = interval(stats.mean_ci(have), DIGITS[m])
        if len(have) < len(x):
            text += f" ({len(have)} of {len(x)} seeds)"
        cells.append(text)
    return cells


def navigation_section(results: dict, mazes, strategies, seeds) -> list[str]:
    """The tables.md section of one test mode: per maze and arm, each metric's mean
    over seeds [95% CI]. ``results``: read_results()'s (maze, arm, seed) -> episode
    columns; empty if results.csv has no attempt counts (written before them)."""
    if not all(set(FIRST_COUNT_COLUMNS) <= set(v) for v in results.values()):
        return []
    L = [
        "",
        "## Navigation: per goal attempt",
        "",
        "An attempt starts when a goal is set (an episode's start, which retries the goal "
        "a collision or the step limit missed unless env.restart_goal is new, or the next "
        "goal after one is reached) and "
        "ends at the goal within the attempt limit (success), in a collision within it, "
        "after the whole attempt limit (timeout; by default the limit is the episode's, so "
        "only an attempt spanning a whole episode times out), or cut off by its episode's "
        "end before its own limit (`cut`: counted per episode, left out of the rates). Per "
        "seed, over its decided attempts: the shares of the three ends (they sum to 1), the "
        "mean path travelled (`path_length_m`), SPL (the mean of S l / max(p, l), l the "
        "shortest path of the robot's disc from the attempt's start to its goal, p the "
        "path travelled, S the success); the mean time of the successful attempts "
        "(`time_to_goal_s`) and successes per minute of driving (`goals_per_min`); the "
        "mean absolute change of the driven speed and yaw rate from one step to the next "
        "within an attempt (`dv_per_step` m/s, `dw_per_step` rad/s: smoothness). Then "
        f"the mean over seeds [{int(stats.CONFIDENCE * 100)}% bootstrap CI].",
        "",
    ]

    def cells(m, s) -> list[str]:
        seed_cells = metric_cells([seed_metrics(results[(m, s, k)]) for k in seeds])
        smooth = [smoothness(results[(m, s, k)]) for k in seeds]
        return seed_cells + metric_cells(smooth, SMOOTH_METRICS)

    rows = [[m, display_name(s), *cells(m, s)] for m in mazes for s in strategies]
    return (
        L
        + markdown_table(["maze", "strategy", *METRICS, *SMOOTH_METRICS], rows)
        + gap_section(results, mazes, strategies, seeds)
    )


GAP_METRICS = ("success", "spl")  # the metrics whose train - test gap is shown


def gap_section(results: dict, mazes, strategies, seeds) -> list[str]:
    """The generalisation gap of a maze family: per arm, each seed's metric on the
    family's train layouts minus on its test layouts (``grid:train``, ``grid:test``),
    the mean over seeds [95% CI]. Empty without both splits."""
    families = [m[: -len(":train")] for m in mazes if m.endswith(":train")]
    families = [f for f in families if f"{f}:test" in mazes]
    if not families:
        return []
    L = [
        "",
        "## Generalisation gap: train layouts minus test layouts",
        "",
        "Per seed, the metric over its attempts in the family's train layouts (drawn "
        "with the test's keys) minus in its test layouts, which training never draws; "
        f"then the mean over seeds [{int(stats.CONFIDENCE * 100)}% bootstrap CI]. A gap "
        "above 0 is what the policy loses on mazes it has not seen.",
        "",
    ]
    rows = []
    for f in families:
        for s in strategies:
            cells = []
            for metric in GAP_METRICS:
                d = [
                    seed_metrics(results[(f"{f}:train", s, k)])[metric]
                    - seed_metrics(results[(f"{f}:test", s, k)])[metric]
                    for k in seeds
                ]
                cells.append(interval(stats.mean_ci(np.asarray(d, np.float64)), 2))
            rows.append([f, display_name(s), *cells])
    return L + markdown_table(["family", "strategy", *(f"{m} gap" for m in GAP_METRICS)], rows)


def navigation_text(rows: list[dict[str, str]]) -> str:
    """The table ``jaxnav evaluate`` prints (empty without attempt counts): per arm,
    each metric over every attempt of a seed on every test maze, the mean over seeds
    [95% CI]."""
    if not rows or any(r.get(c) in (None, "") for r in rows for c in FIRST_COUNT_COLUMNS):
        return ""
    by: dict[str, dict[int, dict[str, list[float]]]] = {}
    for r in rows:
        sums = by.setdefault(row_arm(r), {}).setdefault(int(r["seed"]), {})
        for c in (*COUNT_COLUMNS, "collided"):
            if r.get(c) not in (None, ""):
                sums.setdefault(c, []).append(float(r[c]))
    table = [["strategy", "seeds", *METRICS]]
    for arm in arms_in(by):
        per_seed = [seed_metrics(_arrays(s)) for s in by[arm].values()]
        table.append([arm, str(len(per_seed)), *metric_cells(per_seed)])
    return aligned_table(table)


LONG_WAIT_S = 60.0  # a cut attempt longer than this is a stall the success count leaves out
DT_S = 0.2  # s, the control period of every shipped preset (for the attempt limit in steps)


def cut_wait_s(row: dict[str, str]) -> float | None:
    """How long (s) a test episode's cut attempt had lasted, from its results row: the
    episode's driving time less its successful attempts' (``drive_s - time_s``). None
    where the episode ended on no cut attempt, or had a collision or a time-out, where
    that difference is not the cut attempt's alone."""
    if float(row["cut"]) == 0:
        return None
    if float(row.get("collisions") or 0) or float(row.get("timeouts") or 0):
        return None
    return float(row["drive_s"]) - float(row["time_s"])


def long_waits_text(rows: list[dict[str, str]], over: float = LONG_WAIT_S) -> str:
    """One line per arm whose test episodes ended with the robot stalled on a goal: on
    it for longer than ``over`` seconds (:func:`cut_wait_s`), neither reaching it nor
    hitting anything, when the episode ran out. Success counts neither such a stall nor
    the goal the episode ran out on (the attempt is cut), so a driver that stands still
    never counts as failing; ``env.attempt_limit`` counts each as a time-out. Empty if
    none stalled, or without the driving time."""
    if not rows or any(r.get(c) in (None, "") for r in rows for c in ("cut", "drive_s")):
        return ""
    long: dict[str, list[int]] = {}
    for r in rows:
        counts = long.setdefault(row_arm(r), [0, 0])
        counts[1] += 1
        wait = cut_wait_s(r)
        counts[0] += wait is not None and wait > over
    limit = int(round(over / DT_S))
    return "\n".join(
        f"{arm}: stalled in {k} of its {n} test episodes: on one goal for over {over:g} s, "
        "neither reaching it nor hitting anything, when the episode ran out. Success "
        "leaves such a stall out (the episode ran out, not the attempt); "
        f"env.attempt_limit={limit} (steps of {DT_S:g} s) counts each as a time-out."
        for arm in arms_in(long)
        for k, n in [long[arm]]
        if k
    )


def _arrays(columns: dict[str, list[float]]) -> dict[str, np.ndarray]:
    return {c: np.asarray(v, np.float64) for c, v in columns.items()}


def training_success_text(rows: list[dict[str, str]], max_steps: int, last: int) -> str:
    """Per arm, the success of each seed's goal attempts over its last ``last`` training
    episodes (metrics.csv rows; the cut attempts left out,
    :func:`jaxnav.report.navigation.training_outcomes`), the mean over seeds [95% CI]."""
    by: dict[str, dict[int, list[tuple[int, tuple]]]] = {}
    for r in rows:
        episodes = by.setdefault(row_arm(r), {}).setdefault(int(r["seed"]), [])
        episodes.append((int(r["episode"]), training_outcomes(r, max_steps)))
    table = [["strategy", "seeds", "success", "collision", "timeout", "cut per episode"]]
    for arm in arms_in(by):
        per_seed = []
        for episodes in by[arm].values():
            tail = [c for _, c in sorted(episodes)[-last:]]
            s, c, t, x = (float(sum(col)) for col in zip(*tail))
            decided = s + c + t
            rates = [v / decided if decided else float("nan") for v in (s, c, t)]
            per_seed.append([*rates, x / len(tail)])
        cells = []
        for k in range(4):
            x = np.asarray([p[k] for p in per_seed], np.float64)
            have = x[np.isfinite(x)]
            cells.append(interval(stats.mean_ci(have), 2) if len(have) else "n/a")
        table.append([arm, str(len(per_seed)), *cells])
    return aligned_table(table)
