"""The robustness figure, from robustness.csv text: the mean test return over seeds
under each perturbation, a bar per arm with its 95% bootstrap interval, one panel per
maze."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxnav.report.fig_common import arm_colors, plt, save_fig
from jaxnav.report.results import arms_in, display_name, robustness_summary


def plot_robustness(robustness_csv: str, out: Path, title: str = "Robustness") -> Path:
    """Mean return over seeds per perturbation (x) and strategy (bars), 95% bootstrap
    CI as error bars; one panel per maze. From robustness.csv text."""
    rows = robustness_summary(robustness_csv)
    mazes = list(dict.fromkeys(r.maze for r in rows))
    perts = list(dict.fromkeys(r.perturbation for r in rows))
    strategies = arms_in(r.strategy for r in rows)
    colors = arm_colors(strategies)
    width = 0.8 / len(strategies)
    fig, axes = plt.subplots(
        len(mazes), 1, figsize=(max(6.0, 0.9 * len(perts) + 1.5), 3.6 * len(mazes)), squeeze=False
    )
    for ax, m in zip(axes[:, 0], mazes):
        for j, s in enumerate(strategies):
            by = {r.perturbation: r for r in rows if r.maze == m and r.strategy == s}
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
                np.asarray(xs) + (j - (len(strategies) - 1) / 2) * width,
                mean,
                width,
                yerr=yerr,
                capsize=3,
                color=colors[s],
                label=f"{display_name(s)} ({n} seeds)",
            )
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.set_xticks(range(len(perts)))
        ax.set_xticklabels(perts, rotation=30, ha="right", fontsize=8)
        ax.set_ylabel("mean test return")
        ax.set_title(f"{title} on {m}\nmean over seeds, 95% bootstrap interval", fontsize=10)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return save_fig(fig, out, dpi=110)
