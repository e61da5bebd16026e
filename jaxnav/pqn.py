"""PQN, a second agent beside DQN in the same trainer shape.

PQN (Gallici et al. 2024, "Simplifying Deep Temporal Difference Learning") has no
replay memory and no target network: each run steps ``pqn.num_envs`` environments in
parallel for ``pqn.rollout`` steps (T), computes lambda-returns backwards over the
rollout from its own network's max-Q (:func:`lambda_returns`), and fits them in
``pqn.epochs`` passes of ``pqn.minibatches`` shuffled minibatches, its gradients
clipped to ``pqn.max_grad_norm``. The Q-network is the paper's with LayerNorm before
each hidden ReLU (:func:`network_of`). The run's registered strategy acts
on the Q-values of every environment, so EBE, epsilon-greedy and Boltzmann work as
with DQN.

One update (rollout, returns, learning) is the trainer's ``step``; a chunk is a loop
of updates; ``vmap`` runs seeds, strategies and sweep points, and the host loop
(:mod:`jaxnav.run.training`) drives both agents alike.

Counting (docs/training.md): ``step`` is the env steps of all of a run's
environments and ``episode`` the episodes finished by any of them, numbered in the
order they finish (environments in index order within a step); ``episodes`` and
``total_steps`` bound these totals and are checked between updates, so the last update
plays its rollout to the end (its episodes beyond the budget train the network but
are not logged). Epsilon's schedule advances with ``episode``: once per episode any
environment finishes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from jaxnav.agent import bonus, levels, noisy
from jaxnav.agent.bonus import Steps
from jaxnav.agent.episodes import Episodes
from jaxnav.agent.exploration import explore_action
from jaxnav.agent.explored import BLOCK, Explored, visited
from jaxnav.agent.hyper import Hyper
from jaxnav.agent.networks import QNetwork
from jaxnav.agent.qlearning import lr_decay_steps, optimizer_of, td_loss
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
from jaxnav.core import strategies as registry
from jaxnav.core.config import Config
from jaxnav.env import EnvParams, EnvState, NavEnv, bank_key, from_config
from jaxnav.planners.raster import (
    ORACLE_CELL,
    Raster,
    block_index,
    blocks_of,
    origin_of,
    raster_for,
)


def network_of(config: Config, env: NavEnv | None = None) -> QNetwork:
    """PQN's Q-network of a config's runs: the paper's with LayerNorm before each hidden
    ReLU (``env``: the config's environment, if already made), its layers noisy where a
    strategy of the config explores by noise (NoisyNets)."""
    env = from_config(config, prepare=False)[0] if env is None else env
    d = config.dqn
    conv = {"scan_conv": tuple(d.scan_conv), "scan_layout": env.scan_layout}
    noisy = {"noisy": True, "noisy_sigma": config.exploration.noisy_sigma}
    return QNetwork(
        env.num_actions,
        tuple(d.hidden),
        d.dropout,
        d.dueling,
        layer_norm=True,
        **conv,
        **(noisy if registry.noisy_of(config.strategies) else {}),
    )


# ----------------------------------------------------------------------------
# Lambda-returns
# ----------------------------------------------------------------------------


def lambda_returns(reward, terminated, truncated, next_value, gamma, lam) -> chex.Array:
    """PQN's targets: lambda-returns computed backwards over a rollout (Peng's Q(lambda)
    with the max-Q bootstrap),

        G_t = r_t + gamma (1 - term_t) ((1 - lam) v_t + lam G_{t+1}),

    where ``v_t = max_a Q(s'_t, a)`` of the observation after step t (before an
    auto-reset) and G_{t+1} is replaced by v_t where the episode or the rollout ends at
    t: a truncation bootstraps from its final observation, a collision (terminated)
    does not bootstrap. Each argument is [T, ...] (time first); returns f32[T, ...].
    """

    def back(g_next, x):
        r, term, trunc, v = x
        boot = jnp.where(term | trunc, v, (1.0 - lam) * v + lam * g_next)
        g = r + gamma * jnp.where(term, 0.0, boot)
        return g, g

    xs = (reward, terminated, truncated, next_value)
    _, g = jax.lax.scan(back, next_value[-1], xs, reverse=True)
    return g


# ----------------------------------------------------------------------------
# Training state
# ----------------------------------------------------------------------------


@struct.dataclass
class PQNState:
    """One PQN run. The fields the host loop reads (``params``, ``step``, ``episode``,
    ``metrics``, ``diverged_at``) mean what they mean in :class:`jaxnav.dqn.TrainState`,
    over all the run's environments."""

    params: chex.ArrayTree
    opt_state: chex.ArrayTree
    env_state: EnvState  # each leaf [num_envs, ...]
    obs: chex.Array  # f32[num_envs, D]
    key: chex.PRNGKey
    strategy: chex.Array  # i32[] registered strategy number (jaxnav.core.strategies.index)
    hyper: Hyper
    step: chex.Array  # i32[] env steps taken, all environments together
    episode: chex.Array  # i32[] episodes finished, all environments together
    metrics: Episodes  # finished episodes; the running sums one per environment
    diverged_at: chex.Array  # i32[] env step of the update that first broke; -1 while none
    bank: Any = None  # the run's layouts drawn ahead (env.maze_bank), else None
    # each intrinsic reward's state (jaxnav.agent.bonus), in the order of the config's
    # strategies with one; None without any
    bonus: Any = None
    explored: Any = None  # jaxnav.agent.explored.Explored with run.coverage, else None
    levels: Any = None  # jaxnav.agent.levels.Levels with pqn.level_replay, else None


