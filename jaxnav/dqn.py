"""DQN with entropy-based or epsilon-greedy exploration, as one compiled program.

One ``lax.scan`` step does everything for one environment step of one run: act,
step the environment, store the transition, sample a batch, take one gradient
step and sync the target network. ``jax.vmap`` runs many seeds and both
exploration strategies (a strategy index in the carry) in the same call. The replay
memory is :mod:`jaxnav.agent.replay`.

Paper equations in one place each:

* Q-network (Table 2): :class:`jaxnav.agent.networks.QNetwork`.
* TD target ``y = r + gamma * max_b Q(s', b; theta^-)``, squared error:
  :func:`jaxnav.agent.qlearning.td_target`, :func:`jaxnav.agent.qlearning.td_loss`.
* EBE (Sec. 5), epsilon-greedy and Boltzmann exploration: :mod:`jaxnav.agent.exploration`.
  The trainer acts through the run's registered strategy
  (:mod:`jaxnav.core.strategies`, :func:`jaxnav.agent.exploration.explore_action`).

Beyond the paper, each off by default (``dqn.*``; off is the paper's agent): double
DQN (``td_target``'s ``next_q_online``), the dueling head (``dueling_q``), Polyak
target updates (``soft_update``), the Huber loss, Adam (``optimizer_of``) and n-step
returns
(:func:`jaxnav.agent.replay.sample_n_step`). Each picks its code in Python from the
static config, so a switch that is off leaves the compiled program as it was.
"""

from __future__ import annotations

import functools
from typing import Any

import chex
import jax
import jax.numpy as jnp
import optax
from flax import struct

from jaxnav.agent import noisy, replay
from jaxnav.agent.episodes import Episodes
from jaxnav.agent.exploration import explore_action
from jaxnav.agent.hyper import Hyper
from jaxnav.agent.networks import QNetwork
from jaxnav.agent.qlearning import lr_decay_steps, optimizer_of, soft_update, td_loss, td_target
from jaxnav.agent.replay import Buffer
from jaxnav.agent.sharding import any_run
from jaxnav.agent.trainer import (
    RUNNING,
    StepLog,
    Trainer,
    all_finite,
    run_limits,
    select,
    step_chunk,
    still_training,
)
from jaxnav.core import strategies as registry
from jaxnav.core.config import Config, DQNConfig
from jaxnav.env import EnvState, NavEnv, bank_key, from_config


def network_of(config: Config, env: NavEnv | None = None) -> QNetwork:
    """DQN's Q-network of a config's runs (``env``: its environment, if already made),
    its layers noisy where a strategy of the config explores by noise (NoisyNets)."""
    env = from_config(config, prepare=False)[0] if env is None else env
    d = config.dqn
    conv = {"scan_conv": tuple(d.scan_conv), "scan_layout": env.scan_layout}
    noisy = {"noisy": True, "noisy_sigma": config.exploration.noisy_sigma}
    more = noisy if registry.noisy_of(config.strategies) else {}
    return QNetwork(env.num_actions, tuple(d.hidden), d.dropout, d.dueling, **conv, **more)


NOISE_SALT = 3  # a key folded with this (and the next two) draws a noisy network's noise


def noise_switch(config: Config, strategy: chex.Array) -> chex.Array | None:
    """A run's noise switch (f32[]: 1 in a NoisyNets run, 0 in the others), None where
    no strategy of the config is noisy."""
    noisy = registry.noisy_of(config.strategies)
    if not noisy:
        return None
    return (strategy == registry.index(noisy[0])).astype(jnp.float32)


# ----------------------------------------------------------------------------
# Training state
# ----------------------------------------------------------------------------


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


# ----------------------------------------------------------------------------
# The trainer: make_trainer's step calls one helper per section.
# ----------------------------------------------------------------------------


def make_trainer(config: Config) -> Trainer:
    """The run of a config as pure ``init(key, strategy, hyper)``, ``step``, ``chunk``,
    ``active``; the settings of :class:`Hyper` are read from the run's state, so the
    runs of a sweep (:func:`run_inputs`) share the program."""
    env, base_params = from_config(config, prepare=False)
    budget = config.total_steps or 1  # env steps: the pace curriculum's span
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
        env_params = env.at_progress(h.env_params(base_params, ts.bank), ts.step / budget)
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
                noise_switch(config, ts.strategy),
            )
        diverged = (ts.diverged_at < 0) & run & (broke | ~q_finite)
        diverged_at = jnp.where(diverged, n_steps, ts.diverged_at)

        # TARGET SYNC (or, with dqn.tau < 1, a Polyak step every env step)
        target_params = _target(d, h, ts.target_params, params, run, n_steps, done)

        # EPISODE METRICS: a finished run files nothing (its slot is out of range), so
        # only the running sums are held; a select over the rings would copy them.
        slot = jnp.where(run & done, ts.episode % slots, slots)  # out of range: not filed
        metrics = ts.metrics.record(
            slot, reward, info["goal_reached"], info["collision"], done, explore, env.attempt_limit
        )
        held_sums = {k: select(run, getattr(metrics, k), getattr(ts.metrics, k)) for k in RUNNING}
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
            bank=env.refreshed_bank(ts.bank, ts.key, ts.step, jnp.where(run, n_steps, ts.step)),
        )
        log = StepLog(
            explore=jnp.where(run, explore, jnp.nan),
            loss=loss,
            max_q=jnp.where(run, max_q, jnp.nan),
        )
        return held, log

    chunk = step_chunk(step, config.run.chunk_steps)
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
    switch = noise_switch(config, ts.strategy)
    if switch is None:
        q = network.apply(ts.params, ts.obs)
    else:
        rngs = {"noise": jax.random.fold_in(key, NOISE_SALT)}
        q = network.apply(ts.params, ts.obs, noise=switch, rngs=rngs)
    action, prob = explore_action(ts.strategy, key, q, ts.episode, ts.hyper, config.strategies)
    return action, prob, jnp.all(jnp.isfinite(q)), jnp.max(q)


