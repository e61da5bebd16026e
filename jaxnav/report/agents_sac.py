"""SAC beside PQN on the worlds both drive: docs/agents.md's table and figure, from the
driving study's committed data (``docs/driving/``, :mod:`jaxnav.report.driving_page`).

Per config: its env steps per run and whole command's seconds (``runs.csv``); its greedy
test beside the oracle's on the same keys (``NAME.csv``): success and collisions, and the
smoothness of the driven command (:func:`jaxnav.report.navigation.smoothness`, NaN for
results written before the command was recorded); and from its greedy evaluations while
it trained (``evals/NAME.csv``), the first at which the mean success over seeds is within
0.02 of the oracle's test success (:func:`jaxnav.report.navigation.solved`): its env steps
and its seconds since the command started, compilation included. No JAX.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from jaxnav.report import stats
from jaxnav.report.driving_page import EVALS, RUNS
from jaxnav.report.markdown import interval, markdown_table
from jaxnav.report.navigation import seed_metrics, smoothness, solved
from jaxnav.report.results import read_results

# (SAC's config, the PQN config of the same world)
PAIRS = (("drive_sac_obstacles", "drive_obstacles"), ("drive_sac_stage4", "drive_stage4"))
FIGURE = "agents/sac-curves.png"  # beside docs/driving.md
COLORS = {"SAC": "tab:purple", "PQN": "tab:orange"}


def _rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


def pairs(folder: Path) -> list[tuple[str, str]]:
    """The pairs whose configs both have rows in the data folder."""
    have = {r["config"] for r in _rows(Path(folder) / RUNS)}
    return [p for p in PAIRS if set(p) <= have]


def agent_of(strategy: str) -> str:
    return "SAC" if strategy == "policy" else "PQN"


def curve(folder: Path, config: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(env steps, seconds since the command started, f[evaluations, seeds] success) of
    a config's greedy evaluations while it trained; empty without them."""
    path = Path(folder) / EVALS / f"{config}.csv"
    if not path.is_file():
        return np.empty(0), np.empty(0), np.empty((0, 0))
    by: dict[int, list[tuple[float, float]]] = {}
    for r in _rows(path):
        by.setdefault(int(r["env_step"]), []).append((float(r["wall_s"]), float(r["success"])))
    steps = np.asarray(sorted(by), np.float64)
    wall = np.asarray([max(w for w, _ in by[s]) for s in sorted(by)])
    success = np.nan_to_num(np.asarray([[x for _, x in by[s]] for s in sorted(by)]), nan=0.0)
    return steps, wall, success


def entry(folder: Path, config: str) -> dict:
    """One config's row: its run, its test and the oracle's on its own world."""
    folder = Path(folder)
    run = next(r for r in _rows(folder / RUNS) if r["config"] == config)
    res = read_results((folder / f"{config}.csv").read_text())
    maze = next(k[0] for k in res)  # the world's own maze: the config's first test maze

    def per_seed(driver: str) -> list[dict]:
        seeds = sorted(k[2] for k in res if k[:2] == (maze, driver))
        return [{**seed_metrics(res[(maze, driver, s)]), **smoothness(res[(maze, driver, s)])}
                for s in seeds]  # fmt: skip

    policy, oracle = per_seed(run["strategy"]), per_seed("oracle")
    ref = float(np.mean([m["success"] for m in oracle]))
    steps, wall, success = curve(folder, config)
    first = next((k for k, x in enumerate(success.mean(1)) if solved(float(x), ref)), None)
    return {
        "run": run,
        "maze": maze,
        "agent": agent_of(run["strategy"]),
        "policy": policy,
        "oracle": ref,
        "solved_at": None if first is None else (steps[first], wall[first]),
    }


def _mean(per_seed: list[dict], metric: str) -> float:
    x = np.asarray([m[metric] for m in per_seed], np.float64)
    return float(np.mean(x)) if np.isfinite(x).all() else math.nan


def _seeds(e: dict, metric: str) -> np.ndarray:
    return np.asarray([s[metric] for s in e["policy"]], np.float64)


def block(folder: Path) -> str:
    """docs/agents.md's table of SAC beside PQN, from the data folder."""
    rows = []
    for pair in pairs(folder):
        for config in pair:
            e = entry(folder, config)
            dv, dw = _mean(e["policy"], "dv_per_step"), _mean(e["policy"], "dw_per_step")
            at = e["solved_at"]
            rows.append(
                [
                    e["maze"],
                    f"`{config}` ({e['agent']})",
                    f"{int(e['run']['env_steps']):,}",
                    f"{interval(stats.mean_ci(_seeds(e, 'success')), 3)} ({e['oracle']:.3f})",
                    interval(stats.mean_ci(_seeds(e, "collision")), 3),
                    "n/a" if math.isnan(dv) else f"{dv:.3f} / {dw:.2f}",
                    f"{float(e['run']['command_s']):.0f}",
                    "not within the budget" if at is None else f"{int(at[0]):,} / {at[1]:.0f} s",
                ]
            )
    head = [
        "world",
        "config",
        "env steps per run",
        "greedy success (oracle)",
        "collisions",
        "change per step: speed (m/s) / yaw rate (rad/s)",
        "whole command (s)",
        "first evaluation within 0.02 of the oracle: env steps / s",
    ]
    return "\n".join(markdown_table(head, rows))


def figure(folder: Path, path: Path) -> Path:
    """Greedy success while training, SAC beside PQN on each world: mean over seeds
    with a normal 95% band, against env steps and against the command's seconds; the
    oracle's test success as a line."""
    from jaxnav.report.fig_common import plt, save_fig

    ps = pairs(folder)
    fig, axes = plt.subplots(len(ps), 2, figsize=(9, 3.0 * len(ps)), squeeze=False)
    for i, pair in enumerate(ps):
        for config in pair:
            e = entry(folder, config)
            steps, wall, success = curve(folder, config)
            if not steps.size:
                continue
            mean = success.mean(1)
            n = success.shape[1]
            half = 1.96 * success.std(1, ddof=1) / np.sqrt(n) if n > 1 else 0 * mean
            for j, x in enumerate((steps, wall)):
                ax = axes[i, j]
                ax.plot(x, mean, "o-", ms=3, color=COLORS[e["agent"]], label=e["agent"])
                ax.fill_between(x, mean - half, mean + half, color=COLORS[e["agent"]], alpha=0.2)
                ax.axhline(e["oracle"], color="k", lw=1)
        axes[i, 0].set_xscale("log")
        axes[i, 0].minorticks_off()  # the minor ticks' labels overlap
        axes[i, 0].set_ylabel(f"{entry(folder, pair[0])['maze']}\ngreedy success", fontsize=8)
        for ax in axes[i]:
            ax.set_ylim(0, 1.05)
            ax.tick_params(labelsize=7)
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("env steps per run", fontsize=8)
    axes[-1, 1].set_xlabel("seconds since the command started", fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_fig(fig, path, dpi=90)
