"""Prioritised replay (Schaul et al. 2016, proportional) against NumPy references."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav.agent import replay, sumtree
from jaxnav.core.config import ConfigError, load_config

D = 3  # observation size


def _buffer(capacity=20, stored=15, seed=0):
    """A prioritised buffer holding ``stored`` transitions whose priorities come from
    known TD errors: (buffer, TD errors f32[stored])."""
    buf = replay.init(capacity, D, 500, prioritised=True)
    for i in range(stored):
        obs = jnp.full(D, float(i))
        buf = replay.add(buf, obs, jnp.int32(i % 5), jnp.float32(i), False, False, obs + 1)
    td = np.random.default_rng(seed).normal(scale=2.0, size=stored).astype(np.float32)
    buf = replay.update_priorities(buf, jnp.arange(stored), jnp.asarray(td), 0.6, 1e-6, True)
    return buf, td


def test_the_sum_tree_sums_the_priorities_and_finds_their_cumulative_sum():
    p = np.random.default_rng(1).uniform(0.0, 2.0, 13).astype(np.float32)  # 13: not 2^k
    tree = sumtree.set_priorities(sumtree.init(13), jnp.arange(13), jnp.asarray(p))
    assert tree.shape == (32,) and float(sumtree.total(tree)) == pytest.approx(p.sum(), rel=1e-6)
    mass = np.random.default_rng(2).uniform(0.0, p.sum() * 0.999, 500).astype(np.float32)
    want = np.searchsorted(np.cumsum(p.astype(np.float64)), mass, side="right")
    got = np.asarray(sumtree.find(tree, jnp.asarray(mass)))
    # agree except where float32 sums put a mass on the other side of a boundary
    assert np.mean(got == want) > 0.99
    # setting some again (one twice) keeps every sum right
    tree = sumtree.set_priorities(tree, jnp.array([3, 7, 3]), jnp.array([5.0, 0.0, 5.0]))
    p[3], p[7] = 5.0, 0.0
    assert float(sumtree.total(tree)) == pytest.approx(p.sum(), rel=1e-6)
    np.testing.assert_allclose(sumtree.get(tree, jnp.arange(13)), p)


def test_slots_are_drawn_in_proportion_to_their_priorities():
    buf, td = _buffer()
    prob = (np.abs(td.astype(np.float64)) + 1e-6) ** 0.6
    prob /= prob.sum()
    keys = jax.random.split(jax.random.PRNGKey(0), 4000)
    draw = jax.jit(jax.vmap(lambda k: replay.sample_prioritised(buf, k, 32, 0.4)[0]))
    idx = np.asarray(draw(keys)).ravel()  # 128,000 draws
    assert idx.min() >= 0 and idx.max() < 15  # never an empty slot
    freq = np.bincount(idx, minlength=15) / idx.size
    # binomial standard error at most 0.0014; stratified draws have less
    np.testing.assert_allclose(freq, prob, atol=0.006)


@pytest.mark.parametrize("beta", [0.0, 0.4, 1.0])
def test_importance_weights_are_n_p_to_the_minus_beta_over_the_batch_maximum(beta):
    buf, td = _buffer(seed=3)
    prob = (np.abs(td.astype(np.float64)) + 1e-6) ** 0.6
    prob /= prob.sum()
    idx, w = replay.sample_prioritised(buf, jax.random.PRNGKey(5), 64, beta)
    idx, w = np.asarray(idx), np.asarray(w)
    want = (15 * prob[idx]) ** -beta
    np.testing.assert_allclose(w, want / want.max(), rtol=1e-4)
    assert w.max() == pytest.approx(1.0)


def test_a_new_transition_gets_the_largest_priority_given_so_far():
    buf, td = _buffer()
    top = (np.abs(td).max() + 1e-6) ** 0.6
    assert float(buf.max_priority) == pytest.approx(top, rel=1e-5)
    obs = jnp.zeros(D)
    buf = replay.add(buf, obs, jnp.int32(0), jnp.float32(0.0), False, False, obs)
    assert float(sumtree.get(buf.priority, jnp.int32(15))) == pytest.approx(top, rel=1e-5)
    # a finished run's buffer (add with active false) keeps its priorities
    same = replay.add(buf, obs, jnp.int32(0), jnp.float32(0.0), False, False, obs, False)
    np.testing.assert_array_equal(same.priority, buf.priority)


def test_uniform_replay_carries_no_priorities():
    buf = replay.init(20, D, 500)
    assert buf.priority is None and len(jax.tree.leaves(buf)) == 6  # the checkpoint's layout


@pytest.mark.parametrize(
    "overrides, message",
    [
        (["dqn.per_alpha=0.5"], "dqn.per_alpha is a prioritised replay setting"),
        (["dqn.prioritised=true", "dqn.per_beta=1.5"], "dqn.per_beta must be in [0, 1]"),
        (["dqn.prioritised=true", "dqn.per_eps=0"], "dqn.per_eps must be positive"),
        (["agent=pqn", "dqn.prioritised=true"], "dqn.prioritised is a replay or target"),
    ],
)
def test_bad_prioritised_settings_are_one_line_naming_the_setting(overrides, message):
    with pytest.raises(ConfigError) as e:
        load_config(None, overrides)
    assert message in str(e.value) and "\n" not in str(e.value)
