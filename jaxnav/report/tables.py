"""The report's markdown tables, pure functions of results.csv and robustness.csv text."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from jaxnav.core import baselines
from jaxnav.core.config import PAPER_STRATEGIES
from jaxnav.core.errors import RunError
from jaxnav.core.sweep import row_arm
from jaxnav.report import stats
from jaxnav.report.markdown import aligned_table, interval, markdown_table
from jaxnav.report.nav_tables import navigation_section
from jaxnav.report.paper import PAPER_TABLES
from jaxnav.report.results import (
    MODE_NAMES,
    UNPERTURBED,
    RobustnessRow,
    arm_strategy,
    arms_in,
    display_name,
    ordered_unique,
    per_seed_scores,
    read_results,
    read_robustness,
    result_modes,
    robustness_summary,
    scores_over_mazes,
)


def _pm(mean: float, std: float) -> str:
    return f"{mean:.2f} ± {std:.2f}"


class _Test(NamedTuple):
    """What every section of the test tables needs, read once from results.csv."""

    results: dict  # (maze, strategy, seed) -> per-episode arrays
    mazes: list[str]
    strategies: list[str]
    seeds: list[int]
    seed0: int  # the single seed of the paper-form table
    names: list[str]  # display names of the strategies

    def paper_form(self, maze: str, strategy: str, seed: int) -> str:
        return _pm(*stats.mean_std(self.results[(maze, strategy, seed)]["return"]))

    def scores(self, maze: str, strategy: str) -> np.ndarray:
        return per_seed_scores(self.results, maze, strategy, self.seeds)


def tables_markdown(
    results_csv: str, train_maze: str, first_seed: int, title: str = "Test results"
) -> str:
    """The report's tables from results.csv text, one part per test mode.

    Args:
      results_csv: the text of results.csv.
      train_maze: the training maze (picks the paper's Table 3 or 4).
      first_seed: the config's seed: the single-seed table uses it, as the paper
        shows one run.
    """
    modes = result_modes(results_csv)
    if not modes:
        raise RunError("results.csv has no rows")
    L: list[str] = [f"# {title}", ""]
    for mode in modes:
        t = _test(read_results(results_csv, mode), first_seed)
        n_eps = {len(v["return"]) for v in t.results.values()}
        L += [
            f"## Test mode: {MODE_NAMES[mode]}",
            "",
            f"Trained on `{train_maze}`; {len(t.seeds)} seed(s) per strategy; "
            f"{'/'.join(map(str, sorted(n_eps)))} consecutive test episodes per seed and maze "
            "in the training environment's settings (dropout off).",
            "",
        ]
        sections = _paper_form_section(t) + _across_seeds_section(t)
        sections += navigation_section(t.results, t.mazes, t.strategies, t.seeds)
        sections += _sweep_section(t)
        if set(PAPER_STRATEGIES) <= set(t.strategies):
            sections += _improvement_section(t)
        sections += _beside_paper_section(t, train_maze)
        L += [("#" + line) if line.startswith("## ") else line for line in sections]
        L += [""]
    return "\n".join(L).rstrip("\n") + "\n"


def _test(results: dict, first_seed: int) -> _Test:
    strategies = arms_in(k[1] for k in results)
    seeds = sorted({k[2] for k in results})
    return _Test(
        results=results,
        mazes=ordered_unique(k[0] for k in results),
        strategies=strategies,
        seeds=seeds,
        seed0=first_seed if first_seed in seeds else seeds[0],
        names=[display_name(s) for s in strategies],
    )


def _paper_form_section(t: _Test) -> list[str]:
    L = [
        "## Paper form: mean ± std (ddof 0) of the episode return over the test episodes, "
        f"seed {t.seed0}",
        "",
    ]
    L += markdown_table(
        ["maze"] + t.names,
        [[m] + [t.paper_form(m, s, t.seed0) for s in t.strategies] for m in t.mazes],
    )
    L += ["", "## Paper form, every seed", ""]
    L += markdown_table(
        ["maze", "seed"] + t.names,
        [
            [m, str(k)] + [t.paper_form(m, s, k) for s in t.strategies]
            for m in t.mazes
            for k in t.seeds
        ],
    )
    return L


def _across_seeds_section(t: _Test) -> list[str]:
    L = [
        "",
        "## Across seeds",
        "",
        "A seed's score is its mean return over the test episodes. Mean and IQM "
        "(interquartile mean, rliable's `aggregate_iqm`) of the per-seed scores, with "
        f"{int(stats.CONFIDENCE * 100)}% percentile-bootstrap confidence intervals over seeds "
        f"({stats.N_RESAMPLES} resamples; n/a with one seed; with a handful of seeds the interval "
        "is little more than the range of the per-seed scores). Goals per episode and the "
        "collision rate (share of test episodes that ended in a collision) pool all seeds.",
        "",
    ]
    rows = []
    for m in t.mazes:
        for s in t.strategies:
            x = t.scores(m, s)
            goals = np.concatenate([t.results[(m, s, k)]["goals"] for k in t.seeds])
            coll = np.concatenate([t.results[(m, s, k)]["collided"] for k in t.seeds])
            rows.append(
                [
                    m,
                    display_name(s),
                    interval(stats.mean_ci(x)),
                    interval(stats.iqm_ci(x)),
                    f"{goals.mean():.2f}",
                    f"{coll.mean():.2f}",
                ]
            )
    L += markdown_table(
        ["maze", "strategy", "mean [95% CI]", "IQM [95% CI]", "goals / episode", "collision rate"],
        rows,
    )
    return L


class SweepComparison(NamedTuple):
    """P(x > y) over seeds of two arms' scores, with the verdict of its interval."""

    x: str
    y: str
    p: stats.Interval
    side: int | None  # stats.side: 1 x better, -1 y better, 0 no detectable difference;
    # None: too few seeds for a verdict (stats.MIN_SEEDS)


class SweepSummary(NamedTuple):
    """A swept run's test in one mode: per arm the per-seed scores (mean return over
    the test episodes, averaged over the mazes), each strategy's best arm, each arm
    against epsilon-greedy, and the strategies' best arms against each other."""

    arms: list[str]
    scores: dict[str, np.ndarray]
    best: dict[str, str]  # strategy -> its arm with the highest mean score
    against_eps: dict[str, SweepComparison]  # arm -> it against epsilon-greedy
    best_against_best: list[SweepComparison]


def sweep_summary(t: _Test) -> SweepSummary | None:
    """The summary of a swept run's test (None without a sweep); the reference drivers
    have no sweep points and are left out."""
    learned = [(s, n) for s, n in zip(t.strategies, t.names) if not baselines.is_baseline(s)]
    t = t._replace(strategies=[s for s, _ in learned], names=[n for _, n in learned])
    if all(s == arm_strategy(s) for s in t.strategies):
        return None
    score = {s: scores_over_mazes(t.results, t.mazes, s, t.seeds) for s in t.strategies}
    best: dict[str, str] = {}
    for s in t.strategies:
        strategy = arm_strategy(s)
        if strategy not in best or score[s].mean() > score[best[strategy]].mean():
            best[strategy] = s

    def compare(x: str, y: str) -> SweepComparison:
        p = stats.probability_of_improvement_ci(score[x], score[y])
        decided = stats.enough_seeds(len(score[x]), len(score[y]))
        return SweepComparison(x, y, p, stats.side(p) if decided else None)

    eps = best.get("epsilon_greedy")
    against = {s: compare(s, eps) for s in t.strategies if eps and arm_strategy(s) != eps}
    bests = [a for s, a in best.items() if s != "epsilon_greedy"]
    pairs = [compare(a, b) for i, a in enumerate(bests) for b in bests[i + 1 :]]
    return SweepSummary(list(t.strategies), score, best, against, pairs)


def sweep_answers(summary: SweepSummary) -> list[str]:
    """The questions a sweep answers, in sentences computed from ``summary``: at which
    points each strategy beats epsilon-greedy (or loses to it), and how the
    strategies' best points compare."""
    lines = []
    for strategy in (s for s in summary.best if s != "epsilon_greedy"):
        arms = [a for a in summary.arms if arm_strategy(a) == strategy]
        if not summary.against_eps:
            break
        name = display_name(strategy)
        if any(summary.against_eps[a].side is None for a in arms):
            lines.append(f"{name} against epsilon-greedy: {_too_few(summary, arms)}.")
            continue
        won = [_point(a) for a in arms if summary.against_eps[a].side == 1]
        lost = [_point(a) for a in arms if summary.against_eps[a].side == -1]
        text = f"{name} beats epsilon-greedy at " + (
            ", ".join(won) if won else "none of its points"
        )
        if lost:
            text += f"; epsilon-greedy beats it at {', '.join(lost)}"
        others = len(arms) - len(won) - len(lost)
        if others:
            text += f"; no detectable difference at {'the other ' if won or lost else ''}{others}"
            text += " point" + ("s" if others > 1 else "")
        lines.append(text + ".")
    for c in summary.best_against_best:
        verdict = {1: "is better than", -1: "is worse than", 0: "is not detectably different from"}
        p = interval(c.p, 2)
        x = f"{display_name(c.x)} (the best {display_name(arm_strategy(c.x))} point)"
        y = f"{display_name(c.y)} (the best {display_name(arm_strategy(c.y))} point)"
        if c.side is None:
            lines.append(f"{x} against {y}: P = {p}; {_too_few(summary, [c.x, c.y])}.")
        else:
            lines.append(f"{x} {verdict[c.side]} {y}: P = {p}.")
    return lines


def _too_few(summary: SweepSummary, arms: list[str]) -> str:
    n = min(len(summary.scores[a]) for a in arms)
    return f"{stats.TOO_FEW_SEEDS} for a verdict ({n} per arm; it needs {stats.MIN_SEEDS})"


def _point(arm: str) -> str:
    return arm.partition(" ")[2] or arm


def _sweep_section(t: _Test) -> list[str]:
    """A swept run: each strategy's return at each sweep point, its best point, and
    each point against epsilon-greedy and the strategies' best points against each
    other (empty without a sweep)."""
    summary = sweep_summary(t)
    if summary is None:
        return []
    t = t._replace(strategies=summary.arms)
    mazes = t.mazes if len(t.mazes) > 1 else []
    L = [
        "",
        "## Sweep: return at each point",
        "",
        "Mean over seeds of the per-seed score [95% CI]"
        + (" on each maze and averaged over the mazes" if mazes else "")
        + "; the best point of each strategy (highest mean) in bold. P(point > epsilon-"
        "greedy): rliable's probability of improvement with its bootstrap CI; the verdict "
        "says which is better when the interval excludes 0.5, else no detectable difference"
        + (
            f"; with fewer than {stats.MIN_SEEDS} seeds per arm it says {stats.TOO_FEW_SEEDS}, "
            "since every seed of one arm can score above every seed of the other by chance."
            if _undecided(summary)
            else "."
        ),
        "",
    ]
    rows = []
    for s in t.strategies:
        mark = "**" if summary.best[arm_strategy(s)] == s and s != arm_strategy(s) else ""
        row = [f"{mark}{display_name(s)}{mark}"]
        row += [interval(stats.mean_ci(t.scores(m, s))) for m in mazes]
        row.append(interval(stats.mean_ci(summary.scores[s])))
        if summary.against_eps:
            c = summary.against_eps.get(s)
            row += ["", ""] if c is None else [interval(c.p, 2), _better(c)]
        rows.append(row)
    header = ["arm"] + mazes + ["all mazes" if mazes else "mean [95% CI]"]
    if summary.against_eps:
        header += ["P(arm > epsilon-greedy) [95% CI]", "verdict"]
    L += markdown_table(header, rows)
    if summary.best_against_best:
        L += [
            "",
            "Best points against each other (each chosen as the best of its strategy on "
            "these same seeds, which flatters both):",
            "",
        ]
        rows = [
            [display_name(c.x), display_name(c.y), interval(c.p, 2), _better(c)]
            for c in summary.best_against_best
        ]
        L += markdown_table(["X", "Y", "P(X > Y) [95% CI]", "verdict"], rows)
    return L + ["", "In words:", ""] + [f"- {line}" for line in sweep_answers(summary)]


def _undecided(summary: SweepSummary) -> bool:
    """Whether some comparison of ``summary`` had too few seeds for a verdict."""
    comparisons = [*summary.against_eps.values(), *summary.best_against_best]
    return any(c.side is None for c in comparisons)


def sweep_markdown(results_csv: str, first_seed: int) -> list[str]:
    """The sweep section of every test mode of results.csv text, each under a
    ``### Test mode`` heading (empty without a sweep)."""
    L: list[str] = []
    for mode in result_modes(results_csv):
        section = _sweep_section(_test(read_results(results_csv, mode), first_seed))
        if section:
            L += ["", f"### Test mode: {MODE_NAMES[mode]}", ""]
            L += [line for line in section[3:]]  # without its own heading
    return L


def _better(c: SweepComparison) -> str:
    x, y = display_name(c.x), display_name(c.y)
    if c.side is None:
        return stats.TOO_FEW_SEEDS
    return {1: f"{x} better", -1: f"{y} better", 0: "no detectable difference"}[c.side]


def _improvement_section(t: _Test) -> list[str]:
    L = [
        "",
        "## Probability of improvement",
        "",
        "P(EBE > epsilon-greedy) as rliable defines it: the chance that a seed of EBE "
        "scores more than a seed of epsilon-greedy, ties counting half "
        "(P(X > Y) + 0.5 P(X = Y) over all pairs of per-seed scores), with a percentile "
        "bootstrap CI: the seeds of each strategy are resampled independently, and in the "
        "last row (the average over the mazes) each drawn seed keeps its scores on every "
        "maze, since all mazes test the same trained networks. 0.5: no difference.",
        "",
    ]
    rows = []
    xs, ys = [], []
    for m in t.mazes:
        x, y = t.scores(m, "ebe"), t.scores(m, "epsilon_greedy")
        xs.append(x)
        ys.append(y)
        rows.append([m, interval(stats.probability_of_improvement_ci(x, y), 2)])
    if len(t.mazes) > 1:
        pooled = stats.probability_of_improvement_ci(np.stack(xs, 1), np.stack(ys, 1))
        rows.append(["all mazes", interval(pooled, 2)])
    return L + markdown_table(["maze", "P(EBE > epsilon-greedy) [95% CI]"], rows)


def _beside_paper_section(t: _Test, train_maze: str) -> list[str]:
    L = ["", "## Beside the paper", ""]
    paper = PAPER_TABLES.get(train_maze)
    rows = []
    if paper is not None:
        caption, table = paper
        for m in (m for m in t.mazes if m in table):
            row_name, vals = table[m]
            row = [m, row_name]
            for s in t.strategies:
                row += [
                    _pm(*vals[s]) if s in vals else "not in the paper",
                    t.paper_form(m, s, t.seed0),
                    interval(stats.mean_ci(t.scores(m, s))),
                ]
            rows.append(row)
    if not rows:
        return L + [
            f"The paper reports no test results for these mazes after training on `{train_maze}`."
        ]
    L += [
        f"The paper's {caption}: mean ± std over 10 consecutive test episodes of its "
        f"single training run. Ours: seed {t.seed0} in the same form, and the mean over "
        "seeds of the per-seed mean return [95% bootstrap CI].",
        "",
    ]
    header = ["maze", "paper row"]
    for n in t.names:
        header += [f"{n} paper", f"{n} ours, seed {t.seed0}", f"{n} ours, all seeds"]
    return L + markdown_table(header, rows)


def _seeds_by_arm(rows: list[dict[str, str]]) -> dict[str, list[list[dict[str, str]]]]:
    """Episode rows (metrics.csv or results.csv) per arm, in arm order: one list per
    seed, in the order the seeds are met, each in episode order."""
    by: dict[str, dict[int, list[dict[str, str]]]] = {}
    for r in rows:
        by.setdefault(row_arm(r), {}).setdefault(int(r["seed"]), []).append(r)
    return {
        s: [sorted(eps, key=lambda r: int(r["episode"])) for eps in by[s].values()]
        for s in arms_in(by)
    }


def _seed_means(per_seed: list[list[dict[str, str]]], column: str, last: int | None) -> np.ndarray:
    """Each seed's mean of ``column`` over its last ``last`` episodes (all if None)."""
    return np.asarray(
        [np.mean([float(r[column]) for r in (e[-last:] if last else e)]) for e in per_seed]
    )


OUTCOME_HEADER = ("seeds", "return", "goals per episode", "share ending in a collision")


def _outcome_cells(per_seed: list[list[dict[str, str]]], last: int | None) -> list[str]:
    """An arm's outcome (:data:`OUTCOME_HEADER`): its seeds, and the mean over seeds
    [95% bootstrap CI] of each seed's mean return, goals and collisions per episode."""
    return [
        str(len(per_seed)),
        interval(stats.mean_ci(_seed_means(per_seed, "return", last)), 0),
        interval(stats.mean_ci(_seed_means(per_seed, "goals", last)), 2),
        interval(stats.mean_ci(_seed_means(per_seed, "collided", last)), 2),
    ]


def outcome_text(rows: list[dict[str, str]], last: int | None = None) -> str:
    """The small table the commands print: per arm (named as the files name it), the
    outcome of its episodes (:func:`_outcome_cells`; the last ``last`` per seed, or all),
    in aligned columns. ``rows``: metrics.csv or results.csv rows."""
    table = [["strategy", *OUTCOME_HEADER]]
    table += [[s, *_outcome_cells(eps, last)] for s, eps in _seeds_by_arm(rows).items()]
    return aligned_table(table)


def training_markdown(metrics_rows: list[dict[str, str]], last: int = 50) -> str:
    """Training outcome per strategy from metrics.csv rows: the last ``last`` episodes
    of each seed (return, goals, collisions) and the mean return over all episodes,
    each a mean over seeds with a 95% bootstrap CI."""
    explore = bool(metrics_rows) and all("explore" in r for r in metrics_rows)
    rows = []
    for s, per_seed in _seeds_by_arm(metrics_rows).items():
        rows.append(
            [display_name(s), *_outcome_cells(per_seed, last)]
            + [interval(stats.mean_ci(_seed_means(per_seed, "return", None)), 0)]
            + (
                [interval(stats.mean_ci(_seed_means(per_seed, "explore", last)), 2)]
                if explore
                else []
            )
        )
    header = [
        "strategy",
        "seeds",
        f"return, last {last} episodes",
        "goals per episode",
        "share ending in a collision",
        "return, all episodes (learning speed)",
    ] + ([f"exploration, last {last} episodes"] if explore else [])
    intro = (
        f"Training episodes (exploration on). Per seed: the mean over its last {last} "
        "episodes, and over all its episodes; then the mean over seeds [95% bootstrap CI]."
        + (
            " Exploration: the strategy's chance of a random (EBE, epsilon-greedy) or "
            "non-greedy (Boltzmann) action, averaged over each episode's steps."
            if explore
            else ""
        )
    )
    return "\n".join([intro, "", *markdown_table(header, rows)]) + "\n"


def _signed_ci(iv: stats.Interval, digits: int = 1) -> str:
    if np.isnan(iv.low):
        return f"{iv.value:+.{digits}f} [n/a]"
    return f"{iv.value:+.{digits}f} [{iv.low:+.{digits}f}, {iv.high:+.{digits}f}]"


def setting_text(overrides: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v}" for k, v in overrides.items())


ROBUSTNESS_HEADER = [
    "perturbation",
    "setting",
    "strategy",
    "mean return [95% CI]",
    "change [95% CI]",
    "change %",
    "goals / episode",
    "collision rate",
]


def robustness_markdown(
    robustness_csv: str,
    train_maze: str,
    training: dict[str, Any],
    perturbations: dict[str, dict[str, Any]],
    title: str = "Robustness",
    figure: str | None = None,
) -> str:
    """robustness.md from robustness.csv text.

    Args:
      robustness_csv: the text of robustness.csv.
      train_maze: the training maze.
      training: the training env's realism settings (name -> value).
      perturbations: the sweep, for the setting column (names not in it show none).
      figure: a link to robustness.png to show under the introduction, if given.
    """
    rows = robustness_summary(robustness_csv)
    res = read_robustness(robustness_csv)
    seeds = sorted({k[3] for k in res})
    n_eps = sorted({len(v["return"]) for v in res.values()})
    mazes = ordered_unique(r.maze for r in rows)
    L = [f"# {title}", ""]
    L += [
        f"Trained on `{train_maze}` with {setting_text(training)}. Every policy plays the "
        f"plain test ({'/'.join(map(str, n_eps))} consecutive greedy episodes per seed, the "
        "same test keys) under each perturbation: the named setting replaces the training "
        "environment's, every other setting stays as trained, and `none` is the plain test.",
        "",
        f"A seed's score is its mean return. Mean over {len(seeds)} seed(s) with a "
        f"{int(stats.CONFIDENCE * 100)}% percentile-bootstrap CI; change: the mean over seeds "
        "of each seed's score minus its unperturbed score (paired by seed) with its CI, and "
        "in % of the unperturbed mean; goals per episode and the collision rate pool all "
        "seeds and episodes.",
        "",
    ]
    if figure:
        L += [f"![return under each perturbation]({figure})", ""]
    for m in mazes:
        if len(mazes) > 1:
            L += [f"## {m}", ""]
        table = [_robustness_row(r, perturbations) for r in rows if r.maze == m]
        L += markdown_table(ROBUSTNESS_HEADER, table)
        L += [""]
    return "\n".join(L)


def _robustness_row(r: RobustnessRow, perturbations: dict[str, dict[str, Any]]) -> list[str]:
    setting = (
        "as trained"
        if r.perturbation == UNPERTURBED
        else setting_text(perturbations.get(r.perturbation, {}))
    )
    return [
        r.perturbation,
        setting,
        display_name(r.strategy),
        interval(r.mean),
        "" if r.change is None else _signed_ci(r.change),
        "" if np.isnan(r.change_pct) else f"{r.change_pct:+.0f}%",
        f"{r.goals:.2f}",
        f"{r.collision_rate:.2f}",
    ]
