"""SAC's run in the trainer shape DQN and PQN share: ``init``, ``step`` (one step of
every environment, then the gradient steps), ``chunk`` and ``active``."""

from __future__ import annotations

from typing import Any

import chex
import jax
import jax.numpy as jnp
from flax import struct

from jaxnav.agent.episodes import Episodes
from jaxnav.agent.hyper import Hyper
from jaxnav.agent.trainer import (
    StepLog,
    Trainer,
    file_episodes,
    run_limits,
    select,
    still_training,
    update_chunk,
)
from jaxnav.core.agent_settings import sac_capacity
from jaxnav.core.config import Config
from jaxnav.env import EnvState, bank_key, from_config
from jaxnav.sac.learner import (
    Learner,
    Memory,
    make_learner,
    optimizers,
    temperature_optimizer,
)
from jaxnav.sac.networks import (
    ACTION_SIZE,
    critic_of,
    network_of,
    split_torso,
    trained_part,
    with_torso,
)


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


def _steps_per_chunk(config: Config) -> int:
    """Steps of all environments per chunk: as many as fit in ``run.chunk_steps``."""
    return max(1, config.run.chunk_steps // config.sac.num_envs)


def make_trainer(config: Config) -> Trainer:
    """The SAC run of a config as pure ``init(key, strategy, hyper)``, ``step`` (one
    step of every environment, then ``sac.updates`` gradient steps, the actor's in every
    ``sac.actor_every``-th), ``chunk`` and
    ``active``, driven by the host loop as DQN and PQN are."""
    env, base_params = from_config(config, prepare=False)
    budget = config.total_steps or 1  # env steps: the pace curriculum's span
    s = config.sac
    envs = s.num_envs
    actor, critic = network_of(config, env), critic_of(config, env)
    actor_optimizer, critic_optimizer = optimizers(config)
    learn = make_learner(config, env)
    every = s.actor_every
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
            done=jnp.zeros((capacity,), bool) if s.n_step > 1 else None,
        )
        return SACState(
            params=params,
            critic=critic_params,
            target_critic=critic_params,
            log_alpha=log_alpha,
            actor_opt=actor_optimizer.init(trained_part(config, params)),
            critic_opt=critic_optimizer.init(critic_params),
            alpha_opt=temperature_optimizer(config).init(log_alpha),
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
        env_params = env.at_progress(ts.hyper.env_params(base_params, ts.bank), ts.step / budget)
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
            done=None if m.done is None else m.done.at[rows].set(done, mode="drop"),
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

        def gradient_steps(carry, keys):
            """sac.actor_every gradient steps, the actor's and temperature's in the last."""
            lr, ok = carry
            losses = []
            for i in range(every):
                new, loss, finite = learn(lr, memory, keys[i], actor_step=i == every - 1)
                lr, ok = select(finite & ok, new, lr), ok & finite
                losses.append(loss)
            return (lr, ok), jnp.stack(losses)

        keys = jax.random.split(k_learn, s.updates)
        (learned, ok), losses = jax.lax.scan(
            gradient_steps,
            (learner, jnp.asarray(True)),
            keys.reshape((s.updates // every, every) + keys.shape[1:]),
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
