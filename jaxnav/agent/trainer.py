"""The trainer contract every agent fills, and what the host loop builds on it.

An agent (registered in :mod:`jaxnav.core.agents`) makes a :class:`Trainer` from a
config: pure ``init``, ``step``, ``chunk`` and ``active`` functions over one run's
state, which ``vmap`` runs over seeds, strategies and sweep points
(:func:`run_inputs`). A run's state is the agent's own pytree; the host loop
(:mod:`jaxnav.run.training`), evaluation and export read only these fields of it:
``params`` (the network's, :meth:`jaxnav.core.agents.Agent.network_of`), ``step``
(i32[] env steps taken), ``episode`` (i32[] episodes finished), ``metrics``
(:class:`jaxnav.agent.episodes.Episodes`), ``diverged_at`` (i32[], -1 while finite),
``key`` and ``bank`` (the run's maze bank or None); an agent with replay
(``replay=True``) also has ``buffer`` (:mod:`jaxnav.agent.replay`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.agent.hyper import Hyper, arm_hypers, stack
from jaxnav.core import agents
from jaxnav.core import strategies as registry
from jaxnav.core.config import Config
from jaxnav.env import EnvParams, NavEnv


def still_training(episode, step, episodes_limit, steps_limit):
    """Whether a run still trains: fewer episodes finished and fewer env steps taken
    than the limits. NumPy or JAX arrays alike (``&``, not ``and``)."""
    return (episode < episodes_limit) & (step < steps_limit)


def run_limits(config: Config) -> tuple[int, int]:
    """(episodes, env steps) per seed for :func:`still_training`; no limit is int32 max."""
    never = int(jnp.iinfo(jnp.int32).max)
    episodes = config.episodes if config.episodes is not None else never
    steps = config.total_steps if config.total_steps is not None else never
    return episodes, steps


class StepLog(NamedTuple):
    """What one step reports besides the state, each f32[] (f32[chunk_steps] from a
    chunk); NaN where there is nothing to report."""

    explore: chex.Array  # the strategy's exploration; NaN once the run has finished
    loss: chex.Array  # the TD loss of the step's gradient step; NaN when none was taken
    max_q: chex.Array  # max_a Q(s, a) at the acting state; NaN once the run has finished


class Trainer(NamedTuple):
    """The pieces of a run. ``init`` and ``chunk`` are pure; vmap them over runs.
    ``step`` is ``chunk``'s loop body, one environment step of one run (tests and
    benchmarks call it alone); the agent's ``network_of`` gives the run's network.
    ``step_size``: the env steps one ``step`` takes (PQN's update: many);
    ``chunk_length``: the most env steps one ``chunk`` takes, the length of its logs."""

    env: NavEnv
    env_params: EnvParams
    metric_slots: int
    init: Callable[[chex.PRNGKey, chex.Array, Hyper], Any]
    step: Callable[[Any, None], tuple[Any, StepLog]]
    chunk: Callable[..., tuple[Any, StepLog]]  # (state, n_steps=None)
    active: Callable[[Any], chex.Array]
    step_size: int = 1
    chunk_length: int = 0


def step_chunk(step: Callable[[Any, None], tuple[Any, StepLog]], length: int):
    """The ``chunk`` of a trainer whose ``step`` takes one env step: up to ``length``
    steps of one run in one compiled loop.

    ``n_steps`` (i32[], the same for every run under vmap) ends the loop early: the host
    passes the most steps any run can still take, so the last chunk (or all of a short
    run) does not step runs that have finished to the chunk's end. Returns (state,
    :class:`StepLog` of f32[length] per step, NaN where no step was taken)."""

    def chunk(ts, n_steps: chex.Array | None = None):
        n = length if n_steps is None else jnp.minimum(n_steps, length)

        def body(i, carry):
            ts, logs = carry
            ts, log = step(ts, None)
            return ts, jax.tree.map(lambda a, x: a.at[i].set(x), logs, log)

        logs = StepLog(*(jnp.full(length, jnp.nan, jnp.float32) for _ in StepLog._fields))
        return jax.lax.fori_loop(0, n, body, (ts, logs))

    return chunk


def update_chunk(update: Callable[[Any, None], tuple[Any, StepLog]], per_update: int, updates: int):
    """The ``chunk`` of a trainer whose ``step`` takes ``per_update`` env steps at once
    (PQN's update, SAC's step of all its environments): up to ``updates`` of them in one
    compiled loop. ``n_steps`` (i32[], the same for every run) ends it after the updates
    that cover that many env steps. Returns (state, :class:`StepLog` of
    f32[updates * per_update], per env step, NaN where no step was taken)."""
    length = updates * per_update

    def chunk(ts, n_steps: chex.Array | None = None):
        n = updates if n_steps is None else jnp.minimum(-(-n_steps // per_update), updates)

        def body(i, carry):
            ts, logs = carry
            ts, log = update(ts, None)
            at = (i * per_update,)
            return ts, jax.tree.map(lambda a, x: jax.lax.dynamic_update_slice(a, x, at), logs, log)

        logs = StepLog(*(jnp.full(length, jnp.nan, jnp.float32) for _ in StepLog._fields))
        return jax.lax.fori_loop(0, n, body, (ts, logs))

    return chunk


def file_episodes(
    metrics,
    episode: chex.Array,
    run: chex.Array,
    reward: chex.Array,
    reached: chex.Array,
    terminated: chex.Array,
    done: chex.Array,
    explore: chex.Array,
    limit: int,
    slots: int,
    attempt_limit: int,
):
    """(metrics, episode) after one step of many environments ([E] each): the episodes
    they finished numbered from ``episode`` in environment order, filed where ``run``
    and below ``limit`` (slot ``number % slots``), the count capped at ``limit``."""
    number = episode + jnp.cumsum(done.astype(jnp.int32)) - 1
    filed = run & done & (number < limit)
    slot = jnp.where(filed, number % slots, slots)  # out of range: not filed
    metrics = metrics.record(slot, reward, reached, terminated, done, explore, attempt_limit)
    return metrics, jnp.minimum(episode + jnp.sum(done, dtype=jnp.int32), limit)


def all_finite(tree) -> chex.Array:
    """bool[]: every element of every leaf is finite."""
    return jnp.all(jnp.stack([jnp.all(jnp.isfinite(leaf)) for leaf in jax.tree.leaves(tree)]))


def select(pred, a, b):
    return jax.tree.map(lambda x, y: jnp.where(pred, x, y), a, b)


# The running sums of Episodes, the fields a finished run's step would still change.
RUNNING = (
    "cur_return",
    "cur_length",
    "cur_goals",
    "cur_explore",
    "cur_age",  # these three are None (no leaves) without an attempt limit
    "cur_successes",
    "cur_timeouts",
)


class RunInputs(NamedTuple):
    """What ``Trainer.init`` takes, one entry per run along the leading axis."""

    keys: chex.Array  # u32[runs, 2]
    strategy: chex.Array  # i32[runs] registered strategy number (jaxnav.core.strategies.index)
    hyper: Hyper  # each field [runs]


def run_inputs(config: Config) -> RunInputs:
    """Per-run PRNG keys, strategy indices and settings, in ``config.run_arms()`` order:
    strategy, then sweep point, then seed.

    Every arm of one seed shares the seed's key (same initial network and goals), so
    comparisons between strategies and between sweep points are paired.
    """
    seeds = np.arange(config.seeds) + config.seed
    seed_keys = np.asarray(jax.vmap(jax.random.PRNGKey)(jnp.asarray(seeds)))
    arms = config.arms()
    keys = np.concatenate([seed_keys] * len(arms))
    strat = np.repeat(np.asarray([registry.index(s) for s, _ in arms], np.int32), config.seeds)
    hypers = [h for h in arm_hypers(config) for _ in range(config.seeds)]
    return RunInputs(keys, strat, stack(hypers))


def make_train(
    config: Config, trainer: Trainer | None = None
) -> Callable[[chex.PRNGKey, chex.Array, Hyper], Any]:
    """A pure ``train(key, strategy, hyper) -> TrainState`` that runs one seed to the end.

    Built on the same :class:`Trainer` as ``jaxnav train``: chunks until inactive.
    ``jax.jit(jax.vmap(make_train(cfg)))(*run_inputs(cfg))`` trains every seed,
    strategy and sweep point of the config in one compiled program. ``trainer``: default
    the config's agent's (``agent``, :mod:`jaxnav.core.agents`).
    """
    trainer = agents.get(config.agent).make_trainer(config) if trainer is None else trainer

    def train(key: chex.PRNGKey, strategy: chex.Array, hyper: Hyper) -> Any:
        ts = trainer.init(key, strategy, hyper)
        return jax.lax.while_loop(trainer.active, lambda s: trainer.chunk(s)[0], ts)

    return train


__all__ = [
    "RUNNING",
    "RunInputs",
    "StepLog",
    "Trainer",
    "all_finite",
    "file_episodes",
    "make_train",
    "run_inputs",
    "run_limits",
    "select",
    "step_chunk",
    "still_training",
    "update_chunk",
]
