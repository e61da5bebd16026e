"""A ladder study's page and figures, from its data alone (``study.yaml``,
``scores.csv``, ``curves.csv``, ``cells.csv``: :mod:`jaxnav.experiments.ladder`).

Every sentence under the verdicts is computed: the verdict rule is the claims table's
(the 95% interval of P(EBE > other) over seeds, resampled, excludes 0.5), and with
fewer seeds than :data:`jaxnav.report.stats.MIN_SEEDS` a verdict says so instead.
"""

from __future__ import annotations

import csv
import io
import json
from collections import Counter
from pathlib import Path

import numpy as np
import yaml

from jaxnav.core import strategies
from jaxnav.report import stats
from jaxnav.report.claims import verdict
from jaxnav.report.markdown import interval, markdown_table, page_head, settings_text
from jaxnav.report.navigation import SOLVED_TOLERANCE, solved

ORACLE = "oracle"  # the reference driver whose success on the same test defines "solved"
TRAJECTORY_SUCCESS = 0.5  # the trajectory figure's world: an arm reaches this share of goals
EBE, EPS, BOLTZMANN = "ebe", "epsilon_greedy", "boltzmann"


class _Labels(dict):
    """The strategies' names in tables: these three, any other its registered label."""

    def __missing__(self, key: str) -> str:
        return strategies.label(key)


NAMES = _Labels({EBE: "EBE", EPS: "epsilon-greedy", BOLTZMANN: "Boltzmann"})
MEASURES = ("success", "return")
DRIVE_MEASURES = ("collision", "spl")  # how the arms drive, beside success
DRIVERS = {ORACLE: "oracle", "dwa": "DWA"}  # the reference drivers, as tables name them
NO_GOALS = "neither reaches a goal"  # a success verdict where every seed of both scores 0
FIGURES = ("ladder.png", "curves.png", "trajectories.png")
DATA_FILES = ("study.yaml", "scores.csv", "curves.csv", "cells.csv", "run.json")
LEARNING_FILES = ("evals.csv",)  # a study with evaluations while training (eval_points)
TEST_NAMES = {"own": "own world", "test": "unseen layouts", "larger": "larger size"}


def _rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


class Data:
    """A study's data folder, read once."""

    def __init__(self, folder: Path):
        folder = Path(folder)
        self.doc = yaml.safe_load((folder / "study.yaml").read_text())
        self.rungs = list(self.doc["rungs"])
        self.agents = list(self.doc["agents"])
        self.strategies = list(self.doc["strategies"])
        self.rung_label = {k: v.get("label", k) for k, v in self.doc["rungs"].items()}
        self.agent_label = {k: v.get("label", k) for k, v in self.doc["agents"].items()}
        self.scores: dict[tuple[str, str, str, str], dict[int, dict[str, float]]] = {}
        rows = _rows(folder / "scores.csv")
        # Data written before attempts cut by an episode's end were counted apart counts
        # them as time-outs: success is capped below 1 even for a perfect driver.
        self.counted_cut = bool(rows) and "cut" in rows[0]
        for r in rows:
            key = (r["rung"], r["agent"], r["test"], r["strategy"])
            self.scores.setdefault(key, {})[int(r["seed"])] = {
                m: float(r[m]) for m in (*MEASURES, *DRIVE_MEASURES, "goals_per_min") if m in r
            }
        self.curves = _rows(folder / "curves.csv")
        self.cells = _rows(folder / "cells.csv")
        self.run = json.loads((folder / "run.json").read_text())
        # greedy evaluations while training (a study with eval_points): None without
        evals = folder / "evals.csv"
        self.evals = _rows(evals) if evals.is_file() else None

    def has(self, rung: str, agent: str) -> bool:
        """Whether the agent trained on the rung (a study may give an agent some rungs)."""
        return any(k[0] == rung and k[1] == agent for k in self.scores)

    def tests(self, rung: str) -> list[str]:
        return list(dict.fromkeys(k[2] for k in self.scores if k[0] == rung))

    def per_seed(self, rung, agent, test, strategy, measure) -> np.ndarray:
        by = self.scores.get((rung, agent, test, strategy), {})
        return np.asarray([by[s][measure] for s in sorted(by)], np.float64)

    def n_seeds(self) -> int:
        return min(len(v) for v in self.scores.values())


