"""A study of options: one strategy, several agents that differ only in their settings
(an observation, a network), each compared with the first on every test, the kinds of
world no rung trained on above all. Its page and its one sentence, from the data alone
(:mod:`jaxnav.experiments.ladder` writes it; ``jaxnav study observation_anywhere``).

The rule is the claims table's: the 95% interval of P(arm > first arm) over seeds,
resampled, names the better arm when it excludes 0.5.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxnav.report import stats
from jaxnav.report.claims import verdict
from jaxnav.report.heldout import (
    HELD_OUT_SKIP,
    NO_HELD_OUT,
    held_out_tests,
    reference,
    reference_means,
    test_name,
)
from jaxnav.report.ladder import DRIVERS, NAMES, ORACLE, Data, _timing
from jaxnav.report.markdown import interval, markdown_table, page_head, settings_text

FIGURES = ("options.png",)
WORDS = {"supported": "better", "contradicted": "worse"}


def of_options(data: Data) -> bool:
    """A study of options: one strategy, several agents."""
    return len(data.strategies) == 1 and len(data.agents) > 1


def _tests(data: Data, rung: str) -> list[str]:
    """A rung's tests, its own world first, the held-out kinds of world last."""
    tests = data.tests(rung)
    return [t for t in tests if t in HELD_OUT_SKIP] + [t for t in tests if t not in HELD_OUT_SKIP]


def compare(data: Data, rung: str, test: str, agent: str, measure: str = "success"):
    """P(agent > the first agent) on a test with its interval, and the verdict's word:
    ``better``, ``worse``, ``-`` (no detectable difference) or too few seeds."""
    s = data.strategies[0]
    x = data.per_seed(rung, agent, test, s, measure)
    y = data.per_seed(rung, data.agents[0], test, s, measure)
    p = stats.probability_of_improvement_ci(x, y)
    if not stats.enough_seeds(min(len(x), len(y))):
        return p, stats.TOO_FEW_SEEDS
    return p, WORDS.get(verdict(p), "-")


def summary_sentence(data: Data) -> str:
    """Each arm against the first on the kinds of world no rung trained on, success by
    the claims' rule, with every arm's mean success over them beside the reference
    drivers' on the same tests."""
    s = data.strategies[0]
    first = data.agents[0]
    parts = []
    tests = list(dict.fromkeys((r, t) for r, _, t in held_out_tests(data)))
    if not tests:
        return NO_HELD_OUT

    def mean(agent: str) -> float:
        return float(np.mean([data.per_seed(r, agent, t, s, "success").mean() for r, t in tests]))

    for agent in data.agents[1:]:
        words = [compare(data, r, t, agent)[1] for r, t in tests]
        parts.append(
            f"{data.agent_label[agent]} {mean(agent):.2f} (detectably lower on "
            f"{words.count('worse')} of the {len(tests)}, higher on {words.count('better')})"
        )
    means = reference_means(data, tests)
    names = ", ".join(dict.fromkeys(test_name(t) for _, t in tests))
    refs = f"; {', '.join(means)} on the same tests" if means else ""
    return (
        f"On {len(tests)} kinds of world no policy trained on ({names}), {data.n_seeds()} "
        f"seeds per arm, mean success {data.agent_label[first]} {mean(first):.2f}, "
        + ", ".join(parts)
        + f"{refs}."
    )


def _success_table(data: Data, measure: str) -> list[str]:
    s = data.strategies[0]
    rows = []
    for rung in data.rungs:
        for t in _tests(data, rung):
            cells = [data.rung_label[rung], test_name(t)]
            for agent in data.agents:
                x = data.per_seed(rung, agent, t, s, measure)
                cells.append(interval(stats.mean_ci(x), 2) if x.size else "")
            for who in DRIVERS:
                x = reference(data, rung, t, who, measure)
                cells.append(f"{x.mean():.2f}" if x is not None else "")
            rows.append(cells)
    head = ["trained on", "tested on", *(data.agent_label[a] for a in data.agents)]
    return markdown_table(head + list(DRIVERS.values()), rows)


def _verdict_table(data: Data) -> list[str]:
    rows = []
    for rung in data.rungs:
        for t in _tests(data, rung):
            cells = [data.rung_label[rung], test_name(t)]
            for agent in data.agents[1:]:
                p, word = compare(data, rung, t, agent)
                cells.append(f"{interval(p, 2)} {word}")
            rows.append(cells)
    first = data.agent_label[data.agents[0]]
    head = ["trained on", "tested on"]
    head += [f"P({data.agent_label[a]} > {first})" for a in data.agents[1:]]
    return markdown_table(head, rows)


