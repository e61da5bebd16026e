"""Agents are registered peers: a toy agent declared in this file alone trains,
evaluates and exports through the same commands as DQN and PQN.

The toy is online Q-learning (Watkins 1989) with a small Q-network: one SGD step on
the TD error of each transition as it happens, no replay memory, no target network.
"""

import csv

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest
from flax import struct

from jaxnav.agent.episodes import Episodes
from jaxnav.agent.exploration import explore_action
from jaxnav.agent.networks import QNetwork
from jaxnav.agent.qlearning import td_loss, td_target
from jaxnav.agent.trainer import (
    StepLog,
    Trainer,
    make_train,
    run_inputs,
    run_limits,
    select,
    step_chunk,
)
from jaxnav.commands import evaluate
from jaxnav.commands import train as train_cmd
from jaxnav.core import agents, rundir
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.env import from_config
from jaxnav.robot.deploy import Policy
from jaxnav.robot.export import export_policy


def toy_network(config, env=None):
    env = from_config(config)[0] if env is None else env
    return QNetwork(env.num_actions, tuple(config.dqn.hidden), dropout=0.0)


@struct.dataclass
class ToyState:
    params: dict
    env_state: object
    obs: jax.Array
    key: jax.Array
    strategy: jax.Array
    hyper: object
    step: jax.Array
    episode: jax.Array
    metrics: Episodes
    diverged_at: jax.Array
    bank: object = None


def toy_trainer(config) -> Trainer:
    env, base = from_config(config)
    net = toy_network(config, env)
    sgd = optax.sgd(config.dqn.lr)
    slots = config.episodes if config.episodes is not None else config.run.chunk_steps
    episodes_limit, steps_limit = run_limits(config)

    def init(key, strategy, hyper):
        k_net, k_env, k_run = jax.random.split(key, 3)
        obs, env_state = env.reset(k_env, base)
        return ToyState(
            params=net.init(k_net, obs),
            env_state=env_state,
            obs=obs,
            key=k_run,
            strategy=jnp.asarray(strategy, jnp.int32),
            hyper=hyper,
            step=jnp.zeros((), jnp.int32),
            episode=jnp.zeros((), jnp.int32),
            metrics=Episodes.zeros(slots, attempts=bool(env.attempt_limit)),
            diverged_at=jnp.asarray(-1, jnp.int32),
        )

    def active(ts):
        return (ts.episode < episodes_limit) & (ts.step < steps_limit) & (ts.diverged_at < 0)

    def step(ts, _):
        run = active(ts)
        key, k_act, k_env = jax.random.split(ts.key, 3)
        q = net.apply(ts.params, ts.obs)
        action, explore = explore_action(
            ts.strategy, k_act, q, ts.episode, ts.hyper, config.strategies
        )
        obs, env_state, reward, terminated, truncated, info = env.step(
            k_env, ts.env_state, action, base
        )
        done = terminated | truncated

        def loss(p):
            q_now = net.apply(p, ts.obs[None])
            q_next = net.apply(jax.lax.stop_gradient(p), info["final_obs"][None])
            y = td_target(reward[None], terminated[None], q_next, ts.hyper.gamma)
            return td_loss(q_now, action[None], y)

        value, grads = jax.value_and_grad(loss)(ts.params)
        updates, _ = sgd.update(grads, sgd.init(ts.params))
        params = select(run, optax.apply_updates(ts.params, updates), ts.params)
        slot = jnp.where(run & done, ts.episode % slots, slots)
        metrics = ts.metrics.record(
            slot, reward, info["goal_reached"], terminated, done, explore, env.attempt_limit
        )
        new = ts.replace(
            params=params,
            env_state=env_state,
            obs=obs,
            key=key,
            step=ts.step + 1,
            episode=ts.episode + done.astype(jnp.int32),
            metrics=metrics,
        )
        held = select(run, new, ts)
        return held, StepLog(explore, jnp.where(run, value, jnp.nan), jnp.max(q))

    chunk = step_chunk(step, config.run.chunk_steps)  # the contract's loop of steps
    return Trainer(env, base, slots, init, step, chunk, active, 1, config.run.chunk_steps)