def compare(data: Data, rung, agent, test, other, measure) -> tuple[stats.Interval, str]:
    """P(EBE > other) with its interval, and the verdict."""
    x = data.per_seed(rung, agent, test, EBE, measure)
    y = data.per_seed(rung, agent, test, other, measure)
    p = stats.probability_of_improvement_ci(x, y)
    if not stats.enough_seeds(min(len(x), len(y))):
        return p, stats.TOO_FEW_SEEDS
    if measure == "success" and not (x.any() or y.any()):
        return p, NO_GOALS
    word = {"supported": "EBE better", "contradicted": "EBE worse"}.get(verdict(p))
    return p, word or "no detectable difference"


def verdicts(data: Data, test: str = "own") -> list[dict]:
    """One row per (rung, agent, opponent, measure) on ``test``."""
    out = []
    for rung in data.rungs:
        for agent in data.agents:
            if (rung, agent, test, EBE) not in data.scores:
                continue
            for other in (EPS, BOLTZMANN):
                if other not in data.strategies:
                    continue
                for measure in MEASURES:
                    p, word = compare(data, rung, agent, test, other, measure)
                    out.append(dict(rung=rung, agent=agent, other=other, measure=measure, p=p,
                                    verdict=word))  # fmt: skip
    return out


def oracle_success(data: Data, rung: str, who: str = ORACLE) -> float | None:
    """The oracle's (or another reference driver's, ``who``) mean greedy success on the
    rung's own test (over every cell that drove it); None where the data has no rows of it."""
    x = [data.per_seed(rung, a, "own", who, "success") for a in data.agents]
    x = np.concatenate([v for v in x if v.size]) if any(v.size for v in x) else np.empty(0)
    return float(np.mean(x)) if x.size else None


def solved_by(data: Data, rung: str) -> list[tuple[str, str]] | None:
    """(agent, strategy) arms whose mean greedy success on the rung's own world is
    within :data:`~jaxnav.report.navigation.SOLVED_TOLERANCE` of the oracle's on the
    same test (:func:`jaxnav.report.navigation.solved`); None where the data cannot say
    (counted before cut attempts were told apart, or without the oracle's rows)."""
    reference = oracle_success(data, rung)
    if not data.counted_cut or reference is None:
        return None
    return [
        (a, s)
        for a in data.agents
        if data.has(rung, a)
        for s in data.strategies
        if solved(float(np.mean(data.per_seed(rung, a, "own", s, "success"))), reference)
    ]


def trajectory_cell(data: Data) -> tuple[str, str] | None:
    """The hardest rung (last in the ladder) with a fixed maze (no unseen split) where
    some arm reaches at least :data:`TRAJECTORY_SUCCESS` of its goals, and the agent of
    its best arm; None if there is none."""
    for rung in reversed(data.rungs):
        if "test" in data.tests(rung):
            continue
        if data.evals is not None:  # a study of learning: the hardest world an arm solves
            arms = solved_by(data, rung) or []
            if arms:
                best = max(
                    arms,
                    key=lambda arm: np.mean(
                        data.per_seed(rung, *arm[:1], "own", arm[1], "success")
                    ),
                )
                return rung, best[0]
            continue
        arms = [(a, s) for a in data.agents if data.has(rung, a) for s in data.strategies]
        mean = {arm: np.mean(data.per_seed(rung, arm[0], "own", arm[1], "success")) for arm in arms}
        best = max(arms, key=lambda arm: mean[arm])
        if mean[best] >= TRAJECTORY_SUCCESS:
            return rung, best[0]
    return None


def _count(rows: list[dict], other: str, measure: str) -> Counter:
    return Counter(r["verdict"] for r in rows if r["other"] == other and r["measure"] == measure)


