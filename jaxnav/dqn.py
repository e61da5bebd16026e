"""DQN with entropy-based or epsilon-greedy exploration, as one compiled program.

One ``lax.scan`` step does everything for one environment step of one run: act,
step the environment, store the transition, sample a batch, take one gradient
step and sync the target network. ``jax.vmap`` runs many seeds and both
exploration strategies (a strategy index in the carry) in the same call. The replay
memory is :mod:`jaxnav.agent.replay`.

Paper equations in one place each:

* Q-network (Table 2): :class:`QNetwork`.
* TD target ``y = r + gamma * max_b Q(s', b; theta^-)``, squared error: :func:`td_loss`.
* EBE (Sec. 5), epsilon-greedy and Boltzmann exploration: :mod:`jaxnav.agent.exploration`.
  The trainer acts through the run's registered strategy
  (:mod:`jaxnav.core.strategies`, :func:`jaxnav.agent.exploration.explore_action`).

Beyond the paper, each off by default (``dqn.*``; off is the paper's agent): double
DQN (:func:`td_target`'s ``next_q_online``), the dueling head (:func:`dueling_q`),
Polyak target updates (:func:`soft_update`), the Huber loss, Adam
(:func:`optimizer_of`) and n-step returns
(:func:`jaxnav.agent.replay.sample_n_step`). Each picks its code in Python from the
static config, so a switch that is off leaves the compiled program as it was.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, NamedTuple

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from jaxnav.agent import replay
from jaxnav.agent.episodes import Episodes
from jaxnav.agent.exploration import explore_action
from jaxnav.agent.hyper import (
    Hyper,
    arm_hypers,
    stack,
)
from jaxnav.agent.replay import Buffer
from jaxnav.agent.sharding import any_run
from jaxnav.core import strategies as registry
from jaxnav.core.config import Config, DQNConfig
from jaxnav.env import EnvParams, EnvState, NavEnv, bank_key, from_config

# ----------------------------------------------------------------------------
# Network
# ----------------------------------------------------------------------------


class QNetwork(nn.Module):
    """Paper Table 2: Dense 64 ReLU, Dense 64 ReLU, Dropout 0.2, Dense |A| linear.

    ``dueling`` (Wang et al. 2016) replaces the last layer by two linear streams on
    the same hidden features, a value ``value`` (1 output) and an advantage
    ``advantage`` (|A| outputs), joined by :func:`dueling_q`. ``layer_norm`` (PQN,
    Gallici et al. 2024) normalises each hidden layer before its ReLU.
    """

    num_actions: int = 5
    hidden: tuple[int, ...] = (64, 64)
    dropout: float = 0.2
    dueling: bool = False
    layer_norm: bool = False

    @nn.compact
    def __call__(self, obs: chex.Array, train: bool = False, dropout=None) -> chex.Array:
        """``dropout``: the rate as data (f32[]); None takes ``self.dropout``."""
        x = obs
        init = nn.initializers.lecun_uniform()  # ROBOTIS' Keras initialiser
        for width in self.hidden:
            x = nn.Dense(width, kernel_init=init)(x)
            if self.layer_norm:
                x = nn.LayerNorm()(x)
            x = nn.relu(x)
        if train and (dropout is not None or self.dropout > 0.0):
            rate = self.dropout if dropout is None else dropout
            x = dropout16(self.make_rng("dropout"), x, rate)
        if not self.dueling:
            return nn.Dense(self.num_actions, kernel_init=init)(x)
        value = nn.Dense(1, kernel_init=init, name="value")(x)
        advantage = nn.Dense(self.num_actions, kernel_init=init, name="advantage")(x)
        return dueling_q(value, advantage)


def dueling_q(value: chex.Array, advantage: chex.Array) -> chex.Array:
    """Q = V + A - mean_a A (Wang et al. 2016, eq. 9): ``value`` f32[..., 1],
    ``advantage`` f32[..., A] -> f32[..., A]."""
    return value + advantage - jnp.mean(advantage, axis=-1, keepdims=True)


def network_of(config: Config, env: NavEnv | None = None) -> QNetwork:
    """The Q-network of a config's runs (``env``: its environment, if already made);
    PQN's has LayerNorm."""
    env = from_config(config)[0] if env is None else env
    d = config.dqn
    return QNetwork(env.num_actions, tuple(d.hidden), d.dropout, d.dueling, d.agent == "pqn")


