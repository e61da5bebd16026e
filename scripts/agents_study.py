"""EBE against epsilon-greedy for three agents: the paper's DQN, double + dueling DQN
and PQN, at equal environment steps on square4; writes docs/agents/ (each agent's
results_*.csv, summary.csv, curves.png) and the tables of docs/agents.md between its markers.

    python scripts/agents_study.py [--out runs/agents] [--seeds 16] [--steps 65536]
    python scripts/agents_study.py --publish-only      # the page from the committed data
    python scripts/agents_study.py --baselines-only    # the oracle's and DWA's rows only

Every agent trains ``--seeds`` seeds of both strategies for ``--steps`` env steps per
seed (DQN from configs/smoke.yaml with the budget in steps, PQN from configs/pqn.yaml),
then ``jaxnav evaluate`` tests each policy greedily for 10 episodes on square4. A run
directory that finished is reused, one that was interrupted is resumed, so the script
can be stopped and started again. The verdict is the claims table's rule: where the
95% interval of P(EBE > epsilon-greedy) lies, over seeds resampled jointly.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jaxnav.report import stats  # noqa: E402
from jaxnav.report.claims import verdict  # noqa: E402
from jaxnav.report.markdown import interval, markdown_table  # noqa: E402
from jaxnav.report.navigation import seed_metrics, solved  # noqa: E402
from jaxnav.report.results import read_results  # noqa: E402

AGENTS = {
    "DQN (the paper's)": ("smoke", []),
    "double + dueling DQN": ("smoke", ["dqn.double=true", "dqn.dueling=true"]),
    "PQN": ("pqn", []),
}
DOCS = ROOT / "docs" / "agents"
PAGE = ROOT / "docs" / "agents.md"
BEGIN, END = "<!-- agents_study: begin -->", "<!-- agents_study: end -->"


def slug(agent: str) -> str:
    return {"DQN (the paper's)": "dqn", "double + dueling DQN": "double_dueling", "PQN": "pqn"}[
        agent
    ]


def jaxnav(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "jaxnav", *args], cwd=ROOT, check=True)


def run_agent(agent: str, out: Path, seeds: int, steps: int) -> Path:
    config, extra = AGENTS[agent]
    run = out / slug(agent)
    overrides = [
        *extra,
        f"seeds={seeds}",
        "episodes=null",
        f"total_steps={steps}",
        "run.test_mazes=[square4]",
        "run.test_episodes=10",
    ]
    if not (run / "summary.json").is_file():
        if run.is_dir():
            jaxnav("train", "--resume", str(run))
        else:
            jaxnav("train", config, "--out", str(run), "--yes", *overrides)
    if not (run / "eval" / "results.csv").is_file():
        jaxnav("evaluate", str(run))
    return run


def run_baselines(out: Path, seeds: int) -> None:
    """The oracle and DWA through the same test (smoke's square4 and step limit, the
    same seeds' test keys, 10 episodes): docs/agents/baselines_*.csv."""
    for name in ("oracle", "dwa"):
        dest = out / name
        out.mkdir(parents=True, exist_ok=True)
        if not (dest / "results.csv").is_file():
            jaxnav("evaluate", "--baseline", name, "smoke", "--seeds", str(seeds), "--episodes",
                   "10", "--out", str(dest))  # fmt: skip
        (DOCS / f"baselines_{name}.csv").write_text((dest / "results.csv").read_text())


def collect(out: Path, seeds: int, steps: int) -> None:
    """Train and test every agent; write docs/agents/results.csv, summary.csv, curves."""
    DOCS.mkdir(parents=True, exist_ok=True)
    run_baselines(out, seeds)
    summary, curves = [], {}
    for agent in AGENTS:
        run = run_agent(agent, out, seeds, steps)
        text = (run / "eval" / "results.csv").read_text()
        (DOCS / f"results_{slug(agent)}.csv").write_text(text)
        s = json.loads((run / "summary.json").read_text())
        summary.append(
            {
                "agent": agent,
                "env_steps": s["env_steps"],
                "train_s": s["wall_clock_s"],
                "steps_per_s": s["steps_per_s"],
                "compile_s": s["compile_s"],
            }
        )
        with open(run / "metrics.csv") as f:
            curves[agent] = list(csv.DictReader(f))
    _write_csv(DOCS / "summary.csv", summary)
    _curves_figure(curves, DOCS / "curves.png")


def _write_csv(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _curves_figure(curves: dict[str, list[dict]], path: Path, window: int = 20) -> None:
    """Training goals per episode against the share of the env-step budget, mean over
    seeds with a normal 95% band (mean +- 1.96 standard errors)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(curves), figsize=(4.2 * len(curves), 3.4), sharey=True)
    grid = np.linspace(0, 1, 101)
    for ax, (agent, rows) in zip(np.atleast_1d(axes), curves.items()):
        for strategy, color in (("ebe", "tab:blue"), ("epsilon_greedy", "tab:orange")):
            per_seed = []
            for seed in sorted({int(r["seed"]) for r in rows}):
                mine = [r for r in rows if r["strategy"] == strategy and int(r["seed"]) == seed]
                steps = np.cumsum([float(r["length"]) for r in mine])
                goals = stats.moving_average([float(r["goals"]) for r in mine], window)
                per_seed.append(np.interp(grid * steps[-1], steps, goals))
            y = np.asarray(per_seed)
            mean, sem = y.mean(0), y.std(0, ddof=1) / np.sqrt(len(y))
            label = "EBE" if strategy == "ebe" else "epsilon-greedy"
            ax.plot(grid, mean, color=color, label=label)
            ax.fill_between(grid, mean - 1.96 * sem, mean + 1.96 * sem, color=color, alpha=0.2)
        ax.set_title(agent, fontsize=10)
        ax.set_xlabel("share of the env-step budget")
    np.atleast_1d(axes)[0].set_ylabel(f"goals per episode ({window}-episode mean)")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def tables() -> str:
    """The page's tables from docs/agents/results_*.csv, baselines_*.csv and summary.csv."""
    with open(DOCS / "summary.csv") as f:
        summary = {r["agent"]: r for r in csv.DictReader(f)}
    refs = {}
    for name in ("oracle", "dwa"):
        res = read_results((DOCS / f"baselines_{name}.csv").read_text())
        seeds = sorted({k[2] for k in res})
        refs[name] = _scores(res, name, seeds, "success")
    oracle = float(np.mean(refs["oracle"]))
    rows, n_seeds = [], 0
    for agent in AGENTS:
        res = read_results((DOCS / f"results_{slug(agent)}.csv").read_text())
        seeds = sorted({k[2] for k in res})
        n_seeds = len(seeds)
        cells = [agent]
        for measure in ("return", "success"):
            ebe, eps = (_scores(res, s, seeds, measure) for s in ("ebe", "epsilon_greedy"))
            p = stats.probability_of_improvement_ci(ebe, eps)
            if measure == "return":
                cells += [interval(stats.mean_ci(ebe), 0), interval(stats.mean_ci(eps), 0)]
            else:
                cells += [interval(stats.mean_ci(ebe), 2), interval(stats.mean_ci(eps), 2)]
            cells += [interval(p, 2), _verdict(p, len(seeds))]
        cells.append(
            " / ".join(
                "yes" if solved(float(np.mean(_scores(res, s, seeds, "success"))), oracle) else "no"
                for s in ("ebe", "epsilon_greedy")
            )
        )
        s = summary[agent]
        cells.append(f"{float(s['steps_per_s']):,.0f}")
        rows.append(cells)
    head = [
        "agent",
        "EBE return",
        "eps return",
        "P(EBE > eps), return",
        "verdict",
        "EBE success",
        "eps success",
        "P(EBE > eps), success",
        "verdict",
        "solved (EBE / eps)",
        "train transitions/s",
    ]
    ref_rows = [
        [label, interval(stats.mean_ci(refs[name]), 2)]
        for name, label in (("oracle", "oracle"), ("dwa", "DWA"))
    ]
    lines = [
        f"{n_seeds} seeds per strategy and agent; greedy test, 10 episodes per policy on "
        "square4; each cell the mean over seeds [95% bootstrap CI]. Success is the share "
        "of the decided goal attempts that reach the goal (an attempt cut off by an "
        "episode's end is left out: [navigation metrics](reproducing.md#navigation-metrics)). "
        "A strategy *solves* square4 when its mean success is within 0.02 of the oracle's "
        "on the same test. Transitions/s is the trainer's steady state over all seeds of "
        "both strategies (summary.json's steps_per_s), on the machine that ran the study.",
        "",
        *markdown_table(head, rows),
        "",
        "The reference drivers through the same test (the same seeds' test keys, square4, "
        "its 200-step episodes), success with its 95% interval over seeds:",
        "",
        *markdown_table(["driver", "success"], ref_rows),
    ]
    return "\n".join(lines)


def _scores(res, strategy: str, seeds, measure: str) -> np.ndarray:
    if measure == "return":
        return np.asarray([res[("square4", strategy, k)]["return"].mean() for k in seeds])
    return np.asarray([seed_metrics(res[("square4", strategy, k)])["success"] for k in seeds])


def _verdict(p: stats.Interval, n_seeds: int) -> str:
    if not stats.enough_seeds(n_seeds):
        return stats.TOO_FEW_SEEDS
    return {"supported": "EBE better", "contradicted": "EBE worse"}.get(
        verdict(p), "no detectable difference"
    )


def publish() -> None:
    page = PAGE.read_text()
    head, rest = page.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    PAGE.write_text(f"{head}{BEGIN}\n{tables()}\n{END}{tail}")
    print(f"wrote {PAGE.relative_to(ROOT)}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="runs/agents")
    p.add_argument("--seeds", type=int, default=16)
    p.add_argument("--steps", type=int, default=65536)
    p.add_argument("--publish-only", action="store_true")
    p.add_argument(
        "--baselines-only", action="store_true", help="drive the oracle and DWA, then publish"
    )
    a = p.parse_args(argv)
    if a.baselines_only:
        run_baselines(ROOT / a.out, a.seeds)
    elif not a.publish_only:
        collect(ROOT / a.out, a.seeds, a.steps)
    publish()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
