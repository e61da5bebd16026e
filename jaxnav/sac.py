"""SAC, the continuous-action agent, in the trainer shape DQN and PQN share.

Soft actor-critic (Haarnoja et al. 2018, "Soft Actor-Critic Algorithms and
Applications": twin critics, target critics by Polyak averaging, automatic entropy
temperature) drives continuous commands (``env.actions continuous``: an action in
[-1, 1]^2 sets the speed across ``env.speed_range`` and the yaw rate across
+-``env.max_yaw_rate``). As in the fast recipes for parallel simulation (FastTD3 and
its SAC variant, 2025), each run steps ``sac.num_envs`` environments together and takes
``sac.updates`` gradient steps after each step of all of them, from a replay memory of
``sac.buffer_size`` transitions.

* The actor (:class:`Actor`) is a squashed Gaussian: a = tanh(u), u ~ N(mu, sigma), its
  log-probability with the tanh correction (:func:`squashed_sample`). Its mean action
  tanh(mu) is the policy that is tested, exported and deployed; exploring, it samples.
* The critics (:class:`TwinCritic`) fit the soft target
  y = r + gamma (1 - terminated) (min_i Q'_i(s', a') - alpha log pi(a' | s')),
  a' ~ pi(s') (:func:`soft_target`); a truncation bootstraps from its final observation.
* The actor minimises alpha log pi(a | s) - min_i Q_i(s, a); the temperature minimises
  -log(alpha) (log pi(a | s) + H_target) (:func:`temperature_loss`), H_target =
  -``sac.entropy_scale`` x 2.
* The first ``sac.learning_starts`` env steps act uniformly at random.
* With ``sac.actor_average`` > 0 the policy that is evaluated, tested and exported is a
  Polyak average of the actor's parameters, moved that far towards the actor after each
  gradient step; the actor that explores and learns is unchanged by it.

Counting is PQN's (docs/training.md): ``step`` is the env steps of all the run's
environments, ``episode`` the episodes any of them finished.
"""

from __future__ import annotations

from typing import Any

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp
import optax
from flax import struct

from jaxnav.agent.episodes import Episodes
from jaxnav.agent.hyper import Hyper
from jaxnav.agent.networks import ScanTorso
from jaxnav.agent.qlearning import soft_update
from jaxnav.agent.trainer import (
    StepLog,
    Trainer,
    all_finite,
    file_episodes,
    run_limits,
    select,
    still_training,
    update_chunk,
)
from jaxnav.core.agent_settings import sac_capacity
from jaxnav.core.config import Config
from jaxnav.env import EnvState, NavEnv, bank_key, from_config

# The actor's log standard deviation, squashed into this range (CleanRL's, SB3's).
LOG_STD_MIN, LOG_STD_MAX = -5.0, 2.0
ACTION_SIZE = 2  # (speed, yaw rate)


# ----------------------------------------------------------------------------
# The squashed Gaussian
# ----------------------------------------------------------------------------


def squashed_sample(key: chex.PRNGKey, mean: chex.Array, log_std: chex.Array):
    """(a, log pi(a)) of a = tanh(u), u ~ N(mean, exp(log_std)) element-wise:
    log pi(a) = sum_j [log N(u_j; mean_j, std_j) - log(1 - tanh(u_j)^2)] over the last
    axis (Haarnoja et al. 2018, appendix C), the correction computed as
    2 (log 2 - u - softplus(-2u)), which stays finite where tanh(u) rounds to +-1."""
    std = jnp.exp(log_std)
    eps = jax.random.normal(key, mean.shape, mean.dtype)
    u = mean + std * eps
    gauss = -0.5 * eps**2 - log_std - 0.5 * jnp.log(2.0 * jnp.pi)
    correction = 2.0 * (jnp.log(2.0) - u - jax.nn.softplus(-2.0 * u))
    return jnp.tanh(u), jnp.sum(gauss - correction, axis=-1)