def summary_sentence(data: Data) -> str:
    """The study in one sentence, from its verdict table (success on each rung's own world)."""
    c = _count(verdicts(data), EPS, "success")
    n = sum(c.values())
    tail = f", and neither reaches a goal in {c[NO_GOALS]}" if c[NO_GOALS] else ""
    if c[stats.TOO_FEW_SEEDS]:
        tail += f" ({stats.TOO_FEW_SEEDS} in {c[stats.TOO_FEW_SEEDS]})"
    worlds = (
        f"On {data.rung_label[data.rungs[0]]} with"
        if len(data.rungs) == 1
        else f"Across {len(data.rungs)} worlds of growing difficulty and"
    )
    agents = f"{len(data.agents)} agent" + ("s" if len(data.agents) != 1 else "")
    cells = f"{n} cell" + ("s" if n != 1 else "")
    return (
        f"{worlds} {agents} "
        f"({cells}, {data.n_seeds()} seeds per arm), entropy-based exploration reaches more "
        f"goals than epsilon-greedy in {c['EBE better']}, fewer in {c['EBE worse']}, shows "
        f"no detectable difference in {c['no detectable difference']}{tail}."
    )


def _verdict_table(data: Data, test: str) -> list[str]:
    rows = []
    others = [o for o in (EPS, BOLTZMANN) if o in data.strategies]
    by = {(r["rung"], r["agent"], r["other"], r["measure"]): r for r in verdicts(data, test)}
    for rung in data.rungs:
        for agent in data.agents:
            if (rung, agent, EPS, "success") not in by:
                continue
            cells = [data.rung_label[rung], data.agent_label[agent]]
            for other in others:
                for measure in MEASURES:
                    r = by.get((rung, agent, other, measure))
                    cells += [f"{interval(r['p'], 2)} {r['verdict']}" if r else ""]
            rows.append(cells)
    head = ["world", "agent"] + [f"P(EBE > {NAMES[o]}), {m}" for o in others for m in MEASURES]
    return markdown_table(head, rows)


def _success_table(data: Data) -> list[str]:
    rows = []
    oracle = any(oracle_success(data, r) is not None for r in data.rungs)
    for rung in data.rungs:
        for agent in (a for a in data.agents if data.has(rung, a)):
            cells = [data.rung_label[rung], data.agent_label[agent]]
            for s in data.strategies + ([ORACLE] if oracle else []):
                x = data.per_seed(rung, agent, "own", s, "success")
                cells.append(interval(stats.mean_ci(x), 2) if x.size else "")
            rows.append(cells)
    names = [NAMES[s] for s in data.strategies] + (["oracle"] if oracle else [])
    return markdown_table(["world", "agent", *names], rows)


def _drive_table(data: Data) -> list[str]:
    rows = []

    def cells(rung, agent, who) -> list[str]:
        s, c, spl = (
            data.per_seed(rung, agent, "own", who, m) for m in ("success", *DRIVE_MEASURES)
        )
        out = (s, c, np.maximum(1.0 - s - c, 0.0), spl)  # a share's rounding is not below 0
        return [interval(stats.mean_ci(x), 2) for x in out]

    for rung in data.rungs:
        for agent in data.agents:
            for s in data.strategies:
                if data.per_seed(rung, agent, "own", s, "success").size:
                    label = [data.rung_label[rung], data.agent_label[agent], NAMES[s]]
                    rows.append(label + cells(rung, agent, s))
        for who, name in DRIVERS.items():  # driven once per world, beside one agent
            have = [a for a in data.agents if data.per_seed(rung, a, "own", who, "spl").size]
            if have:
                rows.append([data.rung_label[rung], "", name] + cells(rung, have[0], who))
    head = ["world", "agent", "driver", "success", "collision", "time-out", "SPL"]
    return markdown_table(head, rows)


def _gap_table(data: Data) -> list[str]:
    rows = []
    family = [r for r in data.rungs if "test" in data.tests(r)]
    more = list(dict.fromkeys(t for r in family for t in data.tests(r) if t not in ("own", "test")))
    for rung in family:
        tests = data.tests(rung)
        for agent in (a for a in data.agents if data.has(rung, a)):
            for s in data.strategies:
                own = data.per_seed(rung, agent, "own", s, "success")
                unseen = data.per_seed(rung, agent, "test", s, "success")
                cells = [data.rung_label[rung], data.agent_label[agent], NAMES[s]]
                cells += [interval(stats.mean_ci(own), 2), interval(stats.mean_ci(unseen), 2)]
                cells.append(interval(stats.mean_ci(own - unseen), 2, sign="+"))
                for t in more:
                    x = data.per_seed(rung, agent, t, s, "success")
                    cells.append(interval(stats.mean_ci(x), 2) if t in tests else "")
                rows.append(cells)
    if not rows:
        return ["No rung of this study draws its mazes: there is no unseen split to test."]
    head = ["world", "agent", "strategy", "train layouts", "unseen layouts", "gap (train - unseen)"]
    return markdown_table(head + [f"success, {TEST_NAMES.get(m, m)}" for m in more], rows)


