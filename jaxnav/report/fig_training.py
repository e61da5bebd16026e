"""Training figures, from metrics.csv and explore.csv: episode return and exploration
over training, a mean over seeds with its 95% bootstrap band per arm."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxnav.core import rundir
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError, RunError
from jaxnav.core.sweep import row_arm
from jaxnav.report import stats
from jaxnav.report.fig_common import arm_colors, band, plt, save_fig
from jaxnav.report.results import arm_strategy, arms_in, display_name

Curves = dict[str, tuple[np.ndarray, np.ndarray]]  # arm -> (x f[T], y f[seeds, T])


def read_curves(path: Path, x_col: str, y_col: str) -> Curves:
    """{arm: (x f[T], y f[seeds, T])} of a metrics or explore CSV, cut to the x values
    every seed of the arm reached."""
    by: dict[str, dict[int, dict[float, float]]] = {}
    for r in rundir.CsvLog(path, ()).read():
        by.setdefault(row_arm(r), {}).setdefault(int(r["seed"]), {})[float(r[x_col])] = float(
            r[y_col]
        )
    out = {}
    for s in arms_in(by):
        seeds = sorted(by[s])
        common = sorted(set.intersection(*(set(by[s][k]) for k in seeds)))
        if not common:
            continue
        x = np.asarray(common)
        y = np.asarray([[by[s][k][v] for v in common] for k in seeds])
        out[s] = (x, y)
    return out


def plot_training_curves(run_dir: Path, out: Path, window: int | None = None) -> Path:
    """Episode return vs episode, smoothed, mean and 95% interval over seeds."""
    curves = read_curves(run_dir / rundir.METRICS, "episode", "return")
    colors = arm_colors(list(curves))
    if not curves:
        raise RunError(f"{run_dir / rundir.METRICS} has no episodes")
    n_ep = max(len(x) for x, _ in curves.values())
    w = window or int(np.clip(n_ep // 20, 1, 50))
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for s, (x, y) in curves.items():
        band(
            ax,
            x + 1,
            stats.moving_average(y, w),
            colors[s],
            f"{display_name(s)} ({y.shape[0]} seeds)",
        )
    ax.set_xlabel("episode")
    ax.set_ylabel("episode return")
    ax.set_title(
        f"Training on {_train_maze(run_dir)}: return, moving average over {w} episodes\n"
        f"mean over seeds and 95% bootstrap interval",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    return save_fig(fig, out, dpi=110)


def plot_exploration(run_dir: Path, out: Path, window: int = 10) -> Path:
    """Each strategy's exploration per 100-step block over training: EBE's entropy
    H(s), epsilon, Boltzmann's chance of a non-greedy action."""
    curves = read_curves(run_dir / rundir.EXPLORE, "step", "explore")
    colors = arm_colors(list(curves))
    if not curves:
        raise RunError(f"{run_dir / rundir.EXPLORE} has no rows")
    labels = {
        "ebe": "EBE: entropy H(s) (= chance of a random action)",
        "epsilon_greedy": "epsilon-greedy: epsilon",
        "boltzmann": "Boltzmann: chance of a non-greedy action",
    }
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for s, (x, y) in curves.items():
        label = labels[arm_strategy(s)]
        if s != arm_strategy(s):  # a sweep point: its values after the strategy's text
            label = f"{label} ({s.partition(' ')[2]})"
        band(ax, x, stats.moving_average(y, window), colors[s], f"{label}, {y.shape[0]} seeds")
    ax.set_xlabel("environment step (per seed)")
    ax.set_ylabel("exploration probability")
    ax.set_ylim(0, 1.02)
    ax.set_title(
        "Exploration over training (means over 100-step blocks, moving average over "
        f"{window} blocks)\n"
        "mean over seeds and 95% bootstrap interval",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=9)
    fig.tight_layout()
    return save_fig(fig, out, dpi=110)


def _train_maze(run_dir: Path) -> str:
    try:
        return load_config(str(run_dir / rundir.CONFIG)).env.maze
    except ConfigError:
        return "?"