class Actor(nn.Module):
    """The policy: ReLU layers of ``hidden`` widths, then one linear layer giving the
    mean and the (squashed) log standard deviation of each of the action's numbers.

    ``actor(obs)`` is the mean action tanh(mean) (tested, exported, deployed);
    ``actor(obs, key)`` samples: (a, log pi(a)). Its layers are ``Dense_0``, ... with
    the last giving [mean, raw log std], so a NumPy reader runs it as a plain MLP (after
    the scan's convolutions with ``scan_conv``, :class:`jaxnav.agent.networks.ScanTorso`)."""

    hidden: tuple[int, ...] = (128, 128)
    action_size: int = ACTION_SIZE
    scan_conv: tuple[int, ...] = ()
    scan_layout: tuple[int, int, int] = (0, 0, 0)

    @nn.compact
    def __call__(self, obs: chex.Array, key: chex.PRNGKey | None = None):
        x = obs
        if self.scan_conv:  # the circular convolutions over the scan first
            x = ScanTorso(self.scan_conv, self.scan_layout, name="ScanTorso")(x)
        for width in self.hidden:
            x = nn.relu(nn.Dense(width)(x))
        mean, raw = jnp.split(nn.Dense(2 * self.action_size)(x), 2, axis=-1)
        if key is None:
            return jnp.tanh(mean)
        log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (jnp.tanh(raw) + 1.0)
        return squashed_sample(key, mean, log_std)


class Critic(nn.Module):
    """Q(s, a): ReLU layers of ``hidden`` widths on [s, a] (LayerNorm before each ReLU
    with ``layer_norm``), one linear output; with ``scan_conv`` s is first what the
    scan's convolutions make of it (its own, not the actor's)."""

    hidden: tuple[int, ...] = (128, 128)
    layer_norm: bool = True
    scan_conv: tuple[int, ...] = ()
    scan_layout: tuple[int, int, int] = (0, 0, 0)

    @nn.compact
    def __call__(self, obs: chex.Array, action: chex.Array) -> chex.Array:
        if self.scan_conv:
            obs = ScanTorso(self.scan_conv, self.scan_layout, name="ScanTorso")(obs)
        x = jnp.concatenate([obs, action], axis=-1)
        for width in self.hidden:
            x = nn.Dense(width)(x)
            if self.layer_norm:
                x = nn.LayerNorm()(x)
            x = nn.relu(x)
        return nn.Dense(1)(x)[..., 0]


class TwinCritic(nn.Module):
    """Two :class:`Critic` s with their own parameters: Q f32[2, ...]. With ``shared``
    the scan's convolutions (``ScanTorso``) are one, before both (sac.shared_torso)."""

    hidden: tuple[int, ...] = (128, 128)
    layer_norm: bool = True
    scan_conv: tuple[int, ...] = ()
    scan_layout: tuple[int, int, int] = (0, 0, 0)
    shared: bool = False

    @nn.compact
    def __call__(self, obs: chex.Array, action: chex.Array) -> chex.Array:
        conv = self.scan_conv
        if self.shared and conv:
            obs = ScanTorso(conv, self.scan_layout, name="ScanTorso")(obs)
            conv = ()
        twins = nn.vmap(
            Critic,
            variable_axes={"params": 0},
            split_rngs={"params": True},
            in_axes=None,
            out_axes=0,
            axis_size=2,
        )
        return twins(self.hidden, self.layer_norm, conv, self.scan_layout)(obs, action)


def _conv(config: Config, env: NavEnv | None) -> dict:
    """The scan convolutions' settings of SAC's networks (``env``: the config's
    environment, made here if needed for the observation's layout)."""
    if not config.sac.scan_conv:
        return {}
    env = from_config(config)[0] if env is None else env
    return {"scan_conv": tuple(config.sac.scan_conv), "scan_layout": env.scan_layout}


def network_of(config: Config, env: NavEnv | None = None) -> Actor:
    """The network SAC's policy acts with: the actor (``env``: the config's
    environment, if already made)."""
    return Actor(tuple(config.sac.hidden), **_conv(config, env))


