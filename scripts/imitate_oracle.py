"""Policies that imitate the oracle: the oracle's steps as demonstrations, fit by a
Q-network from what the policy sees, written as a finished run.

The oracle (:mod:`jaxnav.planners.oracle`) drives a config's world as its test plays
it (:meth:`jaxnav.core.config.Config.tested`), in ``--envs`` environments for
``--steps`` steps each; every step's observation, the policy's own, is paired with
the oracle's action. Each run of the config (strategy, seed) then gets its own
Q-network, of the config's shape, fit to those pairs by cross-entropy on its outputs
read as logits (behaviour cloning), so its greedy action is the oracle's most likely
one. The run directory it writes holds ``config.yaml``, ``params.npz`` and
``summary.json`` (the demonstrations' counts and the networks' agreement with the
oracle on them), so that

* ``jaxnav evaluate DIR`` tests the imitation as it tests a trained run, and
* ``jaxnav train CONFIG run.init_from=DIR`` starts training from it.

    python scripts/imitate_oracle.py drive_stage3 --out runs/imitate_stage3
    python -m jaxnav evaluate runs/imitate_stage3 --no-baselines env.restart_goal=new
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxnav.core import agents, rundir
from jaxnav.core.config import dump_config, load_config, resolve_config_path
from jaxnav.core.errors import JaxnavError
from jaxnav.env import EnvParams, NavEnv, from_config
from jaxnav.experiments.baselines import planner_of
from jaxnav.planners.oracle import Oracle
from jaxnav.run.checkpoint import params_arrays

BATCH = 512
CHUNK = 100  # oracle steps per compiled call


class Teacher(NamedTuple):
    """The oracle in a config's world as its test plays it (its environment, settings)."""

    env: NavEnv
    params: EnvParams
    oracle: Oracle


def teacher_of(cfg) -> Teacher:
    """The config's :class:`Teacher`: made once, since the oracle's way out of a start
    can take a search of a minute (stage 3)."""
    env, params = from_config(cfg.tested())
    return Teacher(env, params, planner_of("oracle", env, [params.maze], params))


