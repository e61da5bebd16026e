"""The page of a study of exploring (``configs/studies/hard_exploration.yaml``): which
exploration method reaches the oracle on worlds whose goals lie behind walls, how soon,
and where EBE ranks among them.

A ladder study whose runs recorded what they explored (``run.coverage``: the columns
``first_goal`` and ``coverage`` of ``evals.csv``, :mod:`jaxnav.experiments.ladder`) gives,
per seed of every arm (each strategy is one method):

* ``first_goal``: the env steps (all of a run's environments together) by its first goal
  in training; a seed that never reaches one ranks below every seed that does;
* ``coverage``: the share of the world's free cells its robot visited in training (the
  oracle's raster, pooled into 0.25 m cells, :mod:`jaxnav.agent.explored`);
* ``reach``: the env steps to the first greedy evaluation at 90% of the oracle's success,
  and ``auc``, the area under the greedy success curve (:mod:`jaxnav.report.learning`);
* ``success``: the final greedy test's success (goals per decided goal attempt).

A method *reaches the oracle* on a world when at least half its seeds reach 90% of the
oracle's success there within the budget (its median steps to it are finite). Every
comparison is P(EBE > X), rliable's probability of improvement with its 95% interval over
seeds, under the claims table's rule (:func:`jaxnav.report.claims.verdict`); for the steps,
where fewer is better, "EBE > X" means EBE needs fewer.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from jaxnav.report import stats
from jaxnav.report.claims import verdict
from jaxnav.report.ladder import (
    EBE,
    NAMES,
    Data,
    _drive_table,
    _success_table,
    _timing,
    oracle_success,
)
from jaxnav.report.learning import REACH, Learning, _median
from jaxnav.report.markdown import interval, markdown_table, page_head, settings_text

# measure: (how a table names it, more is better)
MEASURES = {
    "reach": ("sooner to 90% of the oracle", False),
    "first_goal": ("sooner to the first goal", False),
    "coverage": ("coverage", True),
    "auc": ("area under the success curve", True),
    "success": ("final success", True),
}
SHORT = {"EBE better": "better", "EBE worse": "worse", "no detectable difference": "-"}
FIGURES = ("success.png", "coverage.png")


def is_exploring(data: Data) -> bool:
    """Whether a study's data recorded what its runs explored (run.coverage)."""
    return bool(data.evals) and "coverage" in data.evals[0]


class Exploring(Learning):
    """A study's per-seed measures of exploring beside its measures of learning."""

    def last(self, rung, agent, strategy, column: str) -> np.ndarray:
        """Each seed's ``column`` at its last evaluation (NaN where empty), in seed order."""
        by: dict[int, tuple[float, str]] = {}
        for r in self.data.evals:
            if (r["rung"], r["agent"], r["strategy"]) == (rung, agent, strategy):
                step = float(r["env_step"])
                seed = int(r["seed"])
                if seed not in by or step >= by[seed][0]:
                    by[seed] = (step, r[column])
        return np.asarray([float(by[s][1]) if by[s][1] else math.nan for s in sorted(by)])

    def per_seed(self, rung, agent, strategy, measure) -> np.ndarray:
        """A measure per seed, oriented so that more is better (:data:`MEASURES`)."""
        if measure == "first_goal":
            steps = self.last(rung, agent, strategy, "first_goal")
            never = 2.0 * self.budget(rung, agent)  # below every seed that reaches one
            return -np.where(np.isfinite(steps), steps, never)
        if measure == "coverage":
            return self.last(rung, agent, strategy, "coverage")
        return super().per_seed(rung, agent, strategy, measure)

    def methods(self) -> list[str]:
        return list(self.data.strategies)

    def others(self) -> list[str]:
        return [s for s in self.data.strategies if s != EBE]

    def reaches(self, rung, agent, strategy) -> bool:
        """At least half the seeds reach 90% of the oracle's success within the budget."""
        steps, _ = self.reached(rung, agent, strategy)
        return bool(steps.size) and np.sum(np.isfinite(steps)) * 2 >= steps.size

    def ranking(self, rung, agent) -> list[str]:
        """The methods by mean area under the success curve, best first (ties: the
        sooner median to 90% of the oracle, then the study's order)."""

        def key(s):
            steps, _ = self.reached(rung, agent, s)
            return (-float(np.mean(self.per_seed(rung, agent, s, "auc"))), float(np.median(steps)))

        return sorted(self.methods(), key=key)

    def compare_with(self, rung, agent, other, measure) -> tuple[stats.Interval, str]:
        x = self.per_seed(rung, agent, EBE, measure)
        y = self.per_seed(rung, agent, other, measure)
        p = stats.probability_of_improvement_ci(x, y)
        if not stats.enough_seeds(min(len(x), len(y))):
            return p, stats.TOO_FEW_SEEDS
        word = {"supported": "EBE better", "contradicted": "EBE worse"}.get(verdict(p))
        return p, word or "no detectable difference"

    @functools.cached_property
    def rows(self) -> list[dict]:
        """Every verdict, once: (rung, agent, opponent, measure), P and the word."""
        return [
            dict(rung=r, agent=a, other=o, measure=m, p=p, verdict=w)
            for r, a in self.cells()
            for o in self.others()
            for m in MEASURES
            for p, w in [self.compare_with(r, a, o, m)]
        ]


