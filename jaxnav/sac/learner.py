"""One SAC gradient step: the losses, the replay memory, the optimisers, and the
learners with a torso each or a shared one (sac.shared_torso)."""

from __future__ import annotations

from typing import Any

import chex
import jax
import jax.numpy as jnp
import optax
from flax import struct

from jaxnav.agent.networks import ScanTorso
from jaxnav.agent.qlearning import soft_update
from jaxnav.agent.trainer import all_finite
from jaxnav.core.config import Config
from jaxnav.env import NavEnv
from jaxnav.sac.networks import (
    ACTION_SIZE,
    Actor,
    TwinCritic,
    critic_of,
    network_of,
    split_torso,
    with_torso,
)

# ----------------------------------------------------------------------------
# The losses
# ----------------------------------------------------------------------------


def soft_target(reward, terminated, next_q, next_log_prob, alpha, gamma) -> chex.Array:
    """y = r + gamma (1 - terminated) (min_i Q'_i(s', a') - alpha log pi(a' | s')):
    ``next_q`` f32[2, B] the target critics at (s', a'), ``next_log_prob`` f32[B];
    ``gamma`` a number, or f32[B] (gamma^m after m steps of reward, :func:`n_step_returns`)."""
    soft_value = jnp.min(next_q, axis=0) - alpha * next_log_prob
    return reward + gamma * (1.0 - terminated.astype(jnp.float32)) * soft_value


def temperature_loss(log_alpha, log_prob, target_entropy) -> chex.Array:
    """-log(alpha) mean(log pi + H_target), log pi held fixed: its gradient raises alpha
    while the policy's entropy (-log pi) is below the target, and lowers it above."""
    return -log_alpha * jnp.mean(jax.lax.stop_gradient(log_prob) + target_entropy)


# ----------------------------------------------------------------------------
# The replay memory and one gradient step
# ----------------------------------------------------------------------------


@struct.dataclass
class Memory:
    """A run's replay memory, a ring of ``capacity`` transitions."""

    obs: chex.Array  # f32[C, D]
    action: chex.Array  # f32[C, 2]
    reward: chex.Array  # f32[C]
    next_obs: chex.Array  # f32[C, D] the observation after the step, before any reset
    terminated: chex.Array  # bool[C] a collision: no bootstrap
    filled: chex.Array  # i32[] transitions stored (at most C)
    cursor: chex.Array  # i32[] the next slot written
    # bool[C] the episode ended at the step (a collision or the step limit), with
    # sac.n_step > 1: its environment's next slot starts another; None otherwise
    done: Any = None


class Learner(struct.PyTreeNode):
    """What one gradient step changes."""

    actor: chex.ArrayTree
    average: chex.ArrayTree  # the tested actor (the actor itself when actor_average is 0)
    critic: chex.ArrayTree
    target: chex.ArrayTree
    log_alpha: chex.Array
    actor_opt: chex.ArrayTree
    critic_opt: chex.ArrayTree
    alpha_opt: chex.ArrayTree