def _generalisation_verdicts(data: Data) -> list[str]:
    rows = []
    for rung in data.rungs:
        for t in data.tests(rung):
            if t == "own":
                continue
            for agent in (a for a in data.agents if data.has(rung, a)):
                for other in (o for o in (EPS, BOLTZMANN) if o in data.strategies):
                    p, word = compare(data, rung, agent, t, other, "success")
                    cells = [data.rung_label[rung], TEST_NAMES.get(t, t), data.agent_label[agent]]
                    rows.append(cells + [NAMES[other], interval(p, 2), word])
    if not rows:
        return ["No policy of this study was tested on a world it did not train on."]
    head = ["trained on", "tested on", "agent", "EBE against", "P(EBE > it), success", "verdict"]
    return markdown_table(head, rows)


def _in_words(data: Data) -> list[str]:
    rows = verdicts(data)
    out = []
    for other in (EPS, BOLTZMANN):
        if other not in data.strategies:
            continue
        for measure in MEASURES:
            c = _count(rows, other, measure)
            better = [
                f"{data.rung_label[r['rung']]} with {data.agent_label[r['agent']]}"
                for r in rows
                if r["other"] == other and r["measure"] == measure and r["verdict"] == "EBE better"
            ]
            worse = [
                f"{data.rung_label[r['rung']]} with {data.agent_label[r['agent']]}"
                for r in rows
                if r["other"] == other and r["measure"] == measure and r["verdict"] == "EBE worse"
            ]
            line = (
                f"- Against {NAMES[other]}, on {measure}: EBE better in {c['EBE better']} "
                f"cells, worse in {c['EBE worse']}, no detectable difference in "
                f"{c['no detectable difference']}"
            )
            for other_word in (NO_GOALS, stats.TOO_FEW_SEEDS):
                if c[other_word]:
                    line += f", {other_word} in {c[other_word]}"
            line += "."
            if better:
                line += f" Better: {'; '.join(better)}."
            if worse:
                line += f" Worse: {'; '.join(worse)}."
            out.append(line)
    return out


def _solved_lines(data: Data) -> list[str]:
    if any(solved_by(data, r) is None for r in data.rungs):
        why = (
            "This study's data counts an attempt cut off by an episode's end as a time-out "
            "(it was written before such attempts were counted apart), so its success is "
            "capped below 1 even for a driver that reaches every goal it has time for; "
            "and it has no oracle rows to measure against. It does not say which worlds "
            "are solved: a new run of the study counts cut attempts apart and drives the "
            "oracle through every test."
            if not data.counted_cut
            else "This study's data has no oracle rows: it does not say which worlds are solved."
        )
        return [why]
    first, last = data.rungs[0], data.rungs[-1]

    def arms(rung: str) -> int:
        return sum(data.has(rung, a) for a in data.agents) * len(data.strategies)

    out = []
    for rung in data.rungs:
        s = solved_by(data, rung)
        names = ", ".join(f"{NAMES[b]} ({data.agent_label[a]})" for a, b in s) or "none"
        out.append(f"- {data.rung_label[rung]}: {len(s)} of {arms(rung)} arms ({names}).")
    if len(data.rungs) > 1:
        out.append("")
        out.append(
            f"The easiest world ({data.rung_label[first]}) is solved by "
            f"{len(solved_by(data, first))} of {arms(first)} arms; the hardest "
            f"({data.rung_label[last]}) by {len(solved_by(data, last))}."
        )
    return out


def _timing(data: Data) -> tuple[list[str], float]:
    rows, total = [], 0.0
    for c in data.cells:
        t = float(c["train_s"]) + float(c["test_s"])
        total += t
        rows.append(
            [
                data.rung_label[c["rung"]],
                data.agent_label[c["agent"]],
                c["runs"],
                f"{int(c['env_steps']):,}",
                f"{float(c['train_s']):.0f}",
                f"{float(c['test_s']):.0f}",
                f"{int(c['transitions_per_s']):,}",
            ]
        )
    head = ["world", "agent", "runs", "env steps", "train s", "test s", "transitions/s"]
    return markdown_table(head, rows), total


