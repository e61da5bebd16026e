"""DQN with entropy-based or epsilon-greedy exploration, as one compiled program.

One ``lax.scan`` step does everything for one environment step of one run: act,
step the environment, store the transition, sample a batch, take one gradient
step and sync the target network. ``jax.vmap`` runs many seeds and both
exploration strategies (a strategy index in the carry) in the same call.

Paper equations in one place each:

* Q-network (Table 2): :class:`QNetwork`.
* TD target ``y = r + gamma * max_b Q(s', b; theta^-)``, squared error: :func:`td_loss`.
* EBE (Sec. 5): :func:`ebe`; epsilon-greedy baseline: :func:`epsilon_greedy`,
  :func:`epsilon_schedule`.
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp
import optax
from flax import struct

from jaxnav.config import STRATEGIES, Config
from jaxnav.env import EnvParams, EnvState, NavEnv, make

# ----------------------------------------------------------------------------
# Network
# ----------------------------------------------------------------------------


class QNetwork(nn.Module):
    """Paper Table 2: Dense 64 ReLU, Dense 64 ReLU, Dropout 0.2, Dense |A| linear."""

    num_actions: int = 5
    hidden: tuple[int, ...] = (64, 64)
    dropout: float = 0.2

    @nn.compact
    def __call__(self, obs: chex.Array, train: bool = False) -> chex.Array:
        x = obs
        init = nn.initializers.lecun_uniform()  # ROBOTIS' Keras initialiser
        for width in self.hidden:
            x = nn.relu(nn.Dense(width, kernel_init=init)(x))
        if train and self.dropout > 0.0:
            x = dropout16(self.make_rng("dropout"), x, self.dropout)
        return nn.Dense(self.num_actions, kernel_init=init)(x)


def dropout16(key: chex.PRNGKey, x: chex.Array, rate: float) -> chex.Array:
    """Inverted dropout whose mask takes 16 random bits per unit, two per 32-bit draw.

    A unit is dropped when its 16 bits fall below round(rate * 2^16), so the rate is
    quantised to 1/65536 (0.2 -> 0.199997). Half the random bits of
    ``flax.linen.Dropout``: the mask is a large share of a small network's step.
    """
    n = x.size
    words = jax.random.bits(key, ((n + 1) // 2,), jnp.uint32)
    halves = jnp.stack([words & 0xFFFF, words >> 16], axis=-1).reshape(-1)[:n]
    keep = halves.reshape(x.shape) >= jnp.uint32(round(rate * 65536))
    return jnp.where(keep, x / (1.0 - rate), 0.0)


# ----------------------------------------------------------------------------
# Exploration
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


def explore_or_greedy(key: chex.PRNGKey, q: chex.Array, prob: chex.Array) -> chex.Array:
    """A uniformly random action with probability ``prob``, else argmax Q."""
    k_coin, k_act = jax.random.split(key)
    explore = jax.random.uniform(k_coin) < prob
    random_action = jax.random.randint(k_act, (), 0, q.shape[-1])
    return jnp.where(explore, random_action, jnp.argmax(q, axis=-1))


def ebe(key: chex.PRNGKey, q: chex.Array, temperature: float = 1.0):
    """Entropy-based exploration: random action with probability H(s), else greedy.

    Returns (action i32[], H f32[]).
    """
    h = normalised_entropy(q, temperature)
    return explore_or_greedy(key, q, h), h


def epsilon_greedy(key: chex.PRNGKey, q: chex.Array, eps: chex.Array):
    """Random action with probability eps, else greedy. Returns (action, eps)."""
    return explore_or_greedy(key, q, eps), jnp.asarray(eps, jnp.float32)


def epsilon_schedule(episode: chex.Array, start=1.0, decay=0.99, minimum=0.05) -> chex.Array:
    """eps_i = max(decay * eps_{i-1}, minimum), eps_1 = start; ``episode`` counts from 0."""
    return jnp.maximum(start * decay ** episode.astype(jnp.float32), minimum)


# ----------------------------------------------------------------------------
# Replay memory: each observation stored once
# ----------------------------------------------------------------------------


@struct.dataclass
class Buffer:
    """Ring buffer of transitions that stores each observation once.

    Slot i holds (obs_i, action_i, reward_i, terminated_i, truncated_i). The next
    observation of slot i is obs of slot i + 1, except for the newest slot (its next
    observation is ``tail``) and for truncated slots (the observation before the
    auto-reset is kept in the small ring ``final_obs``, as truncation bootstraps).
    After a collision the next observation is never used.
    """

    obs: chex.Array  # f32[N, D]
    action: chex.Array  # u8[N]
    reward: chex.Array  # f32[N]
    terminated: chex.Array  # bool[N]
    truncated: chex.Array  # bool[N]
    final_index: chex.Array  # i32[N] row of final_obs for truncated slots
    final_obs: chex.Array  # f32[K, D]
    tail: chex.Array  # f32[D] next observation of the newest slot
    pos: chex.Array  # i32[] next slot to write
    size: chex.Array  # i32[] filled slots
    n_final: chex.Array  # i32[] truncations stored so far


class Batch(NamedTuple):
    obs: chex.Array
    action: chex.Array
    reward: chex.Array
    next_obs: chex.Array
    terminated: chex.Array


def buffer_init(capacity: int, obs_dim: int, max_steps: int) -> Buffer:
    # Every truncated episode fills max_steps slots, so at most capacity // max_steps
    # + 1 truncated slots are alive at once.
    k = capacity // max_steps + 2
    return Buffer(
        obs=jnp.zeros((capacity, obs_dim), jnp.float32),
        action=jnp.zeros((capacity,), jnp.uint8),
        reward=jnp.zeros((capacity,), jnp.float32),
        terminated=jnp.zeros((capacity,), bool),
        truncated=jnp.zeros((capacity,), bool),
        final_index=jnp.zeros((capacity,), jnp.int32),
        final_obs=jnp.zeros((k, obs_dim), jnp.float32),
        tail=jnp.zeros((obs_dim,), jnp.float32),
        pos=jnp.zeros((), jnp.int32),
        size=jnp.zeros((), jnp.int32),
        n_final=jnp.zeros((), jnp.int32),
    )


def buffer_bytes(capacity: int, obs_dim: int, max_steps: int) -> int:
    """Bytes of one run's buffer."""
    b = jax.eval_shape(lambda: buffer_init(capacity, obs_dim, max_steps))
    return sum(x.size * x.dtype.itemsize for x in jax.tree.leaves(b))


