"""Exploration: the paper's EBE, its epsilon-greedy baseline, Boltzmann exploration, and
the acts of the field's methods (RND and the count bonus act epsilon-greedy on Q-values
that learn their intrinsic reward, :mod:`jaxnav.agent.rnd` and :mod:`jaxnav.agent.counts`;
NoisyNets greedy on a noisy network's, :mod:`jaxnav.agent.noisy`).

Each strategy is a pure function ``act_NAME(key, q f32[A], episode i32[], settings) ->
(action i32[], exploration f32[])`` registered by name in :mod:`jaxnav.core.strategies`
(which also says which settings it reads). :func:`explore_action` runs the one a run
was given, branchless, so runs of several strategies share one compiled program.

Paper equations: EBE (Sec. 5) :func:`normalised_entropy` and :func:`ebe`;
epsilon-greedy :func:`epsilon_schedule` and :func:`epsilon_greedy`.
"""

from __future__ import annotations

import math
from typing import Any

import chex
import jax
import jax.numpy as jnp

from jaxnav.core import strategies as registry

# ----------------------------------------------------------------------------


def normalised_entropy(q: chex.Array, temperature: float = 1.0) -> chex.Array:
    """H(s) in [0, 1]: entropy of softmax((Q - max Q) / T), log base |A|.

    Args:
      q: f32[..., A] Q-values.
    Returns:
      f32[...] normalised entropy.
    """
    z = (q - jnp.max(q, axis=-1, keepdims=True)) / temperature
    logp = jax.nn.log_softmax(z, axis=-1)
    p = jnp.exp(logp)
    h = -jnp.sum(p * logp, axis=-1) / math.log(q.shape[-1])
    return jnp.clip(h, 0.0, 1.0)


def epsilon_schedule(episode: chex.Array, start=1.0, decay=0.99, minimum=0.05) -> chex.Array:
    """eps_i = max(decay * eps_{i-1}, minimum), eps_1 = start; ``episode`` counts from 0."""
    return jnp.maximum(start * decay ** episode.astype(jnp.float32), minimum)


def explore_or_greedy(key: chex.PRNGKey, q: chex.Array, prob: chex.Array) -> chex.Array:
    """A uniformly random action with probability ``prob``, else argmax Q."""
    k_coin, k_act = jax.random.split(key)
    explore = jax.random.uniform(k_coin) < prob
    random_action = jax.random.randint(k_act, (), 0, q.shape[-1])
    return jnp.where(explore, random_action, jnp.argmax(q, axis=-1))


def ebe(key: chex.PRNGKey, q: chex.Array, temperature: float = 1.0, power: float = 1.0):
    """Entropy-based exploration: random action with probability H(s)^power, else greedy.

    The paper's EBE is power 1; the EBE author's Breakout code raised H to a power.
    Returns (action i32[], exploration probability f32[]).
    """
    h = normalised_entropy(q, temperature)
    h = jnp.where(power == 1.0, h, h**power)  # power 1 is exactly the paper's H
    return explore_or_greedy(key, q, h), h


def epsilon_greedy(key: chex.PRNGKey, q: chex.Array, eps: chex.Array):
    """Random action with probability eps, else greedy. Returns (action, eps)."""
    return explore_or_greedy(key, q, eps), jnp.asarray(eps, jnp.float32)


def boltzmann(key: chex.PRNGKey, q: chex.Array, temperature: float = 1.0):
    """Boltzmann exploration: the action is sampled from softmax(Q / T), the softmax
    EBE takes its entropy from (for EBE's control).

    Returns (action i32[], the probability that the sampled action is not the greedy
    one, 1 - max_a softmax(Q / T)_a, f32[]).
    """
    z = (q - jnp.max(q, axis=-1, keepdims=True)) / temperature
    action = jax.random.categorical(key, z, axis=-1)
    return action, 1.0 - jnp.max(jax.nn.softmax(z, axis=-1), axis=-1)


def act_ebe(key, q, episode, x):
    del episode
    return ebe(key, q, x.ebe_temperature, x.ebe_power)


def act_epsilon_greedy(key, q, episode, x):
    return epsilon_greedy(key, q, epsilon_schedule(episode, x.eps_start, x.eps_decay, x.eps_min))


def act_boltzmann(key, q, episode, x):
    del episode
    return boltzmann(key, q, x.boltzmann_temperature)


def act_noisy(key, q, episode, x):
    """NoisyNets' act: the greedy action of Q-values that carry the network's noise
    (the trainer draws it, :mod:`jaxnav.agent.noisy`); no probability of exploring is
    defined, so it reports 0."""
    del key, episode, x
    return jnp.argmax(q, axis=-1).astype(jnp.int32), jnp.float32(0.0)


def act_policy(key, q, episode, x):
    """The ``policy`` strategy's act over Q-values: greedy. It is a continuous agent's
    own exploration (SAC samples its policy), which a config never gives a Q-learner
    (:func:`jaxnav.core.config.action_problem`); a Q-learner handed it does not explore."""
    del key, episode, x
    return jnp.argmax(q, axis=-1).astype(jnp.int32), jnp.float32(0.0)


def explore_action(
    strategy: chex.Array,
    key: chex.PRNGKey,
    q: chex.Array,
    episode: chex.Array,
    x: Any,
    strategies: tuple[str, ...] | None = None,
) -> tuple[chex.Array, chex.Array]:
    """(action i32[], exploration f32[]) of the registered strategy number ``strategy``
    (i32[]; :func:`jaxnav.core.strategies.index`); ``x`` holds the exploration settings.

    Branchless: the act of every strategy in ``strategies`` (those a program can meet)
    is computed from the same key and one is selected, so one compiled program serves
    runs of several strategies under ``vmap``. The same key gives EBE and epsilon-greedy
    the same coin and random action, so only the probability differs between them.
    """
    registered = registry.names()
    strategies = registered if strategies is None else strategies
    acts = [registry.get(name).function()(key, q, episode, x) for name in strategies]
    if len(acts) == 1:
        return acts[0]
    position = jnp.asarray([strategies.index(s) if s in strategies else 0 for s in registered])
    i = position[strategy]
    action = jax.lax.select_n(i, *[a.astype(jnp.int32) for a, _ in acts])
    return action, jax.lax.select_n(i, *[jnp.asarray(p, jnp.float32) for _, p in acts])
