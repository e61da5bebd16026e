"""Test results as files: the rows of results.csv and robustness.csv, reading them
back, per-seed scores and summaries, and the recorded test episodes.

A seed's score is its mean return over its test episodes. No JAX here: tables and
figures are pure functions of these files.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from jaxnav.core import baselines
from jaxnav.core import strategies as registry
from jaxnav.core.errors import RunError
from jaxnav.core.sweep import row_arm
from jaxnav.report import stats
from jaxnav.report.navigation import COUNT_COLUMNS, FIRST_COUNT_COLUMNS, SMOOTH_COLUMNS

EPISODE_COLUMNS = (
    "strategy",
    "seed",
    "mode",
    "maze",
    "episode",
    "return",
    "goals",
    "collided",
    "length",
)
# results.csv: each episode, then its sums over its goal attempts (jaxnav.report.navigation),
# then its smoothness sums (empty where the commands were not recorded).
RESULT_COLUMNS = EPISODE_COLUMNS + COUNT_COLUMNS + SMOOTH_COLUMNS
# Test modes: "greedy" (argmax Q) or "exploring" (each strategy's own exploration at
# the end of its training); see jaxnav.experiments.rollout.
MODE_NAMES = {
    "greedy": "greedy (argmax Q, no exploration)",
    "exploring": "exploring (each strategy's own exploration as at the end of training)",
}


def arm_strategy(arm: str) -> str:
    """The strategy of an arm (``ebe`` of ``ebe ebe_temperature=0.1``)."""
    return arm.split(" ", 1)[0]


def arms_in(arms, with_baselines: bool = True) -> list[str]:
    """The distinct arms among ``arms`` (strategies, or strategies at sweep points),
    strategy by strategy in registration order, each strategy's points in the order
    met; then the reference drivers (:mod:`jaxnav.core.baselines`) unless left out."""
    known = list(registry.names()) + (list(baselines.names()) if with_baselines else [])
    found = [a for a in ordered_unique(arms) if arm_strategy(a) in known]
    return sorted(found, key=lambda a: known.index(arm_strategy(a)))


def display_name(arm: str) -> str:
    """An arm as tables and figures name it: ``EBE``, ``EBE ebe_temperature=0.1``,
    ``oracle``."""
    if baselines.is_baseline(arm):
        return baselines.BASELINES[arm].label
    strategy, _, point = arm.partition(" ")
    return " ".join(x for x in (registry.label(strategy), point) if x)


# robustness.csv: an episode's columns, the perturbation in place of the test mode.
ROBUSTNESS_COLUMNS = tuple("perturbation" if c == "mode" else c for c in EPISODE_COLUMNS)
UNPERTURBED = "none"


def episode_rows(fields, names, results, n_episodes, tag: str, counts=None):
    """CSV rows (strategy, [swept values,] seed, tag, maze, episode, return, goals,
    collided, length[, attempt counts]) of run_tests() results; ``fields`` holds each
    policy's leading fields, (strategy, seed) or jaxnav.core.config.Config.run_fields()'s;
    the tag is the test mode or the perturbation. ``counts``: per maze, per policy,
    each episode's sums over its attempts
    (:func:`jaxnav.experiments.navigation.navigation_counts`), for results.csv."""
    for i, (name, res) in enumerate(zip(names, results)):
        for r, lead in enumerate(fields):
            for e in range(n_episodes):
                row = (
                    *lead,
                    tag,
                    name,
                    e,
                    f"{float(res.ret[r, e]):.4f}",
                    int(res.goals[r, e]),
                    int(res.collided[r, e]),
                    int(res.length[r, e]),
                )
                if counts is not None:
                    row += _count_cells(counts[i][r], e)
                yield row


def _count_cells(counts: dict[str, np.ndarray], e: int) -> tuple:
    """Episode e's attempt counts as results.csv writes them (COUNT_COLUMNS, then
    SMOOTH_COLUMNS, empty where absent)."""
    c = {k: float(v[e]) for k, v in counts.items()}
    smooth = (
        (f"{c['dv_sum']:.6f}", f"{c['dw_sum']:.6f}", int(c["pairs"]))
        if all(k in c for k in SMOOTH_COLUMNS)
        else ("", "", "")
    )
    return (
        int(c["attempts"]),
        int(c["successes"]),
        int(c["timeouts"]),
        f"{c['path_m']:.4f}",
        f"{c['spl_sum']:.6f}",
        f"{c['time_s']:.4f}",
        int(c["collisions"]),
        int(c["cut"]),
        f"{c['drive_s']:.4f}",
        *smooth,
    )


def read_results(
    text: str, mode: str = "greedy"
) -> dict[tuple[str, str, int], dict[str, np.ndarray]]:
    """The rows of one test mode of results.csv text ->
    {(maze, strategy, seed): {column: per-episode array}}."""
    return _read_episodes(text, ("maze", "strategy", "seed"), {"mode": mode})


def result_modes(text: str) -> list[str]:
    """The test modes in results.csv text, in file order."""
    return ordered_unique(row["mode"] for row in csv.DictReader(io.StringIO(text)))


def _read_episodes(
    text: str, key_columns: Sequence[str], where: dict[str, str] | None = None
) -> dict[tuple, dict[str, np.ndarray]]:
    """Episode rows (those matching ``where``) -> {key (seed as int, the arm as
    "strategy"): {column: per-episode array, by episode}}."""
    out: dict[tuple, dict[str, list]] = {}
    for row in csv.DictReader(io.StringIO(text)):
        if where and any(row.get(k) != v for k, v in where.items()):
            continue
        row["strategy"] = row_arm(row)
        key = tuple(int(row[c]) if c == "seed" else row[c] for c in key_columns)
        columns = ("episode", "return", "goals", "collided", "length")
        if all(row.get(c) not in (None, "") for c in COUNT_COLUMNS):
            columns += COUNT_COLUMNS
        elif all(row.get(c) not in (None, "") for c in FIRST_COUNT_COLUMNS):
            columns += FIRST_COUNT_COLUMNS  # written before cut attempts were told apart
        if all(row.get(c) not in (None, "") for c in SMOOTH_COLUMNS):
            columns += SMOOTH_COLUMNS
        d = out.setdefault(key, {c: [] for c in columns})
        for c in d:
            d[c].append(float(row[c]))
    res = {}
    for key, d in out.items():
        order = np.argsort(d["episode"])
        res[key] = {c: np.asarray(v)[order] for c, v in d.items()}
    return res


def ordered_unique(xs):
    seen = []
    for x in xs:
        if x not in seen:
            seen.append(x)
    return seen


def per_seed_scores(
    results, maze: str, strategy: str, seeds: Sequence[int], column: str = "return"
) -> np.ndarray:
    """Per-seed mean of a column over the test episodes -> f[len(seeds)]."""
    return np.asarray([results[(maze, strategy, s)][column].mean() for s in seeds])


def scores_over_mazes(
    results, mazes: Sequence[str], strategy: str, seeds: Sequence[int]
) -> np.ndarray:
    """Per-seed score averaged over ``mazes`` (every maze tests the same network, so a
    seed keeps its scores together) -> f[len(seeds)]."""
    return np.mean([per_seed_scores(results, m, strategy, seeds) for m in mazes], axis=0)


def read_robustness(text: str) -> dict[tuple[str, str, str, int], dict[str, np.ndarray]]:
    """robustness.csv text -> {(perturbation, maze, strategy, seed): {column: episodes}}."""
    return _read_episodes(text, ("perturbation", "maze", "strategy", "seed"))


class RobustnessRow(NamedTuple):
    """One (maze, perturbation, strategy) line of the robustness table."""

    maze: str
    perturbation: str
    strategy: str
    n_seeds: int
    mean: stats.Interval  # mean over seeds of the per-seed mean return
    change: stats.Interval | None  # mean over seeds of (perturbed - unperturbed) score
    change_pct: float  # change / |unperturbed mean| in %, NaN if undefined
    goals: float  # goals per episode, all seeds pooled
    collision_rate: float  # share of episodes that ended in a collision


def _by_seed(res, perturbation: str, maze: str, strategy: str) -> dict[int, dict[str, np.ndarray]]:
    return {k[3]: v for k, v in res.items() if k[:3] == (perturbation, maze, strategy)}


def robustness_summary(text: str) -> list[RobustnessRow]:
    """The robustness table's numbers from robustness.csv text.

    A seed's score is its mean return over the test episodes; the change is paired
    by seed (same seed, same test key) against the unperturbed setting.
    """
    res = read_robustness(text)
    if not res:
        raise RunError("robustness.csv has no rows")
    perts = ordered_unique(k[0] for k in res)
    mazes = ordered_unique(k[1] for k in res)
    strategies = arms_in(k[2] for k in res)
    out = []
    for m in mazes:
        for s in strategies:
            ref = {k: v["return"].mean() for k, v in _by_seed(res, UNPERTURBED, m, s).items()}
            for p in perts:
                eps = _by_seed(res, p, m, s)
                if not eps:
                    continue
                seeds = sorted(eps)
                x = np.asarray([eps[k]["return"].mean() for k in seeds])
                change, pct = None, float("nan")
                if p != UNPERTURBED and ref and set(seeds) <= set(ref):
                    b = np.asarray([ref[k] for k in seeds])
                    change = stats.mean_ci(x - b)
                    if b.mean() != 0:
                        pct = 100.0 * change.value / abs(b.mean())
                goals = np.concatenate([eps[k]["goals"] for k in seeds])
                coll = np.concatenate([eps[k]["collided"] for k in seeds])
                out.append(
                    RobustnessRow(
                        maze=m,
                        perturbation=p,
                        strategy=s,
                        n_seeds=len(seeds),
                        mean=stats.mean_ci(x),
                        change=change,
                        change_pct=pct,
                        goals=float(goals.mean()),
                        collision_rate=float(coll.mean()),
                    )
                )
    # Perturbation by perturbation, the strategies side by side.
    rank = {p: i for i, p in enumerate(perts)}
    out.sort(
        key=lambda r: (mazes.index(r.maze), rank[r.perturbation], strategies.index(r.strategy))
    )
    return out


Episodes = dict[str, dict[str, dict[str, Any]]]  # maze -> strategy -> first_episode()


def episodes_npz(episodes: Episodes, goal_radius: float) -> bytes:
    """trajectories.npz bytes: "<maze index>/<strategy>/<field>", the maze names and
    the goal radius (what a plot needs besides the maze)."""
    arrays: dict[str, np.ndarray] = {
        "mazes": np.asarray(list(episodes), dtype=str),
        "goal_radius": np.asarray(goal_radius, np.float64),
    }
    for i, per_strategy in enumerate(episodes.values()):
        for s, ep in per_strategy.items():
            for k, v in ep.items():
                arrays[f"{i}/{s}/{k}"] = np.asarray(v)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


# {maze: {arm: {"collision" | "timeout": f[K, 2]}}}: where a test's failed attempts ended
Failures = dict[str, dict[str, dict[str, np.ndarray]]]
FAILURE_KINDS = ("collision", "timeout")


def failures_npz(failures: Failures, n_seeds: int, n_episodes: int) -> bytes:
    """failures.npz bytes: "<maze index>/<arm index>/<kind>" -> f[K, 2], the maze and
    arm names, and the seeds and episodes they pool."""
    mazes = list(failures)
    arms = list(dict.fromkeys(a for per in failures.values() for a in per))
    arrays: dict[str, np.ndarray] = {
        "mazes": np.asarray(mazes, dtype=str),
        "arms": np.asarray(arms, dtype=str),
        "seeds": np.asarray(n_seeds),
        "episodes": np.asarray(n_episodes),
    }
    for i, m in enumerate(mazes):
        for a, kinds in failures[m].items():
            for k in FAILURE_KINDS:
                arrays[f"{i}/{arms.index(a)}/{k}"] = np.asarray(kinds[k], np.float32).reshape(-1, 2)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def read_failures_npz(path: str | Path) -> tuple[Failures, int, int]:
    """Inverse of :func:`failures_npz`: (failures, seeds, episodes)."""
    with np.load(path, allow_pickle=False) as data:
        mazes = [str(m) for m in data["mazes"]]
        arms = [str(a) for a in data["arms"]]
        out: Failures = {m: {} for m in mazes}
        for key in data.files:
            if key in ("mazes", "arms", "seeds", "episodes"):
                continue
            i, a, k = key.split("/")
            out[mazes[int(i)]].setdefault(arms[int(a)], {})[k] = data[key]
        return out, int(data["seeds"]), int(data["episodes"])


def read_episodes_npz(path: str | Path) -> tuple[Episodes, float]:
    """Inverse of :func:`episodes_npz`: (episodes, goal radius)."""
    with np.load(path, allow_pickle=False) as data:
        names = [str(m) for m in data["mazes"]]
        goal_radius = float(data["goal_radius"])
        out: Episodes = {m: {} for m in names}
        for key in data.files:
            if key in ("mazes", "goal_radius"):
                continue
            i, s, k = key.split("/")
            v = data[key]
            out[names[int(i)]].setdefault(s, {})[k] = v if v.ndim else v.item()
    return out, goal_radius