class Rollout(NamedTuple):
    """T steps of every environment, each field [T, num_envs, ...]."""

    obs: chex.Array  # f32 the observation acted on
    action: chex.Array  # i32
    reward: chex.Array  # f32
    terminated: chex.Array  # bool: a collision
    truncated: chex.Array  # bool: the step limit
    next_obs: chex.Array  # f32 the observation after the step, before an auto-reset
    explore: chex.Array  # f32 the strategy's exploration
    max_q: chex.Array  # f32 max_a Q(s, a) at the acting state
    q_finite: chex.Array  # bool every Q-value at the acting state finite
    # where the robot stood after the step (before a reset) and whether it reached a
    # goal: only where a count bonus or run.coverage (pos, reached) or level replay
    # (reached) reads them, else None
    pos: chex.Array | None = None  # f32[..., 2]
    reached: chex.Array | None = None  # bool
    # i32 the bank index of the layout the step was in: with level replay, else None
    layout: chex.Array | None = None


# ----------------------------------------------------------------------------
# The trainer
# ----------------------------------------------------------------------------


class Rollouts(NamedTuple):
    """A config's rollout and its targets, as :func:`make_trainer` uses them (tests
    call them alone). ``play(ts, run, key)``: ``pqn.rollout`` steps of every
    environment with ``ts.params``, episodes filed where ``run`` (bool[]); returns
    ((obs, env_state, metrics, episode) after it, :class:`Rollout`). ``targets(params,
    rollout, gamma, noise=None, key=None)``: its lambda-returns f32[T, num_envs] (a
    noisy network's: with its run's ``noise`` switch, drawn from ``key``).
    ``noise(ts)``: the run's noise switch (f32[]: 1 in a NoisyNets run, 0 in the
    others), None where no strategy of the config is noisy."""

    env: NavEnv
    env_params: EnvParams
    network: QNetwork
    slots: int
    play: Callable[..., tuple[tuple, Rollout]]
    targets: Callable[..., chex.Array]
    noise: Callable[[Any], chex.Array | None] = lambda ts: None


NOISE_SALT = 3  # a step's or learning key folded with this draws a noisy network's noise
LEVELS_SALT = 11  # an update's learning key folded with this breaks level replay's ties


