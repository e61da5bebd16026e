"""How fast each arm of a ladder study learns, and the page of a study that measures it.

A ladder study with ``eval_points`` (``configs/studies/when_ebe_helps.yaml``) evaluates
every policy greedily at equal shares of its budget while it trains; its ``evals.csv``
holds each seed's curve of success against env steps (:mod:`jaxnav.experiments.ladder`).
From it, per seed:

* ``reach``: the env steps (and wall seconds) of the first evaluation at which the seed's
  greedy success reaches :data:`REACH` of the oracle's success on the same world; a seed
  that never does ranks below every seed that does, and equal to every other that does not.
* ``auc``: the area under the seed's success curve over its budget, as a share of the
  area of a policy at success 1 from the first evaluation on: the mean of its evaluations.

Beside them, the final greedy test's success, collisions, SPL and goals per minute. Every
comparison is P(EBE > X), rliable's probability of improvement with its 95% interval over
seeds resampled jointly, under the claims table's rule (:func:`jaxnav.report.claims.verdict`);
for a measure where less is better (steps, collisions) "EBE > X" means EBE has less.
"""

from __future__ import annotations

import functools
import math
from collections import Counter

import numpy as np

from jaxnav.report import stats
from jaxnav.report.claims import verdict
from jaxnav.report.heldout import held_out_sentence, held_out_tests
from jaxnav.report.ladder import (
    BOLTZMANN,
    DRIVERS,
    EBE,
    EPS,
    NAMES,
    NO_GOALS,
    Data,
    oracle_success,
    solved_by,
)
from jaxnav.report.markdown import interval, markdown_table, page_head, settings_text
from jaxnav.report.navigation import SOLVED_TOLERANCE

REACH = 0.9  # the share of the oracle's success a seed must reach
# measure: (how a table names it, higher is better)
MEASURES = {
    "reach": ("sooner to 90% of the oracle", False),
    "auc": ("area under the success curve", True),
    "success": ("final success", True),
    "collision": ("fewer collisions", False),
    "spl": ("SPL", True),
    "goals_per_min": ("goals per minute", True),
}
LEARNING = ("reach", "auc")  # from the evaluations while training; the rest: the final test
SHORT = {"EBE better": "better", "EBE worse": "worse", "no detectable difference": "-"}
FIGURES = ("success.png", "measures.png", "trajectories.png")


def _curves(data: Data) -> dict[tuple[str, str, str], dict[int, np.ndarray]]:
    """(rung, agent, strategy) -> seed -> f[evaluations, 4] (env step, wall s, success,
    collision), in env-step order. An evaluation with no decided attempt scores 0."""
    out: dict[tuple[str, str, str], dict[int, list]] = {}
    for r in data.evals or ():
        row = [float(r[c]) for c in ("env_step", "wall_s", "success", "collision")]
        key = (r["rung"], r["agent"], r["strategy"])
        out.setdefault(key, {}).setdefault(int(r["seed"]), []).append(row)
    return {
        k: {s: np.nan_to_num(np.asarray(sorted(v)), nan=0.0) for s, v in by.items()}
        for k, by in out.items()
    }


