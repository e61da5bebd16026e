"""The sweep figure, from a swept run's results.csv text: test return against the
swept values, one panel per test mode (each titled with its mode)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from jaxnav.core.sweep import swept_columns
from jaxnav.report import stats
from jaxnav.report.fig_common import is_number, plt, save_fig, strategy_colors
from jaxnav.report.results import (
    arm_strategy,
    arms_in,
    display_name,
    read_results,
    result_modes,
    scores_over_mazes,
)


def plot_sweep(results_csv: str, out: Path, title: str = "Sweep") -> Path | None:
    """A swept run's test return against the swept values, one panel per test mode:
    per strategy the mean over seeds of the per-seed score (averaged over the test
    mazes) with its 95% bootstrap interval; a strategy with one point (not reading the
    swept key) is a horizontal band. None without a swept column."""
    header = next(csv.reader(io.StringIO(results_csv)), [])
    keys = swept_columns(header)
    if not keys:
        return None
    modes = result_modes(results_csv)
    fig, axes = plt.subplots(1, len(modes), figsize=(5.2 * len(modes), 4.0), squeeze=False)
    for ax, mode in zip(axes[0], modes):
        results = read_results(results_csv, mode)  # (maze, arm, seed) -> episodes
        mazes = list(dict.fromkeys(k[0] for k in results))
        by = arms_in(k[1] for k in results)
        seeds = sorted({k[2] for k in results})
        score = {a: scores_over_mazes(results, mazes, a, seeds) for a in by}
        # an arm's point: its swept values ("ebe ebe_temperature=0.1" -> "0.1")
        point = {a: ", ".join(p.split("=", 1)[1] for p in a.split(" ")[1:]) for a in by}
        ticks = list(dict.fromkeys(p for p in point.values() if p))
        numeric = all(is_number(t) for t in ticks)
        xs = {t: float(t) if numeric else i for i, t in enumerate(ticks)}
        strategies = strategy_colors(arm_strategy(a) for a in by)
        colors = {s: color for s, (color, _) in strategies.items()}
        for s in strategies:
            arms = [a for a in by if arm_strategy(a) == s]
            ivs = [stats.mean_ci(score[a]) for a in arms]
            n = len(score[arms[0]])
            if len(arms) == 1 and not point[arms[0]]:
                iv = ivs[0]
                ax.axhline(
                    iv.value, color=colors[s], lw=1.4, label=f"{display_name(s)} ({n} seeds)"
                )
                if not np.isnan(iv.low):
                    ax.axhspan(iv.low, iv.high, color=colors[s], alpha=0.15, lw=0)
                continue
            x = np.asarray([xs[point[a]] for a in arms])
            mean = np.asarray([iv.value for iv in ivs])
            low, high = np.asarray([iv.low for iv in ivs]), np.asarray([iv.high for iv in ivs])
            yerr = None if np.isnan(low).any() else np.stack([mean - low, high - mean])
            ax.errorbar(
                x,
                mean,
                yerr=yerr,
                color=colors[s],
                marker="o",
                capsize=3,
                lw=1.4,
                label=f"{display_name(s)} ({n} seeds)",
            )
        if numeric and ticks and min(xs.values()) > 0 and max(xs.values()) / min(xs.values()) >= 10:
            ax.set_xscale("log")
        if not numeric:
            ax.set_xticks(range(len(ticks)))
            ax.set_xticklabels(ticks, rotation=30, ha="right", fontsize=8)
        ax.set_xlabel(", ".join(keys))
        ax.set_ylabel("test return (mean over mazes and episodes)")
        ax.set_title(f"{title}: {mode} test\nmean over seeds, 95% bootstrap interval", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return save_fig(fig, out, dpi=110)