def make_rollouts(config: Config) -> Rollouts:
    """The rollout and targets of a config's PQN runs (:class:`Rollouts`)."""
    env, base_params = from_config(config, prepare=False)
    budget = config.total_steps or 1  # env steps: the pace curriculum's span
    p = config.pqn
    network = network_of(config, env)
    envs = p.num_envs
    length = _updates(config) * envs * p.rollout
    slots = config.episodes if config.episodes is not None else length
    limit = run_limits(config)[0]
    noisy_ones = registry.noisy_of(config.strategies)
    # where the robot stands after each step: for a count bonus, and run.coverage
    places = config.run.coverage or bool(registry.with_bonus(config.strategies))
    replay = bool(p.level_replay)

    def noise(ts: PQNState) -> chex.Array | None:
        if not noisy_ones:
            return None
        return (ts.strategy == registry.index(noisy_ones[0])).astype(jnp.float32)

    def q_values(params, obs, switch, drawn):
        """Q-values of ``obs``; a noisy network's with the run's noise ``switch`` and a
        draw of its noise (:func:`jaxnav.agent.noisy.draw`)."""
        if switch is None:
            return network.apply(params, obs)
        return network.apply(noisy.with_draw(params, drawn), obs, noise=switch)

    def drawn_for(params, obs, switch, key):
        """A draw of a noisy network's noise for ``obs`` (None without noise)."""
        if switch is None:
            return None
        return noisy.draw(network, jax.lax.stop_gradient(params), obs, switch, key)

    def env_step(ts: PQNState, run: chex.Array, drawn, carry, key: chex.PRNGKey):
        """One step of every environment: act, step, file the finished episodes."""
        obs, env_state, metrics, episode = carry
        h = ts.hyper
        k_act, k_env = jax.random.split(key)
        q = q_values(ts.params, obs, noise(ts), drawn)  # f32[E, A]

        def act(k, q_env):
            return explore_action(ts.strategy, k, q_env, episode, h, config.strategies)

        action, explore = jax.vmap(act)(jax.random.split(k_act, envs), q)
        step = jax.vmap(env.step, in_axes=(0, 0, 0, None))
        new_obs, env_state, reward, terminated, truncated, info = step(
            jax.random.split(k_env, envs),
            env_state,
            action,
            env.at_progress(run_env_params(h, base_params, ts), ts.step / budget),
        )
        done = terminated | truncated
        layout = carry[1].layout  # where the step's attempt was (before any restart)
        metrics, episode = file_episodes(
            metrics, episode, run, reward, info["goal_reached"], info["collision"], done, explore,
            limit, slots, env.attempt_limit,
        )  # fmt: skip
        row = Rollout(
            obs,
            action,
            reward,
            terminated,
            truncated,
            info["final_obs"],
            explore,
            jnp.max(q, -1),
            jnp.all(jnp.isfinite(q), -1),
            info["final_pos"] if places else None,
            info["goal_reached"] if places or replay else None,
            layout if replay else None,
        )
        return (new_obs, env_state, metrics, episode), row

    def play(ts: PQNState, run: chex.Array, key: chex.PRNGKey):
        carry = (ts.obs, ts.env_state, ts.metrics, ts.episode)
        keys = jax.random.split(key, p.rollout)
        # a noisy network: each environment's own draw, held for the rollout
        drawn = drawn_for(ts.params, ts.obs, noise(ts), jax.random.fold_in(key, NOISE_SALT))
        return jax.lax.scan(lambda c, k: env_step(ts, run, drawn, c, k), carry, keys)

    def targets(params, ro: Rollout, gamma, switch=None, key=None) -> chex.Array:
        drawn = drawn_for(params, ro.next_obs[0, 0], switch, key)  # one draw for them all
        next_v = jnp.max(q_values(params, ro.next_obs, switch, drawn), -1)  # before any reset
        return lambda_returns(ro.reward, ro.terminated, ro.truncated, next_v, gamma, p.td_lambda)

    return Rollouts(env, base_params, network, slots, play, targets, noise)