class Learning:
    """A study's per-seed measures of learning (``reach``, ``auc``) beside its test's."""

    def __init__(self, data: Data):
        self.data = data
        self.curves = _curves(data)

    def target(self, rung: str) -> float:
        """The success a seed must reach: :data:`REACH` of the oracle's (of 1 without it)."""
        ref = oracle_success(self.data, rung)
        return REACH * (1.0 if ref is None else ref)

    def budget(self, rung: str, agent: str) -> float:
        ends = [c[-1, 0] for s in self.data.strategies for c in self.seeds(rung, agent, s)]
        return max(ends) if ends else math.nan

    def seeds(self, rung, agent, strategy) -> list[np.ndarray]:
        """Each seed's evaluations, f[evaluations, 4], in seed order."""
        by = self.curves.get((rung, agent, strategy), {})
        return [by[s] for s in sorted(by)]

    def start_s(self, rung, agent) -> float:
        """When the cell began to train, on its evaluations' clock (the seconds since its
        command started, which in a study ran the cells before it): its last evaluation,
        at the end of training, less its training's seconds (compilation included)."""
        cell = next(c for c in self.data.cells if c["rung"] == rung and c["agent"] == agent)
        last = max(c[-1, 1] for s in self.data.strategies for c in self.seeds(rung, agent, s))
        return last - float(cell["train_s"])

    def resumed(self, rung, agent) -> bool:
        """Whether the cell's training was resumed: its evaluations' clock restarted (the
        seconds since a command started), so their seconds are not one training's."""
        return any(
            np.any(np.diff(c[:, 1]) < 0)
            for s in self.data.strategies
            for c in self.seeds(rung, agent, s)
        )

    def reached(self, rung, agent, strategy) -> tuple[np.ndarray, np.ndarray]:
        """Per seed, the env steps and the wall seconds since its cell began to train
        (:meth:`start_s`) at which it first reaches the target (inf where it never does;
        the seconds NaN for a :meth:`resumed` cell)."""
        steps, secs = [], []
        start = self.start_s(rung, agent) if self.seeds(rung, agent, strategy) else 0.0
        lost = self.resumed(rung, agent)
        for c in self.seeds(rung, agent, strategy):
            hit = np.flatnonzero(c[:, 2] >= self.target(rung) - 1e-9)
            steps.append(c[hit[0], 0] if hit.size else math.inf)
            secs.append(math.nan if lost else c[hit[0], 1] - start if hit.size else math.inf)
        return np.asarray(steps), np.asarray(secs)

    def per_seed(self, rung, agent, strategy, measure) -> np.ndarray:
        """A measure per seed, oriented so that more is better (:data:`MEASURES`)."""
        if measure == "reach":
            steps, _ = self.reached(rung, agent, strategy)
            never = 2.0 * self.budget(rung, agent)  # below every seed that reaches it
            return -np.where(np.isfinite(steps), steps, never)
        if measure == "auc":
            return np.asarray([c[:, 2].mean() for c in self.seeds(rung, agent, strategy)])
        x = self.data.per_seed(rung, agent, "own", strategy, measure)
        return x if MEASURES[measure][1] else -x

    def compare(self, rung, agent, other, measure) -> tuple[stats.Interval, str]:
        x = self.per_seed(rung, agent, EBE, measure)
        y = self.per_seed(rung, agent, other, measure)
        p = stats.probability_of_improvement_ci(x, y)
        if not stats.enough_seeds(min(len(x), len(y))):
            return p, stats.TOO_FEW_SEEDS
        if measure == "success" and not (x.any() or y.any()):
            return p, NO_GOALS
        word = {"supported": "EBE better", "contradicted": "EBE worse"}.get(verdict(p))
        return p, word or "no detectable difference"

    def cells(self) -> list[tuple[str, str]]:
        """(rung, agent) pairs that trained, in the study's order."""
        d = self.data
        return [(r, a) for r in d.rungs for a in d.agents if d.has(r, a)]

    def others(self) -> list[str]:
        return [o for o in (EPS, BOLTZMANN) if o in self.data.strategies]

    @functools.cached_property
    def rows(self) -> list[dict]:
        """Every verdict, once: (rung, agent, opponent, measure), P and the word."""
        return [
            dict(rung=r, agent=a, other=o, measure=m, p=p, verdict=w)
            for r, a in self.cells()
            for o in self.others()
            for m in MEASURES
            for p, w in [self.compare(r, a, o, m)]
        ]


def _count(rows: list[dict], other: str, measure: str, rungs=None) -> Counter:
    return Counter(
        r["verdict"]
        for r in rows
        if r["other"] == other and r["measure"] == measure and (rungs is None or r["rung"] in rungs)
    )


def solved_rungs(data: Data) -> list[str]:
    return [r for r in data.rungs if solved_by(data, r)]


def summary_sentence(data: Data) -> str:
    """The study in one sentence: EBE against epsilon-greedy on reaching 90% of the oracle
    sooner, on the worlds some arm solves, from the verdict table."""
    return _sentence(Learning(data))


def _sentence(L: Learning) -> str:
    data = L.data
    rows = L.rows
    solved = solved_rungs(data)
    cells = [(r, a) for r, a in L.cells() if r in solved]
    c = _count(rows, EPS, "reach", solved)
    a = _count(rows, EPS, "auc", solved)
    s = _count(rows, EPS, "success", solved)
    if not solved:
        n = len(data.rungs)
        which = "its world" if n == 1 else f"any of the {n} worlds"
        return (
            f"No arm drives {which} within {SOLVED_TOLERANCE} of the oracle with "
            f"{data.n_seeds()} seeds per arm, so no verdict on reaching it sooner is "
            "counted; the tables below give every measure as it is."
        )
    return (
        f"On the {len(solved)} of {len(data.rungs)} worlds that an arm drives within "
        f"{SOLVED_TOLERANCE} of the oracle, with {data.n_seeds()} seeds per arm, "
        "entropy-based exploration "
        f"reaches 90% of the oracle's success sooner than epsilon-greedy in "
        f"{c['EBE better']} of {_cells(len(cells))}, later in {c['EBE worse']} and with no "
        f"detectable difference in {c['no detectable difference']}; on the area under the "
        f"success curve it is better in {a['EBE better']} and worse in {a['EBE worse']}; "
        f"on final success better in {s['EBE better']} and worse in {s['EBE worse']}."
    )


