"""Policies that imitate the oracle: the oracle's steps as demonstrations, fit by a
Q-network from what the policy sees, written as a finished run.

The oracle (:mod:`jaxnav.planners.oracle`) drives a config's world as its test plays
it (:meth:`jaxnav.core.config.Config.tested`), in ``envs`` environments for ``steps``
steps each; every step's observation, the policy's own, is paired with the oracle's
action. Each run of the config (strategy, seed) then gets its own Q-network, of the
config's shape, fit to those pairs by cross-entropy on its outputs read as logits
(behaviour cloning), so its greedy action is the oracle's most likely one; ``dagger``
rounds then let the policies drive while the oracle labels the states they visit. The
run directory it writes holds ``config.yaml``, ``params.npz`` and ``summary.json`` (the
demonstrations' counts and the networks' agreement with the oracle on them), so that

* ``jaxnav evaluate DIR`` tests the imitation as it tests a trained run, and
* ``jaxnav train CONFIG run.init_from=DIR`` starts training from it.

    jaxnav imitate drive_stage3 --out runs/imitate_stage3
    jaxnav evaluate runs/imitate_stage3 --no-baselines env.restart_goal=new
"""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxnav.core import agents, rundir, startup
from jaxnav.core.config import Config, dump_config
from jaxnav.core.errors import JaxnavError, RunError
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


def imitate(
    cfg: Config,
    out: Path,
    envs: int = 64,
    steps: int = 1500,
    epochs: int = 20,
    dagger: int = 0,
    seed: int = 0,
    quiet: bool = False,
    overwrite: bool = False,
) -> tuple[dict, np.ndarray]:
    """Fit every run of ``cfg`` to the oracle's actions (``envs`` x ``steps`` of its
    driving, ``epochs`` passes, then ``dagger`` rounds of the policies driving) and
    write the run directory ``out`` (:func:`write_run`). Returns (its summary, each
    run's agreement with the oracle on every round's pairs). ``out`` must not exist
    unless ``overwrite`` (then it must be a run directory that no process uses); a
    continuous agent's config is refused: the oracle's actions are discrete."""
    if out.exists() and not overwrite:
        raise RunError(f"{out} exists already: give a new run directory (--overwrite replaces it)")
    if out.exists():
        replaceable(out)
    if agents.get(cfg.agent).actions != "discrete":
        raise JaxnavError("the oracle's actions are discrete: give a Q-learner's config")
    t0 = time.perf_counter()
    teacher, network = teacher_of(cfg), network_of(cfg)
    obs, action, goals, collisions, episodes = demonstrations(teacher, envs, steps, seed, quiet)
    params, agree = fit(cfg, obs, action, epochs, seed)
    first, rounds = len(action), []
    for k in range(dagger):  # the policies drive, the oracle labels
        more = demonstrations(teacher, envs, steps, seed + 1 + k, quiet, (network, params))
        obs, action = np.concatenate([obs, more[0]]), np.concatenate([action, more[1]])
        rounds.append({"goals": more[2], "collisions": more[3], "episodes": more[4]})
        if not quiet:
            print(f"  round {k + 1}: the policies' goals {more[2]}, collisions {more[3]}")
        # as many gradient steps as the first fit, now over every round's pairs
        params, agree = fit(cfg, obs, action, epochs, seed, params, first)
    summary = {
        "imitation": "behaviour cloning of the oracle",
        "demonstration_steps": len(action),
        "oracle_goals": goals,
        "oracle_collisions": collisions,
        "oracle_episodes": episodes,
        "epochs": epochs,
        "dagger_rounds": rounds,
        "agreement": [round(float(a), 4) for a in agree],
        "env_steps": 0,
        "wall_s": round(time.perf_counter() - t0, 1),
    }
    write_run(out, cfg, params, summary, overwrite)
    return summary, agree


def replaceable(out: Path) -> None:
    """Refuse (:class:`RunError`) to replace ``out`` unless it is a run directory that
    holds only what a run writes and that no process uses now."""
    if not out.is_dir():
        raise RunError(f"{out} exists and is not a directory: choose another --out")
    if not (out / rundir.CONFIG).is_file():
        raise RunError(f"{out} is not a run directory (no {rundir.CONFIG}); not overwriting it")
    foreign = sorted(
        p.name
        for p in out.iterdir()
        if not p.name.startswith(".") and p.name not in rundir.RUN_ENTRIES
    )
    if foreign:
        raise RunError(
            f"{out} holds {foreign[0]!r}, which a run does not write; not overwriting it"
        )
    if rundir.in_use(out):
        raise RunError(f"run directory {out} is in use by another process")


def write_run(out: Path, cfg, params, summary: dict, overwrite: bool = False) -> None:
    """The run directory ``out``, whole or not at all: written beside it, then renamed
    (with ``overwrite``, over the run directory there, where one is: :func:`replaceable`).
    Ctrl-C or an error on the way removes what was written."""
    part = out.with_name(out.name + ".part")
    shutil.rmtree(part, ignore_errors=True)
    with startup.on_interrupt(lambda: shutil.rmtree(part, ignore_errors=True)):
        try:
            part.mkdir(parents=True)
            rundir.atomic_write_text(part / rundir.CONFIG, dump_config(cfg))
            rundir.atomic_write_npz(part / rundir.PARAMS, params_arrays(cfg, params))
            rundir.atomic_write_text(part / rundir.SUMMARY, json.dumps(summary, indent=1) + "\n")
            with startup.no_interrupt():  # the old run goes only when the new one is there
                if out.exists():  # checked before the work; checked again now
                    if not overwrite:
                        raise RunError(f"{out} exists already: give a new run directory")
                    replaceable(out)
                    old = out.with_name(f".{out.name}.old{os.getpid()}")
                    with rundir.Lock(out):
                        out.rename(old)
                    part.rename(out)
                    shutil.rmtree(old, ignore_errors=True)
                else:
                    part.rename(out)
        finally:
            shutil.rmtree(part, ignore_errors=True)
