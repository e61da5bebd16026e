"""An intrinsic reward as a bundle of pure functions: what a strategy with a ``bonus``
(:mod:`jaxnav.core.strategies`) adds to the environment's reward in its runs.

A bonus module's ``make(config, env) -> Bonus`` gives

* ``init(key, obs f32[E, D]) -> state``: one run's state (E environments);
* ``reward(state, steps, hyper) -> (f32[T, E], state)``: the bonus of each step of a
  rollout (:class:`Steps`), its weight (a setting in ``hyper``) applied, and the state
  after counting the rollout;
* ``learn(state, steps, key) -> state``: what it learns from the rollout (RND's
  predictor), or the state unchanged.

The trainer (:mod:`jaxnav.pqn`) calls them once per update for every run of a program
that lists the strategy, and adds the reward where the run's strategy is the bonus's own,
so the other runs learn from the environment's reward exactly (``r + 0``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import chex
import jax.numpy as jnp

from jaxnav.core import strategies as registry
from jaxnav.core.refs import resolve


class Steps(NamedTuple):
    """What a bonus reads of a rollout, each [T, E, ...] (time first)."""

    next_obs: chex.Array  # f32[T, E, D] the observation after each step, before a reset
    pos: chex.Array  # f32[T, E, 2] where the robot stood after each step, before a reset


class Bonus(NamedTuple):
    init: Callable[[chex.PRNGKey, chex.Array], Any]
    reward: Callable[[Any, Steps, Any], tuple[chex.Array, Any]]
    learn: Callable[[Any, Steps, chex.PRNGKey], Any]


class Moments(NamedTuple):
    """Running mean and variance of a stream of samples (the parallel update of Chan et
    al., as OpenAI baselines' RunningMeanStd, which RND normalises with)."""

    count: chex.Array  # f32[]
    mean: chex.Array  # f32[...]
    var: chex.Array  # f32[...]

    @staticmethod
    def start(shape: tuple[int, ...] = ()) -> Moments:
        """No samples yet: count 1e-4 (baselines' epsilon), mean 0, variance 1."""
        zeros, ones = jnp.zeros(shape, jnp.float32), jnp.ones(shape, jnp.float32)
        return Moments(jnp.float32(1e-4), zeros, ones)

    def update(self, x: chex.Array) -> Moments:
        """After the samples ``x`` f32[N, ...] (the leading axis the samples)."""
        n = jnp.float32(x.shape[0])
        mean, var = jnp.mean(x, axis=0), jnp.var(x, axis=0)
        total = self.count + n
        delta = mean - self.mean
        new_mean = self.mean + delta * n / total
        m2 = self.var * self.count + var * n + delta**2 * self.count * n / total
        return Moments(total, new_mean, m2 / total)


def maker(name: str) -> Callable[..., Bonus]:
    """The registered strategy ``name``'s bonus maker, ``make(config, env)``."""
    return resolve(registry.get(name).bonus)


__all__ = ["Bonus", "Moments", "Steps", "maker"]