def _cells(n: int) -> str:
    return f"{n} world and agent cell" + ("" if n == 1 else "s")


def _median(x: np.ndarray, digits: str) -> str:
    """The median of per-seed values with inf for never: a number where more than half
    are finite, else '-'."""
    if x.size and np.isnan(x).all():
        return "n/a (resumed)"
    if not x.size or np.sum(np.isfinite(x)) * 2 <= x.size:
        return "-"
    v = float(np.median(x))
    return f"{round(v):,}" if digits == "," else format(v, digits)


def learning_table(L: Learning) -> list[str]:
    data = L.data
    rows = []
    for rung, agent in L.cells():
        for s in data.strategies:
            steps, secs = L.reached(rung, agent, s)
            auc = L.per_seed(rung, agent, s, "auc")
            final = [c[-1, 2] for c in L.seeds(rung, agent, s)]
            rows.append(
                [
                    data.rung_label[rung],
                    data.agent_label[agent],
                    NAMES[s],
                    f"{int(np.sum(np.isfinite(steps)))} of {steps.size}",
                    _median(steps, ","),
                    _median(secs, ".0f"),
                    interval(stats.mean_ci(auc), 2),
                    interval(stats.mean_ci(np.asarray(final)), 2),
                ]
            )
    head = [
        "world",
        "agent",
        "strategy",
        "seeds at 90% of the oracle",
        "median env steps to it",
        "median wall s to it",
        "area under the success curve",
        "last evaluation's success",
    ]
    return markdown_table(head, rows)


def verdict_table(L: Learning, other: str) -> list[str]:
    data = L.data
    by = {(r["rung"], r["agent"], r["measure"]): r for r in L.rows if r["other"] == other}
    rows = []
    for rung, agent in L.cells():
        cells = [data.rung_label[rung], data.agent_label[agent]]
        for m in MEASURES:
            r = by[(rung, agent, m)]
            cells.append(f"{interval(r['p'], 2)} {SHORT.get(r['verdict'], r['verdict'])}")
        rows.append(cells)
    return markdown_table(["world", "agent", *(v[0] for v in MEASURES.values())], rows)


def in_words(L: Learning) -> list[str]:
    data = L.data
    rows = L.rows
    solved = set(solved_rungs(data))
    out = []
    for other in L.others():
        for m, (name, _) in MEASURES.items():
            c = _count(rows, other, m)
            named = {
                w: [
                    f"{data.rung_label[r['rung']]}"
                    + ("" if r["rung"] in solved else " (unsolved)")
                    + (f" with {data.agent_label[r['agent']]}" if len(data.agents) > 1 else "")
                    for r in rows
                    if r["other"] == other and r["measure"] == m and r["verdict"] == w
                ]
                for w in ("EBE better", "EBE worse")
            }
            line = (
                f"- Against {NAMES[other]}, {name}: EBE better in "
                f"{c['EBE better']} of {_cells(sum(c.values()))}, worse in {c['EBE worse']}, "
                f"no detectable difference in {c['no detectable difference']}"
            )
            for w in (NO_GOALS, stats.TOO_FEW_SEEDS):
                if c[w]:
                    line += f", {w} in {c[w]}"
            line += "."
            for w, say in (("EBE better", "Better"), ("EBE worse", "Worse")):
                if named[w]:
                    line += f" {say}: {'; '.join(named[w])}."
            out.append(line)
    return out


def rung_table(data: Data) -> list[str]:
    """Each world: its config, budget, the reference drivers' success and who solves it."""
    rows = []
    for rung, v in data.doc["rungs"].items():
        ref = [oracle_success(data, rung, who) for who in DRIVERS]
        ref = ["" if x is None else f"{x:.3f}" for x in ref]
        solved = solved_by(data, rung) or []
        arms = sum(data.has(rung, a) for a in data.agents) * len(data.strategies)
        rows.append(
            [
                data.rung_label[rung],
                f"`{v['config']}`",
                f"{int(v.get('total_steps', data.doc['total_steps'])):,}",
                *ref,
                f"{len(solved)} of {arms}",
            ]
        )
    head = ["world", "config", "env steps per seed", *DRIVERS.values(), "arms that solve it"]
    return markdown_table(head, rows)