def critic_of(config: Config, env: NavEnv | None = None) -> TwinCritic:
    s = config.sac
    return TwinCritic(tuple(s.hidden), s.layer_norm, shared=s.shared_torso, **_conv(config, env))


# With sac.shared_torso the actor's and the critics' parameters each hold the one torso
# under "ScanTorso", beside their own layers: split off, it runs alone, and the rest
# runs as the same network without convolutions.
TORSO = "ScanTorso"


def split_torso(variables: dict) -> tuple[dict, dict]:
    """(the torso's variables, the rest's) of a network with a ``ScanTorso``."""
    p = variables["params"]
    return {"params": p[TORSO]}, {"params": {k: v for k, v in p.items() if k != TORSO}}


def with_torso(head: dict, torso: dict) -> dict:
    """The network's variables: ``head``'s layers after ``torso``'s convolutions."""
    return {"params": {**head["params"], TORSO: torso["params"]}}


# ----------------------------------------------------------------------------
# The losses
# ----------------------------------------------------------------------------


def soft_target(reward, terminated, next_q, next_log_prob, alpha, gamma) -> chex.Array:
    """y = r + gamma (1 - terminated) (min_i Q'_i(s', a') - alpha log pi(a' | s')):
    ``next_q`` f32[2, B] the target critics at (s', a'), ``next_log_prob`` f32[B]."""
    soft_value = jnp.min(next_q, axis=0) - alpha * next_log_prob
    return reward + gamma * (1.0 - terminated.astype(jnp.float32)) * soft_value


def temperature_loss(log_alpha, log_prob, target_entropy) -> chex.Array:
    """-log(alpha) mean(log pi + H_target), log pi held fixed: its gradient raises alpha
    while the policy's entropy (-log pi) is below the target, and lowers it above."""
    return -log_alpha * jnp.mean(jax.lax.stop_gradient(log_prob) + target_entropy)


# ----------------------------------------------------------------------------
# Training state
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


@struct.dataclass
class SACState:
    """One SAC run. The fields the host loop reads (``params``: the tested actor's,
    ``step``, ``episode``, ``metrics``, ``diverged_at``, ``key``, ``bank``) mean what
    they mean for PQN (:class:`jaxnav.pqn.PQNState`)."""

    params: chex.ArrayTree  # the tested actor's: the actor's, or their average (actor_average)
    critic: chex.ArrayTree
    target_critic: chex.ArrayTree
    log_alpha: chex.Array  # f32[]
    actor_opt: chex.ArrayTree
    critic_opt: chex.ArrayTree
    alpha_opt: chex.ArrayTree
    memory: Memory
    env_state: EnvState  # each leaf [num_envs, ...]
    obs: chex.Array  # f32[num_envs, D]
    key: chex.PRNGKey
    strategy: chex.Array  # i32[] (the policy strategy's number)
    hyper: Hyper
    step: chex.Array  # i32[] env steps taken, all environments together
    episode: chex.Array  # i32[] episodes finished, all environments together
    metrics: Episodes
    diverged_at: chex.Array  # i32[] env step of the step that first broke; -1 while none
    bank: Any = None  # the run's layouts drawn ahead (env.maze_bank), else None
    # the actor that samples and learns, where the tested one is its average
    # (sac.actor_average); None: ``params`` is that actor
    actor: Any = None

    def acting(self) -> chex.ArrayTree:
        """The parameters of the actor that samples and learns."""
        return self.params if self.actor is None else self.actor


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


