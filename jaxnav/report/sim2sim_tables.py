"""The sim-to-sim tables, pure functions of their per-seed CSVs (no JAX, no MuJoCo).

A sim2sim CSV (:data:`SUMMARY_COLUMNS`) holds one row per simulator ("jaxnav" or
"mujoco"), strategy, seed and maze: the means over that policy's test episodes of
the return, the goals per episode, the collision rate and the length.

* :func:`gap_markdown`: the gap of one run, return, goals per episode and collision
  rate per strategy over all seeds and mazes, jaxnav beside MuJoCo, with 95%
  bootstrap intervals over seeds (:mod:`jaxnav.report.stats`), then per maze.
* :func:`realism_markdown`: which training options help in MuJoCo, from several
  runs' CSVs in one with an ``option`` column first (:data:`REALISM_COLUMNS`).
* :func:`campaign_markdown`: a sim-to-sim campaign's page (``jaxnav study`` of a
  ``kind: sim2sim`` file), that table and how it was made, from its CSV and its JSON.
"""

from __future__ import annotations

import csv
import io

import numpy as np

from jaxnav.core import strategies as registry
from jaxnav.report import stats
from jaxnav.report.markdown import interval, markdown_table
from jaxnav.report.results import ordered_unique

SIMULATORS = ("jaxnav", "mujoco")
SUMMARY_COLUMNS = (
    "simulator",
    "strategy",
    "seed",
    "maze",
    "episodes",
    "return",
    "goals",
    "collision_rate",
    "length",
)
REALISM_COLUMNS = ("option", *SUMMARY_COLUMNS)  # several runs' sim2sim CSVs in one

# (CSV column, name in the table, decimals)
METRICS = (
    ("return", "return", 1),
    ("goals", "goals per episode", 2),
    ("collision_rate", "collision rate", 2),
)


def _summary_entries(text: str):
    """(row, (simulator, maze, strategy, seed), {metric: value}) of each CSV row."""
    for row in csv.DictReader(io.StringIO(text)):
        key = (row["simulator"], row["maze"], row["strategy"], int(row["seed"]))
        yield row, key, {c: float(row[c]) for c in SUMMARY_COLUMNS[4:]}


def read_summary(text: str) -> dict[tuple[str, str, str, int], dict[str, float]]:
    """sim2sim CSV text -> {(simulator, maze, strategy, seed): {metric: value}}."""
    return {key: values for _, key, values in _summary_entries(text)}


def gap_markdown(text: str, title: str = "Sim-to-sim gap") -> str:
    """Markdown of a sim2sim CSV: per strategy over all seeds and mazes, each metric in
    jaxnav and in MuJoCo with 95% bootstrap intervals over seeds, and their difference
    (a seed's own MuJoCo minus jaxnav, seeds resampled jointly over the mazes); then
    per maze."""
    res = read_summary(text)
    keys = [k for k in res if k[0] == "mujoco"]
    mazes = ordered_unique(k[1] for k in keys)
    strategies = ordered_unique(k[2] for k in keys)
    seeds = sorted({k[3] for k in keys})
    n_eps = {
        sim: ordered_unique(int(v["episodes"]) for k, v in res.items() if k[0] == sim)
        for sim in SIMULATORS
    }

    def scores(sim, strategy, metric, maze_list):  # f[seeds, mazes]
        return np.asarray([[res[(sim, m, strategy, s)][metric] for m in maze_list] for s in seeds])

    lines = [f"# {title}", ""]
    lines.append(
        f"Every policy greedy (argmax Q, or SAC's mean action), {len(seeds)} seeds per "
        "strategy, test mazes "
        f"{', '.join(mazes)}; episodes per policy and maze: jaxnav "
        f"{'/'.join(map(str, n_eps['jaxnav']))}, MuJoCo {'/'.join(map(str, n_eps['mujoco']))}. "
        "Mean over seeds and mazes of each seed's mean over its episodes, with a 95% "
        "percentile bootstrap interval over seeds (a drawn seed keeps all its mazes); "
        "the gap is MuJoCo minus jaxnav for the same network."
    )
    lines += ["", "## Over all test mazes", ""]
    header = ["strategy", "metric", "jaxnav", "MuJoCo", "MuJoCo - jaxnav"]
    rows = []
    for strategy in strategies:
        for metric, label, digits in METRICS:
            jx = scores("jaxnav", strategy, metric, mazes)
            mj = scores("mujoco", strategy, metric, mazes)
            rows.append(
                [
                    registry.label(strategy),
                    label,
                    interval(stats.mean_ci(jx), digits),
                    interval(stats.mean_ci(mj), digits),
                    interval(stats.mean_ci(mj - jx), digits, "+"),
                ]
            )
    lines += markdown_table(header, rows)
    lines += ["", "## Per maze", ""]
    header = ["maze", "strategy", "return jaxnav", "return MuJoCo", "return gap"]
    header += ["goals/ep jaxnav", "goals/ep MuJoCo", "collisions jaxnav", "collisions MuJoCo"]
    rows = []
    for maze in mazes:
        for strategy in strategies:
            jx = {m: scores("jaxnav", strategy, m, [maze])[:, 0] for m, _, _ in METRICS}
            mj = {m: scores("mujoco", strategy, m, [maze])[:, 0] for m, _, _ in METRICS}
            rows.append(
                [
                    maze,
                    registry.label(strategy),
                    interval(stats.mean_ci(jx["return"]), 1),
                    interval(stats.mean_ci(mj["return"]), 1),
                    interval(stats.mean_ci(mj["return"] - jx["return"]), 1, "+"),
                    f"{jx['goals'].mean():.2f}",
                    f"{mj['goals'].mean():.2f}",
                    f"{jx['collision_rate'].mean():.2f}",
                    f"{mj['collision_rate'].mean():.2f}",
                ]
            )
    lines += markdown_table(header, rows)
    return "\n".join(lines) + "\n"