def options_markdown(folder: Path, prefix: str) -> str:
    """The page from the data in ``folder``; ``prefix`` names its figure."""
    data = Data(folder)
    doc = data.doc
    timing, total = _timing(data)
    first = data.agent_label[data.agents[0]]
    agent_rows = [[data.agent_label[a], settings_text(v)] for a, v in doc["agents"].items()]
    rung_rows = [
        [
            data.rung_label[r],
            f"`{v['config']}`",
            f"{int(v.get('total_steps', doc['total_steps'])):,}",
        ]
        for r, v in doc["rungs"].items()
    ]
    L = [
        *page_head(data.doc, data.run, total),
        summary_sentence(data),
        "",
        "## Setup",
        "",
        f"- Every arm is the same config but for the settings in the second table, "
        f"{data.n_seeds()} seeds per arm, strategy {NAMES[data.strategies[0]]}, every seed "
        f"of an arm in one compiled program; settings over every arm: {settings_text(doc)}.",
        f"- Test: {doc.get('test_episodes', 10)} greedy episodes (argmax Q) per policy on "
        "each test: its own world (drawn mazes: fresh layouts of their train split), the "
        "unseen layouts of their test split, which training never draws, and each fixed "
        "world of the study's `generalise_to`, kinds of world no rung trains on; the "
        "oracle and DWA drive the same episodes.",
        f"- P(arm > {first}) is rliable's probability of improvement on success with a "
        "95% percentile bootstrap interval over seeds; the verdict says `better` or "
        "`worse` when the interval excludes 0.5 and `-` otherwise (no detectable "
        "difference at this seed count). With many tests and arms about one verdict in "
        "twenty names a winner by chance.",
        "",
        *markdown_table(["world", "config", "env steps per seed"], rung_rows),
        "",
        *markdown_table(["arm", "settings"], agent_rows),
        "",
        "## Success on each test",
        "",
        "Mean greedy success over seeds [95% CI] (goals reached per decided goal attempt), "
        "and the reference drivers' on the same episodes.",
        "",
        *_success_table(data, "success"),
        "",
        "## Against the first arm",
        "",
        f"P(arm > {first}) on success [95% CI] and the verdict.",
        "",
        *_verdict_table(data),
        "",
        "## Collisions",
        "",
        "The share of decided goal attempts that end in a collision; mean over seeds [95% CI].",
        "",
        *_success_table(data, "collision"),
        "",
    ]
    notes = [*(f"- {n}" for n in doc.get("notes", []))]
    left = [*(f"- {n}" for n in doc.get("left_out", []))]
    if notes:
        L += ["## Notes", "", *notes, ""]
    if left:
        L += ["## Left out", "", *left, ""]
    L += [
        "## Figure",
        "",
        f"![success per test and arm]({prefix}-{FIGURES[0]})",
        "",
        "*Mean greedy success per test and arm with its 95% interval; the oracle's as a "
        "black tick.*",
        "",
        "## Time",
        "",
        *timing,
        "",
        f"Total: {total / 60:.0f} minutes (training includes compiling).",
        "",
    ]
    return "\n".join(L)


def figures(folder: Path, out: Path, prefix: str) -> list[Path]:
    """Success per test and arm with its interval, beside the oracle's."""
    from jaxnav.report.fig_common import plt, save_fig

    data = Data(folder)
    s = data.strategies[0]
    cols = [(r, t) for r in data.rungs for t in _tests(data, r)]
    fig, ax = plt.subplots(figsize=(max(6.0, 1.1 * len(cols)), 3.4))
    width = 0.8 / len(data.agents)
    for k, agent in enumerate(data.agents):
        ivs = [stats.mean_ci(data.per_seed(r, agent, t, s, "success")) for r, t in cols]
        xs = np.arange(len(cols)) + (k - (len(data.agents) - 1) / 2) * width
        mid = np.array([iv.value for iv in ivs])
        err = np.array([[iv.value - iv.low, iv.high - iv.value] for iv in ivs]).T
        ax.bar(xs, mid, width, yerr=err, capsize=2, label=data.agent_label[agent])
    for j, (r, t) in enumerate(cols):
        x = reference(data, r, t, ORACLE)
        if x is not None:
            ax.plot([j - 0.42, j + 0.42], [x.mean()] * 2, color="black", lw=1.2)
    ax.set_xticks(np.arange(len(cols)), [test_name(t) for _, t in cols], rotation=20, fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("greedy success")
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    return [save_fig(fig, out / f"{prefix}-{FIGURES[0]}", dpi=90)]
