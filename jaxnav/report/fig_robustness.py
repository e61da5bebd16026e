"""The robustness figure, from robustness.csv text: the mean test return over seeds
under each perturbation, a bar per arm with its 95% bootstrap interval, one panel per
maze; the title names the test mode the episodes were played in."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxnav.report.fig_common import arm_styles, mode_title, plt, save_fig
from jaxnav.report.results import arms_in, display_name, robustness_summary

# jaxnav.experiments.robustness plays the plain test (rollout.run_tests' default mode)
# under each perturbation; robustness.csv has no mode column.
ROBUSTNESS_MODE = "greedy"


def robustness_figure(robustness_csv: str, title: str = "Robustness", mode: str = ROBUSTNESS_MODE):
    """The figure of :func:`plot_robustness`."""
    rows = robustness_summary(robustness_csv)
    mazes = list(dict.fromkeys(r.maze for r in rows))
    perts = list(dict.fromkeys(r.perturbation for r in rows))
    arms = arms_in(r.strategy for r in rows)
    styles = arm_styles(arms)
    width = 0.8 / len(arms)
    size = (max(6.0, 0.9 * len(perts) + 1.5) + 3.0, 3.6 * len(mazes))  # + 3 in: the legend
    fig, axes = plt.subplots(len(mazes), 1, figsize=size, squeeze=False)
    for ax, m in zip(axes[:, 0], mazes):
        for j, a in enumerate(arms):
            by = {r.perturbation: r for r in rows if r.maze == m and r.strategy == a}
            xs = [i for i, p in enumerate(perts) if p in by]
            iv = [by[perts[i]].mean for i in xs]
            mean = np.asarray([v.value for v in iv])
            low = np.asarray([v.low for v in iv])
            high = np.asarray([v.high for v in iv])
            yerr = None
            if not np.isnan(low).any():  # one seed: no interval
                yerr = np.stack([mean - low, high - mean])
            n = by[perts[xs[0]]].n_seeds if xs else 0
            ax.bar(
                np.asarray(xs) + (j - (len(arms) - 1) / 2) * width,
                mean,
                width,
                yerr=yerr,
                capsize=3,
                color=styles[a].color,
                hatch=styles[a].hatch,
                edgecolor="white" if styles[a].hatch else None,
                linewidth=0,
                label=f"{display_name(a)} ({n} seeds)",
            )
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.set_xticks(range(len(perts)))
        ax.set_xticklabels(perts, rotation=30, ha="right", fontsize=8)
        ax.set_ylabel("mean test return")
        ax.set_title(
            f"{title} on {m}, {mode_title(mode)}\nmean over seeds, 95% bootstrap interval",
            fontsize=10,
        )
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    fig.tight_layout()
    return fig


def plot_robustness(
    robustness_csv: str, out: Path, title: str = "Robustness", mode: str = ROBUSTNESS_MODE
) -> Path:
    """Mean return over seeds per perturbation (x) and arm (bars), 95% bootstrap CI as
    error bars; one panel per maze. From robustness.csv text, whose episodes were
    played in test mode ``mode`` (the title says which)."""
    return save_fig(robustness_figure(robustness_csv, title, mode), out, dpi=110)