def buffer_add(
    buf: Buffer,
    obs: chex.Array,
    action: chex.Array,
    reward: chex.Array,
    terminated: chex.Array,
    truncated: chex.Array,
    next_obs: chex.Array,
    active: chex.Array = True,
) -> Buffer:
    """Store one transition; ``next_obs`` is the observation before any auto-reset.

    With ``active`` false the buffer is returned unchanged (a finished run).
    """
    n = buf.obs.shape[0]
    k = buf.final_obs.shape[0]
    p = buf.pos
    fi = buf.n_final % k

    def put(arr, i, value):
        return arr.at[i].set(jnp.where(active, value, arr[i]))

    active = jnp.asarray(active, bool)
    store_final = active & jnp.asarray(truncated, bool)
    return Buffer(
        obs=put(buf.obs, p, obs),
        action=put(buf.action, p, action.astype(jnp.uint8)),
        reward=put(buf.reward, p, reward),
        terminated=put(buf.terminated, p, terminated),
        truncated=put(buf.truncated, p, truncated),
        final_index=put(buf.final_index, p, fi),
        final_obs=buf.final_obs.at[fi].set(
            jnp.where(store_final, next_obs, buf.final_obs[fi])
        ),
        tail=jnp.where(active, next_obs, buf.tail),
        pos=jnp.where(active, (p + 1) % n, p),
        size=jnp.where(active, jnp.minimum(buf.size + 1, n), buf.size),
        n_final=buf.n_final + store_final.astype(jnp.int32),
    )