def results_sections(data: Data, solved_intro: str, gap_note: str = "") -> list[str]:
    """The sections every ladder page shares, from "Which worlds are solved" to the
    generalisation verdicts; ``solved_intro`` opens the first, ``gap_note`` ends the
    generalisation section's first paragraph."""
    return [
        "## Which worlds are solved",
        "",
        solved_intro,
        "",
        *_success_table(data),
        "",
        *_solved_lines(data),
        "",
        "## How they drive",
        "",
        "How each arm's goal attempts end on its own world, beside the reference drivers' "
        "on the same test: the shares of successes, collisions and time-outs (they sum to "
        "1) and SPL (success weighted by the shortest path over the path driven); mean "
        "over seeds [95% CI]."
        + (
            ""
            if data.counted_cut
            else " This data counts an attempt cut by its episode's end as a time-out."
        ),
        "",
        *_drive_table(data),
        "",
        "## Does it generalise?",
        "",
        "Per seed, success on the family's train layouts minus success on its unseen "
        "layouts; mean over seeds [95% CI]. A gap whose interval covers 0 is not "
        "detectable at this seed count." + gap_note,
        "",
        *_gap_table(data),
        "",
        "EBE against each other strategy on the worlds the policies never trained on:",
        "",
        *_generalisation_verdicts(data),
        "",
    ]


def ladder_markdown(folder: Path, prefix: str) -> str:
    """The page from the data in ``folder``; ``prefix`` names its figures
    (``PREFIX-ladder.png``, beside the page)."""
    data = Data(folder)
    doc = data.doc
    timing, total = _timing(data)
    n = data.n_seeds()
    rung_rows = [
        [data.rung_label[r], f"`{v['config']}`", settings_text(v)] for r, v in doc["rungs"].items()
    ]
    own_budgets = any("total_steps" in v for v in doc["rungs"].values())
    budget = f"{int(doc['total_steps']):,} environment steps per seed"
    rung_head = ["world", "config", "settings over it"]
    if own_budgets:  # each world's budget in its row
        budget = "its world's budget of environment steps per seed (the table below)"
        rung_head.append("env steps per seed")
        for row, v in zip(rung_rows, doc["rungs"].values()):
            row.append(f"{int(v.get('total_steps', doc['total_steps'])):,}")
    agent_rows = [[data.agent_label[a], settings_text(v)] for a, v in doc["agents"].items()]
    traj = trajectory_cell(data)
    L = [
        *page_head(data.doc, data.run, total),
        summary_sentence(data),
        "",
        "## Setup",
        "",
        f"- Every arm trains {budget}, "
        f"{n} seeds per arm, every strategy and seed of a world and agent in one compiled "
        f"program; strategies {', '.join(NAMES[s] for s in data.strategies)}; "
        f"settings over every world: {settings_text(doc)}.",
        f"- Test: {doc.get('test_episodes', 10)} greedy episodes (argmax Q) per policy on "
        "each test world. A world's own test is its maze, or for a drawn family fresh "
        "layouts of its train split; unseen layouts are the family's test split, which "
        "training never draws.",
        "- A seed's score is its success (goals reached per goal attempt) or its mean "
        "return. P(EBE > X) is rliable's probability of improvement with a 95% percentile "
        "bootstrap interval over seeds; the verdict names the better strategy when the "
        "interval excludes 0.5, and otherwise says there is no detectable difference at "
        "this seed count. With 2 opponents, 2 measures and many cells, about one verdict "
        "in twenty names a winner by chance: a lone verdict is a hypothesis for fresh seeds.",
        "",
        *markdown_table(rung_head, rung_rows),
        "",
        *markdown_table(["agent", "settings"], agent_rows),
        "",
        "## Verdicts on each world",
        "",
        "Greedy test on the world each policy trained on.",
        "",
        *_verdict_table(data, "own"),
        "",
        "In words:",
        "",
        *_in_words(data),
        "",
        *results_sections(
            data,
            "Mean greedy success over seeds [95% CI] on each world"
            + (
                "; an arm solves a world when its mean success is within "
                f"{SOLVED_TOLERANCE} of the oracle's on the same test."
                if all(solved_by(data, r) is not None for r in data.rungs)
                else "."
            ),
        ),
        "## Figures",
        "",
        f"![P(EBE > epsilon-greedy) along the ladder]({prefix}-{FIGURES[0]})",
        "",
        "*P(EBE > epsilon-greedy) on success, each world and agent, with its 95% "
        "interval; the dashed line at 0.5 is no difference.*",
        "",
        f"![learning curves]({prefix}-{FIGURES[1]})",
        "",
        "*Training goals per episode (a 20-episode moving mean) against the share of "
        "the step budget: mean over seeds with a normal 95% band.*",
        "",
    ]
    if traj is not None:
        L += [
            f"![trajectories]({prefix}-{FIGURES[2]})",
            "",
            f"*The first greedy test episode of the first seed on "
            f"{data.rung_label[traj[0]]}, the hardest world with a fixed maze where an arm "
            f"reaches at least {TRAJECTORY_SUCCESS:.0%} of its goals, with "
            f"{data.agent_label[traj[1]]}.*",
            "",
        ]
    else:
        L += [
            f"No arm reaches {TRAJECTORY_SUCCESS:.0%} of its goals on a world with a fixed "
            "maze: no trajectory figure.",
            "",
        ]
    L += [
        "## Time",
        "",
        *timing,
        "",
        f"Total: {total / 60:.0f} minutes (training includes compiling). A machine with a "
        "GPU runs the same command with more seeds (`seeds:` in the study file).",
        "",
    ]
    return "\n".join(L)


