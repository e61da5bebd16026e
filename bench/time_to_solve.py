"""Time to solve: how long after a training command starts its greedy policy solves a world.

For each maze (square4, and square4_obstacles, the stage-2 maze with four cylinders)
and each agent, one ``jaxnav train`` command trains every seed of EBE and
epsilon-greedy at once with ``run.eval_every`` (``jaxnav/run/greedy.py``); this
script starts it in a subprocess with an empty compilation cache, so compilation is
part of the time, and reads its ``eval.csv``. A world is solved by a success within
0.02 of the oracle's on the same test (``jaxnav.report.navigation.solved``): the
oracle (and DWA, for comparison) first drives through the very evaluation the runs
take (the same seeds' test keys, ``run.eval_episodes`` episodes in the training
environment, ``jaxnav evaluate --baseline``). A run is solved at its first
evaluation whose greedy success (over its decided goal attempts) is within 0.02 of
the oracle's mean; its time is that row's ``wall_s``, seconds since the command
started (the evaluations before it included). All runs of a command train side by
side in one compiled program, so a run's time is the command's wall clock, shared
with the other runs.

The agents, each its own shipped config with only the maze, the step budget and
the evaluation changed (a budget of env steps per run, ``episodes=null``):

* DQN: the paper's (``configs/paper_no_obstacles.yaml``, ``paper_obstacles.yaml``);
* double + dueling DQN: the same with ``dqn.double=true dqn.dueling=true``;
* PQN: ``configs/pqn.yaml`` (its own ``env.max_steps`` of 200 and no range noise);
* PQN, modern: the ``drive_*`` config of the world (``configs/drive_square4.yaml``,
  ``drive_obstacles.yaml``: the ``modern`` preset's observation, (v, omega) actions and
  reward, epsilon-greedy only), at its own budget (its learning rate decays over it),
  evaluated every 40,960 env steps (ten of its updates).

Per maze, agent and strategy: the seeds solved within the budget, the median
over all seeds of the time (and env steps) to solve, a seed never solved counting
as never (so the median is "not solved" when half or more are not), and the best
success the seeds reached on average at any one evaluation (how near the line came).

With ``--drive``, instead: every shipped ``drive_*`` config of the driving study
(``configs/studies/driving.yaml``: PQN on seven worlds, SAC on two), each its own
whole command at its own seeds and budget, evaluated greedily at eight equal shares
of the budget (whole updates), beside the oracle and DWA on the same evaluation in
its training world. Besides each run's time, the row gives when the mean over all
seeds first comes within 0.02 of the oracle (the driving page's "solved", on the
evaluation's episodes) and the target: 30 s on square4, 300 s elsewhere.

    python bench/time_to_solve.py --quick    # 2 seeds, tiny budgets: checks it runs
    python bench/time_to_solve.py            # 8 seeds, 200,000 env steps per run
    python bench/time_to_solve.py --drive    # the shipped drive configs (about 35 min)
    python bench/time_to_solve.py --drive --quick
    python bench/time_to_solve.py --drive --configs drive_rooms   # one row again

Commands run one after another, never two at once; use a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from pathlib import Path

from common import (
    ROOT,
    budget,
    budget_arguments,
    machine,
    reference_success,
    train_evaluating,
)

from jaxnav.report.navigation import SOLVED_TOLERANCE, solved

MAZES = {  # maze -> the paper's config for it
    "square4": "configs/paper_no_obstacles.yaml",
    "square4_obstacles": "configs/paper_obstacles.yaml",
}
STRATEGIES = ("ebe", "epsilon_greedy")
MODERN = {  # maze -> its drive config (the modern recipe)
    "square4": "configs/drive_square4.yaml",
    "square4_obstacles": "configs/drive_obstacles.yaml",
}
MODERN_AGENT = "PQN, modern"
MODERN_EVAL_EVERY = 40_960  # whole updates of 8 to 32 environments x 32 steps


def agents(maze: str) -> dict[str, list[str]]:
    """Each agent's config and overrides on ``maze``."""
    paper = MAZES[maze]
    return {
        "DQN": [paper],
        "double + dueling DQN": [paper, "dqn.double=true", "dqn.dueling=true"],
        "PQN": ["configs/pqn.yaml", f"env.maze={maze}"],
        MODERN_AGENT: [MODERN[maze]],
    }


