"""docs/agents.md's tables: EBE against epsilon-greedy with the paper's DQN, double +
dueling DQN and PQN on square4, from the committed data in ``docs/agents/`` (each
agent's ``results_*.csv``, the reference drivers' ``baselines_*.csv`` and
``summary.csv``). No JAX: a pure function of the files."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from jaxnav.report import stats
from jaxnav.report.claims import verdict
from jaxnav.report.markdown import interval, markdown_table
from jaxnav.report.navigation import seed_metrics, solved
from jaxnav.report.results import read_results

# The agents in the table's order, each with the slug of its results file.
AGENTS = {"DQN (the paper's)": "dqn", "double + dueling DQN": "double_dueling", "PQN": "pqn"}


def tables(docs: Path) -> str:
    """The page's tables from ``docs``' results_*.csv, baselines_*.csv and summary.csv."""
    with open(docs / "summary.csv") as f:
        summary = {r["agent"]: r for r in csv.DictReader(f)}
    refs = {}
    for name in ("oracle", "dwa"):
        res = read_results((docs / f"baselines_{name}.csv").read_text())
        seeds = sorted({k[2] for k in res})
        refs[name] = _scores(res, name, seeds, "success")
    oracle = float(np.mean(refs["oracle"]))
    rows, n_seeds = [], 0
    for agent in AGENTS:
        res = read_results((docs / f"results_{AGENTS[agent]}.csv").read_text())
        seeds = sorted({k[2] for k in res})
        n_seeds = len(seeds)
        cells = [agent]
        for measure in ("return", "success"):
            ebe, eps = (_scores(res, s, seeds, measure) for s in ("ebe", "epsilon_greedy"))
            p = stats.probability_of_improvement_ci(ebe, eps)
            if measure == "return":
                cells += [interval(stats.mean_ci(ebe), 0), interval(stats.mean_ci(eps), 0)]
            else:
                cells += [interval(stats.mean_ci(ebe), 2), interval(stats.mean_ci(eps), 2)]
            cells += [interval(p, 2), _verdict(p, len(seeds))]
        cells.append(
            " / ".join(
                "yes" if solved(float(np.mean(_scores(res, s, seeds, "success"))), oracle) else "no"
                for s in ("ebe", "epsilon_greedy")
            )
        )
        s = summary[agent]
        cells.append(f"{float(s['steps_per_s']):,.0f}")
        rows.append(cells)
    head = [
        "agent",
        "EBE return",
        "eps return",
        "P(EBE > eps), return",
        "verdict",
        "EBE success",
        "eps success",
        "P(EBE > eps), success",
        "verdict",
        "solved (EBE / eps)",
        "train transitions/s",
    ]
    ref_rows = [
        [label, interval(stats.mean_ci(refs[name]), 2)]
        for name, label in (("oracle", "oracle"), ("dwa", "DWA"))
    ]
    lines = [
        f"{n_seeds} seeds per strategy and agent; greedy test, 10 episodes per policy on "
        "square4; each cell the mean over seeds [95% bootstrap CI]. Success is the share "
        "of the decided goal attempts that reach the goal (an attempt cut off by an "
        "episode's end is left out: [navigation metrics](reproducing.md#navigation-metrics)). "
        "A strategy *solves* square4 when its mean success is within 0.02 of the oracle's "
        "on the same test. Transitions/s is the trainer's steady state over all seeds of "
        "both strategies (summary.json's steps_per_s), on the machine that ran the study.",
        "",
        *markdown_table(head, rows),
        "",
        "The reference drivers through the same test (the same seeds' test keys, square4, "
        "its 200-step episodes), success with its 95% interval over seeds:",
        "",
        *markdown_table(["driver", "success"], ref_rows),
    ]
    return "\n".join(lines)


def _scores(res, strategy: str, seeds, measure: str) -> np.ndarray:
    if measure == "return":
        return np.asarray([res[("square4", strategy, k)]["return"].mean() for k in seeds])
    return np.asarray([seed_metrics(res[("square4", strategy, k)])["success"] for k in seeds])


def _verdict(p: stats.Interval, n_seeds: int) -> str:
    if not stats.enough_seeds(n_seeds):
        return stats.TOO_FEW_SEEDS
    return {"supported": "EBE better", "contradicted": "EBE worse"}.get(
        verdict(p), "no detectable difference"
    )


__all__ = ["AGENTS", "tables"]