def buffer_sample(buf: Buffer, key: chex.PRNGKey, batch_size: int) -> Batch:
    """Uniform sample (with replacement) of filled slots only."""
    n = buf.obs.shape[0]
    idx = jax.random.randint(key, (batch_size,), 0, jnp.maximum(buf.size, 1))
    newest = (buf.pos - 1) % n
    following = buf.obs[(idx + 1) % n]
    final = buf.final_obs[buf.final_index[idx]]
    trunc = buf.truncated[idx]
    next_obs = jnp.where(
        (idx == newest)[:, None],
        buf.tail[None, :],
        jnp.where(trunc[:, None], final, following),
    )
    return Batch(
        obs=buf.obs[idx],
        action=buf.action[idx].astype(jnp.int32),
        reward=buf.reward[idx],
        next_obs=next_obs,
        terminated=buf.terminated[idx],
    )


# ----------------------------------------------------------------------------
# TD loss
# ----------------------------------------------------------------------------


def td_target(reward, terminated, next_q_target, gamma) -> chex.Array:
    """y = r + gamma * max_b Q(s', b; theta^-), no bootstrap after a collision.

    Truncation (the step limit) is not terminal, so it bootstraps.
    """
    return reward + gamma * (1.0 - terminated.astype(jnp.float32)) * jnp.max(next_q_target, -1)


def td_loss(q: chex.Array, action: chex.Array, target: chex.Array) -> chex.Array:
    """Mean squared TD error of the taken actions."""
    q_a = jnp.take_along_axis(q, action[:, None], axis=-1)[:, 0]
    return jnp.mean((q_a - jax.lax.stop_gradient(target)) ** 2)


# ----------------------------------------------------------------------------
# Training state
# ----------------------------------------------------------------------------


@struct.dataclass
class Metrics:
    """Per-episode metrics (a ring of ``slots`` episodes) and running sums."""

    ep_return: chex.Array  # f32[slots]
    ep_length: chex.Array  # i32[slots]
    ep_goals: chex.Array  # i32[slots]
    ep_collided: chex.Array  # bool[slots]
    ep_explore: chex.Array  # f32[slots] mean H or eps over the episode
    cur_return: chex.Array  # f32[]
    cur_length: chex.Array  # i32[]
    cur_goals: chex.Array  # i32[]
    cur_explore: chex.Array  # f32[] sum over the episode


@struct.dataclass
class TrainState:
    params: chex.ArrayTree
    target_params: chex.ArrayTree
    opt_state: chex.ArrayTree
    buffer: Buffer
    env_state: EnvState
    obs: chex.Array
    key: chex.PRNGKey
    strategy: chex.Array  # i32[] index into STRATEGIES
    step: chex.Array  # i32[] env steps taken
    episode: chex.Array  # i32[] episodes finished
    metrics: Metrics


class Trainer(NamedTuple):
    """The pieces of a run. ``init`` and ``chunk`` are pure; vmap them over runs."""

    config: Config
    env: NavEnv
    env_params: EnvParams
    network: QNetwork
    optimizer: optax.GradientTransformation
    metric_slots: int
    init: Callable[[chex.PRNGKey, chex.Array], TrainState]
    step: Callable[[TrainState, None], tuple[TrainState, chex.Array]]
    chunk: Callable[[TrainState], tuple[TrainState, chex.Array]]
    active: Callable[[TrainState], chex.Array]


def make_env(config: Config) -> tuple[NavEnv, EnvParams]:
    """The training environment of a config."""
    e = config.env
    overrides = dict(
        n_beams=e.n_beams,
        max_steps=e.max_steps,
        lidar_noise_std=e.lidar_noise_std,
        beam_dropout=e.beam_dropout,
        odom_noise=tuple(e.odom_noise),
        random_start=e.random_start,
        maze_scale=tuple(e.maze_scale),
    )
    for name in ("R_plus", "R_minus", "reward_span", "reward_distance_exp", "obstacle_obs"):
        if getattr(e, name) is not None:
            overrides[name] = getattr(e, name)
    return make(e.maze, preset=config.preset, **overrides)