def agent_budget(agent: str, items: list[str], args) -> argparse.Namespace:
    """The budget of one agent's command: the script's, or for the modern recipe its
    config's own step budget, evaluated every MODERN_EVAL_EVERY steps."""
    if agent != MODERN_AGENT:
        return args
    from jaxnav.core.config import load_config

    out = argparse.Namespace(**vars(args))
    out.eval_every = 4096 if args.quick else MODERN_EVAL_EVERY
    out.steps = 8192 if args.quick else int(load_config(items[0]).total_steps)
    return out


def solved_at(
    rows: list[dict[str, str]], oracle: float
) -> dict[tuple[str, int], tuple[float, int] | None]:
    """Each run's first (wall_s, env_step) whose success solves the world (within
    SOLVED_TOLERANCE of the oracle's ``oracle``); None if never."""
    runs: dict[tuple[str, int], tuple[float, int] | None] = {}
    for r in sorted(rows, key=lambda r: int(r["env_step"])):
        key = (r["strategy"], int(r["seed"]))
        runs.setdefault(key, None)
        if runs[key] is None and solved(float(r["success"]), oracle):
            runs[key] = (float(r["wall_s"]), int(r["env_step"]))
    return runs


def mean_by_step(
    rows: list[dict[str, str]], strategy: str | None = None
) -> dict[int, tuple[float, float]]:
    """{env step: (wall_s, success averaged over the runs)} of every evaluation of a
    command's runs (of one strategy's, or all); a success of NaN (every attempt cut,
    none decided) counts as 0."""
    by_step: dict[int, list[dict[str, str]]] = {}
    for r in rows:
        if strategy is None or r["strategy"] == strategy:
            by_step.setdefault(int(r["env_step"]), []).append(r)
    out = {}
    for step, at in sorted(by_step.items()):
        xs = [float(r["success"]) for r in at]
        out[step] = (float(at[0]["wall_s"]), statistics.mean(0.0 if x != x else x for x in xs))
    return out


def best_mean_success(rows: list[dict[str, str]], strategy: str) -> float:
    """The highest success, averaged over the strategy's seeds, at any evaluation."""
    return max(mean for _, mean in mean_by_step(rows, strategy).values())