def dropout16(key: chex.PRNGKey, x: chex.Array, rate) -> chex.Array:
    """Inverted dropout whose mask takes 16 random bits per unit, two per 32-bit draw.

    A unit is dropped when its 16 bits fall below round(rate * 2^16), so the rate is
    quantised to 1/65536 (0.2 -> 0.199997). Half the random bits of
    ``flax.linen.Dropout``: the mask is a large share of a small network's step.
    ``rate`` may be data; rate 0 keeps every unit unchanged.
    """
    n = x.size
    words = jax.random.bits(key, ((n + 1) // 2,), jnp.uint32)
    halves = jnp.stack([words & 0xFFFF, words >> 16], axis=-1).reshape(-1)[:n]
    rate = jnp.asarray(rate, jnp.float32)
    threshold = jnp.round(rate * 65536).astype(jnp.uint32)
    keep = halves.reshape(x.shape) >= threshold
    return jnp.where(keep, x / (1.0 - rate), 0.0)


# ----------------------------------------------------------------------------
# TD loss
# ----------------------------------------------------------------------------


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


# ----------------------------------------------------------------------------
# Training state
# ----------------------------------------------------------------------------


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


@struct.dataclass
class TrainState:
    params: chex.ArrayTree
    target_params: chex.ArrayTree
    opt_state: chex.ArrayTree
    buffer: Buffer
    env_state: EnvState
    obs: chex.Array
    key: chex.PRNGKey
    strategy: chex.Array  # i32[] registered strategy number (jaxnav.core.strategies.index)
    hyper: Hyper  # the run's settings that are data (a sweep point's values)
    step: chex.Array  # i32[] env steps taken
    episode: chex.Array  # i32[] episodes finished
    metrics: Episodes  # the run's finished episodes and the one being played
    # i32[] the env step at which the run's loss, Q-values or new parameters were first
    # not finite; -1 while all are. A diverged run is frozen with its last finite
    # parameters (the update that would have broken them is not applied).
    diverged_at: chex.Array
    bank: Any = None  # the run's layouts drawn ahead (env.maze_bank), else None


class StepLog(NamedTuple):
    """What one step reports besides the state, each f32[] (f32[chunk_steps] from a
    chunk); NaN where there is nothing to report."""

    explore: chex.Array  # the strategy's exploration; NaN once the run has finished
    loss: chex.Array  # the TD loss of the step's gradient step; NaN when none was taken
    max_q: chex.Array  # max_a Q(s, a) at the acting state; NaN once the run has finished


class Trainer(NamedTuple):
    """The pieces of a run. ``init`` and ``chunk`` are pure; vmap them over runs.
    ``step`` is ``chunk``'s loop body, one environment step of one run (tests and
    benchmarks call it alone); :func:`network_of` gives the run's Q-network.
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


# ----------------------------------------------------------------------------
# The trainer: make_trainer's step calls one helper per section.
# ----------------------------------------------------------------------------


def make_trainer(config: Config) -> Trainer:
    """The run of a config as pure ``init(key, strategy, hyper)``, ``step``, ``chunk``,
    ``active``; the settings of :class:`Hyper` are read from the run's state, so the
    runs of a sweep (:func:`run_inputs`) share the program."""
    env, base_params = from_config(config)
    d = config.dqn
    network = network_of(config, env)
    decay = lr_decay_steps(config)
    optimizer = optimizer_of(d, d.optimizer, decay)  # the state's layout; a step uses the run's
    slots = config.episodes if config.episodes is not None else config.run.chunk_steps
    limits = run_limits(config)

    def init(key: chex.PRNGKey, strategy: chex.Array, hyper: Hyper) -> TrainState:
        buffer = replay.init(
            config.buffer_capacity, env.obs_size, base_params.max_steps, d.prioritised
        )
        env_params = env.with_bank(hyper.env_params(base_params), bank_key(key))
        return _init_state(env, env_params, network, optimizer, buffer, slots, key, strategy, hyper)

    def active(ts: TrainState) -> chex.Array:
        return still_training(ts.episode, ts.step, *limits) & (ts.diverged_at < 0)

    def step(ts: TrainState, _):
        run = active(ts)
        h = ts.hyper
        env_params = h.env_params(base_params, ts.bank)
        # Each part is a named scope: the compiled program's operations carry its name
        # (bench/profile_train.py sums the time per part).
        with jax.named_scope("keys"):
            key, k_act, k_env, k_sample, k_drop = jax.random.split(ts.key, 5)

        # ACT: the run's strategy explores (its number picks its registered act).
        with jax.named_scope("act"):
            action, explore, q_finite, max_q = _act(network, config, ts, k_act)

        # STEP ENV (auto-resets to the start pose after a collision or truncation).
        with jax.named_scope("env_step"):
            obs, env_state, reward, terminated, truncated, info = env.step(
                k_env, ts.env_state, action, env_params
            )
        done = terminated | truncated

        # STORE
        with jax.named_scope("replay_add"):
            buffer = replay.add(
                ts.buffer, ts.obs, action, reward, terminated, truncated, info["final_obs"], run
            )

        # LEARN: one gradient step per environment step once learning has started.
        n_steps = ts.step + 1
        with jax.named_scope("learn"):
            params, opt_state, broke, loss, buffer = _learn(
                network,
                d,
                ts,
                buffer,
                n_steps,
                run,
                (k_sample, k_drop),
                config.max_total_steps,
                decay,
            )
        diverged = (ts.diverged_at < 0) & run & (broke | ~q_finite)
        diverged_at = jnp.where(diverged, n_steps, ts.diverged_at)

        # TARGET SYNC (or, with dqn.tau < 1, a Polyak step every env step)
        target_params = _target(d, h, ts.target_params, params, run, n_steps, done)

        # EPISODE METRICS: a finished run files nothing (its slot is out of range), so
        # only the running sums are held; a select over the rings would copy them.
        slot = jnp.where(run & done, ts.episode % slots, slots)  # out of range: not filed
        metrics = ts.metrics.record(
            slot, reward, info["goal_reached"], terminated, done, explore, env.attempt_limit
        )
        held_sums = {k: _select(run, getattr(metrics, k), getattr(ts.metrics, k)) for k in _RUNNING}
        metrics = metrics.replace(**held_sums)

        # A finished run is held still: params, optimiser, target, buffer and episode
        # rings were masked above; the rest is small.
        held = _where_running(
            run,
            ts,
            env_state=env_state,
            obs=obs,
            key=key,
            step=n_steps,
            episode=ts.episode + done.astype(jnp.int32),
        ).replace(
            params=params,
            target_params=target_params,
            opt_state=opt_state,
            buffer=buffer,
            metrics=metrics,
            diverged_at=diverged_at,
        )
        log = StepLog(
            explore=jnp.where(run, explore, jnp.nan),
            loss=loss,
            max_q=jnp.where(run, max_q, jnp.nan),
        )
        return held, log

    def chunk(ts: TrainState, n_steps: chex.Array | None = None):
        """Up to ``run.chunk_steps`` env steps of one run in one compiled loop.

        ``n_steps`` (i32[], the same for every run under vmap) ends the loop early: the
        host passes the most steps any run can still take, so the last chunk (or all of
        a short run) does not step runs that have finished to the chunk's end.
        Returns (state, :class:`StepLog` of f32[chunk_steps] per step, NaN where no
        step was taken)."""
        length = config.run.chunk_steps
        n = length if n_steps is None else jnp.minimum(n_steps, length)

        def body(i, carry):
            ts, logs = carry
            ts, log = step(ts, None)
            return ts, jax.tree.map(lambda a, x: a.at[i].set(x), logs, log)

        logs = StepLog(*(jnp.full(length, jnp.nan, jnp.float32) for _ in StepLog._fields))
        return jax.lax.fori_loop(0, n, body, (ts, logs))

    return Trainer(env, base_params, slots, init, step, chunk, active, 1, config.run.chunk_steps)


def _init_state(
    env, env_params, network, optimizer, buffer, slots, key, strategy, hyper
) -> TrainState:
    """A fresh run: network from the first key, first episode from the second."""
    k_net, k_env, k_run = jax.random.split(key, 3)
    obs, env_state = env.reset(k_env, env_params)
    params = network.init(k_net, obs)
    return TrainState(
        params=params,
        target_params=params,
        opt_state=optimizer.init(params),
        buffer=buffer,
        env_state=env_state,
        obs=obs,
        key=k_run,
        strategy=jnp.asarray(strategy, jnp.int32),
        hyper=hyper,
        step=jnp.zeros((), jnp.int32),
        episode=jnp.zeros((), jnp.int32),
        metrics=Episodes.zeros(slots, attempts=bool(env.attempt_limit)),
        diverged_at=jnp.asarray(-1, jnp.int32),
        bank=env_params.bank,
    )


def _act(network: QNetwork, config: Config, ts: TrainState, key: chex.PRNGKey):
    """(action i32[], exploration f32[], whether the Q-values are finite, max Q f32[])
    of the run's strategy at ``ts.obs``."""
    q = network.apply(ts.params, ts.obs)
    action, prob = explore_action(ts.strategy, key, q, ts.episode, ts.hyper, config.strategies)
    return action, prob, jnp.all(jnp.isfinite(q)), jnp.max(q)


def _loss(
    network: QNetwork,
    h: Hyper,
    params,
    target_params,
    batch: replay.Batch,
    key,
    *,
    double=False,
    kind="mse",
    weights=None,
):
    """The TD loss of a batch; ``double`` (bool, or bool[] data: both targets, one
    kept) and ``kind`` (:func:`td_loss`) are the run's dqn.double and dqn.loss. With
    ``weights`` (prioritised replay's importance weights, f32[B]): (the weighted loss,
    the TD errors f32[B] for the new priorities)."""
    q = network.apply(params, batch.obs, train=True, dropout=h.dropout, rngs={"dropout": key})
    next_q = network.apply(target_params, batch.next_obs)  # dropout off, as Keras predict
    gamma = h.gamma if batch.discount is None else batch.discount  # n-step: gamma^k
    y = None
    if double is not True:  # False, or data (bool[]): the plain target
        y = td_target(batch.reward, batch.terminated, next_q, gamma)
    if double is not False:  # the online network picks the next action, dropout off
        online = network.apply(jax.lax.stop_gradient(params), batch.next_obs)
        y_double = td_target(batch.reward, batch.terminated, next_q, gamma, online)
        y = y_double if y is None else jnp.where(double, y_double, y)
    if weights is None:
        return td_loss(q, batch.action, y, kind)
    q_a = jnp.take_along_axis(q, batch.action[:, None], axis=-1)[:, 0]
    return td_loss(q, batch.action, y, kind, weights), jax.lax.stop_gradient(q_a - y)


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


def _learn(
    network, d: DQNConfig, ts, buffer, n_steps, run, keys, horizon: int, decay: int | None = None
):
    """(params, opt_state, broke, loss, buffer) after one gradient step, unchanged before
    learning starts and where the loss or the new parameters would not be finite
    (``broke``); ``loss`` is NaN where no gradient step was due. ``keys``: (sample,
    dropout). With prioritised replay the batch's slots get their new priorities, and
    beta goes from dqn.per_beta to 1 over ``horizon`` env steps (the run's most)."""
    h = ts.hyper
    k_sample, k_drop = keys
    idx = weights = None
    with jax.named_scope("replay_sample"):
        if d.prioritised:
            beta = d.per_beta + (1.0 - d.per_beta) * jnp.minimum(n_steps / horizon, 1.0)
            idx, weights = replay.sample_prioritised(buffer, k_sample, d.batch_size, beta)
            if d.n_step > 1:
                batch = replay.n_step_batch(buffer, idx, d.n_step, h.gamma)
            else:
                batch = replay.batch_at(buffer, idx)
        elif d.n_step > 1:
            batch = replay.sample_n_step(buffer, k_sample, d.batch_size, d.n_step, h.gamma)
        else:
            batch = replay.sample(buffer, k_sample, d.batch_size)
    bootstrap = ts.target_params
    if d.target_update != "periodic":  # ROBOTIS: online net gives the targets during warm-up
        bootstrap = jax.tree.map(
            lambda o, t: jnp.where(n_steps <= h.target_update_every, o, t),
            ts.params,
            ts.target_params,
        )
    double = d.double if h.double is None else h.double  # swept: the run's, as data
    kind = d.loss if h.loss is None else h.loss
    loss_fn = functools.partial(_loss, network, h, double=double, kind=kind, weights=weights)
    if weights is None:
        loss, grads = jax.value_and_grad(loss_fn)(ts.params, bootstrap, batch, k_drop)
    else:
        grad_fn = jax.value_and_grad(loss_fn, has_aux=True)
        (loss, td_error), grads = grad_fn(ts.params, bootstrap, batch, k_drop)
    updates, opt_state = optimizer_of(h, d.optimizer, decay).update(grads, ts.opt_state, ts.params)
    new_params = optax.apply_updates(ts.params, updates)
    finite = jnp.isfinite(loss) & all_finite(new_params)
    due = run & replay.can_sample(buffer, h.learning_starts)
    learn = due & finite
    params = _select(learn, new_params, ts.params)
    opt_state = _select(learn, opt_state, ts.opt_state)
    if d.prioritised:
        buffer = replay.update_priorities(buffer, idx, td_error, d.per_alpha, d.per_eps, learn)
    return params, opt_state, due & ~finite, jnp.where(due, loss, jnp.nan), buffer


def all_finite(tree) -> chex.Array:
    """bool[]: every element of every leaf is finite."""
    return jnp.all(jnp.stack([jnp.all(jnp.isfinite(leaf)) for leaf in jax.tree.leaves(tree)]))


def _target(d: DQNConfig, h: Hyper, target_params, params, run, n_steps, done):
    """The target network after a step: a copy when a sync is due (tau 1, the
    paper's), or tau of the way to the online network every step (tau < 1). A swept
    tau is data: both are computed and the run's tau picks one. Under ROBOTIS'
    episode_end rule with tau < 1 the Polyak step replaces the episode-end copy; the
    online network still gives the targets during the warm-up."""
    tau = d.tau if h.tau is None else h.tau
    static = isinstance(tau, (int, float))

    def copied():
        due = run & _target_sync_due(d, h, n_steps, done)
        if d.target_update != "periodic":
            return _select(due, params, target_params)
        # Due once in target_update_every steps: the copy is skipped, not selected away,
        # on the steps where no run of the batch is due.
        return jax.lax.cond(
            any_run(due), lambda: _select(due, params, target_params), lambda: target_params
        )

    if static and tau >= 1.0:
        return copied()
    polyak = _select(run, soft_update(params, target_params, tau), target_params)
    if static:
        return polyak
    return _select(tau < 1.0, polyak, copied())


def _target_sync_due(d: DQNConfig, h: Hyper, n_steps: chex.Array, done: chex.Array):
    """Paper: every target_update_every steps. ROBOTIS: at every episode end (during
    the warm-up too, so the first target the network bootstraps from after it is the
    last episode's copy, never the initial network)."""
    if d.target_update == "periodic":
        return n_steps % h.target_update_every == 0
    return done


def _select(pred, a, b):
    return jax.tree.map(lambda x, y: jnp.where(pred, x, y), a, b)


def _where_running(run: chex.Array, ts: TrainState, **new) -> TrainState:
    """``ts`` with the fields ``new`` where the run is active, unchanged where finished."""
    return ts.replace(**{k: _select(run, v, getattr(ts, k)) for k, v in new.items()})


# The running sums of Episodes, the fields a finished run's step would still change.
_RUNNING = (
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
) -> Callable[[chex.PRNGKey, chex.Array, Hyper], TrainState]:
    """A pure ``train(key, strategy, hyper) -> TrainState`` that runs one seed to the end.

    Built on the same :class:`Trainer` as ``jaxnav.train``: chunks until inactive.
    ``jax.jit(jax.vmap(make_train(cfg)))(*run_inputs(cfg))`` trains every seed,
    strategy and sweep point of the config in one compiled program. ``trainer``: another
    agent's (``jaxnav.pqn.make_trainer(cfg)``); default this module's DQN.
    """
    trainer = make_trainer(config) if trainer is None else trainer

    def train(key: chex.PRNGKey, strategy: chex.Array, hyper: Hyper) -> TrainState:
        ts = trainer.init(key, strategy, hyper)
        return jax.lax.while_loop(trainer.active, lambda s: trainer.chunk(s)[0], ts)

    return train