TINY = [
    "agent=toy",
    "seeds=2",
    "episodes=6",
    "env.max_steps=30",
    "dqn.hidden=[16]",
    "dqn.lr=0.01",
    "run.chunk_steps=64",
    "run.test_mazes=[square4]",
    "run.test_episodes=2",
]


@pytest.fixture
def toy():
    agents.register(
        "toy",
        trainer=toy_trainer,
        network=toy_network,
        reads=("dqn",),
        about="online Q-learning, one SGD step per transition",
    )
    yield agents.get("toy")
    agents.unregister("toy")


@pytest.mark.slow
def test_a_toy_agent_registered_here_trains_evaluates_and_exports(toy, tmp_path):
    out = tmp_path / "run"
    assert train_cmd.main([*TINY, "--out", str(out)]) == 0
    cfg = load_config(str(out / rundir.CONFIG))
    assert cfg.agent == "toy"
    with open(out / rundir.METRICS) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == cfg.n_runs * cfg.episodes  # every episode of every run is logged
    # The host loop's parameters are the toy's own program's, run to the end.
    final = jax.jit(jax.vmap(make_train(cfg)))(*run_inputs(cfg))
    for r, (strategy, seed) in enumerate(cfg.run_labels()):
        saved = rundir.load_params(out / rundir.PARAMS, strategy, seed)
        for a, b in zip(jax.tree.leaves(saved), jax.tree.leaves(final.params)):
            np.testing.assert_array_equal(np.asarray(b)[r], a)
    assert evaluate.main([str(out)]) == 0
    with open(out / "eval" / "results.csv") as f:
        assert len(list(csv.DictReader(f))) >= cfg.n_runs
    # Its exported policy acts as its network does.
    policy = Policy.from_arrays(export_policy(out, "ebe", 0))
    x = np.random.default_rng(3).uniform(0.1, 3.5, (7, policy.obs_size)).astype(np.float32)
    params = rundir.load_params(out / rundir.PARAMS, "ebe", 0)
    want = toy_network(cfg).apply(params, jnp.asarray(x))
    np.testing.assert_allclose(policy.q_values(x), want, rtol=1e-5, atol=1e-5)


def test_an_agent_setting_names_the_registered_agents(toy):
    with pytest.raises(ConfigError, match="agent must be one of dqn, pqn, sac, toy, got 'ppo'"):
        load_config(None, ["agent=ppo"])
    # A section the agent does not read keeps its defaults.
    with pytest.raises(ConfigError, match="pqn.rollout is a PQN setting: it needs agent pqn"):
        load_config(None, ["agent=toy", "pqn.rollout=8"])


def test_the_old_agent_key_still_reads_with_a_note(capsys):
    assert load_config(None, ["dqn.agent=pqn"]).agent == "pqn"
    assert "dqn.agent is now agent" in capsys.readouterr().err
    with pytest.raises(ConfigError, match="dqn.agent is the old name of agent"):
        load_config(None, ["dqn.agent=pqn", "agent=pqn"])


def test_an_agent_is_refused_a_clash_or_a_bad_declaration(toy):
    with pytest.raises(ConfigError, match="registered already"):
        agents.register("toy", trainer=toy_trainer, network=toy_network)
    with pytest.raises(ConfigError, match="not an agent settings section"):
        agents.register("toy2", trainer=toy_trainer, network=toy_network, reads=("env",))
    with pytest.raises(ConfigError, match="actions must be discrete or continuous"):
        agents.register("toy3", trainer=toy_trainer, network=toy_network, actions="hybrid")
    assert "toy2" not in agents.names() and "toy3" not in agents.names()
