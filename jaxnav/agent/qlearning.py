"""The Q-learning pieces DQN and PQN share: the TD target and loss, the Polyak
target update, the optimiser and its learning-rate decay.

* TD target ``y = r + gamma * max_b Q(s', b; theta^-)``, squared error (the paper's):
  :func:`td_target`, :func:`td_loss`; double DQN by :func:`td_target`'s
  ``next_q_online``, the Huber loss by :func:`td_loss`'s ``kind``.
"""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
import optax

from jaxnav.agent.hyper import Hyper
from jaxnav.core.config import Config, DQNConfig


def td_target(reward, terminated, next_q_target, gamma, next_q_online=None) -> chex.Array:
    """y = r + gamma * max_b Q(s', b; theta^-), no bootstrap after a collision.

    Truncation (the step limit) is not terminal, so it bootstraps. With
    ``next_q_online`` (double DQN, van Hasselt et al. 2016) the online network picks
    the next action and the target network values it:
    y = r + gamma * Q(s', argmax_b Q(s', b; theta); theta^-).
    """
    if next_q_online is None:
        next_v = jnp.max(next_q_target, -1)
    else:
        pick = jnp.argmax(next_q_online, -1)
        next_v = jnp.take_along_axis(next_q_target, pick[..., None], axis=-1)[..., 0]
    return reward + gamma * (1.0 - terminated.astype(jnp.float32)) * next_v


def td_loss(q: chex.Array, action: chex.Array, target: chex.Array, kind="mse", weights=None):
    """Mean TD loss of the taken actions: squared error (``mse``, the paper's) or
    Huber with delta 1 (``huber``: 0.5 x^2 for |x| <= 1, |x| - 0.5 beyond); ``kind``
    may be data, bool[] true for Huber (both computed, one kept). ``weights`` (f32[B],
    prioritised replay's importance weights) weigh each transition's loss in the mean."""
    q_a = jnp.take_along_axis(q, action[:, None], axis=-1)[:, 0]
    if weights is not None:
        target = jax.lax.stop_gradient(target)
        squared, huber = (q_a - target) ** 2, optax.huber_loss(q_a, target, delta=1.0)
        if isinstance(kind, str):
            each = squared if kind == "mse" else huber
        else:
            each = jnp.where(kind, huber, squared)
        return jnp.mean(weights * each)
    if isinstance(kind, str) and kind == "mse":
        return jnp.mean((q_a - jax.lax.stop_gradient(target)) ** 2)
    huber = jnp.mean(optax.huber_loss(q_a, jax.lax.stop_gradient(target), delta=1.0))
    if isinstance(kind, str):
        return huber
    return jnp.where(kind, huber, jnp.mean((q_a - jax.lax.stop_gradient(target)) ** 2))


def soft_update(params, target_params, tau: float):
    """Polyak target update theta^- <- tau theta + (1 - tau) theta^- (tau 1: a copy)."""
    return jax.tree.map(lambda p, t: tau * p + (1.0 - tau) * t, params, target_params)


def optimizer_of(
    h: Hyper | DQNConfig, kind: str = "rmsprop", decay_steps: int | None = None
) -> optax.GradientTransformation:
    """RMSprop as ROBOTIS' Keras uses it (eps outside the root), ``adam`` (optax's
    defaults: b1 0.9, b2 0.999, eps 1e-8) or ``radam`` (Liu et al. 2020, optax's
    defaults), at the learning rate of a config or of a run (data): optax takes
    traced hyperparameters as they are. ``decay_steps``: the rate falls linearly to 0
    over that many gradient steps (``dqn.lr_decay``)."""
    lr = h.lr if decay_steps is None else optax.linear_schedule(h.lr, 0.0, decay_steps)
    if kind == "adam":
        return optax.adam(lr)
    if kind == "radam":
        return optax.radam(lr)
    return optax.rmsprop(lr, decay=h.rms_decay, eps=h.rms_eps, eps_in_sqrt=False)


def lr_decay_steps(config: Config, per_run_steps: int | None = None) -> int | None:
    """The gradient steps ``dqn.lr_decay`` spreads the decay over (None: no decay):
    one per env step of the run's budget (DQN), or ``per_run_steps`` (PQN's)."""
    if not config.dqn.lr_decay:
        return None
    return max(1, per_run_steps if per_run_steps is not None else config.max_total_steps)


__all__ = ["lr_decay_steps", "optimizer_of", "soft_update", "td_loss", "td_target"]
