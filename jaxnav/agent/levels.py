"""Level replay over a bank of drawn layouts (``pqn.level_replay``): a curriculum that
picks more often the layouts the policy can just solve.

Each layout of a run's bank (``env.maze_bank``) keeps a recency-weighted count of the
goal attempts begun in it while training and of those that reached the goal; both
decay by half every ``pqn.level_halflife`` env steps, so ``p = wins / tries`` is the
layout's recent success. Its learnability is ``p (1 - p)`` (0 for a layout without an
attempt): largest where the policy succeeds half the time, 0 where it always or never
does. This is the score of SFL, sampling for learnability (Rutherford et al. 2024, the
curriculum of JaxNav), measured here from the training episodes themselves, as PLR
(Jiang et al. 2021) scores levels from the episodes it trains on, rather than from
extra rollouts.

A new layout is then picked from the ``level_top`` share of the bank with the highest
learnability (uniformly among them) with probability ``level_replay``, else uniformly
from the whole bank: each layout's weight is ``(1 - rho) / N + rho / K`` in the top K,
``(1 - rho) / N`` elsewhere. The environment picks by the cumulative weights
(``EnvParams.bank_cdf``), which are renewed after every update from the rollout's
attempts. Ties (many layouts at 0 early on) are broken by a small random draw, so the
top K is never the bank's first K by index.
"""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class Levels:
    """A run's record of its bank's layouts (each f32[N])."""

    tries: chex.Array  # goal attempts begun in each layout, decayed
    wins: chex.Array  # of them, those that reached the goal, decayed
    cdf: chex.Array  # the cumulative weights the environment picks new layouts by

    @classmethod
    def start(cls, n: int) -> Levels:
        """No attempt yet: every layout weighs the same."""
        zeros = jnp.zeros(n, jnp.float32)
        return cls(tries=zeros, wins=zeros, cdf=uniform_cdf(n))


def uniform_cdf(n: int) -> chex.Array:
    """f32[N]: cumulative weights of N equal layouts."""
    return jnp.arange(1, n + 1, dtype=jnp.float32) / n


def learnability(levels: Levels) -> chex.Array:
    """f32[N]: p (1 - p), p each layout's recent success (0 without an attempt)."""
    p = levels.wins / jnp.maximum(levels.tries, 1e-6)
    return jnp.where(levels.tries > 0.0, p * (1.0 - p), 0.0)


def weights(score: chex.Array, replay: float, top: int, key: chex.PRNGKey) -> chex.Array:
    """f32[N]: each layout's probability of being picked: ``replay`` spread over the
    ``top`` layouts of highest ``score`` (ties broken at random with ``key``), the rest
    over all of them."""
    n = score.shape[0]
    jitter = jax.random.uniform(key, (n,), jnp.float32, 0.0, 1e-6)
    _, best = jax.lax.top_k(score + jitter, top)
    chosen = jnp.zeros(n, jnp.float32).at[best].set(1.0)
    return (1.0 - replay) / n + replay * chosen / top


def record(
    levels: Levels,
    layout: chex.Array,
    ended: chex.Array,
    won: chex.Array,
    decay: float,
    replay: float,
    top: int,
    key: chex.PRNGKey,
) -> Levels:
    """``levels`` after a rollout: the counts decayed by ``decay`` (the rollout's share of
    a half-life), each ended attempt (``ended`` bool[...], in the layout ``layout``
    i32[...] it was begun in; ``won`` where it reached its goal) added, and the weights
    renewed (:func:`weights`)."""
    idx = layout.reshape(-1)
    tries = levels.tries * decay
    tries = tries.at[idx].add(ended.reshape(-1).astype(jnp.float32))
    wins = levels.wins * decay
    wins = wins.at[idx].add((ended & won).reshape(-1).astype(jnp.float32))
    new = levels.replace(tries=tries, wins=wins)
    w = weights(learnability(new), replay, top, key)
    cdf = jnp.cumsum(w)
    return new.replace(cdf=cdf / cdf[-1])


__all__ = ["Levels", "learnability", "record", "uniform_cdf", "weights"]