def make_learner(config: Config, env: NavEnv | None = None):
    """``learn(learner, memory, key) -> (learner, critic loss, finite)``: one SAC
    gradient step on a uniform batch of the memory (critics, then the actor against the
    new critics, then the temperature, then the targets and the tested actor); with
    sac.shared_torso, :func:`_shared_learner`'s."""
    s = config.sac
    actor, critic = network_of(config, env), critic_of(config, env)
    if s.shared_torso:
        return _shared_learner(config, actor, critic)
    optimizer = optax.adam(s.lr)

    def learn(lr: Learner, memory: Memory, key: chex.PRNGKey):
        k_idx, k_next, k_new = jax.random.split(key, 3)
        obs, action, reward, next_obs, term = _batch(memory, k_idx, s.batch_size)
        alpha = jnp.exp(lr.log_alpha)

        next_a, next_logp = actor.apply(lr.actor, next_obs, k_next)
        next_q = critic.apply(lr.target, next_obs, next_a)
        y = jax.lax.stop_gradient(soft_target(reward, term, next_q, next_logp, alpha, s.gamma))

        c_loss, critic_params, critic_opt = _critic_step(critic, optimizer, lr, obs, action, y)

        def actor_loss(params):
            a, logp = actor.apply(params, obs, k_new)
            q = jnp.min(critic.apply(critic_params, obs, a), axis=0)
            return jnp.mean(alpha * logp - q), logp

        (a_loss, logp), grads = jax.value_and_grad(actor_loss, has_aux=True)(lr.actor)
        updates, actor_opt = optimizer.update(grads, lr.actor_opt, lr.actor)
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


def _batch(memory: Memory, key: chex.PRNGKey, size: int):
    """(obs, action, reward, next_obs, terminated) of ``size`` transitions drawn
    uniformly from the filled part of the memory."""
    idx = jax.random.randint(key, (size,), 0, jnp.maximum(memory.filled, 1))
    m = memory
    return m.obs[idx], m.action[idx], m.reward[idx], m.next_obs[idx], m.terminated[idx]


def _finish(config, lr, actor_params, actor_opt, critic_params, critic_opt, logp, c_loss, a_loss):
    """A gradient step's end, shared by both learners: the temperature's step, the
    target critics' and the tested actor's Polyak steps, and whether all is finite."""
    s = config.sac
    optimizer = optax.adam(s.lr)
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
    s = config.sac
    optimizer = optax.adam(s.lr)
    torso = ScanTorso(actor.scan_conv, actor.scan_layout)
    head = Actor(actor.hidden, actor.action_size)
    heads = TwinCritic(critic.hidden, critic.layer_norm)

    def learn(lr: Learner, memory: Memory, key: chex.PRNGKey):
        k_idx, k_next, k_new = jax.random.split(key, 3)
        obs, action, reward, next_obs, term = _batch(memory, k_idx, s.batch_size)
        alpha = jnp.exp(lr.log_alpha)
        c_torso, _ = split_torso(lr.critic)
        t_torso, t_heads = split_torso(lr.target)
        _, a_head = split_torso(lr.actor)

        next_a, next_logp = head.apply(a_head, torso.apply(c_torso, next_obs), k_next)
        next_q = heads.apply(t_heads, torso.apply(t_torso, next_obs), next_a)
        y = jax.lax.stop_gradient(soft_target(reward, term, next_q, next_logp, alpha, s.gamma))

        c_loss, critic_params, critic_opt = _critic_step(critic, optimizer, lr, obs, action, y)
        new_torso, new_heads = split_torso(critic_params)
        features = jax.lax.stop_gradient(torso.apply(new_torso, obs))

        def actor_loss(params):
            a, logp = head.apply(params, features, k_new)
            q = jnp.min(heads.apply(new_heads, features, a), axis=0)
            return jnp.mean(alpha * logp - q), logp

        (a_loss, logp), grads = jax.value_and_grad(actor_loss, has_aux=True)(a_head)
        updates, actor_opt = optimizer.update(grads, lr.actor_opt, a_head)
        actor_params = with_torso(optax.apply_updates(a_head, updates), new_torso)
        return _finish(
            config, lr, actor_params, actor_opt, critic_params, critic_opt, logp, c_loss, a_loss
        )

    return learn


def trained_part(config: Config, actor_params: dict) -> dict:
    """The part of the actor's parameters its optimiser steps: all of them, or with
    sac.shared_torso all but the torso (the critics train that)."""
    return split_torso(actor_params)[1] if config.sac.shared_torso else actor_params


