"""The replay memory: ring order, next observations, and the truncation ring."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav.agent import replay


def _fill(buf, n, trunc_at=(), term_at=()):
    for i in range(n):
        obs = jnp.full(2, float(i))
        nxt = jnp.full(2, 1000.0 + i)  # the observation before any reset
        buf = replay.add(
            buf, obs, jnp.int32(i % 5), jnp.float32(i), i in term_at, i in trunc_at, nxt
        )
    return buf


# -- Ring order -----------------------------------------------------------------


def test_buffer_wraps_around_and_samples_only_filled_slots():
    buf = _fill(replay.init(5, 2, max_steps=2), 3)
    assert int(buf.size) == 3 and int(buf.pos) == 3
    batch = replay.sample(buf, jax.random.PRNGKey(0), 512)
    assert set(np.asarray(batch.reward).tolist()) == {0.0, 1.0, 2.0}
    buf = _fill(replay.init(5, 2, max_steps=2), 7)
    assert int(buf.size) == 5 and int(buf.pos) == 2
    # slots 0, 1 were overwritten by transitions 5, 6
    np.testing.assert_array_equal(buf.reward, [5.0, 6.0, 2.0, 3.0, 4.0])
    batch = replay.sample(buf, jax.random.PRNGKey(0), 512)
    assert set(np.asarray(batch.reward).tolist()) == {2.0, 3.0, 4.0, 5.0, 6.0}


def test_buffer_next_obs_is_following_slot_tail_or_final_obs():
    # transitions 0..5; 2 truncated, 4 terminated; obs of step i is i
    buf = _fill(replay.init(8, 2, max_steps=2), 6, trunc_at={2}, term_at={4})
    batch = replay.sample(buf, jax.random.PRNGKey(3), 1024)
    r = np.asarray(batch.reward).astype(int)
    nxt = np.asarray(batch.next_obs)[:, 0]
    for i, n in zip(r, nxt, strict=True):
        if i == 2:
            assert n == 1002.0  # the pre-reset observation kept for bootstrapping
        elif i == 5:
            assert n == 1005.0  # newest slot: the tail
        else:
            assert n == i + 1  # the next slot's observation
    np.testing.assert_array_equal(np.asarray(batch.obs)[:, 0], r)
    np.testing.assert_array_equal(np.asarray(batch.terminated), r == 4)


def test_buffer_inactive_add_changes_nothing():
    buf = _fill(replay.init(4, 2, max_steps=2), 2)
    same = replay.add(
        buf, jnp.ones(2), jnp.int32(1), jnp.float32(9.0), False, True, jnp.ones(2), False
    )
    for a, b in zip(jax.tree.leaves(buf), jax.tree.leaves(same), strict=True):
        np.testing.assert_array_equal(a, b)
    # vmapped over runs, as the trainer stores: the finished run's buffer (its ring
    # full, the next slot the last) stays, the other stores its truncated transition
    bufs = jax.tree.map(lambda *x: jnp.stack(x), buf, _fill(replay.init(4, 2, max_steps=2), 7))
    args = (jnp.ones((2, 2)), jnp.int32([1, 1]), jnp.float32([9, 9]), jnp.bool_([0, 0]))
    new = jax.vmap(replay.add)(
        bufs, *args, jnp.bool_([1, 1]), 2 * jnp.ones((2, 2)), jnp.bool_([1, 0])
    )
    stored = replay.add(buf, *(a[0] for a in args), True, 2 * jnp.ones(2), True)
    for a, b, c in zip(*map(jax.tree.leaves, (bufs, new, stored)), strict=True):
        np.testing.assert_array_equal(b[1], a[1])
        np.testing.assert_array_equal(b[0], c)
    assert float(stored.reward[2]) == 9.0 and float(stored.final_obs[int(buf.n_final)][0]) == 2.0


def test_can_sample_once_enough_transitions_are_stored():
    buf = replay.init(8, 2, max_steps=4)
    assert not bool(replay.can_sample(buf, 1))
    buf = _fill(buf, 3)
    assert bool(replay.can_sample(buf, 3)) and not bool(replay.can_sample(buf, 4))


# -- Layout (checkpoints depend on it) -------------------------------------------


def test_layout_field_order_dtypes_and_bytes():
    buf = replay.init(10, 3, max_steps=4)
    assert [f for f in buf.__dataclass_fields__] == [
        "records",
        "final_obs",
        "tail",
        "pos",
        "size",
        "n_final",
        "priority",
        "max_priority",
    ]
    # uniform replay: no priorities, so its leaves (the checkpoint's) are the first 6
    assert buf.priority is None and buf.max_priority is None and len(jax.tree.leaves(buf)) == 6
    assert buf.records.shape == (10, 3 + 3) and buf.records.dtype == jnp.uint32
    assert buf.obs.shape == (10, 3) and buf.obs.dtype == jnp.float32
    assert buf.action.dtype == jnp.uint8 and buf.final_index.dtype == jnp.int32
    assert [(name, getattr(buf, name).dtype) for name, _ in replay.SLOT_FIELDS] == [
        (name, jnp.dtype(dtype)) for name, dtype in replay.SLOT_FIELDS
    ]
    assert buf.final_obs.shape == (10 // 4 + 2, 3)
    # 10 records of 3 + 3 words, 4 rows of 3 floats, the tail, 3 counters
    uniform = 10 * (12 + 12) + 4 * 12 + 12 + 3 * 4
    assert replay.nbytes(10, 3, 4) == uniform
    # prioritised: a sum tree of 2 x 16 floats (16 leaves for 10 slots) and the largest
    assert replay.nbytes(10, 3, 4, prioritised=True) == uniform + 2 * 16 * 4 + 4


def test_a_record_keeps_every_field_bit_for_bit():
    obs = jnp.array([[-0.0, jnp.nan, jnp.inf, 1e-40], [3.5, -jnp.inf, 0.0, -1e-45]])
    fields = {
        "obs": obs,
        "action": jnp.array([4, 255], jnp.uint8),
        "reward": jnp.array([-0.0, -150.0]),
        "terminated": jnp.array([True, False]),
        "truncated": jnp.array([False, True]),
        "final_index": jnp.array([0, 2**31 - 1], jnp.int32),
    }
    buf = replay.init(2, 4, max_steps=1).replace(records=replay.pack(**fields))
    for name, value in fields.items():
        got = getattr(buf, name)
        assert got.dtype == value.dtype, name
        np.testing.assert_array_equal(
            np.asarray(got).view(np.uint8), np.asarray(value).view(np.uint8)
        )


# -- validate ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "sizes, name",
    [
        ((0, 3, 4), "capacity"),
        ((10, -1, 4), "obs_dim"),
        ((10, 3, 0), "max_steps"),
        ((10.0, 3, 4), "capacity"),
        ((10, 3, True), "max_steps"),
    ],
)
def test_validate_rejects_non_positive_or_non_integer_sizes(sizes, name):
    with pytest.raises(ValueError, match=f"replay buffer {name} must be a positive integer"):
        replay.validate(*sizes)
    with pytest.raises(ValueError, match=name):
        replay.init(*sizes)


def test_validate_accepts_positive_sizes_of_any_integer_type():
    replay.validate(1, 1, 1)
    replay.validate(np.int64(10), np.int32(3), 500)


# -- The truncation ring ------------------------------------------------------------


def _episode_stream(n_episodes, max_steps, seed):
    """Transitions of episodes that end by collision (shorter) or truncation (exactly
    max_steps steps, as the environment truncates). Transition t has obs t, reward t
    and, when it ends an episode, pre-reset observation 1000 + t."""
    rng = np.random.default_rng(seed)
    t = 0
    for _ in range(n_episodes):
        collide = rng.random() < 0.3
        length = int(rng.integers(1, max_steps)) if collide else max_steps
        for s in range(length):
            last = s == length - 1
            nxt = 1000.0 + t if last else t + 1.0
            yield t, last and collide, last and not collide, nxt
            t += 1


def _check_every_sample(capacity, max_steps, final_rows, n_episodes=60, seed=0):
    """Add the stream one transition at a time; after each add sample the buffer and
    return how many sampled truncated slots bootstrapped from the wrong observation."""
    buf = replay.init(capacity, 1, max_steps)
    buf = buf.replace(final_obs=jnp.zeros((final_rows, 1), jnp.float32))
    add, sample = jax.jit(replay.add), jax.jit(replay.sample, static_argnums=2)
    wrong = checked = 0
    key = jax.random.PRNGKey(seed)
    for t, term, trunc, nxt in _episode_stream(n_episodes, max_steps, seed):
        obs, next_obs = jnp.full(1, float(t)), jnp.full(1, nxt)
        buf = add(buf, obs, jnp.int32(0), jnp.float32(t), term, trunc, next_obs)
        key, k = jax.random.split(key)
        b = sample(buf, k, 4 * capacity)
        stored = np.asarray(b.reward).astype(int)
        got = np.asarray(b.next_obs)[:, 0]
        is_trunc = np.asarray(buf.truncated)[stored % capacity]
        checked += int(is_trunc.sum())
        wrong += int((got[is_trunc] != 1000.0 + stored[is_trunc]).sum())
    assert checked > 0
    return wrong


def test_truncated_slots_bootstrap_from_their_own_final_observation():
    # 23 slots, episodes of at most 4 steps: up to 6 truncated slots alive at once.
    capacity, max_steps = 23, 4
    k = replay.final_rows(capacity, max_steps)
    assert k == 23 // 4 + 2
    assert _check_every_sample(capacity, max_steps, k) == 0


def test_a_smaller_truncation_ring_would_bootstrap_from_the_wrong_observation():
    # Fewer rows than ceil(capacity / max_steps): a live truncated slot's row is reused.
    capacity, max_steps = 23, 4
    too_few = math.ceil(capacity / max_steps) - 1
    assert _check_every_sample(capacity, max_steps, too_few) > 0


@pytest.mark.parametrize("max_steps", [1, 2, 3, 7, 500])
def test_truncation_ring_outlasts_the_buffer(max_steps):
    # Two truncations that share a row are >= K * max_steps adds apart, more than the
    # buffer holds, so the older one has been overwritten before its row is reused.
    for capacity in range(1, 2000, 37):
        assert replay.final_rows(capacity, max_steps) * max_steps > capacity


# -- n-step returns (dqn.n_step) -----------------------------------------------------


def _episodes(n_adds, capacity, max_steps, seed=0):
    """A buffer of random episodes (collisions at random, time-outs at exactly
    max_steps) and the transitions as a list, each with its true next observation."""
    rng = np.random.default_rng(seed)
    buf = replay.init(capacity, 2, max_steps)
    out, length = [], 0
    for t in range(n_adds):
        length += 1
        trunc = length == max_steps
        term = not trunc and rng.random() < 0.25
        length = 0 if trunc or term else length
        reward = float(rng.normal())
        nxt = 1000.0 + t if trunc or term else t + 1.0  # pre-reset obs, or the next one
        out.append((reward, term, trunc, nxt))
        buf = replay.add(
            buf, jnp.full(2, float(t)), jnp.int32(t % 5), jnp.float32(reward), term, trunc,
            jnp.full(2, nxt),
        )  # fmt: skip
    return buf, out


def _np_n_step(trans, t, n, gamma):
    """(return, terminated, discount, next obs) of transition t, by a plain loop."""
    ret = 0.0
    for k in range(n):
        reward, term, trunc, nxt = trans[t + k]
        ret += gamma**k * reward
        if term or trunc or t + k == len(trans) - 1 or k == n - 1:
            return ret, term, gamma ** (k + 1), nxt
    raise AssertionError


@pytest.mark.parametrize("n", [1, 2, 3, 6])
def test_n_step_returns_stop_at_episode_ends_and_time_outs_as_a_numpy_loop(n):
    capacity, n_adds, gamma = 12, 31, 0.9  # wrapped: slots hold transitions 19..30
    buf, trans = _episodes(n_adds, capacity, max_steps=4)
    assert any(x[1] for x in trans[19:]) and any(x[2] for x in trans[19:])  # both kinds
    ts = np.arange(n_adds - capacity, n_adds)
    batch = replay.n_step_batch(buf, jnp.asarray(ts % capacity), n, gamma)
    for i, t in enumerate(ts):
        ret, term, discount, nxt = _np_n_step(trans, int(t), n, gamma)
        assert float(batch.obs[i, 0]) == t
        assert float(batch.reward[i]) == pytest.approx(ret, rel=1e-5, abs=1e-6), t
        assert bool(batch.terminated[i]) == term, t
        assert float(batch.discount[i]) == pytest.approx(discount, rel=1e-6), t
        if not term:  # after a collision the next observation is never used
            assert float(batch.next_obs[i, 0]) == nxt, t  # a time-out's own pre-reset obs


def test_one_step_sample_n_step_is_sample():
    buf, _ = _episodes(31, 12, max_steps=4)
    key = jax.random.PRNGKey(5)
    one, n1 = replay.sample(buf, key, 64), replay.sample_n_step(buf, key, 64, 1, 0.9)
    for name in ("obs", "action", "reward", "next_obs", "terminated"):
        np.testing.assert_array_equal(getattr(one, name), getattr(n1, name))
    np.testing.assert_allclose(n1.discount, 0.9)