def batch_loss(
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
    noise=None,
):
    """The TD loss of a batch; ``double`` (bool, or bool[] data: both targets, one
    kept) and ``kind`` (:func:`td_loss`) are the run's dqn.double and dqn.loss. With
    ``weights`` (prioritised replay's importance weights, f32[B]): (the weighted loss,
    the TD errors f32[B] for the new priorities). ``noise``: a noisy network's switch of
    the run (None: none); the online and target networks draw their own noise, one draw
    for the batch (NoisyNet-DQN's one per optimisation step)."""

    def with_noise(variables, salt: int) -> tuple[dict, dict]:
        """(``variables`` with one draw of the noise for the batch, the switch)."""
        if noise is None:
            return variables, {}
        k = jax.random.fold_in(key, NOISE_SALT + salt)
        drawn = noisy.draw(network, jax.lax.stop_gradient(variables), batch.obs[0], noise, k)
        return noisy.with_draw(variables, drawn), {"noise": noise}

    online_vars, extra = with_noise(params, 0)
    rngs = {"dropout": key}
    q = network.apply(online_vars, batch.obs, train=True, dropout=h.dropout, rngs=rngs, **extra)
    target_vars, extra = with_noise(target_params, 1)
    next_q = network.apply(target_vars, batch.next_obs, **extra)  # dropout off (Keras)
    gamma = h.gamma if batch.discount is None else batch.discount  # n-step: gamma^k
    y = None
    if double is not True:  # False, or data (bool[]): the plain target
        y = td_target(batch.reward, batch.terminated, next_q, gamma)
    if double is not False:  # the online network picks the next action, dropout off
        online_vars, extra = with_noise(jax.lax.stop_gradient(params), 2)
        online = network.apply(online_vars, batch.next_obs, **extra)
        y_double = td_target(batch.reward, batch.terminated, next_q, gamma, online)
        y = y_double if y is None else jnp.where(double, y_double, y)
    if weights is None:
        return td_loss(q, batch.action, y, kind)
    q_a = jnp.take_along_axis(q, batch.action[:, None], axis=-1)[:, 0]
    return td_loss(q, batch.action, y, kind, weights), jax.lax.stop_gradient(q_a - y)


def _learn(
    network,
    d: DQNConfig,
    ts,
    buffer,
    n_steps,
    run,
    keys,
    horizon: int,
    decay: int | None = None,
    noise=None,
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
    loss_fn = functools.partial(
        batch_loss, network, h, double=double, kind=kind, weights=weights, noise=noise
    )
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
    params = select(learn, new_params, ts.params)
    opt_state = select(learn, opt_state, ts.opt_state)
    if d.prioritised:
        buffer = replay.update_priorities(buffer, idx, td_error, d.per_alpha, d.per_eps, learn)
    return params, opt_state, due & ~finite, jnp.where(due, loss, jnp.nan), buffer


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
            return select(due, params, target_params)
        # Due once in target_update_every steps: the copy is skipped, not selected away,
        # on the steps where no run of the batch is due.
        return jax.lax.cond(
            any_run(due), lambda: select(due, params, target_params), lambda: target_params
        )

    if static and tau >= 1.0:
        return copied()
    polyak = select(run, soft_update(params, target_params, tau), target_params)
    if static:
        return polyak
    return select(tau < 1.0, polyak, copied())


def _target_sync_due(d: DQNConfig, h: Hyper, n_steps: chex.Array, done: chex.Array):
    """Paper: every target_update_every steps. ROBOTIS: at every episode end (during
    the warm-up too, so the first target the network bootstraps from after it is the
    last episode's copy, never the initial network)."""
    if d.target_update == "periodic":
        return n_steps % h.target_update_every == 0
    return done


def _where_running(run: chex.Array, ts: TrainState, **new) -> TrainState:
    """``ts`` with the fields ``new`` where the run is active, unchanged where finished."""
    return ts.replace(**{k: select(run, v, getattr(ts, k)) for k, v in new.items()})


__all__ = ["TrainState", "batch_loss", "make_trainer", "network_of"]