def ladder_figures(folder: Path, out: Path, prefix: str) -> list[Path]:
    """The P-along-the-ladder figure and the learning curves, into ``out``."""
    from jaxnav.report.fig_common import plt, save_fig

    data = Data(folder)
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(data.rungs)), 3.8))
    xs = np.arange(len(data.rungs))
    width = 0.8 / len(data.agents)
    for k, agent in enumerate(data.agents):
        ps = [compare(data, r, agent, "own", EPS, "success")[0] for r in data.rungs]
        x = xs - 0.4 + width * (k + 0.5)
        y = np.asarray([p.value for p in ps])
        err = np.asarray([[p.value - p.low, p.high - p.value] for p in ps]).T
        ax.errorbar(x, y, yerr=err, fmt="o", capsize=3, label=data.agent_label[agent])
    ax.axhline(0.5, color="grey", lw=1, ls="--")
    ax.set_xticks(xs, [data.rung_label[r] for r in data.rungs], rotation=30, ha="right")
    ax.set_ylabel("P(EBE > epsilon-greedy), success")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=8)
    fig.tight_layout()
    written = [save_fig(fig, out / f"{prefix}-{FIGURES[0]}", dpi=100)]

    nr, na = len(data.rungs), len(data.agents)
    fig, axes = plt.subplots(nr, na, figsize=(3.4 * na, 2.3 * nr), squeeze=False, sharex=True)
    colors = {EBE: "tab:blue", EPS: "tab:orange", BOLTZMANN: "tab:green"}
    for i, rung in enumerate(data.rungs):
        for j, agent in enumerate(data.agents):
            ax = axes[i, j]
            for s in data.strategies:
                rows = [
                    r
                    for r in data.curves
                    if r["rung"] == rung and r["agent"] == agent and r["strategy"] == s
                ]
                x = [float(r["share"]) for r in rows]
                ax.plot(x, [float(r["goals"]) for r in rows], color=colors[s], label=NAMES[s])
                ax.fill_between(
                    x,
                    [float(r["low"]) for r in rows],
                    [float(r["high"]) for r in rows],
                    color=colors[s],
                    alpha=0.2,
                )
            if i == 0:
                ax.set_title(data.agent_label[agent], fontsize=9)
            if j == 0:
                ax.set_ylabel(data.rung_label[rung], fontsize=8)
    axes[0, 0].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("share of the step budget")
    fig.tight_layout()
    written.append(save_fig(fig, out / f"{prefix}-{FIGURES[1]}", dpi=80))
    return written
