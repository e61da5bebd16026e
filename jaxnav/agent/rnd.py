"""Random network distillation (Burda, Edwards, Storkey, Klimov 2018, "Exploration by
Random Network Distillation"): the intrinsic reward of strategy ``rnd``.

A fixed, randomly initialised network ``target`` maps an observation to features; a
``predictor`` learns to give the same features. Its error is small on observations
like those it has trained on and large on new ones, so

    bonus(s') = mean_k (predictor(n(s'))_k - target(n(s'))_k)^2

is a novelty reward for reaching s'. As in the paper:

* the observation is normalised by the running mean and standard deviation of every
  observation seen so far and clipped to [-5, 5] (n above), for both networks;
* the bonus is divided by the running standard deviation of its discounted sum, each
  environment's sum running on across episodes (the paper's ``RewardForwardFilter``,
  discount :data:`INTRINSIC_GAMMA`);
* the predictor learns by Adam at the paper's 1e-4, one pass over each rollout's
  observations in the trainer's minibatches (the paper trains it in PPO's 4 epochs on
  a quarter of the experience with 128 environments: as many samples as one pass over
  all of it); the target never learns; both have
  leaky ReLUs, the predictor one hidden layer deeper. Their weights start He-normal
  (variance 2 / inputs, the scale of the paper's orthogonal initialisation with gain
  sqrt 2: the QR decomposition an orthogonal draw needs stalled XLA's CPU backend
  when vmapped over runs).

Observations here are the LiDAR scan, the goal's heading and distance and the last
command (28 numbers), so the networks are small multilayer perceptrons where the
paper's were convolutional. The bonus, times ``exploration.rnd_scale``, is added to the
environment's reward in the lambda-returns of the strategy's runs; the rest of the
paper's agent (a second value head with its own discount, PPO) is not carried over to
a Q-learner: one sum of rewards, the run's own discount.
"""

from __future__ import annotations

from typing import Any

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp
import optax
from flax import struct

from jaxnav.agent.bonus import Bonus, Moments, Steps

FEATURES = 64  # the target's features
TARGET_HIDDEN = (64, 64)
PREDICTOR_HIDDEN = (64, 64, 64)  # one layer deeper than the target, as the paper's
LEARNING_RATE = 1e-4  # the paper's Adam
INTRINSIC_GAMMA = 0.99  # the discount of the sum whose std scales the bonus (paper)
OBS_CLIP = 5.0  # the normalised observation is clipped to +-this (paper)


class Features(nn.Module):
    """An MLP, leaky ReLUs between its layers, linear out."""

    hidden: tuple[int, ...]
    features: int = FEATURES

    @nn.compact
    def __call__(self, x: chex.Array) -> chex.Array:
        init = nn.initializers.variance_scaling(2.0, "fan_in", "normal")
        for width in self.hidden:
            x = nn.leaky_relu(nn.Dense(width, kernel_init=init)(x))
        return nn.Dense(self.features, kernel_init=init)(x)


TARGET = Features(TARGET_HIDDEN)
PREDICTOR = Features(PREDICTOR_HIDDEN)


@struct.dataclass
class RNDState:
    target: Any  # the fixed network's parameters
    predictor: Any
    opt_state: Any
    obs: Moments  # of every observation seen, per value f32[D]
    returns: Moments  # of the discounted sums of the bonus, f32[]
    running: chex.Array  # f32[E] each environment's discounted sum so far


def normalised(obs: chex.Array, stats: Moments) -> chex.Array:
    """Observations normalised by the running moments and clipped (the paper's)."""
    return jnp.clip((obs - stats.mean) / jnp.sqrt(stats.var), -OBS_CLIP, OBS_CLIP)


def error(target, predictor, x: chex.Array) -> chex.Array:
    """The predictor's mean squared error on the target's features of normalised
    observations ``x`` f32[..., D]: f32[...]."""
    return jnp.mean((PREDICTOR.apply(predictor, x) - TARGET.apply(target, x)) ** 2, axis=-1)


def forward_sums(running: chex.Array, bonus: chex.Array, gamma: float):
    """(each step's discounted sum f32[T, E], the sums after the rollout f32[E]): the
    paper's ``RewardForwardFilter``, sum_t = gamma sum_{t-1} + bonus_t, never reset."""

    def step(s, b):
        s = gamma * s + b
        return s, s

    last, sums = jax.lax.scan(step, running, bonus)
    return sums, last


def make(config, env) -> Bonus:
    """RND's bonus for a config's runs (``env``: its environment)."""
    p = config.pqn
    optimizer = optax.adam(LEARNING_RATE)
    size = p.num_envs * p.rollout // p.minibatches

    def init(key: chex.PRNGKey, obs: chex.Array) -> RNDState:
        k_target, k_predictor = jax.random.split(key)
        target = TARGET.init(k_target, obs[0])
        predictor = PREDICTOR.init(k_predictor, obs[0])
        return RNDState(
            target=target,
            predictor=predictor,
            opt_state=optimizer.init(predictor),
            obs=Moments.start(obs.shape[-1:]),
            returns=Moments.start(),
            running=jnp.zeros(obs.shape[0], jnp.float32),
        )

    def reward(state: RNDState, steps: Steps, hyper) -> tuple[chex.Array, RNDState]:
        flat = steps.next_obs.reshape(-1, steps.next_obs.shape[-1])
        stats = state.obs.update(flat)
        bonus = error(state.target, state.predictor, normalised(steps.next_obs, stats))
        sums, running = forward_sums(state.running, bonus, INTRINSIC_GAMMA)
        returns = state.returns.update(sums.reshape(-1))
        scaled = hyper.rnd_scale * bonus / jnp.sqrt(returns.var)
        return scaled, state.replace(obs=stats, returns=returns, running=running)

    def learn(state: RNDState, steps: Steps, key: chex.PRNGKey) -> RNDState:
        x = normalised(steps.next_obs.reshape(-1, steps.next_obs.shape[-1]), state.obs)
        n = x.shape[0]

        def loss(predictor, batch):
            return jnp.mean(error(state.target, predictor, batch))

        def minibatch(carry, batch):
            predictor, opt_state = carry
            grads = jax.grad(loss)(predictor, batch)
            updates, opt_state = optimizer.update(grads, opt_state, predictor)
            return (optax.apply_updates(predictor, updates), opt_state), None

        def epoch(carry, k):
            order = jax.random.permutation(k, n)
            batches = x[order].reshape(p.minibatches, size, x.shape[-1])
            return jax.lax.scan(minibatch, carry, batches)

        (predictor, opt_state), _ = epoch((state.predictor, state.opt_state), key)
        return state.replace(predictor=predictor, opt_state=opt_state)

    return Bonus(init, reward, learn)


__all__ = [
    "FEATURES",
    "INTRINSIC_GAMMA",
    "LEARNING_RATE",
    "OBS_CLIP",
    "PREDICTOR",
    "RNDState",
    "TARGET",
    "error",
    "forward_sums",
    "make",
    "normalised",
]