def realism_markdown(text: str, baseline: str = "plain") -> str:
    """Markdown table of which training options help in MuJoCo. ``text`` is the sim2sim
    CSVs of several runs of one config, each trained with one option, in one CSV
    with an ``option`` column first (:data:`REALISM_COLUMNS`; the same mazes,
    strategies and seeds for every option); ``baseline`` names the run trained
    without any.

    Per option and strategy, over all test mazes: MuJoCo's return, and the chance
    that a seed trained with the option scores more in MuJoCo than a seed trained
    without (rliable's probability of improvement, mazes as tasks, with its
    bootstrap interval, seeds of the two runs resampled independently); then the
    gap, MuJoCo minus jaxnav, signed and as the mean size of a seed's per-maze gap,
    with the chance that the option's gaps are smaller than the baseline's."""
    res: dict[str, dict] = {}
    for row, key, values in _summary_entries(text):
        res.setdefault(row["option"], {})[key] = values
    if baseline not in res:
        raise ValueError(f"no run named {baseline!r} to compare with")
    keys = [k for k in res[baseline] if k[0] == "mujoco"]
    mazes = ordered_unique(k[1] for k in keys)
    strategies = ordered_unique(k[2] for k in keys)
    seeds = sorted({k[3] for k in keys})
    for name, r in res.items():
        have = {k for k in r if k[0] == "mujoco"}
        if have != set(keys):
            raise ValueError(f"{name}'s mazes, strategies or seeds differ from {baseline}'s")

    def scores(name, sim, strategy):  # f[seeds, mazes]
        r = res[name]
        return np.asarray([[r[(sim, m, strategy, s)]["return"] for m in mazes] for s in seeds])

    def verdict(p: stats.Interval, better: str, worse: str) -> str:
        return {1: better, -1: worse, 0: "no difference"}[stats.side(p)]

    header = ["option", "strategy", "MuJoCo return", f"P(MuJoCo return > {baseline}'s)"]
    header += ["gap", "size of gap", f"P(gap smaller than {baseline}'s)", "narrows the gap?"]
    rows = []
    for name in [baseline, *(n for n in res if n != baseline)]:
        for strategy in strategies:
            mj, jx = scores(name, "mujoco", strategy), scores(name, "jaxnav", strategy)
            size = np.abs(mj - jx)
            row = [name, registry.label(strategy), interval(stats.mean_ci(mj), 1)]
            if name == baseline:
                row += [
                    "",
                    interval(stats.mean_ci(mj - jx), 1, "+"),
                    interval(stats.mean_ci(size), 1),
                ]
                row += ["", ""]
            else:
                base_mj = scores(baseline, "mujoco", strategy)
                base_size = np.abs(base_mj - scores(baseline, "jaxnav", strategy))
                p_return = stats.probability_of_improvement_ci(mj, base_mj)
                p_gap = stats.probability_of_improvement_ci(-size, -base_size)
                row += [
                    f"{interval(p_return, 2)} {verdict(p_return, 'higher', 'lower')}",
                    interval(stats.mean_ci(mj - jx), 1, "+"),
                    interval(stats.mean_ci(size), 1),
                    interval(p_gap, 2),
                    verdict(p_gap, "yes", "widens it"),
                ]
            rows.append(row)
    n_eps = ordered_unique(
        int(v["episodes"]) for r in res.values() for k, v in r.items() if k[0] == "mujoco"
    )
    lines = [
        f"Every policy greedy, {len(seeds)} seeds per strategy and option, test mazes "
        f"{', '.join(mazes)}, {'/'.join(map(str, n_eps))} MuJoCo episodes per policy and "
        "maze. Return: mean over seeds and mazes with a 95% bootstrap interval over "
        f"seeds. P(MuJoCo return > {baseline}'s): the chance that a seed trained with the "
        f"option scores more in MuJoCo than a seed trained without (rliable's probability "
        "of improvement over the mazes; 95% interval, the two runs' seeds resampled "
        "independently). Gap: a seed's MuJoCo return minus its jaxnav return on the same "
        "maze, averaged (signed) and as its size (mean absolute gap per seed and maze); "
        "jaxnav's column is tested in the run's own training settings. A verdict needs "
        "its interval to exclude 0.5.",
        "",
    ]
    return "\n".join(lines + markdown_table(header, rows)) + "\n"


def campaign_markdown(text: str, made: dict) -> str:
    """A sim-to-sim campaign's page from its CSV ``text`` (:data:`REALISM_COLUMNS`) and
    ``made`` (its JSON: the title, the paragraph on how it was made, the header of the
    arms' column and each arm's description, training and MuJoCo minutes)."""
    rows = []
    for arm in made["arms"]:
        train = (
            arm["reused"] if arm["train_min"] is None else f"{arm['train_min']:.1f} min of training"
        )
        rows.append(f"| {arm['arm']} | {arm['what']} | {train} | {arm['mujoco_min']:.1f} min |")
    return "\n".join(
        [
            f"# {made['title']}",
            "",
            realism_markdown(text),
            "## How it was made",
            "",
            made["how"],
            "",
            f"| option | {made['column']} | training | MuJoCo test |",
            "|---|---|---|---|",
            *rows,
            "",
        ]
    )
