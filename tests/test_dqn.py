"""The learner's pieces against hand-computed and NumPy references."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav.config import load_config
from jaxnav.dqn import (
    QNetwork,
    buffer_add,
    buffer_init,
    buffer_sample,
    ebe,
    epsilon_greedy,
    epsilon_schedule,
    make_trainer,
    normalised_entropy,
    run_keys,
    td_loss,
    td_target,
)


# -- TD target and loss -------------------------------------------------------


def test_td_target_bootstraps_through_truncation_not_collision():
    reward = jnp.array([1.0, -150.0, 2.0])
    terminated = jnp.array([False, True, False])  # the third is a truncation: not terminal
    next_q = jnp.array([[0.0, 3.0, 1.0], [10.0, 20.0, 30.0], [-1.0, -2.0, 5.0]])
    y = td_target(reward, terminated, next_q, 0.9)
    np.testing.assert_allclose(y, [1.0 + 0.9 * 3.0, -150.0, 2.0 + 0.9 * 5.0], rtol=1e-6)


def test_td_loss_is_mean_squared_error_of_taken_actions():
    q = jnp.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    action = jnp.array([2, 0])
    target = jnp.array([1.0, 10.0])
    # (3 - 1)^2 = 4, (4 - 10)^2 = 36 -> mean 20
    assert float(td_loss(q, action, target)) == pytest.approx(20.0)
    # the gradient reaches only the taken actions' Q-values
    g = jax.grad(lambda q: td_loss(q, action, target))(q)
    np.testing.assert_allclose(g, [[0, 0, 2.0], [-6.0, 0, 0]])


# -- EBE ----------------------------------------------------------------------


def _np_entropy(q, t=1.0):
    z = (q - q.max()) / t
    p = np.exp(z) / np.exp(z).sum()
    return float(-(p * np.log(p + 1e-300)).sum() / math.log(len(q)))


def test_uniform_q_has_entropy_one():
    assert float(normalised_entropy(jnp.full(5, 3.7))) == pytest.approx(1.0, abs=1e-6)


def test_one_dominant_action_has_entropy_near_zero():
    assert float(normalised_entropy(jnp.array([0.0, 0.0, 100.0, 0.0, 0.0]))) < 1e-3


def test_entropy_matches_numpy():
    rng = np.random.default_rng(0)
    for scale in (0.1, 1.0, 5.0, 50.0):
        for _ in range(20):
            q = rng.normal(size=5) * scale
            for t in (1.0, 10.0):
                got = float(normalised_entropy(jnp.asarray(q, jnp.float32), t))
                assert got == pytest.approx(_np_entropy(q, t), abs=1e-5)


def test_ebe_random_action_rate_matches_entropy():
    q = jnp.array([0.0, 0.5, 1.5, 0.2, -0.3])
    h = float(normalised_entropy(q))
    keys = jax.random.split(jax.random.PRNGKey(0), 40_000)
    actions, hs = jax.vmap(lambda k: ebe(k, q))(keys)
    assert np.allclose(hs, h)
    # a random action is non-greedy 4 times in 5
    non_greedy = float(np.mean(np.asarray(actions) != 2))
    assert non_greedy == pytest.approx(h * 4 / 5, abs=0.01)


def test_epsilon_greedy_rate_and_schedule():
    q = jnp.array([0.0, 1.0, 0.0, 0.0, 0.0])
    keys = jax.random.split(jax.random.PRNGKey(1), 40_000)
    actions, _ = jax.vmap(lambda k: epsilon_greedy(k, q, 0.3))(keys)
    assert float(np.mean(np.asarray(actions) != 1)) == pytest.approx(0.3 * 4 / 5, abs=0.01)
    eps = [1.0]
    for _ in range(400):
        eps.append(max(0.99 * eps[-1], 0.05))
    got = epsilon_schedule(jnp.arange(401))
    np.testing.assert_allclose(got, eps, rtol=1e-5)
    assert float(got[0]) == 1.0 and float(got[-1]) == pytest.approx(0.05)


# -- Replay buffer ------------------------------------------------------------


def _fill(buf, n, trunc_at=(), term_at=()):
    for i in range(n):
        obs = jnp.full(2, float(i))
        nxt = jnp.full(2, 1000.0 + i)  # the observation before any reset
        buf = buffer_add(buf, obs, jnp.int32(i % 5), jnp.float32(i), i in term_at, i in trunc_at, nxt)
    return buf


def test_buffer_wraps_around_and_samples_only_filled_slots():
    buf = _fill(buffer_init(5, 2, max_steps=2), 3)
    assert int(buf.size) == 3 and int(buf.pos) == 3
    batch = buffer_sample(buf, jax.random.PRNGKey(0), 512)
    assert set(np.asarray(batch.reward).tolist()) == {0.0, 1.0, 2.0}
    buf = _fill(buffer_init(5, 2, max_steps=2), 7)
    assert int(buf.size) == 5 and int(buf.pos) == 2
    # slots 0, 1 were overwritten by transitions 5, 6
    np.testing.assert_array_equal(buf.reward, [5.0, 6.0, 2.0, 3.0, 4.0])
    batch = buffer_sample(buf, jax.random.PRNGKey(0), 512)
    assert set(np.asarray(batch.reward).tolist()) == {2.0, 3.0, 4.0, 5.0, 6.0}


def test_buffer_next_obs_is_following_slot_tail_or_final_obs():
    # transitions 0..5; 2 truncated, 4 terminated; obs of step i is i
    buf = _fill(buffer_init(8, 2, max_steps=2), 6, trunc_at={2}, term_at={4})
    batch = buffer_sample(buf, jax.random.PRNGKey(3), 1024)
    r = np.asarray(batch.reward).astype(int)
    nxt = np.asarray(batch.next_obs)[:, 0]
    for i, n in zip(r, nxt):
        if i == 2:
            assert n == 1002.0  # the pre-reset observation kept for bootstrapping
        elif i == 5:
            assert n == 1005.0  # newest slot: the tail
        else:
            assert n == i + 1  # the next slot's observation
    np.testing.assert_array_equal(np.asarray(batch.obs)[:, 0], r)
    np.testing.assert_array_equal(np.asarray(batch.terminated), r == 4)


def test_buffer_inactive_add_changes_nothing():
    buf = _fill(buffer_init(4, 2, max_steps=2), 2)
    same = buffer_add(buf, jnp.ones(2), jnp.int32(1), jnp.float32(9.0), False, True, jnp.ones(2), False)
    for a, b in zip(jax.tree.leaves(buf), jax.tree.leaves(same)):
        np.testing.assert_array_equal(a, b)


# -- Network ------------------------------------------------------------------


def test_q_network_is_paper_table_2_with_dropout_only_in_training():
    net = QNetwork()
    x = jnp.ones((3, 26))
    params = net.init(jax.random.PRNGKey(0), x)
    shapes = jax.tree.map(lambda a: a.shape, params)["params"]
    assert shapes == {
        "Dense_0": {"kernel": (26, 64), "bias": (64,)},
        "Dense_1": {"kernel": (64, 64), "bias": (64,)},
        "Dense_2": {"kernel": (64, 5), "bias": (5,)},
    }
    a = net.apply(params, x)
    np.testing.assert_array_equal(a, net.apply(params, x))  # acting is deterministic
    t1 = net.apply(params, x, train=True, rngs={"dropout": jax.random.PRNGKey(1)})
    t2 = net.apply(params, x, train=True, rngs={"dropout": jax.random.PRNGKey(2)})
    assert not np.allclose(t1, t2)


# -- Training step ------------------------------------------------------------


def _tiny(*overrides):
    return load_config(
        None,
        [
            "seeds=2",
            "episodes=3",
            "env.max_steps=40",
            "run.chunk_steps=50",
            "dqn.batch_size=8",
            *overrides,
        ],
    )


def test_target_sync_every_n_steps():
    cfg = _tiny("dqn.target_update_every=5", "dqn.learning_starts=1")
    tr = make_trainer(cfg)
    keys, strat = run_keys(cfg)
    ts = tr.init(keys[0], strat[0])
    step = jax.jit(tr.step)
    for n in range(1, 12):
        ts, _ = step(ts, None)
        same = all(
            np.array_equal(a, b)
            for a, b in zip(jax.tree.leaves(ts.params), jax.tree.leaves(ts.target_params))
        )
        assert same == (n % 5 == 0), n


def test_learning_starts_after_enough_transitions():
    cfg = _tiny("dqn.learning_starts=4")
    tr = make_trainer(cfg)
    keys, strat = run_keys(cfg)
    ts0 = tr.init(keys[0], strat[0])
    step = jax.jit(tr.step)
    ts = ts0
    for n in range(1, 6):
        ts, _ = step(ts, None)
        changed = not np.array_equal(ts.params["params"]["Dense_0"]["kernel"], ts0.params["params"]["Dense_0"]["kernel"])
        assert changed == (n >= 4), n


def test_seeds_differ_and_strategies_share_the_seed_init():
    cfg = _tiny()
    tr = make_trainer(cfg)
    keys, strat = run_keys(cfg)
    assert list(np.asarray(strat)) == [0, 0, 1, 1]
    ts = jax.vmap(tr.init)(keys, strat)
    k = ts.params["params"]["Dense_0"]["kernel"]
    assert not np.allclose(k[0], k[1])  # seed 0 vs seed 1
    np.testing.assert_array_equal(k[0], k[2])  # ebe and epsilon-greedy on seed 0


def test_dropout16_drops_the_rate_and_rescales_the_rest():
    from jaxnav.dqn import dropout16

    x = jnp.ones((64, 64 * 64 + 1))  # odd size: the last 32-bit draw is half used
    y = np.asarray(jax.jit(dropout16, static_argnums=2)(jax.random.PRNGKey(0), x, 0.2))
    dropped = y == 0.0
    assert abs(dropped.mean() - 0.2) < 0.005  # 262k units: 4 standard deviations ~ 0.003
    np.testing.assert_allclose(y[~dropped], 1.0 / 0.8, rtol=1e-6)
    # Both 16-bit halves of a draw are used, independently.
    assert not np.array_equal(dropped[:, 0::2], dropped[:, 1::2])
    y2 = np.asarray(dropout16(jax.random.PRNGKey(1), x, 0.2))
    assert not np.array_equal(y, y2)