def summary_sentence(data: Data) -> str:
    return _sentence(Exploring(data))


def _sentence(E: Exploring) -> str:
    data = E.data
    cells = E.cells()
    n = len(cells)
    reached = {s: [c for c in cells if E.reaches(*c, s)] for s in E.methods()}
    order = sorted(E.methods(), key=lambda s: (-len(reached[s]), E.methods().index(s)))
    counts = ", ".join(f"{NAMES[s]} on {len(reached[s])}" for s in order)
    ranks = [E.ranking(*c).index(EBE) + 1 for c in cells]
    eps = [c for c in cells if not E.reaches(*c, "epsilon_greedy")]
    beats = {
        w: sum(1 for r in E.rows if r["measure"] == "auc" and r["verdict"] == w)
        for w in ("EBE better", "EBE worse")
    }
    comparisons = sum(1 for r in E.rows if r["measure"] == "auc")
    return (
        f"On {n} worlds whose goal lies behind walls, with the sparse reward and "
        f"{data.n_seeds()} seeds per arm, half the seeds or more reach 90% of the oracle's "
        f"success within the budget with: {counts} of {n}"
        + (
            f" (epsilon-greedy not on {', '.join(data.rung_label[r] for r, _ in eps)})"
            if eps and "epsilon_greedy" in data.strategies
            else ""
        )
        + f"; by area under the success curve EBE ranks {_ranks(ranks)} of "
        f"{len(E.methods())}, detectably larger than another method's in "
        f"{beats['EBE better']} of {comparisons} world and method pairs and smaller in "
        f"{beats['EBE worse']}."
    )


def _ranks(ranks: list[int]) -> str:
    """``2nd, 4th and 1st`` in the worlds' order."""

    def ordinal(k: int) -> str:
        return f"{k}{'tsnrhtdd'[(k // 10 % 10 != 1) * (k % 10 < 4) * k % 10 :: 4]}"

    words = [ordinal(k) for k in ranks]
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"


def reach_table(E: Exploring) -> list[str]:
    data = E.data
    rows = []
    for rung, agent in E.cells():
        ref = oracle_success(data, rung)
        for s in E.methods():
            steps, _ = E.reached(rung, agent, s)
            first = E.last(rung, agent, s, "first_goal")
            first = np.where(np.isfinite(first), first, np.inf)
            rows.append(
                [
                    data.rung_label[rung],
                    NAMES[s],
                    f"{int(np.sum(np.isfinite(steps)))} of {steps.size}",
                    _median(steps, ","),
                    _median(first, ","),
                    interval(stats.mean_ci(E.per_seed(rung, agent, s, "coverage")), 2),
                    interval(stats.mean_ci(E.per_seed(rung, agent, s, "auc")), 2),
                    interval(stats.mean_ci(E.per_seed(rung, agent, s, "success")), 2),
                    "" if ref is None else f"{ref:.2f}",
                ]
            )
    head = [
        "world",
        "method",
        "seeds at 90% of the oracle",
        "median env steps to it",
        "median env steps to the first goal",
        "coverage",
        "area under the success curve",
        "final success",
        "oracle",
    ]
    return markdown_table(head, rows)


def rank_table(E: Exploring) -> list[str]:
    data = E.data
    rows = []
    for rung, agent in E.cells():
        order = E.ranking(rung, agent)
        means = {s: float(np.mean(E.per_seed(rung, agent, s, "auc"))) for s in order}
        rows.append(
            [
                data.rung_label[rung],
                f"{order.index(EBE) + 1} of {len(order)}",
                ", ".join(f"{NAMES[s]} {means[s]:.2f}" for s in order),
                ", ".join(NAMES[s] for s in E.methods() if E.reaches(rung, agent, s)) or "none",
            ]
        )
    head = [
        "world",
        "EBE's rank",
        "methods by mean area under the success curve",
        "methods that reach the oracle",
    ]
    return markdown_table(head, rows)


def verdict_table(E: Exploring) -> list[str]:
    data = E.data
    by = {(r["rung"], r["agent"], r["other"], r["measure"]): r for r in E.rows}
    rows = []
    for rung, agent in E.cells():
        for o in E.others():
            cells = [data.rung_label[rung], NAMES[o]]
            for m in MEASURES:
                r = by[(rung, agent, o, m)]
                cells.append(f"{interval(r['p'], 2)} {SHORT.get(r['verdict'], r['verdict'])}")
            rows.append(cells)
    return markdown_table(["world", "X", *(v[0] for v in MEASURES.values())], rows)


