"""Learning curves beside a peer: rejax's double DQN and PQN against ours, at equal env steps.

``peers_rejax.py`` times rejax's DQN; this script asks whether it learns as ours does.
On two worlds, square4 (``configs/paper_no_obstacles.yaml``) and the drawn 4 x 4 grid
mazes (``configs/grid4.yaml``, a new train-split layout every episode), it trains:

* **ours, double DQN**: ``jaxnav train CONFIG dqn.double=true``, EBE and
  epsilon-greedy, every seed of both in one command;
* **rejax 0.1.3 DQN** with ``ddqn=True`` (its default) and the same network, gamma,
  batch, replay capacity, learning start and 2,000-step hard target copy; the paper's
  RMSprop in place of rejax's hard-coded Adam (as ``peers_rejax.py``); rejax's linear
  epsilon 1.0 -> 0.05 over the first half of the run, its only exploration;
* **ours, PQN**: the ladder study's PQN settings (16 environments x 32 steps per update,
  lambda 0.65, 4 epochs of 4 minibatches, lr 1e-3, RAdam, gradient norm 10, LayerNorm,
  no dropout), EBE and epsilon-greedy;
* **rejax 0.1.3 PQN** with the same numbers of environments, steps, epochs,
  minibatches, lambda, learning rate and clipping; rejax's Adam and its linear epsilon
  (as above).

Every run has the same budget of env steps (all of a PQN run's environments together)
and the same evaluation: every ``--eval-every`` steps, the greedy policy (argmax Q)
plays ``--eval-episodes`` episodes in the training environment with jaxnav's own test
rollout (``jaxnav.agent.rollout.make_rollout``) and test keys, and its success is the
share of goal attempts that reach the goal (``jaxnav.report.navigation``), as
``run.eval_every`` writes to ``eval.csv``. For rejax the evaluation runs inside its
``train`` as its ``eval_callback``; for ours it is ``run.eval_every``.

What differs and stays as each library has it: rejax treats a time-out as terminal
(``done = terminated | truncated``, the pre-1.0 gymnax API it unpacks); its buffer
stores ``next_obs``; rejax's DQN has no dropout, ours keeps the paper's 0.2.

Per world, agent and arm: the greedy success at every evaluation, the mean over seeds
with a 95% bootstrap interval, drawn as curves (``--figure``); and the whole command's
wall clock (compilation and evaluations included, each command in its own process with
an empty compilation cache) and transitions per second of it.

    python bench/peers_curves.py --quick          # 2 seeds, tiny budget: checks it runs
    python bench/peers_curves.py --figure docs/agents/peers.png --json docs/agents/peers.json
    python bench/peers_curves.py --from docs/agents/peers.json   # the table again, no training

rejax runs in this interpreter if it has it, else in ``.venv-peers`` (bench/README.md).
Commands run one after another, never two at once; use a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import (
    MARK,
    budget,
    budget_arguments,
    cores,
    device_env,
    find_python,
    machine,
    train_evaluating,
)
from peers_rejax import dqn_rmsprop, gymnax_env

WORLDS = {"square4": "paper_no_obstacles", "grid4": "grid4"}
PQN = [  # the ladder study's PQN (configs/studies/when_ebe_helps_40k.yaml)
    "agent=pqn",
    "dqn.lr=0.001",
    "dqn.optimizer=radam",
    "dqn.dropout=0.0",
    "pqn.num_envs=16",
    "pqn.rollout=32",
    "pqn.td_lambda=0.65",
    "pqn.epochs=4",
    "pqn.minibatches=4",
    "pqn.max_grad_norm=10.0",
]
AGENTS = {"double DQN": ["dqn.double=true"], "PQN": PQN}
PEER = "rejax 0.1.3"


# --- rejax, in the peer interpreter -------------------------------------------------


def rejax_curves(world: str, agent: str, seeds: int, steps: int, every: int, episodes: int):
    """Train rejax's ``agent`` on ``world`` for ``seeds`` seeds, evaluating greedily every
    ``every`` env steps; per seed and evaluation the goal attempts and successes."""
    import jax
    import numpy as np
    from rejax import PQN

    from jaxnav.agent.rollout import eval_keys, make_rollout
    from jaxnav.core.config import load_config
    from jaxnav.env import from_config
    from jaxnav.report.navigation import CUT, SUCCESS, split_attempts

    cfg = load_config(WORLDS[world], AGENTS[agent])
    env, env_params = from_config(cfg)
    max_steps = int(env_params.max_steps)

    common = dict(
        env=gymnax_env(env, env_params),
        env_params=env_params,
        total_timesteps=steps,
        eval_freq=every,
        skip_initial_evaluation=True,
        gamma=cfg.dqn.gamma,
        eps_start=1.0,
        eps_end=0.05,
        exploration_fraction=0.5,
    )
    if agent == "PQN":
        algo = PQN.create(
            **common,
            num_envs=cfg.pqn.num_envs,
            num_steps=cfg.pqn.rollout,
            num_epochs=cfg.pqn.epochs,
            num_minibatches=cfg.pqn.minibatches,
            td_lambda=cfg.pqn.td_lambda,
            learning_rate=cfg.dqn.lr,
            max_grad_norm=cfg.pqn.max_grad_norm,
        )
    else:
        algo = dqn_rmsprop().create(
            **common,
            agent_kwargs={"activation": "relu"},
            num_envs=1,
            num_epochs=1,
            learning_rate=cfg.dqn.lr,
            batch_size=cfg.dqn.batch_size,
            buffer_size=min(cfg.buffer_capacity, steps),
            fill_buffer=cfg.dqn.batch_size,
            target_update_freq=cfg.dqn.target_update_every,
            polyak=0.0,
            ddqn=True,
        )

    class Greedy:  # jaxnav's rollout calls network.apply(params, obs) -> Q-values
        @staticmethod
        def apply(params, obs):  # rejax's networks flatten all but a batch axis
            return algo.agent.apply(params, obs[None])[0]

    class NoHyper:  # nothing swept: the training environment as it is
        @staticmethod
        def env_params(p):
            return p

    rollout = make_rollout(env, Greedy, episodes, max_steps, navigation=True)

    def train(ts, key):
        def evaluate(algo, ts, rng):
            r = rollout(ts.q_ts.params, key, None, NoHyper, env_params)
            return r.steps, r.ret

        return algo.replace(eval_callback=evaluate).train(train_state=ts)

    keys = jax.random.split(jax.random.PRNGKey(0), seeds)
    test_keys = eval_keys([("", s) for s in range(seeds)])
    t0 = time.perf_counter()
    ts = jax.jit(jax.vmap(algo.init_state))(keys)
    compiled = jax.jit(jax.vmap(train)).lower(ts, test_keys).compile()
    compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    ts, (s, ret) = jax.block_until_ready(compiled(ts, test_keys))
    train_s = time.perf_counter() - t0
    assert int(ts.global_step[0]) == steps, int(ts.global_step[0])
    s, ret = jax.tree.map(np.asarray, (s, ret))
    rows = []
    for seed in range(seeds):
        for e in range(s.pos.shape[1]):
            att = split_attempts(
                s.pos[seed, e],
                s.goal[seed, e],
                s.reached[seed, e],
                s.collided[seed, e],
                s.episode[seed, e],
                episodes,
                max_steps,  # the attempt limit: the episode's step limit
            )
            rows.append(
                {
                    "seed": seed,
                    "env_step": (e + 1) * every,
                    "attempts": len(att.outcome),
                    "successes": int(np.sum(att.outcome == SUCCESS)),
                    "cut": int(np.sum(att.outcome == CUT)),
                    "return": float(np.mean(ret[seed, e])),
                }
            )
    return {"rows": rows, "compile_s": compile_s, "train_s": train_s}


# --- both sides, from the parent ----------------------------------------------------


def success(r: dict) -> float:
    """Successes over the decided attempts (jaxnav.report.navigation: cut ones left out)."""
    decided = r["attempts"] - r["cut"]
    return r["successes"] / decided if decided else 0.0


def run_ours(world: str, agent: str, args, log) -> dict:
    """One ``jaxnav train`` command: both strategies, every seed; curves per strategy."""
    items = [WORLDS[world], *AGENTS[agent], "strategies=[ebe,epsilon_greedy]"]
    res = train_evaluating(items, args, log)
    rows, wall = res["rows"], res["wall_s"]
    arms = {}
    for strategy in ("ebe", "epsilon_greedy"):
        arms[f"ours, {strategy}"] = [
            {
                "seed": int(r["seed"]),
                "env_step": int(r["env_step"]),
                "attempts": int(r["attempts"]),
                "successes": int(r["successes"]),
                "cut": int(r["cut"]),
                "return": float(r["return"]),
            }
            for r in rows
            if r["strategy"] == strategy
        ]
    runs = 2 * args.seeds
    return {
        "arms": arms,
        "command_s": wall,
        "runs": runs,
        "transitions_per_s": runs * args.steps / wall,
        "steady_transitions_per_s": res["summary"]["steps_per_s"],
    }


def run_rejax(world: str, agent: str, args, py: str, log) -> dict:
    cmd = [
        py,
        __file__,
        "--one",
        f"{world},{agent}",
        "--seeds",
        str(args.seeds),
        "--steps",
        str(args.steps),
        "--eval-every",
        str(args.eval_every),
        "--eval-episodes",
        str(args.eval_episodes),
    ]
    log(f"$ rejax {agent} on {world}")
    with tempfile.TemporaryDirectory() as tmp:
        env = device_env(cores())
        env["JAX_COMPILATION_CACHE_DIR"] = tmp  # empty: compilation is part of the time
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=7200)
        wall = time.perf_counter() - t0
    res = next(
        (json.loads(x[len(MARK) :]) for x in p.stdout.splitlines() if x.startswith(MARK)), None
    )
    if res is None:
        tail = (p.stderr.strip().splitlines() or ["no output"])[-1]
        raise RuntimeError(f"rejax {agent} on {world} failed: {tail}")
    return {
        "arms": {f"{PEER}, epsilon (linear)": res["rows"]},
        "command_s": wall,
        "runs": args.seeds,
        "transitions_per_s": args.seeds * args.steps / wall,
        "steady_transitions_per_s": args.seeds * args.steps / res["train_s"],
        "compile_s": res["compile_s"],
    }


def curves(rows: list[dict]):
    """(env steps, success f[seeds, evals]) of one arm's rows."""
    import numpy as np

    steps = sorted({r["env_step"] for r in rows})
    seeds = sorted({r["seed"] for r in rows})
    x = np.full((len(seeds), len(steps)), np.nan)
    for r in rows:
        x[seeds.index(r["seed"]), steps.index(r["env_step"])] = success(r)
    return steps, x