def run_env_params(h: Hyper, base: EnvParams, ts: PQNState) -> EnvParams:
    """The environment's params a run steps with: its swept settings, its bank and,
    with level replay, the bank's weights."""
    params = h.env_params(base, ts.bank)
    if ts.levels is not None:
        params = params.replace(bank_cdf=ts.levels.cdf)
    return params


def _updates(config: Config) -> int:
    """Updates per chunk: as many as fit in ``run.chunk_steps`` env steps, at least one."""
    return max(1, config.run.chunk_steps // (config.pqn.num_envs * config.pqn.rollout))


def make_trainer(config: Config) -> Trainer:
    """The PQN run of a config as pure ``init(key, strategy, hyper)``, ``step`` (one
    update), ``chunk`` and ``active``, the :class:`jaxnav.dqn.Trainer` DQN's host loop
    drives."""
    parts = make_rollouts(config)
    env, base_params, network, slots = parts.env, parts.env_params, parts.network, parts.slots
    d, p = config.dqn, config.pqn
    envs = p.num_envs
    per_update = envs * p.rollout
    updates = _updates(config)
    length = updates * per_update
    limits = run_limits(config)
    decay = lr_decay_steps(config, gradient_steps(config))
    optimizer = _optimizer(d, d.optimizer, p.max_grad_norm, decay)  # the state's layout
    dropout = d.dropout > 0.0 or any(k == "dqn.dropout" for k, _ in config.sweep)
    # the intrinsic rewards: (strategy number, Bonus) of each listed strategy with one
    bonuses = [
        (registry.index(s), bonus.maker(s)(config, env))
        for s in registry.with_bonus(config.strategies)
    ]
    places = coverage_grid(config, base_params) if config.run.coverage else None
    replay = p.level_replay
    if replay:
        n_bank = config.env.maze_bank
        top = max(1, round(p.level_top * n_bank))
        fade = float(0.5 ** (per_update / p.level_halflife))  # the counts' decay per update

    def init(key: chex.PRNGKey, strategy: chex.Array, hyper: Hyper) -> PQNState:
        env_params = env.with_bank(hyper.env_params(base_params), bank_key(key))
        start = levels.Levels.start(n_bank) if replay else None
        if replay:  # the first layouts picked uniformly, by index, so the state keeps it
            env_params = env_params.replace(bank_cdf=start.cdf)
        k_net, k_env, k_run = jax.random.split(key, 3)
        reset = jax.vmap(env.reset, in_axes=(0, None))
        obs, env_state = reset(jax.random.split(k_env, envs), env_params)
        params = network.init(k_net, obs[0])
        states = tuple(
            b.init(jax.random.fold_in(key, BONUS_SALT + i), obs) for i, (_, b) in enumerate(bonuses)
        )
        return PQNState(
            params=params,
            opt_state=optimizer.init(params),
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
            bonus=states or None,
            explored=None if places is None else Explored.start(*places.shape),
            levels=start,
        )

    def active(ts: PQNState) -> chex.Array:
        return still_training(ts.episode, ts.step, *limits) & (ts.diverged_at < 0)

    def update(ts: PQNState, _):
        run = active(ts)
        h = ts.hyper
        key, k_roll, k_learn = jax.random.split(ts.key, 3)

        # ROLLOUT: T steps of every environment with the current network.
        with jax.named_scope("rollout"):
            (obs, env_state, metrics, episode), ro = parts.play(ts, run, k_roll)

        # BONUS: the intrinsic rewards of the strategies with one, each added in its
        # own runs only, and what they learn from the rollout.
        states = ts.bonus
        if bonuses:
            with jax.named_scope("bonus"):
                ro, states = _with_bonuses(bonuses, ts, ro, k_learn)

        # TARGETS: lambda-returns from the same network's max-Q, fixed for the update.
        switch = parts.noise(ts)
        with jax.named_scope("targets"):
            k_noise = jax.random.fold_in(k_learn, NOISE_SALT)
            targets = parts.targets(ts.params, ro, h.gamma, switch, k_noise)

        # LEARN: epochs x minibatches over the rollout.
        with jax.named_scope("learn"):
            data = (ro.obs.reshape(per_update, -1), ro.action.reshape(-1), targets.reshape(-1))
            params, opt_state, broke, loss = _learn(
                network, config, h, ts.params, ts.opt_state, data, k_learn, dropout, switch
            )
        explored = ts.explored
        if places is not None:  # where the robot has been, and its first goal
            iy, ix = block_index(ro.pos, places.origin, places.raster, BLOCK)
            explored = visited(explored, iy, ix, ro.reached, ts.step, envs)
        record = ts.levels
        if replay:  # each attempt that ended, in the layout it was begun in
            ended = ro.reached | ro.terminated | ro.truncated
            k_top = jax.random.fold_in(k_learn, LEVELS_SALT)
            record = levels.record(record, ro.layout, ended, ro.reached, fade, replay, top, k_top)
        n_steps = ts.step + per_update
        diverged = (ts.diverged_at < 0) & run & (broke | ~jnp.all(ro.q_finite))
        held = ts.replace(
            params=select(run, params, ts.params),
            opt_state=select(run, opt_state, ts.opt_state),
            env_state=select(run, env_state, ts.env_state),
            obs=select(run, obs, ts.obs),
            key=select(run, key, ts.key),
            step=jnp.where(run, n_steps, ts.step),
            episode=jnp.where(run, episode, ts.episode),
            metrics=select(run, metrics, ts.metrics),
            diverged_at=jnp.where(diverged, n_steps, ts.diverged_at),
            bank=env.refreshed_bank(ts.bank, ts.key, ts.step, jnp.where(run, n_steps, ts.step)),
            bonus=select(run, states, ts.bonus),
            explored=select(run, explored, ts.explored),
            levels=select(run, record, ts.levels),
        )
        nan = jnp.float32(jnp.nan)
        log = StepLog(
            explore=jnp.where(run, ro.explore.reshape(-1), nan),
            loss=jnp.full(per_update, nan).at[-1].set(jnp.where(run, loss, nan)),
            max_q=jnp.where(run, ro.max_q.reshape(-1), nan),
        )
        return held, log

    # Up to chunk_length env steps (whole updates) of one run in one compiled loop; an
    # update's loss sits at its last env step.
    chunk = update_chunk(update, per_update, updates)

    return Trainer(env, base_params, slots, init, update, chunk, active, per_update, length)


def _optimizer(
    h, kind: str, max_grad_norm: float, decay: int | None = None
) -> optax.GradientTransformation:
    """dqn.optimizer at ``h.lr`` (a config's, or a run's as data), the gradients first
    clipped to their global norm (``pqn.max_grad_norm``); ``decay``: gradient steps of
    the linear decay of ``dqn.lr_decay``."""
    clip = optax.clip_by_global_norm(max_grad_norm)
    return optax.chain(clip, optimizer_of(h, kind, decay))


BONUS_SALT = 1000  # a run's key folded with this (+ i) starts its i-th bonus's state


class Places(NamedTuple):
    """run.coverage's grid: the oracle's raster of the config's maze, pooled in blocks."""

    raster: Raster
    origin: np.ndarray  # f32[2] the centre of the raster's cell (0, 0)
    shape: tuple[int, int]  # (ny, nx) of the blocks


def coverage_grid(config: Config, env_params: EnvParams) -> Places:
    """The grid of run.coverage for a config's fixed maze (``env_params.maze``)."""
    maze = env_params.maze
    raster = raster_for([maze], ORACLE_CELL)
    nx, ny = blocks_of(raster, BLOCK)
    return Places(raster, np.asarray(origin_of(maze, raster)), (ny, nx))


def _with_bonuses(bonuses, ts: PQNState, ro: Rollout, key) -> tuple[Rollout, tuple]:
    """The rollout with each intrinsic reward added to the environment's where the run's
    strategy is the bonus's (exactly ``r + 0`` elsewhere), and the bonuses' states after
    counting and learning from it."""
    steps = Steps(ro.next_obs, ro.pos)
    reward, states = ro.reward, []
    for i, ((number, b), state) in enumerate(zip(bonuses, ts.bonus)):
        extra, state = b.reward(state, steps, ts.hyper)
        reward = reward + jnp.where(ts.strategy == number, extra, 0.0)
        states.append(b.learn(state, steps, jax.random.fold_in(key, BONUS_SALT + i)))
    return ro._replace(reward=reward), tuple(states)


def gradient_steps(config: Config) -> int:
    """A run's gradient steps over its budget (``total_steps``): its updates times
    ``pqn.epochs`` x ``pqn.minibatches``."""
    p = config.pqn
    return -(-config.max_total_steps // (p.num_envs * p.rollout)) * p.epochs * p.minibatches


def _learn(
    network: QNetwork, config: Config, h: Hyper, params, opt_state, data, key, dropout, switch=None
):
    """(params, opt_state, broke, mean loss) after ``pqn.epochs`` passes of
    ``pqn.minibatches`` shuffled minibatches over the rollout's ``data`` (observations
    f32[n, D], actions i32[n], targets f32[n]). A minibatch whose loss or new parameters
    are not finite is not applied, nor is any after it (``broke``). ``switch``: a noisy
    network's noise switch of the run (None: no noise), fresh noise each minibatch."""
    d, p = config.dqn, config.pqn
    n = p.num_envs * p.rollout
    size = n // p.minibatches
    decay = lr_decay_steps(config, gradient_steps(config))
    optimizer = _optimizer(h, d.optimizer, p.max_grad_norm, decay)  # the run's lr
    kind = d.loss if h.loss is None else h.loss

    def loss_fn(params, batch, k):
        obs, action, target = batch
        variables, extra = params, {}
        if switch is not None:  # one draw of the noise for the minibatch
            k_noise = jax.random.fold_in(k, NOISE_SALT)
            drawn = noisy.draw(network, jax.lax.stop_gradient(params), obs[0], switch, k_noise)
            variables, extra = noisy.with_draw(params, drawn), {"noise": switch}
        if dropout:
            rngs = {"dropout": k}
            q = network.apply(variables, obs, train=True, dropout=h.dropout, rngs=rngs, **extra)
        else:
            q = network.apply(variables, obs, **extra)
        return td_loss(q, action, target, kind)

    def minibatch(carry, x):
        params, opt_state, broke = carry
        batch, k = x
        loss, grads = jax.value_and_grad(loss_fn)(params, batch, k)
        updates, new_state = optimizer.update(grads, opt_state, params)
        new_params = optax.apply_updates(params, updates)
        ok = ~broke & jnp.isfinite(loss) & all_finite(new_params)
        params = select(ok, new_params, params)
        opt_state = select(ok, new_state, opt_state)
        return (params, opt_state, broke | ~ok), loss

    def epoch(carry, k):
        k_perm, k_drop = jax.random.split(k)
        order = jax.random.permutation(k_perm, n)
        batches = jax.tree.map(lambda x: x[order].reshape(p.minibatches, size, *x.shape[1:]), data)
        return jax.lax.scan(minibatch, carry, (batches, jax.random.split(k_drop, p.minibatches)))

    carry = (params, opt_state, jnp.asarray(False))
    (params, opt_state, broke), losses = jax.lax.scan(epoch, carry, jax.random.split(key, p.epochs))
    return params, opt_state, broke, jnp.mean(losses)


__all__ = [
    "PQNState",
    "Rollout",
    "Rollouts",
    "gradient_steps",
    "lambda_returns",
    "make_rollouts",
    "make_trainer",
    "network_of",
]