def make_trainer(config: Config) -> Trainer:
    env, env_params = make_env(config)
    d, x = config.dqn, config.exploration
    network = QNetwork(env.num_actions, tuple(d.hidden), d.dropout)
    optimizer = optax.rmsprop(d.lr, decay=d.rms_decay, eps=d.rms_eps, eps_in_sqrt=False)
    capacity = config.buffer_capacity
    max_steps = env_params.max_steps
    slots = config.episodes if config.episodes is not None else config.run.chunk_steps
    episode_limit = config.episodes if config.episodes is not None else jnp.iinfo(jnp.int32).max
    step_limit = (
        config.total_steps if config.total_steps is not None else jnp.iinfo(jnp.int32).max
    )
    periodic = d.target_update == "periodic"

    def init(key: chex.PRNGKey, strategy: chex.Array) -> TrainState:
        k_net, k_env, k_run = jax.random.split(key, 3)
        obs, env_state = env.reset(k_env, env_params)
        params = network.init(k_net, obs)
        return TrainState(
            params=params,
            target_params=params,
            opt_state=optimizer.init(params),
            buffer=buffer_init(capacity, env.obs_size, max_steps),
            env_state=env_state,
            obs=obs,
            key=k_run,
            strategy=jnp.asarray(strategy, jnp.int32),
            step=jnp.zeros((), jnp.int32),
            episode=jnp.zeros((), jnp.int32),
            metrics=Metrics(
                ep_return=jnp.zeros(slots, jnp.float32),
                ep_length=jnp.zeros(slots, jnp.int32),
                ep_goals=jnp.zeros(slots, jnp.int32),
                ep_collided=jnp.zeros(slots, bool),
                ep_explore=jnp.zeros(slots, jnp.float32),
                cur_return=jnp.zeros((), jnp.float32),
                cur_length=jnp.zeros((), jnp.int32),
                cur_goals=jnp.zeros((), jnp.int32),
                cur_explore=jnp.zeros((), jnp.float32),
            ),
        )

    def active(ts: TrainState) -> chex.Array:
        return (ts.episode < episode_limit) & (ts.step < step_limit)

    def loss_fn(params, target_params, batch: Batch, key):
        q = network.apply(params, batch.obs, train=True, rngs={"dropout": key})
        next_q = network.apply(target_params, batch.next_obs)  # dropout off, as Keras predict
        y = td_target(batch.reward, batch.terminated, next_q, d.gamma)
        return td_loss(q, batch.action, y)

    def step(ts: TrainState, _):
        run = active(ts)
        key, k_act, k_env, k_sample, k_drop = jax.random.split(ts.key, 5)

        # ACT: ebe and epsilon_greedy differ only in the exploration probability
        # (H(s) or eps_i); the strategy index picks it, one draw serves both.
        q = network.apply(ts.params, ts.obs)
        h = normalised_entropy(q, x.ebe_temperature)
        eps = epsilon_schedule(ts.episode, x.eps_start, x.eps_decay, x.eps_min)
        explore = jnp.where(ts.strategy == STRATEGIES.index("ebe"), h, eps)
        action = explore_or_greedy(k_act, q, explore)

        # STEP ENV (auto-resets to the start pose after a collision or truncation).
        obs, env_state, reward, terminated, truncated, info = env.step(
            k_env, ts.env_state, action, env_params
        )
        done = terminated | truncated

        # STORE
        buffer = buffer_add(
            ts.buffer, ts.obs, action, reward, terminated, truncated, info["final_obs"], run
        )

        # LEARN: one gradient step per environment step once learning has started.
        n_steps = ts.step + 1
        batch = buffer_sample(buffer, k_sample, d.batch_size)
        bootstrap = ts.target_params
        if not periodic:  # ROBOTIS: online net gives the targets during warm-up
            bootstrap = jax.tree.map(
                lambda o, t: jnp.where(n_steps <= d.target_update_every, o, t),
                ts.params,
                ts.target_params,
            )
        loss, grads = jax.value_and_grad(loss_fn)(ts.params, bootstrap, batch, k_drop)
        updates, opt_state = optimizer.update(grads, ts.opt_state, ts.params)
        new_params = optax.apply_updates(ts.params, updates)
        learn = run & (buffer.size >= d.learning_starts)
        params = _select(learn, new_params, ts.params)
        opt_state = _select(learn, opt_state, ts.opt_state)

        # TARGET SYNC
        if periodic:
            sync = n_steps % d.target_update_every == 0
        else:
            sync = done & (n_steps > d.target_update_every)
        target_params = _select(run & sync, params, ts.target_params)

        # EPISODE METRICS
        m = ts.metrics
        cur_return = m.cur_return + reward
        cur_length = m.cur_length + 1
        cur_goals = m.cur_goals + info["goal_reached"].astype(jnp.int32)
        cur_explore = m.cur_explore + explore
        write = run & done
        i = jnp.where(write, ts.episode % slots, slots)  # out of range: dropped
        metrics = Metrics(
            ep_return=m.ep_return.at[i].set(cur_return, mode="drop"),
            ep_length=m.ep_length.at[i].set(cur_length, mode="drop"),
            ep_goals=m.ep_goals.at[i].set(cur_goals, mode="drop"),
            ep_collided=m.ep_collided.at[i].set(terminated, mode="drop"),
            ep_explore=m.ep_explore.at[i].set(cur_explore / cur_length, mode="drop"),
            cur_return=jnp.where(done, 0.0, cur_return),
            cur_length=jnp.where(done, 0, cur_length),
            cur_goals=jnp.where(done, 0, cur_goals),
            cur_explore=jnp.where(done, 0.0, cur_explore),
        )
        # A finished run is held still: params, optimiser, target and buffer were
        # masked above; the rest is small.
        held = TrainState(
            params=params,
            target_params=target_params,
            opt_state=opt_state,
            buffer=buffer,
            env_state=_select(run, env_state, ts.env_state),
            obs=jnp.where(run, obs, ts.obs),
            key=jnp.where(run, key, ts.key),
            strategy=ts.strategy,
            step=jnp.where(run, n_steps, ts.step),
            episode=jnp.where(run, ts.episode + done.astype(jnp.int32), ts.episode),
            metrics=_select(run, metrics, ts.metrics),
        )
        return held, jnp.where(run, explore, jnp.nan)

    def chunk(ts: TrainState):
        return jax.lax.scan(step, ts, None, length=config.run.chunk_steps)

    return Trainer(
        config=config,
        env=env,
        env_params=env_params,
        network=network,
        optimizer=optimizer,
        metric_slots=slots,
        init=init,
        step=step,
        chunk=chunk,
        active=active,
    )


