"""The greedy evaluations while a run trains (``eval.csv``, ``run.eval_every``) as a
figure: success, collision and time-out against env steps, per arm.

Each evaluation counts every seed's goal attempts over ``run.eval_episodes`` greedy
episodes; the rates are shares of the decided attempts (the attempts cut by an
episode's end left out, :mod:`jaxnav.report.navigation`), so the three panels sum to 1
at every point. A line is the mean over seeds, its band the 95% bootstrap interval.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxnav.core import rundir
from jaxnav.core.sweep import row_arm
from jaxnav.report.fig_common import arm_styles, band, plt, save_fig
from jaxnav.report.results import arms_in, display_name

PANELS = (("success", "successes"), ("collision", "collisions"), ("time-out", "timeouts"))


def read_rates(path: Path) -> dict[str, tuple[np.ndarray, dict[str, np.ndarray]]]:
    """{arm: (env steps f[T], {panel: rate f[seeds, T]})} of an eval.csv, cut to the
    evaluations every seed of the arm reached; {} for a file without attempt counts
    (written before cut attempts were counted apart)."""
    rows = rundir.CsvLog(path, ()).read()
    if not rows or "cut" not in rows[0]:
        return {}
    by: dict[str, dict[int, dict[int, dict[str, float]]]] = {}
    for r in rows:
        decided = float(r["attempts"]) - float(r["cut"])
        rates = {name: float(r[col]) / decided if decided > 0 else np.nan for name, col in PANELS}
        by.setdefault(row_arm(r), {}).setdefault(int(r["seed"]), {})[int(r["env_step"])] = rates
    out = {}
    for arm in arms_in(by):
        seeds = sorted(by[arm])
        common = sorted(set.intersection(*(set(by[arm][s]) for s in seeds)))
        if common:
            out[arm] = (
                np.asarray(common, np.float64),
                {
                    name: np.asarray([[by[arm][s][x][name] for x in common] for s in seeds])
                    for name, _ in PANELS
                },
            )
    return out


MIN_POINTS = 2  # evaluations a curve needs to show a course; fewer draw no figure


def plot_greedy_evaluation(run_dir: Path, out: Path) -> Path | None:
    """eval.csv's success, collision and time-out over training; None (nothing drawn,
    :func:`greedy_evaluation_note` says why) where the run has no evaluations with
    attempt counts, or too few to show a course (``run.eval_every`` as long as the
    budget leaves one point: its numbers are in eval.csv and the summary)."""
    path = run_dir / rundir.EVAL
    curves = read_rates(path) if path.is_file() else {}
    if not curves or max(x.size for x, _ in curves.values()) < MIN_POINTS:
        return None
    styles = arm_styles(list(curves))
    fig, axes = plt.subplots(1, len(PANELS), figsize=(12, 4.2), sharex=True, sharey=True)
    right = max(float(x[-1]) for x, _ in curves.values())
    for ax, (name, _) in zip(axes, PANELS):
        for arm, (x, rates) in curves.items():
            y = rates[name]
            label = f"{display_name(arm)} ({y.shape[0]} seeds)" if name == "success" else None
            band(ax, x, y, styles[arm], label)
            ax.plot(x, np.nanmean(y, axis=0), "o", ms=3, color=styles[arm].color)
        ax.set_title(name, fontsize=10)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlim(0, right * 1.03)  # from the start of training
        ax.set_xlabel("environment step (per seed)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("share of decided goal attempts")
    n = len(curves)
    fig.legend(loc="lower center", ncol=min(n, 4), fontsize=8, frameon=False)
    fig.suptitle(
        "Greedy evaluation while training (run.eval_every): mean over seeds and 95% "
        "bootstrap interval; attempts cut by an episode's end left out",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0.06 + 0.04 * ((n - 1) // 4), 1, 1))  # room for the legend
    return save_fig(fig, out, dpi=110)


def greedy_evaluation_note(run_dir: Path) -> str:
    """Why :func:`plot_greedy_evaluation` drew nothing for a run that has evaluations
    (empty where it has none: nothing to say)."""
    path = run_dir / rundir.EVAL
    curves = read_rates(path) if path.is_file() else {}
    if not curves:
        return ""
    points = max(x.size for x, _ in curves.values())
    return (
        f"greedy_evaluation.png not drawn: {points} greedy evaluation"
        f"{'s' if points != 1 else ''} per run, too few for a curve (run.eval_every is "
        f"{'as long as' if points == 1 else 'a large share of'} the budget); "
        f"their numbers are in {path}"
    )