def in_words(E: Exploring) -> list[str]:
    data = E.data
    out = []
    for o in E.others():
        for m, (name, _) in MEASURES.items():
            rows = [r for r in E.rows if r["other"] == o and r["measure"] == m]
            named = {
                w: [data.rung_label[r["rung"]] for r in rows if r["verdict"] == w]
                for w in ("EBE better", "EBE worse")
            }
            line = (
                f"- Against {NAMES[o]}, {name}: EBE better on {len(named['EBE better'])} of "
                f"{len(rows)} worlds, worse on {len(named['EBE worse'])}"
            )
            for w, say in (("EBE better", "better"), ("EBE worse", "worse")):
                if named[w]:
                    line += f" ({say}: {', '.join(named[w])})"
            out.append(line + ".")
    return out


def rung_table(data: Data) -> list[str]:
    rows = []
    for rung, v in data.doc["rungs"].items():
        env = (v.get("settings") or {}).get("env", {})
        ref = oracle_success(data, rung)
        rows.append(
            [
                data.rung_label[rung],
                f"`{env.get('maze', '')}`",
                f"{int(env['max_steps']):,}" if "max_steps" in env else "",
                f"{int(v.get('total_steps', data.doc['total_steps'])):,}",
                "" if ref is None else f"{ref:.3f}",
            ]
        )
    head = ["world", "maze", "steps per episode", "env steps per seed", "oracle's success"]
    return markdown_table(head, rows)