def optimizers(config: Config) -> tuple[optax.GradientTransformation, ...]:
    """(the actor's, the critics') Adam at sac.lr; with sac.lr_decay each rate falls
    linearly to 0 over its network's gradient steps in the run's budget (the critics'
    from the first env step that learns to the last, the actor's every
    sac.actor_every-th of them). The temperature's rate does not decay
    (:func:`temperature_optimizer`)."""
    s = config.sac
    if not s.lr_decay:
        return optax.adam(s.lr), optax.adam(s.lr)
    learning = max(1, (config.max_total_steps - s.learning_starts) // s.num_envs + 1)
    steps = learning * s.updates
    return (
        optax.adam(optax.linear_schedule(s.lr, 0.0, max(1, steps // s.actor_every))),
        optax.adam(optax.linear_schedule(s.lr, 0.0, steps)),
    )


def temperature_optimizer(config: Config) -> optax.GradientTransformation:
    """The entropy temperature's Adam, at sac.lr throughout."""
    return optax.adam(config.sac.lr)


def make_learner(config: Config, env: NavEnv | None = None):
    """``learn(learner, memory, key, actor_step=True) -> (learner, critic loss,
    finite)``: one SAC gradient step on a uniform batch of the memory (critics, then the
    actor against the new critics, then the temperature, then the targets and the tested
    actor; with ``actor_step`` False, a static flag, the critics and targets alone); with
    sac.shared_torso, :func:`_shared_learner`'s."""
    s = config.sac
    actor, critic = network_of(config, env), critic_of(config, env)
    if s.shared_torso:
        return _shared_learner(config, actor, critic)
    actor_optimizer, critic_optimizer = optimizers(config)

    def learn(lr: Learner, memory: Memory, key: chex.PRNGKey, actor_step: bool = True):
        k_idx, k_next, k_new = jax.random.split(key, 3)
        obs, action, reward, next_obs, term, discount = _batch(memory, k_idx, config)
        alpha = jnp.exp(lr.log_alpha)

        next_a, next_logp = actor.apply(lr.actor, next_obs, k_next)
        next_q = critic.apply(lr.target, next_obs, next_a)
        y = jax.lax.stop_gradient(soft_target(reward, term, next_q, next_logp, alpha, discount))

        c_loss, critic_params, critic_opt = _critic_step(
            critic, critic_optimizer, lr, obs, action, y
        )
        if not actor_step:
            a_params, a_opt = lr.actor, lr.actor_opt
            return _finish(config, lr, a_params, a_opt, critic_params, critic_opt, None, c_loss)

        def actor_loss(params):
            a, logp = actor.apply(params, obs, k_new)
            q = jnp.min(critic.apply(critic_params, obs, a), axis=0)
            return jnp.mean(alpha * logp - q), logp

        (a_loss, logp), grads = jax.value_and_grad(actor_loss, has_aux=True)(lr.actor)
        updates, actor_opt = actor_optimizer.update(grads, lr.actor_opt, lr.actor)
        actor_params = optax.apply_updates(lr.actor, updates)

        return _finish(
            config, lr, actor_params, actor_opt, critic_params, critic_opt, logp, c_loss, a_loss
        )

    return learn


def _critic_step(critic: TwinCritic, optimizer, lr: Learner, obs, action, y):
    """(loss, critic parameters, optimiser state) after one Adam step of both critics
    towards the soft target ``y``: the sum over the twins of their mean squared error."""

    def critic_loss(params):
        q = critic.apply(params, obs, action)  # f32[2, B]
        return jnp.sum(jnp.mean((q - y) ** 2, axis=-1))

    c_loss, grads = jax.value_and_grad(critic_loss)(lr.critic)
    updates, critic_opt = optimizer.update(grads, lr.critic_opt, lr.critic)
    return c_loss, optax.apply_updates(lr.critic, updates), critic_opt


def _batch(memory: Memory, key: chex.PRNGKey, config: Config):
    """(obs, action, reward, next_obs, terminated, discount) of sac.batch_size
    transitions drawn uniformly from the filled part of the memory: one step each
    (discount sac.gamma), or with sac.n_step n > 1 each the first of up to n steps of its
    environment (:func:`n_step_returns`)."""
    s = config.sac
    idx = jax.random.randint(key, (s.batch_size,), 0, jnp.maximum(memory.filled, 1))
    m = memory
    if s.n_step == 1:
        return m.obs[idx], m.action[idx], m.reward[idx], m.next_obs[idx], m.terminated[idx], s.gamma
    reward, last, discount = n_step_returns(m, idx, s.n_step, s.num_envs, s.gamma)
    return m.obs[idx], m.action[idx], reward, m.next_obs[last], m.terminated[last], discount


def n_step_returns(memory: Memory, idx: chex.Array, n: int, envs: int, gamma: float):
    """(G f32[B], last i32[B], discount f32[B]) of the transitions at ``idx``: each
    steps on through its environment's next transitions (``envs`` slots apart, as
    every step writes one per environment in order) while its episode goes on and the
    next was written after it, n steps at most; G = sum_k gamma^k r_k over the m steps
    taken, ``last`` the slot of the m-th (whose s' and terminated the target reads) and
    ``discount`` gamma^m. The entropy bonus of the steps in between is not added: the
    target is the n-step return of the rewards, then the soft value of the m-th s'."""
    capacity = memory.reward.shape[0]
    after = (memory.cursor - 1 - idx) % capacity  # slots written after each one
    reward = memory.reward[idx]
    last, discount, going = idx, jnp.full(idx.shape, gamma, jnp.float32), ~memory.done[idx]
    for k in range(1, n):
        going = going & (k * envs <= after)
        j = (idx + k * envs) % capacity
        reward = reward + jnp.where(going, discount * memory.reward[j], 0.0)
        last = jnp.where(going, j, last)
        discount = jnp.where(going, discount * gamma, discount)
        going = going & ~memory.done[j]
    return reward, last, discount


def _finish(
    config, lr, actor_params, actor_opt, critic_params, critic_opt, logp=None, c_loss=None,
    a_loss=None,
):  # fmt: skip
    """A gradient step's end, shared by both learners: the temperature's step (none
    without the actor's ``logp``, a critics-only step), the target critics' and the
    tested actor's Polyak steps, and whether all is finite."""
    s = config.sac
    if logp is None:
        log_alpha, alpha_opt, t_loss, a_loss = lr.log_alpha, lr.alpha_opt, 0.0, 0.0
    else:
        optimizer = temperature_optimizer(config)
        target_entropy = -s.entropy_scale * ACTION_SIZE
        t_loss, grad = jax.value_and_grad(temperature_loss)(lr.log_alpha, logp, target_entropy)
        updates, alpha_opt = optimizer.update(grad, lr.alpha_opt, lr.log_alpha)
        log_alpha = optax.apply_updates(lr.log_alpha, updates)

    if s.actor_average > 0:
        average = soft_update(actor_params, lr.average, s.actor_average)
    else:
        average = actor_params
    new = Learner(
        actor_params,
        average,
        critic_params,
        soft_update(critic_params, lr.target, s.tau),
        log_alpha,
        actor_opt,
        critic_opt,
        alpha_opt,
    )
    finite = jnp.isfinite(c_loss) & jnp.isfinite(a_loss) & jnp.isfinite(t_loss)
    return new, c_loss, finite & all_finite((actor_params, critic_params))


def _shared_learner(config: Config, actor: Actor, critic: TwinCritic):
    """:func:`make_learner`'s step with sac.shared_torso (DrQ's encoder sharing,
    Yarats et al. 2021): the critics' torso is the only one. Their loss trains it; the
    actor reads its output with the gradient stopped, so the actor's optimiser holds
    only the actor's own layers (``actor_opt`` is over :func:`split_torso`'s rest), and
    after each step the actor's "ScanTorso" is set to the critics' new one. The torso
    runs 4 times a step (the batch's s' with the critics' and the targets' torso, its s
    forward and back, its s again after the critics' step) where separate torsos run
    14 times."""
    actor_optimizer, critic_optimizer = optimizers(config)
    torso = ScanTorso(actor.scan_conv, actor.scan_layout)
    head = Actor(actor.hidden, actor.action_size)
    heads = TwinCritic(critic.hidden, critic.layer_norm)

    def learn(lr: Learner, memory: Memory, key: chex.PRNGKey, actor_step: bool = True):
        k_idx, k_next, k_new = jax.random.split(key, 3)
        obs, action, reward, next_obs, term, discount = _batch(memory, k_idx, config)
        alpha = jnp.exp(lr.log_alpha)
        c_torso, _ = split_torso(lr.critic)
        t_torso, t_heads = split_torso(lr.target)
        _, a_head = split_torso(lr.actor)

        next_a, next_logp = head.apply(a_head, torso.apply(c_torso, next_obs), k_next)
        next_q = heads.apply(t_heads, torso.apply(t_torso, next_obs), next_a)
        y = jax.lax.stop_gradient(soft_target(reward, term, next_q, next_logp, alpha, discount))

        c_loss, critic_params, critic_opt = _critic_step(
            critic, critic_optimizer, lr, obs, action, y
        )
        new_torso, new_heads = split_torso(critic_params)
        if not actor_step:  # the actor's own layers stay; it reads the new torso
            actor_params = with_torso(a_head, new_torso)
            return _finish(
                config, lr, actor_params, lr.actor_opt, critic_params, critic_opt, c_loss=c_loss
            )
        features = jax.lax.stop_gradient(torso.apply(new_torso, obs))

        def actor_loss(params):
            a, logp = head.apply(params, features, k_new)
            q = jnp.min(heads.apply(new_heads, features, a), axis=0)
            return jnp.mean(alpha * logp - q), logp

        (a_loss, logp), grads = jax.value_and_grad(actor_loss, has_aux=True)(a_head)
        updates, actor_opt = actor_optimizer.update(grads, lr.actor_opt, a_head)
        actor_params = with_torso(optax.apply_updates(a_head, updates), new_torso)
        return _finish(
            config, lr, actor_params, actor_opt, critic_params, critic_opt, logp, c_loss, a_loss
        )

    return learn