def figures(L: Learning, out, prefix: str) -> list:
    """Success against env steps on every world (mean over seeds, 95% band, the oracle's
    success and its 90% as lines), and P(EBE > X) on each measure along the ladder."""
    from jaxnav.report.fig_common import plt, save_fig

    data = L.data
    colors = {EBE: "tab:blue", EPS: "tab:orange", BOLTZMANN: "tab:green"}
    styles = ["-", "--", ":"]
    n = len(data.rungs)
    cols = min(4, n)
    rows_n = math.ceil(n / cols)
    fig, axes = plt.subplots(rows_n, cols, figsize=(3.3 * cols, 2.6 * rows_n), squeeze=False)
    for k, rung in enumerate(data.rungs):
        ax = axes[k // cols, k % cols]
        for j, agent in enumerate(a for a in data.agents if data.has(rung, a)):
            for s in data.strategies:
                seeds = L.seeds(rung, agent, s)
                if not seeds:
                    continue
                m = min(len(c) for c in seeds)
                x = seeds[0][:m, 0]
                y = np.stack([c[:m, 2] for c in seeds])
                mean = y.mean(0)
                half = 1.96 * y.std(0, ddof=1) / np.sqrt(len(y)) if len(y) > 1 else 0 * mean
                label = NAMES[s] + (f", {data.agent_label[agent]}" if j else "")
                ax.plot(x, mean, styles[j % 3], color=colors[s], label=label, lw=1.2)
                ax.fill_between(x, mean - half, mean + half, color=colors[s], alpha=0.15)
        ref = oracle_success(data, rung)
        if ref is not None:
            ax.axhline(ref, color="k", lw=1, label="oracle")
            ax.axhline(REACH * ref, color="k", lw=0.8, ls=":", label="90% of the oracle")
        ax.set_title(data.rung_label[rung], fontsize=9)
        ax.set_ylim(0, 1.05)
        ax.set_xlabel("env steps per seed", fontsize=8)
        ax.tick_params(labelsize=7)
        if k % cols == 0:
            ax.set_ylabel("greedy success", fontsize=8)
    for k in range(n, rows_n * cols):
        axes[k // cols, k % cols].axis("off")
    axes[0, 0].legend(fontsize=6)
    fig.tight_layout()
    written = [save_fig(fig, out / f"{prefix}-{FIGURES[0]}", dpi=90)]

    cells = L.cells()
    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5), squeeze=False, sharey=True)
    xs = np.arange(len(cells))
    for k, (m, (name, _)) in enumerate(MEASURES.items()):
        ax = axes[k // 3, k % 3]
        for j, other in enumerate(L.others()):
            by = {
                (r["rung"], r["agent"]): r["p"]
                for r in L.rows
                if (r["other"], r["measure"]) == (other, m)
            }
            ps = [by[c] for c in cells]
            y = np.asarray([p.value for p in ps])
            err = np.nan_to_num(np.asarray([[p.value - p.low, p.high - p.value] for p in ps]).T)
            x = xs + (j - 0.5) * 0.25
            ax.errorbar(x, y, yerr=err, fmt="o", ms=4, capsize=2, color=colors[other],
                        label=f"X = {NAMES[other]}")  # fmt: skip
        ax.axhline(0.5, color="grey", lw=1, ls="--")
        ax.set_title(f"P(EBE > X): {name}", fontsize=9)
        labels = [
            data.rung_label[r] + ("" if len(data.agents) == 1 else f"\n{a}") for r, a in cells
        ]
        ax.set_xticks(xs, labels, rotation=40, ha="right", fontsize=7)
        ax.set_ylim(0, 1)
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    written.append(save_fig(fig, out / f"{prefix}-{FIGURES[1]}", dpi=90))
    return written


def _worlds(data: Data, agent: str) -> list[str]:
    return [data.rung_label[r] for r in data.rungs if data.has(r, agent)]


def learning_markdown(folder, prefix: str) -> str:
    """The page of a study with evaluations while training, from the data in ``folder``;
    ``prefix`` names its figures (``PREFIX-success.png``, beside the page)."""
    from jaxnav.core.values import flatten
    from jaxnav.report.ladder import _timing, results_sections, trajectory_cell

    data = Data(folder)
    learned = Learning(data)  # its verdicts' bootstraps, once for the whole page
    doc = data.doc
    command = data.run["command"]
    timing, total = _timing(data)
    evals = flatten(doc.get("settings") or {}).get("run.eval_episodes", 5)
    agent_rows = [
        [data.agent_label[a], settings_text(v), ", ".join(_worlds(data, a))]
        for a, v in doc["agents"].items()
    ]
    previous = doc.get("previous")
    traj = trajectory_cell(data)
    earlier = f" An earlier version of this study is [{previous}]({previous})."
    L = [
        *page_head(data.doc, data.run, total, earlier if previous else ""),
        _sentence(learned),
        "",
        *([held_out_sentence(data), ""] if held_out_tests(data) else []),
        "## Setup",
        "",
        f"- Every arm trains its world's budget of env steps per seed (the table below), "
        f"{data.n_seeds()} seeds per arm, every strategy and seed of a world and agent in one "
        f"compiled program; strategies {', '.join(NAMES[s] for s in data.strategies)}; "
        f"settings over every world: {settings_text(doc)}.",
        f"- While it trains, every policy drives {evals} greedy episodes (argmax Q) in its "
        f"training world at {doc.get('eval_points')} equal shares of its budget. A seed "
        f"reaches a world at the first of these evaluations where its success (goals per "
        f"decided goal attempt) is at least {REACH:.0%} of the oracle's on the world's own "
        "test; a seed that never does ranks below every seed that does. The area under its "
        "success curve is the mean of its evaluations (1 for a policy that drives every goal "
        "from the first evaluation on).",
        f"- Final test: {doc.get('test_episodes', 10)} greedy episodes per policy on each "
        "test world. A world's own test is its maze, or for a drawn family fresh layouts of "
        "its train split; unseen layouts are the family's test split, which training never "
        "draws. An arm solves a world when its mean success is within "
        f"{SOLVED_TOLERANCE} of the oracle's on the same test.",
        "- P(EBE > X) is rliable's probability of improvement with a 95% percentile "
        "bootstrap interval over seeds; for steps and collisions, where less is better, it "
        "is the chance that EBE has less. The verdict names the better strategy when the "
        "interval excludes 0.5 (`better`, `worse`), and otherwise says there is no "
        "detectable difference at this seed count (`-`). With 2 opponents, 6 measures and "
        "many cells, about one verdict in twenty names a winner by chance: a lone verdict "
        "is a hypothesis for fresh seeds.",
        *[f"- {line}" for line in doc.get("notes", [])],
        "",
        *rung_table(data),
        "",
        *markdown_table(["agent", "settings", "worlds"], agent_rows),
        "",
        "## How fast each arm learns",
        "",
        "From the greedy evaluations while training: the seeds that reach 90% of the "
        "oracle's success, the median env steps and wall seconds to it (`-` where half "
        "the seeds or more never do), and the area under the success curve and the last "
        "evaluation's success, mean over seeds [95% CI]. The seconds are the cell's, "
        "compilation and the evaluations included: every strategy and seed of a world and "
        "agent trains in one program, so the strategies of a cell share one clock.",
        "",
        *learning_table(learned),
        "",
    ]
    for other in learned.others():
        L += [
            f"## EBE against {NAMES[other]}",
            "",
            f"P(EBE > {NAMES[other]}) [95% CI] and the verdict, on each measure; the last "
            "four from the final greedy test on the world each policy trained on.",
            "",
            *verdict_table(learned, other),
            "",
        ]
    L += [
        "In words (cells on worlds no arm solves are marked):",
        "",
        *in_words(learned),
        "",
        *results_sections(
            data,
            "Mean greedy success over seeds [95% CI] on each world's own final test; an arm "
            f"solves a world when its mean success is within {SOLVED_TOLERANCE} of the "
            "oracle's on the same test.",
            " The larger size is drawn from the test split.",
        ),
        "## Figures",
        "",
        f"![success against env steps]({prefix}-{FIGURES[0]})",
        "",
        "*Greedy success at each evaluation while training, against env steps per seed: "
        "mean over seeds with a normal 95% band; the solid black line is the oracle's "
        "success on the world's own test, the dotted one 90% of it.*",
        "",
        f"![P(EBE > X) on each measure]({prefix}-{FIGURES[1]})",
        "",
        "*P(EBE > X) on each measure, each world and agent, with its 95% interval; the "
        "dashed line at 0.5 is no difference.*",
        "",
    ]
    if traj is not None:
        L += [
            f"![trajectories]({prefix}-{FIGURES[2]})",
            "",
            f"*The first greedy test episode of the first seed on "
            f"{data.rung_label[traj[0]]}, the hardest world with a fixed maze that an arm "
            f"solves, with {data.agent_label[traj[1]]}.*",
            "",
        ]
    left = doc.get("left_out", [])
    if left:
        L += ["## What this study leaves out", "", *[f"- {line}" for line in left], ""]
    L += [
        "## Time",
        "",
        *timing,
        "",
        f"Total: {total / 60:.0f} minutes (training includes compiling). A machine with a "
        f"GPU runs more seeds with `{command} seeds=32` (another `--out`).",
        "",
    ]
    return "\n".join(L)