def figures(E: Exploring, out, prefix: str) -> list:
    """Greedy success and coverage against env steps on every world, each method's mean
    over seeds with a normal 95% band; the oracle's success and its 90% as lines."""
    from jaxnav.report.fig_common import plt, save_fig

    data = E.data
    cmap = plt.get_cmap("tab10")
    colors = {s: cmap(i) for i, s in enumerate(E.methods())}
    written = []
    for name, column, ylabel in (
        (FIGURES[0], "success", "greedy success"),
        (FIGURES[1], "coverage", "coverage of the free cells"),
    ):
        cells = E.cells()
        cols = min(3, len(cells))
        rows_n = math.ceil(len(cells) / cols)
        fig, axes = plt.subplots(rows_n, cols, figsize=(3.6 * cols, 2.7 * rows_n), squeeze=False)
        for k, (rung, agent) in enumerate(cells):
            ax = axes[k // cols, k % cols]
            for s in E.methods():
                curves = _curves_of(data, rung, agent, s, column)
                if not curves:
                    continue
                m = min(len(c) for c in curves)
                x = np.asarray(curves[0][:m])[:, 0]
                y = np.stack([np.asarray(c[:m])[:, 1] for c in curves])
                mean = y.mean(0)
                half = 1.96 * y.std(0, ddof=1) / np.sqrt(len(y)) if len(y) > 1 else 0 * mean
                ax.plot(x, mean, color=colors[s], label=NAMES[s], lw=1.2)
                ax.fill_between(x, mean - half, mean + half, color=colors[s], alpha=0.12)
            ref = oracle_success(data, rung)
            if column == "success" and ref is not None:
                ax.axhline(ref, color="k", lw=1, label="oracle")
                ax.axhline(REACH * ref, color="k", lw=0.8, ls=":", label="90% of the oracle")
            ax.set_title(data.rung_label[rung], fontsize=9)
            ax.set_ylim(0, 1.05)
            ax.set_xlabel("env steps per seed", fontsize=8)
            ax.tick_params(labelsize=7)
            if k % cols == 0:
                ax.set_ylabel(ylabel, fontsize=8)
        for k in range(len(cells), rows_n * cols):
            axes[k // cols, k % cols].axis("off")
        axes[0, 0].legend(fontsize=6)
        fig.tight_layout()
        written.append(save_fig(fig, out / f"{prefix}-{name}", dpi=90))
    return written


def _curves_of(data: Data, rung, agent, strategy, column) -> list[list[tuple[float, float]]]:
    """Each seed's (env step, ``column``) at its evaluations, in step order."""
    by: dict[int, list[tuple[float, float]]] = {}
    for r in data.evals:
        if (r["rung"], r["agent"], r["strategy"]) == (rung, agent, strategy):
            value = float(r[column]) if r[column] not in ("", "nan") else 0.0
            by.setdefault(int(r["seed"]), []).append((float(r["env_step"]), value))
    return [sorted(by[s]) for s in sorted(by)]


def exploring_markdown(folder, prefix: str) -> str:
    """The page from the data in ``folder``; ``prefix`` names its figures."""
    from jaxnav.core.values import flatten

    data = Data(folder)
    E = Exploring(data)
    doc = data.doc
    command = data.run["command"]
    timing, total = _timing(data)
    evals = flatten(doc.get("settings") or {}).get("run.eval_episodes", 5)
    agents = ", ".join(
        f"{data.agent_label[a]} ({settings_text(v)})" for a, v in doc["agents"].items()
    )
    L = [
        *page_head(data.doc, data.run, total),
        _sentence(E),
        "",
        "## Setup",
        "",
        f"- Every method trains its world's budget of env steps per seed (the table below), "
        f"{data.n_seeds()} seeds per method, every method and seed of a world in one compiled "
        f"program; agent: {agents}; methods: "
        f"{', '.join(NAMES[s] for s in data.strategies)}; settings over every world: "
        f"{settings_text(doc)}.",
        f"- While it trains, every policy drives {evals} greedy episodes (argmax Q; a noisy "
        f"network's mean weights) in its world at {doc.get('eval_points')} equal shares of "
        "its budget; a seed reaches the oracle at the first of these where its success (goals "
        f"per decided goal attempt) is at least {REACH:.0%} of the oracle's on the same test, "
        "and a method reaches the oracle on a world when half its seeds or more do. The area "
        "under the success curve is the mean of the evaluations.",
        "- The measures of exploring come from training itself: the env steps (all of a "
        "run's environments together) by its first goal, and the share of the world's free "
        "cells (the oracle's 0.05 m raster where the robot's disc fits and that the start "
        "reaches, pooled into 0.25 m cells) its robot has stood in.",
        f"- Final test: {doc.get('test_episodes', 10)} greedy episodes per policy from the "
        "maze's start, its first goal the maze's own, later ones drawn.",
        "- P(EBE > X) is rliable's probability of improvement with a 95% percentile "
        "bootstrap interval over seeds; for steps, where fewer is better, it is the chance "
        "that EBE needs fewer, and a seed that never gets there ranks below every seed that "
        "does. The verdict names the better method when the interval excludes 0.5 "
        "(`better`, `worse`), and otherwise says there is no detectable difference at this "
        f"seed count (`-`). With {len(E.others())} opponents, {len(MEASURES)} measures and "
        "several worlds, about one verdict in twenty names a winner by chance.",
        *[f"- {line}" for line in doc.get("notes", [])],
        "",
        *rung_table(data),
        "",
        "## Which methods reach the oracle, and how soon",
        "",
        "Per world and method: the seeds whose greedy success reaches 90% of the oracle's, "
        "the median env steps to it and to the first goal in training (`-` where half the "
        "seeds or more never get there), and mean over seeds [95% CI] of the coverage, the "
        "area under the success curve and the final test's success.",
        "",
        *reach_table(E),
        "",
        "## Where EBE ranks",
        "",
        *rank_table(E),
        "",
        "P(EBE > X) [95% CI] and the verdict, on each measure:",
        "",
        *verdict_table(E),
        "",
        "In words:",
        "",
        *in_words(E),
        "",
        "## How they drive at the end",
        "",
        "Mean greedy success over seeds [95% CI] on each world's final test, beside the "
        "oracle's on the same test:",
        "",
        *_success_table(data),
        "",
        "How each method's goal attempts end, beside the reference drivers' (the oracle and "
        "the dynamic window approach): the shares of successes, collisions and time-outs "
        "and SPL; mean over seeds [95% CI].",
        "",
        *_drive_table(data),
        "",
        "## Figures",
        "",
        f"![success against env steps]({prefix}-{FIGURES[0]})",
        "",
        "*Greedy success at each evaluation while training, against env steps per seed: "
        "mean over seeds with a normal 95% band; the solid black line is the oracle's "
        "success on the world's test, the dotted one 90% of it.*",
        "",
        f"![coverage against env steps]({prefix}-{FIGURES[1]})",
        "",
        "*The share of the world's free cells visited in training so far, at each "
        "evaluation: mean over seeds with a normal 95% band.*",
        "",
    ]
    left = doc.get("left_out", [])
    if left:
        L += ["## What this study leaves out", "", *[f"- {line}" for line in left], ""]
    again = command if " --resume" in command else f"{command} --resume"
    L += [
        "## Time",
        "",
        *timing,
        "",
        f"Total: {total / 60:.0f} minutes (training includes compiling and the evaluations "
        f"while training; testing includes the oracle and DWA). `{again}` goes on "
        "from the last finished cell (and an unfinished cell's last checkpoint).",
        "",
    ]
    return "\n".join(L)


__all__ = [
    "FIGURES",
    "MEASURES",
    "Exploring",
    "exploring_markdown",
    "figures",
    "is_exploring",
    "summary_sentence",
]