def demonstrations(
    teacher: Teacher, envs: int, steps: int, seed: int, quiet: bool = False, policy=None
):
    """(observations f32[n, D], the oracle's actions i32[n], goals, collisions,
    episodes) over ``envs`` x ``steps`` steps of the teacher's world. The oracle
    drives; with ``policy`` (network, params stacked on the run axis) environment i is
    driven by run i mod runs's greedy policy instead, and the oracle only labels the
    states it visits with its own action (DAgger): goals and collisions are then the
    policies'."""
    env, params, oracle = teacher
    reset = jax.vmap(env.reset, in_axes=(0, None))
    obs, state = reset(jax.random.split(jax.random.PRNGKey(seed), envs), params)
    memory = jax.vmap(oracle.start, in_axes=(None, 0))(params, state)
    plan = jax.vmap(oracle.plan, in_axes=(0, 0, 0, None))
    step = jax.vmap(env.step, in_axes=(0, 0, 0, None))

    if policy is not None:
        network, stacked = policy
        runs = jax.tree.leaves(stacked)[0].shape[0]
        per_env = jax.tree.map(lambda a: a[jnp.arange(envs) % runs], stacked)

        def act(obs):
            return jax.vmap(network.apply)(per_env, obs)

    def body(carry, key):
        obs, state, memory = carry
        action, memory = plan(memory, obs, state, params)
        drive = action if policy is None else jnp.argmax(act(obs), -1).astype(action.dtype)
        new_obs, state, _, terminated, truncated, info = step(
            jax.random.split(key, envs), state, drive, params
        )
        row = (obs, action, info["goal_reached"], terminated, terminated | truncated)
        return (new_obs, state, memory), row

    run = jax.jit(lambda c, k: jax.lax.scan(body, c, jax.random.split(k, CHUNK)))
    carry, rows = (obs, state, memory), []
    t0 = time.perf_counter()
    key = jax.random.PRNGKey(seed + 1)
    for i in range(-(-steps // CHUNK)):
        key, k = jax.random.split(key)
        carry, out = run(carry, k)
        rows.append(jax.device_get(out))
        if not quiet:
            done = (i + 1) * CHUNK
            print(f"\r  oracle steps {done * envs:,} ({time.perf_counter() - t0:.0f} s)", end="")
    if not quiet:
        print()
    obs, action, goal, collided, ended = (np.concatenate(x)[:steps] for x in zip(*rows))
    return (
        obs.reshape(-1, obs.shape[-1]),
        action.reshape(-1),
        int(goal.sum()),
        int(collided.sum()),
        int(ended.sum()),
    )


def network_of(cfg):
    return agents.get(cfg.agent).network_of(cfg, from_config(cfg)[0])


def fit(cfg, obs, action, epochs: int, seed: int, params=None, per: int | None = None):
    """One Q-network per run of ``cfg``, each from its own initial draw (or from
    ``params``, stacked on the run axis), fit to the pairs by cross-entropy
    (minibatches of 512 drawn with replacement, Adam with a cosine decay from 1e-3),
    ``epochs`` passes over ``per`` pairs (None: all of them);
    returns (params stacked on the run axis, each run's agreement with the oracle's
    actions on the pairs)."""
    network = network_of(cfg)
    n, runs = len(action), cfg.n_runs
    steps = max(1, epochs * (per or n) // BATCH)
    keys = jax.random.split(jax.random.PRNGKey(seed), runs)
    if params is None:
        params = jax.vmap(lambda k: network.init(k, jnp.asarray(obs[0])))(keys)
    optimizer = optax.adam(optax.cosine_decay_schedule(1e-3, steps))
    opt_state = jax.vmap(optimizer.init)(params)
    x, y = jnp.asarray(obs), jnp.asarray(action)

    def loss(p, idx):
        logits = network.apply(p, x[idx])
        return optax.softmax_cross_entropy_with_integer_labels(logits, y[idx]).mean()

    @jax.jit
    def train(params, opt_state, key):
        def one(carry, k):
            p, s = carry
            idx = jax.random.randint(k, (runs, BATCH), 0, n)
            grads = jax.vmap(jax.grad(loss))(p, idx)
            updates, s = jax.vmap(optimizer.update)(grads, s, p)
            return (optax.apply_updates(p, updates), s), None

        return jax.lax.scan(one, (params, opt_state), jax.random.split(key, steps))[0]

    params, _ = train(params, opt_state, jax.random.PRNGKey(seed + 1))
    return params, agreement(network, params, obs, action)


def agreement(network, params, obs, action, chunk: int = 4096) -> np.ndarray:
    """Each run's share of ``obs`` where its greedy action is ``action``, ``chunk``
    observations at a time (every run's activations at once would not fit)."""
    greedy = jax.jit(jax.vmap(lambda p, x: jnp.argmax(network.apply(p, x), -1), (0, None)))
    same = np.zeros(jax.tree.leaves(params)[0].shape[0])
    for i in range(0, len(action), chunk):
        same += np.sum(np.asarray(greedy(params, obs[i : i + chunk])) == action[i : i + chunk], 1)
    return same / len(action)


def write_run(out: Path, cfg, params, summary: dict) -> None:
    """The run directory ``out``, whole or not at all: written beside it, then renamed."""
    part = out.with_name(out.name + ".part")
    shutil.rmtree(part, ignore_errors=True)
    try:
        part.mkdir(parents=True)
        rundir.atomic_write_text(part / rundir.CONFIG, dump_config(cfg))
        rundir.atomic_write_npz(part / rundir.PARAMS, params_arrays(cfg, params))
        rundir.atomic_write_text(part / rundir.SUMMARY, json.dumps(summary, indent=1) + "\n")
        part.rename(out)
    finally:
        shutil.rmtree(part, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("items", nargs="+", metavar="CONFIG [key=value ...]")
    p.add_argument("--out", required=True, help="the run directory to write (must not exist)")
    p.add_argument("--envs", type=int, default=64, help="environments the oracle drives")
    p.add_argument("--steps", type=int, default=1500, help="steps of each environment")
    p.add_argument("--epochs", type=int, default=20, help="passes over the demonstrations")
    p.add_argument(
        "--dagger",
        type=int,
        default=0,
        help="rounds in which the policies drive and the oracle labels where they go",
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    try:
        if args.envs < 1 or args.steps < 1 or args.epochs < 1 or args.dagger < 0:
            raise JaxnavError("--envs, --steps and --epochs must be at least 1, --dagger 0 or more")
        out = Path(args.out)
        if out.exists():
            raise JaxnavError(f"{out} exists already: give a new run directory")
        config_path = resolve_config_path(args.items[0])
        cfg = load_config(config_path, args.items[1:])
        if agents.get(cfg.agent).actions != "discrete":
            raise JaxnavError("the oracle's actions are discrete: give a Q-learner's config")
        t0 = time.perf_counter()
        teacher, network = teacher_of(cfg), network_of(cfg)
        obs, action, goals, collisions, episodes = demonstrations(
            teacher, args.envs, args.steps, args.seed, args.quiet
        )
        params, agree = fit(cfg, obs, action, args.epochs, args.seed)
        first, rounds = len(action), []
        for k in range(args.dagger):  # the policies drive, the oracle labels
            more = demonstrations(
                teacher, args.envs, args.steps, args.seed + 1 + k, args.quiet, (network, params)
            )
            obs, action = np.concatenate([obs, more[0]]), np.concatenate([action, more[1]])
            rounds.append({"goals": more[2], "collisions": more[3], "episodes": more[4]})
            if not args.quiet:
                print(f"  round {k + 1}: the policies' goals {more[2]}, collisions {more[3]}")
            # as many gradient steps as the first fit, now over every round's pairs
            params, agree = fit(cfg, obs, action, args.epochs, args.seed, params, first)
        summary = {
            "imitation": "behaviour cloning of the oracle",
            "demonstration_steps": len(action),
            "oracle_goals": goals,
            "oracle_collisions": collisions,
            "oracle_episodes": episodes,
            "epochs": args.epochs,
            "dagger_rounds": rounds,
            "agreement": [round(float(a), 4) for a in agree],
            "env_steps": 0,
            "wall_s": round(time.perf_counter() - t0, 1),
        }
        write_run(out, cfg, params, summary)
    except JaxnavError as e:
        print(f"imitate_oracle: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("imitate_oracle: interrupted; nothing written", file=sys.stderr)
        return 130
    print(
        f"{len(action):,} oracle steps ({goals} goals, {collisions} collisions); "
        f"agreement with the oracle {agree.mean():.2f} (runs {agree.min():.2f}-{agree.max():.2f}); "
        f"{out}/ in {summary['wall_s']:.0f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
