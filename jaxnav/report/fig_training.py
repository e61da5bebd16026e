"""Training figures, from metrics.csv and explore.csv: episode return and exploration
over training, a mean over seeds with its 95% bootstrap band per arm.

Up to :data:`ONE_PANEL_MAX` arms share one panel. More arms (a sweep) get one small
panel each, on shared axes: an arm's band in its colour over the other arms' mean
curves in grey, so that every band can be read and still be compared.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from jaxnav.core import rundir
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError, RunError
from jaxnav.core.sweep import row_arm
from jaxnav.report import stats
from jaxnav.report.fig_common import ArmStyle, arm_styles, band, plt, save_fig
from jaxnav.report.results import arm_strategy, arms_in, display_name

ONE_PANEL_MAX = 3  # arms drawn together in one panel; more get a panel each
PANEL_COLUMNS = 3
OTHERS = ArmStyle("0.65", "-", "")  # the other arms' means behind an arm's panel

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


def curves_figure(
    curves: Curves,
    label: Callable[[str, np.ndarray], str],
    title: str,
    xlabel: str,
    ylabel: str,
    ylim: tuple[float, float] | None = None,
    legend_loc: str = "upper left",
):
    """A figure of smoothed curves (already smoothed: y f[seeds, T] per arm).

    ``label(arm, y)`` names an arm's curve. One panel for up to ONE_PANEL_MAX arms,
    else a panel per arm (its band over the others' means in grey), PANEL_COLUMNS to
    a row, axes shared.
    """
    styles = arm_styles(list(curves))
    if len(curves) <= ONE_PANEL_MAX:
        fig, ax = plt.subplots(figsize=(7, 4.2))
        for a, (x, y) in curves.items():
            band(ax, x, y, styles[a], label(a, y))
        ax.set_title(title, fontsize=10)
        _axes_text(ax, xlabel, ylabel, ylim)
        ax.legend(loc=legend_loc, fontsize=9)
        fig.tight_layout()
        return fig
    cols = min(PANEL_COLUMNS, len(curves))
    rows = math.ceil(len(curves) / cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(3.4 * cols, 2.5 * rows + 0.8), sharex=True, sharey=True, squeeze=False
    )
    for ax in axes.flat[len(curves) :]:
        ax.remove()
    for ax, (a, (x, y)) in zip(axes.flat, curves.items()):
        for other, (xo, yo) in curves.items():
            if other != a:
                ax.plot(xo, yo.mean(axis=0), color=OTHERS.color, lw=0.7, zorder=1)
        band(ax, x, y, styles[a], None, lw=1.4, alpha=0.3)
        ax.set_title(label(a, y), fontsize=8.5, color=styles[a].color)
        _axes_text(ax, None, None, ylim)
        ax.tick_params(labelsize=8)
        ax.label_outer()  # tick labels on the outer panels only
    fig.supxlabel(xlabel, fontsize=9)
    fig.supylabel(ylabel, fontsize=9)
    lines = title.split("\n")
    lines[min(1, len(lines) - 1)] += "; grey: the other arms' means"
    fig.suptitle("\n".join(lines), fontsize=10)
    fig.tight_layout()
    return fig


def _axes_text(ax, xlabel, ylabel, ylim) -> None:
    if xlabel:
        ax.set_xlabel(xlabel)
    if ylabel:
        ax.set_ylabel(ylabel)
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.grid(alpha=0.3)


def plot_training_curves(run_dir: Path, out: Path, window: int | None = None) -> Path:
    """Episode return vs episode, smoothed, mean and 95% interval over seeds."""
    curves = read_curves(run_dir / rundir.METRICS, "episode", "return")
    if not curves:
        raise RunError(f"{run_dir / rundir.METRICS} has no episodes")
    n_ep = max(len(x) for x, _ in curves.values())
    w = window or int(np.clip(n_ep // 20, 1, 50))
    smoothed = {a: (x + 1, stats.moving_average(y, w)) for a, (x, y) in curves.items()}
    fig = curves_figure(
        smoothed,
        lambda a, y: f"{display_name(a)} ({y.shape[0]} seeds)",
        f"Training on {_train_maze(run_dir)}: return, moving average over {w} episodes\n"
        f"mean over seeds and 95% bootstrap interval",
        "episode",
        "episode return",
    )
    return save_fig(fig, out, dpi=110)


EXPLORATION_LABELS = {
    "ebe": "EBE: entropy H(s) (= chance of a random action)",
    "epsilon_greedy": "epsilon-greedy: epsilon",
    "boltzmann": "Boltzmann: chance of a non-greedy action",
}


def _exploration_measure(strategy: str) -> str:
    """What a strategy's explore.csv value is (a registered strategy: what its act returns)."""
    return EXPLORATION_LABELS.get(strategy, f"{display_name(strategy)}: its exploration value")


def _exploration_label(arm: str, y: np.ndarray) -> str:
    label = _exploration_measure(arm_strategy(arm))
    if arm != arm_strategy(arm):  # a sweep point: its values after the strategy's text
        label = f"{label} ({arm.partition(' ')[2]})"
    return f"{label}, {y.shape[0]} seeds"


def _exploration_panel_label(arm: str, y: np.ndarray) -> str:
    return f"{display_name(arm)} ({y.shape[0]} seeds)"


def plot_exploration(run_dir: Path, out: Path, window: int = 10) -> Path:
    """Each strategy's exploration per 100-step block over training: EBE's entropy
    H(s), epsilon, Boltzmann's chance of a non-greedy action."""
    curves = read_curves(run_dir / rundir.EXPLORE, "step", "explore")
    if not curves:
        raise RunError(f"{run_dir / rundir.EXPLORE} has no rows")
    smoothed = {a: (x, stats.moving_average(y, window)) for a, (x, y) in curves.items()}
    one_panel = len(curves) <= ONE_PANEL_MAX
    title = (
        "Exploration over training (means over 100-step blocks, moving average over "
        f"{window} blocks)\nmean over seeds and 95% bootstrap interval"
    )
    if not one_panel:  # the panels name arms only: what each strategy's value is
        title += "\n" + "; ".join(
            _exploration_measure(s) for s in dict.fromkeys(arm_strategy(a) for a in curves)
        )
    fig = curves_figure(
        smoothed,
        _exploration_label if one_panel else _exploration_panel_label,
        title,
        "environment step (per seed)",
        "exploration probability",
        ylim=(0, 1.02),
        legend_loc="upper right",
    )
    return save_fig(fig, out, dpi=110)


def _train_maze(run_dir: Path) -> str:
    try:
        return load_config(str(run_dir / rundir.CONFIG)).env.maze
    except ConfigError:
        return "?"