def median_or_never(values: list[float | None]) -> float | None:
    """The median with None as never (larger than everything); None if it is never."""
    ordered = sorted(values, key=lambda v: (v is None, v or 0.0))
    n = len(ordered)
    mid = ordered[(n - 1) // 2], ordered[n // 2]
    if None in mid:
        return None
    return statistics.mean(mid)


def measure(maze: str, agent: str, items: list[str], args, log, refs) -> list[dict]:
    """Run one command; one result per strategy."""
    res = train_evaluating(items, args, log)
    rows, wall = res["rows"], res["wall_s"]
    runs = solved_at(rows, refs["oracle"])
    log(f"    {wall:.1f} s whole")
    results = []
    for strategy in [s for s in STRATEGIES if any(k[0] == s for k in runs)]:
        mine = [v for (s, _), v in sorted(runs.items()) if s == strategy]
        results.append(
            {
                "maze": maze,
                "agent": agent,
                "strategy": strategy,
                "seeds": len(mine),
                "solved": sum(v is not None for v in mine),
                "median_s": median_or_never([None if v is None else v[0] for v in mine]),
                "median_steps": median_or_never([None if v is None else v[1] for v in mine]),
                "per_seed_s": [None if v is None else v[0] for v in mine],
                "best_mean_success": best_mean_success(rows, strategy),
                "command_s": wall,
                "budget": args.steps,
            }
        )
    return results


def table(results: list[dict], refs: dict[str, dict[str, float]], args) -> str:
    lines = [
        "| maze | agent | strategy | solved | median time to solve (s) "
        "| median env steps | best mean success | whole command (s) |",
        "|---|---|---|--:|--:|--:|--:|--:|",
    ]
    for world, ref in refs.items():
        for name, label in (("oracle", "oracle"), ("dwa", "DWA")):
            lines.append(f"| `{world}` | {label} | (no training) | | | | {ref[name]:.2f} | |")
    for r in results:
        never = f"not solved in {r['budget']:,}"
        s = never if r["median_s"] is None else f"{r['median_s']:.1f}"
        steps = never if r["median_steps"] is None else f"{r['median_steps']:,.0f}"
        lines.append(
            f"| {r['maze']} | {r['agent']} | {r['strategy']} | {r['solved']}/{r['seeds']} "
            f"| {s} | {steps} | {r['best_mean_success']:.2f} | {r['command_s']:.1f} |"
        )
    return "\n".join(lines)


DRIVE_STUDY = ROOT / "jaxnav" / "configs" / "studies" / "driving.yaml"
DRIVE_EVALUATIONS = 8  # greedy evaluations along each drive config's budget
DRIVE_TARGET_S = {"drive_square4": 30.0}  # whole command to solved; others DRIVE_TARGET_DEFAULT
DRIVE_TARGET_DEFAULT = 300.0


def drive_configs() -> list[str]:
    """The driving study's configs, in its order."""
    import yaml

    return list(yaml.safe_load(DRIVE_STUDY.read_text())["configs"])


def drive_budget(name: str, args) -> argparse.Namespace:
    """One drive config's budget: its seeds and env steps (``--seeds`` replaces the
    seeds), evaluated at DRIVE_EVALUATIONS equal shares in whole updates (PQN:
    num_envs x rollout env steps; SAC: one step of all its environments); ``--quick``:
    2 seeds, 4 updates, an evaluation every 2."""
    from jaxnav.core.config import load_config

    cfg = load_config(name)
    update = cfg.sac.num_envs if cfg.agent == "sac" else cfg.pqn.num_envs * cfg.pqn.rollout
    out = argparse.Namespace(**vars(args))
    if args.quick:  # two evaluations, each after every environment has ended an episode
        envs = cfg.sac.num_envs if cfg.agent == "sac" else cfg.pqn.num_envs
        half = math.ceil(envs * (cfg.env.max_steps + 1) / update) * update
        out.steps, out.eval_every = 2 * half, half
    else:
        out.steps = int(cfg.total_steps)
        out.eval_every = max(1, round(out.steps / DRIVE_EVALUATIONS / update)) * update
    out.seeds = args.seeds if args.seeds_given else (2 if args.quick else int(cfg.seeds))
    return out


def mean_solved_at(rows: list[dict[str, str]], oracle: float) -> tuple[float, int] | None:
    """The first evaluation (wall_s, env_step) whose success averaged over every run
    is within SOLVED_TOLERANCE of the oracle's ``oracle``; None if none is."""
    for step, (wall, mean) in mean_by_step(rows).items():
        if solved(mean, oracle):
            return wall, step
    return None


def drive(args, log) -> int:
    """The ``--drive`` form: every shipped drive config, its table on stdout."""
    names = ["drive_square4", "drive_sac_obstacles"] if args.quick else drive_configs()
    if args.configs:  # a row or two again, after their configs changed
        unknown = sorted(set(args.configs) - set(drive_configs()))
        if unknown:
            log(f"time_to_solve: not a drive config of the driving study: {', '.join(unknown)}")
            return 2
        names = [n for n in drive_configs() if n in args.configs]
    lines = [
        "| config | agent | seeds | oracle | DWA | runs solved | median run's time to "
        "solve (s) | mean solved at (s) | mean solved at (env steps) | last mean success "
        "| whole command (s) | target (s) | met |",
        "|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|",
    ]
    results = []
    for name in names:
        b = drive_budget(name, args)
        item = f"configs/{name}.yaml"
        refs = reference_success([item], b.seeds, args.eval_episodes, log)
        log(f"  {name}: oracle {refs['oracle']:.3f}, DWA {refs['dwa']:.3f}")
        res = train_evaluating([item], b, log)
        rows, wall = res["rows"], res["wall_s"]
        log(f"    {wall:.1f} s whole")
        runs = solved_at(rows, refs["oracle"])
        per_run = [None if v is None else v[0] for v in runs.values()]
        at = mean_solved_at(rows, refs["oracle"])
        last_mean = list(mean_by_step(rows).values())[-1][1]
        target = DRIVE_TARGET_S.get(name, DRIVE_TARGET_DEFAULT)
        agent = "SAC" if "_sac_" in name else "PQN"
        median = median_or_never(per_run)
        results.append(
            {
                "config": name,
                "agent": agent,
                "seeds": b.seeds,
                "budget": b.steps,
                "eval_every": b.eval_every,
                "oracle": refs["oracle"],
                "dwa": refs["dwa"],
                "runs_solved": sum(v is not None for v in per_run),
                "median_run_s": median,
                "per_run_s": per_run,
                "mean_solved_s": None if at is None else at[0],
                "mean_solved_steps": None if at is None else at[1],
                "last_mean_success": last_mean,
                "command_s": wall,
                "target_s": target,
            }
        )
        never = f"not in {b.steps:,}"
        lines.append(
            f"| `{name}` | {agent} | {b.seeds} | {refs['oracle']:.2f} | {refs['dwa']:.2f} "
            f"| {results[-1]['runs_solved']}/{b.seeds} "
            f"| {never if median is None else f'{median:.1f}'} "
            f"| {never if at is None else f'{at[0]:.1f}'} "
            f"| {never if at is None else f'{at[1]:,}'} | {last_mean:.2f} | {wall:.1f} "
            f"| {target:.0f} | {'yes' if at is not None and at[0] <= target else 'no'} |"
        )
    budgets = (
        "2 seeds and two greedy evaluations (a check that it runs, not a measurement), "
        if args.quick
        else f"its own seeds and budget, a greedy evaluation at each of {DRIVE_EVALUATIONS} "
        "equal shares of it, "
    )
    which = "".join(f" {n}" for n in args.configs) if args.configs else ""
    print(
        f"`python bench/time_to_solve.py --drive{' --quick' if args.quick else ''}"
        f"{' --configs' + which if which else ''}`: each "
        f"shipped drive config at {budgets}{args.eval_episodes} episodes each; whole "
        "commands, empty compilation cache; the oracle and DWA on the same "
        f"evaluation in the config's training world. A run is solved at its first "
        f"evaluation within {SOLVED_TOLERANCE} of the oracle's success; the mean is "
        "solved where the success averaged over all runs first is; met: the mean is "
        "solved within the target's seconds of the command's start."
    )
    print()
    print("\n".join(lines))
    if args.json:
        Path(args.json).write_text(json.dumps({"drive": results}, indent=2) + "\n")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    budget_arguments(ap, "strategy", seeds=8, steps=200_000)
    ap.add_argument("--eval-episodes", type=int, default=5, help="episodes per evaluation")
    ap.add_argument("--mazes", nargs="+", choices=list(MAZES), default=list(MAZES))
    ap.add_argument("--json", help="also write the results here")
    ap.add_argument(
        "--drive",
        action="store_true",
        help="the shipped drive configs at their own budgets instead (see above)",
    )
    ap.add_argument(
        "--configs",
        nargs="+",
        metavar="NAME",
        help="with --drive: only these drive configs (their rows again after they changed)",
    )
    args = ap.parse_args(argv)
    args.seeds_given = args.seeds is not None
    budget(args)
    quick = args.quick

    def log(text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    log(f"machine: {machine()}")
    if args.drive:
        return drive(args, log)
    results, refs, worlds = [], {}, {}
    for maze in args.mazes:
        for agent, items in agents(maze).items():
            # the world's yardstick: the oracle in the very world the agent trains in
            world = tuple(i for i in items if "=" not in i or i.startswith("env."))
            if world not in worlds:
                worlds[world] = reference_success(list(world), args.seeds, args.eval_episodes, log)
                refs[" ".join(world)] = worlds[world]
                log(f"  {' '.join(world)}: oracle {worlds[world]['oracle']:.3f}, "
                    f"DWA {worlds[world]['dwa']:.3f}")  # fmt: skip
            results += measure(
                maze, agent, items, agent_budget(agent, items, args), log, worlds[world]
            )
    flags = (" --quick" if quick else "") + (
        "" if args.mazes == list(MAZES) else " --mazes " + " ".join(args.mazes)
    )
    print(
        f"`python bench/time_to_solve.py{flags}`: {args.seeds} seeds per strategy, "
        f"{args.steps:,} env steps per run, a greedy evaluation of {args.eval_episodes} "
        f"episodes every {args.eval_every:,} ({MODERN_AGENT}: its config's budget, every "
        f"{MODERN_EVAL_EVERY:,}); whole commands, empty compilation cache. "
        f"Solved: a success within {SOLVED_TOLERANCE} of the oracle's on the same "
        "evaluation in the agent's world (the oracle's and DWA's rows, by the world's "
        "config, above the runs')."
    )
    print()
    print(table(results, refs, args))
    if args.json:
        both = {"runs": results, "references": refs}
        Path(args.json).write_text(json.dumps(both, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