def table(results: list[dict], args) -> str:
    from jaxnav.report.stats import mean_ci

    lines = [
        f"| world | agent | arm | success at {args.steps:,} steps [95% CI] "
        "| best success on the way | whole command (s) | transitions/s, whole command "
        "| transitions/s, training only |",
        "|---|---|---|--:|--:|--:|--:|--:|",
    ]
    for res in results:
        for arm, rows in res["arms"].items():
            _, x = curves(rows)
            final = mean_ci(x[:, -1])
            best = x.mean(axis=0).max()
            lines.append(
                f"| {res['world']} | {res['agent']} | {arm} "
                f"| {final.value:.2f} [{final.low:.2f}, {final.high:.2f}] | {best:.2f} "
                f"| {res['command_s']:.1f} | {res['transitions_per_s']:,.0f} "
                f"| {res['steady_transitions_per_s']:,.0f} |"
            )
    return "\n".join(lines)


def figure(results: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jaxnav.report.stats import bootstrap_band

    worlds = list(dict.fromkeys(r["world"] for r in results))
    agents = list(dict.fromkeys(r["agent"] for r in results))
    fig, axes = plt.subplots(
        len(worlds), len(agents), figsize=(5 * len(agents), 3.4 * len(worlds)), squeeze=False
    )
    for res in results:
        ax = axes[worlds.index(res["world"])][agents.index(res["agent"])]
        for arm, rows in res["arms"].items():
            steps, x = curves(rows)
            mean, low, high = bootstrap_band(x)
            ax.plot(steps, mean, marker="o", ms=3, label=arm)
            ax.fill_between(steps, low, high, alpha=0.2)
        ax.set_title(f"{res['world']}, {res['agent']}")
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("env steps per run")
        ax.set_ylabel("greedy success per goal attempt")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    budget_arguments(ap, "arm", seeds=16, steps=40_960)
    ap.add_argument("--eval-episodes", type=int, default=10, help="episodes per evaluation")
    ap.add_argument("--worlds", nargs="+", choices=list(WORLDS), default=list(WORLDS))
    ap.add_argument("--agents", nargs="+", choices=list(AGENTS), default=list(AGENTS))
    ap.add_argument("--peer-python", help="interpreter with rejax (default: this or .venv-peers)")
    ap.add_argument("--figure", help="draw the curves here (PNG)")
    ap.add_argument("--json", help="also write every curve here")
    ap.add_argument("--from", dest="source", help="no training: the table and figure of a --json")
    ap.add_argument("--one", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.source:
        saved = json.loads(Path(args.source).read_text())
        run_args = argparse.Namespace(**saved["args"])
        print(table(saved["results"], run_args))
        if args.figure:
            figure(saved["results"], args.figure)
        return 0
    budget(args)
    quick = args.quick
    if args.one:
        world, agent = args.one.split(",", 1)
        res = rejax_curves(
            world, agent, args.seeds, args.steps, args.eval_every, args.eval_episodes
        )
        print(MARK + json.dumps(res), flush=True)
        return 0

    def log(text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    py = find_python("rejax", args.peer_python)
    if py is None:
        log("rejax is not installed: see bench/README.md, 'Installing the peers'")
        return 1
    log(f"machine: {machine()}")
    results = []
    for world in args.worlds:
        for agent in args.agents:
            for side in (run_ours, lambda w, a, ar, lg: run_rejax(w, a, ar, py, lg)):
                res = side(world, agent, args, log)
                res.update(world=world, agent=agent)
                log(f"    {res['command_s']:.1f} s whole")
                results.append(res)
    flags = " --quick" if quick else ""
    print(
        f"`python bench/peers_curves.py{flags}`: {args.seeds} seeds per arm, "
        f"{args.steps:,} env steps per run, a greedy evaluation of {args.eval_episodes} "
        f"episodes every {args.eval_every:,}; whole commands, empty compilation cache; "
        f"{machine()}."
    )
    print()
    print(table(results, args))
    if args.figure:
        figure(results, args.figure)
    if args.json:
        Path(args.json).write_text(json.dumps({"args": vars(args), "results": results}) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
