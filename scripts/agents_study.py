"""EBE against epsilon-greedy for three agents: the paper's DQN, double + dueling DQN
and PQN, at equal environment steps on square4; writes docs/agents/ (each agent's
results_*.csv, summary.csv, curves.png) and the tables of docs/agents.md between its markers.

    python scripts/agents_study.py [--out runs/agents] [--seeds 16] [--steps 65536]
    python scripts/agents_study.py --publish-only      # = jaxnav publish agents_study
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

from jaxnav.report import publish as report_publish  # noqa: E402
from jaxnav.report import stats  # noqa: E402

AGENTS = {
    "DQN (the paper's)": ("smoke", []),
    "double + dueling DQN": ("smoke", ["dqn.double=true", "dqn.dueling=true"]),
    "PQN": ("pqn", []),
}
DOCS = ROOT / "docs" / "agents"


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


def publish() -> None:
    for page in report_publish.publish(ROOT, ("agents_study",)):
        print(f"wrote {page}")


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