def _steps_per_chunk(config: Config) -> int:
    """Steps of all environments per chunk: as many as fit in ``run.chunk_steps``."""
    return max(1, config.run.chunk_steps // config.sac.num_envs)


def make_trainer(config: Config) -> Trainer:
    """The SAC run of a config as pure ``init(key, strategy, hyper)``, ``step`` (one
    step of every environment, then ``sac.updates`` gradient steps), ``chunk`` and
    ``active``, driven by the host loop as DQN and PQN are."""
    env, base_params = from_config(config)
    s = config.sac
    envs = s.num_envs
    actor, critic = network_of(config, env), critic_of(config, env)
    optimizer = optax.adam(s.lr)
    learn = make_learner(config, env)
    capacity = sac_capacity(config)
    per_chunk = _steps_per_chunk(config)
    length = per_chunk * envs
    slots = config.episodes if config.episodes is not None else length
    limits = run_limits(config)
    limit = limits[0]

    def init(key: chex.PRNGKey, strategy: chex.Array, hyper: Hyper) -> SACState:
        env_params = env.with_bank(hyper.env_params(base_params), bank_key(key))
        k_actor, k_critic, k_env, k_run = jax.random.split(key, 4)
        reset = jax.vmap(env.reset, in_axes=(0, None))
        obs, env_state = reset(jax.random.split(k_env, envs), env_params)
        a0 = jnp.zeros((ACTION_SIZE,), jnp.float32)
        params = actor.init(k_actor, obs[0])
        critic_params = critic.init(k_critic, obs[0], a0)
        if s.shared_torso:  # the actor reads the critics' torso
            params = with_torso(split_torso(params)[1], split_torso(critic_params)[0])
        log_alpha = jnp.log(jnp.float32(s.init_alpha))
        d = obs.shape[-1]
        memory = Memory(
            obs=jnp.zeros((capacity, d), jnp.float32),
            action=jnp.zeros((capacity, ACTION_SIZE), jnp.float32),
            reward=jnp.zeros((capacity,), jnp.float32),
            next_obs=jnp.zeros((capacity, d), jnp.float32),
            terminated=jnp.zeros((capacity,), bool),
            filled=jnp.zeros((), jnp.int32),
            cursor=jnp.zeros((), jnp.int32),
        )
        return SACState(
            params=params,
            critic=critic_params,
            target_critic=critic_params,
            log_alpha=log_alpha,
            actor_opt=optimizer.init(trained_part(config, params)),
            critic_opt=optimizer.init(critic_params),
            alpha_opt=optimizer.init(log_alpha),
            memory=memory,
            env_state=env_state,
            obs=obs,
            key=k_run,
            strategy=jnp.asarray(strategy, jnp.int32),
            hyper=hyper,
            step=jnp.zeros((), jnp.int32),
            episode=jnp.zeros((), jnp.int32),
            metrics=Episodes.zeros(slots, envs, attempts=bool(env.attempt_limit)),
            diverged_at=jnp.asarray(-1, jnp.int32),
            bank=env_params.bank,
            actor=params if s.actor_average > 0 else None,
        )

    def active(ts: SACState) -> chex.Array:
        return still_training(ts.episode, ts.step, *limits) & (ts.diverged_at < 0)

    def step(ts: SACState, _):
        run = active(ts)
        key, k_act, k_random, k_env, k_learn = jax.random.split(ts.key, 5)
        alpha = jnp.exp(ts.log_alpha)

        # ACT: the policy's sample, or uniform before learning starts.
        sampled, _ = actor.apply(ts.acting(), ts.obs, k_act)
        uniform = jax.random.uniform(k_random, sampled.shape, jnp.float32, -1.0, 1.0)
        action = jnp.where(ts.step < s.learning_starts, uniform, sampled)
        max_q = jnp.min(critic.apply(ts.critic, ts.obs, action), axis=0)

        # STEP every environment; file the finished episodes (PQN's numbering).
        env_params = ts.hyper.env_params(base_params, ts.bank)
        stepped = jax.vmap(env.step, in_axes=(0, 0, 0, None))
        obs, env_state, reward, terminated, truncated, info = stepped(
            jax.random.split(k_env, envs), ts.env_state, action, env_params
        )
        done = terminated | truncated
        explore = jnp.full(envs, alpha)
        metrics, episode = file_episodes(
            ts.metrics, ts.episode, run, reward, info["goal_reached"], terminated, done,
            explore, limit, slots, env.attempt_limit,
        )  # fmt: skip

        # STORE the step's transitions in the ring (a finished run writes nothing: its
        # rows fall outside the ring and are dropped, so the ring is never copied).
        m = ts.memory
        rows = jnp.where(run, (m.cursor + jnp.arange(envs)) % capacity, capacity)
        memory = m.replace(
            obs=m.obs.at[rows].set(ts.obs, mode="drop"),
            action=m.action.at[rows].set(action, mode="drop"),
            reward=m.reward.at[rows].set(reward, mode="drop"),
            next_obs=m.next_obs.at[rows].set(info["final_obs"], mode="drop"),
            terminated=m.terminated.at[rows].set(terminated, mode="drop"),
            filled=jnp.where(run, jnp.minimum(m.filled + envs, capacity), m.filled),
            cursor=jnp.where(run, (m.cursor + envs) % capacity, m.cursor),
        )

        # LEARN: sac.updates gradient steps, once learning has started.
        n_steps = ts.step + envs
        learner = Learner(
            ts.acting(),
            ts.params,
            ts.critic,
            ts.target_critic,
            ts.log_alpha,
            ts.actor_opt,
            ts.critic_opt,
            ts.alpha_opt,
        )

        def gradient_step(carry, k):
            lr, ok = carry
            new, loss, finite = learn(lr, memory, k)
            return (select(finite & ok, new, lr), ok & finite), loss

        (learned, ok), losses = jax.lax.scan(
            gradient_step, (learner, jnp.asarray(True)), jax.random.split(k_learn, s.updates)
        )
        learning = run & (n_steps >= s.learning_starts)
        learner = select(learning, learned, learner)
        diverged = (ts.diverged_at < 0) & learning & ~ok
        held = ts.replace(
            params=learner.average,
            actor=learner.actor if s.actor_average > 0 else None,
            critic=learner.critic,
            target_critic=learner.target,
            log_alpha=learner.log_alpha,
            actor_opt=learner.actor_opt,
            critic_opt=learner.critic_opt,
            alpha_opt=learner.alpha_opt,
            memory=memory,
            env_state=select(run, env_state, ts.env_state),
            obs=select(run, obs, ts.obs),
            key=select(run, key, ts.key),
            step=jnp.where(run, n_steps, ts.step),
            episode=jnp.where(run, episode, ts.episode),
            metrics=select(run, metrics, ts.metrics),
            diverged_at=jnp.where(diverged, n_steps, ts.diverged_at),
            bank=env.refreshed_bank(ts.bank, ts.key, ts.step, jnp.where(run, n_steps, ts.step)),
        )
        nan = jnp.float32(jnp.nan)
        loss = jnp.where(learning, jnp.mean(losses), nan)
        log = StepLog(
            explore=jnp.where(run, explore, nan),
            loss=jnp.full(envs, nan).at[-1].set(loss),
            max_q=jnp.where(run, max_q, nan),
        )
        return held, log

    # Up to chunk_length env steps (whole steps of every environment), logged as PQN's.
    chunk = update_chunk(step, envs, per_chunk)

    return Trainer(env, base_params, slots, init, step, chunk, active, envs, length)


__all__ = [
    "ACTION_SIZE",
    "Actor",
    "Critic",
    "Learner",
    "Memory",
    "SACState",
    "TwinCritic",
    "critic_of",
    "make_learner",
    "make_trainer",
    "network_of",
    "soft_target",
    "split_torso",
    "squashed_sample",
    "temperature_loss",
    "trained_part",
    "with_torso",
]