def _select(pred, a, b):
    return jax.tree.map(lambda x, y: jnp.where(pred, x, y), a, b)


def run_keys(config: Config) -> tuple[chex.Array, chex.Array]:
    """Per-run PRNG keys and strategy indices, strategy-major.

    Run r trains strategy ``config.strategies[r // seeds]`` on seed
    ``config.seed + r % seeds``. Both strategies of one seed share the seed's key
    (same initial network and goals), so their comparison is paired.
    """
    seeds = jnp.arange(config.seeds) + config.seed
    keys = jax.vmap(jax.random.PRNGKey)(seeds)
    keys = jnp.concatenate([keys] * len(config.strategies))
    strat = jnp.repeat(
        jnp.asarray([STRATEGIES.index(s) for s in config.strategies], jnp.int32), config.seeds
    )
    return keys, strat


def make_train(config: Config) -> Callable[[chex.PRNGKey, chex.Array], TrainState]:
    """A pure ``train(key, strategy) -> TrainState`` that runs one seed to the end.

    ``jax.jit(jax.vmap(make_train(cfg)))(*run_keys(cfg))`` trains every seed and
    strategy of the config in one compiled program.
    """
    trainer = make_trainer(config)

    def train(key: chex.PRNGKey, strategy: chex.Array) -> TrainState:
        ts = trainer.init(key, strategy)
        return jax.lax.while_loop(
            trainer.active, lambda s: trainer.chunk(s)[0], ts
        )

    return train
