"""Replay memory: a ring buffer of transitions that stores each observation once.

A small bundle of pure functions over one pytree, in flashbax's shape:
:func:`init` (checked by :func:`validate`), :func:`add`, :func:`sample`,
:func:`can_sample` and :func:`nbytes`; prioritised replay adds
:func:`sample_prioritised` and :func:`update_priorities`. Every function is
traceable, so a run's buffer lives in the trainer's ``lax.scan`` carry and
``jax.vmap`` gives one buffer per run.

Layout. Slot i holds (obs_i, action_i, reward_i, terminated_i, truncated_i) and the
row of its truncation's observation, in one record of 32-bit words (row i of
``records``: the obs, the reward, action and flags in one word, the ring row): a
sample reads two adjacent records, not one element of six arrays spread over memory.
``Buffer.obs``, ``Buffer.reward``, ... read the fields out of the records. The next
observation of slot i is the obs of slot i + 1, except for

* the newest slot, whose next observation is ``tail`` (slot i + 1 is not written yet);
* truncated slots: the environment auto-resets, so slot i + 1 holds the start of the
  next episode, while truncation is not terminal and bootstraps from the observation
  before the reset. That observation is kept in a small ring ``final_obs`` at row
  ``final_index[i]``.

After a collision (``terminated``) the next observation is never used.

n-step returns (:func:`sample_n_step`, ``dqn.n_step``). From slot i the return sums
the rewards of slots i, i + 1, ... for at most n slots and stops at the first slot
that ends its episode or is the newest: after a collision it does not bootstrap;
after a truncation it bootstraps from that slot's ``final_obs`` row, never from the
next episode's start; at the newest slot from ``tail``. The k slots summed give the
bootstrap's discount gamma^k. The slots read lie between i and the newest slot, all
live, so the truncation-ring invariant below covers them too.

Truncation-ring invariant. ``final_obs`` has ``K = capacity // max_steps + 2`` rows;
the j-th truncation stored writes row ``j % K`` and the slot remembers the row in
``final_index``. Requirement: a row may be reused only once the slot that last wrote
it has left the buffer. Why K rows are enough:

* the environment truncates an episode only when it reaches exactly ``max_steps``
  steps, so every truncated episode fills ``max_steps`` slots and two truncations are
  at least ``max_steps`` adds apart;
* so the ``capacity`` live slots hold at most ``ceil(capacity / max_steps) <=
  capacity // max_steps + 1`` truncated slots, and one more row serves the slot being
  written: ``K`` rows. Put the other way, two truncations that share a row are at
  least ``K * max_steps > capacity`` adds apart, so the older slot has been
  overwritten before its row is.

What a smaller ring breaks: with fewer than ``ceil(capacity / max_steps)`` rows, runs
of truncated episodes reuse the row of a truncated slot that is still in the buffer,
and every later sample of that slot bootstraps from another episode's last
observation: wrong TD targets, silently. ``K`` is also part of the checkpoint layout
(the shape of ``final_obs``): changing it changes the checkpoint format.
"""

from __future__ import annotations

import operator
from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp
from flax import struct

from jaxnav.agent import sumtree

# The per-slot fields as a checkpoint stores them (jaxnav.run.checkpoint), each
# (name, dtype); in memory they are the words of a slot's record.
SLOT_FIELDS = (
    ("obs", jnp.float32),  # f32[N, D]
    ("action", jnp.uint8),  # u8[N]
    ("reward", jnp.float32),  # f32[N]
    ("terminated", jnp.bool_),  # bool[N]
    ("truncated", jnp.bool_),  # bool[N]
    ("final_index", jnp.int32),  # i32[N] row of final_obs for truncated slots
)
_EXTRA = 3  # words of a record after the obs: reward, action and flags, ring row


@struct.dataclass
class Buffer:
    """One run's replay memory. Field names and order are the checkpoint layout; the
    records are stored as the fields of :data:`SLOT_FIELDS` (the properties below)."""

    records: chex.Array  # u32[N, D + 3]: obs bits, reward bits, action | flags, ring row
    final_obs: chex.Array  # f32[K, D], K = capacity // max_steps + 2
    tail: chex.Array  # f32[D] next observation of the newest slot
    pos: chex.Array  # i32[] next slot to write
    size: chex.Array  # i32[] filled slots
    n_final: chex.Array  # i32[] truncations stored so far
    # Prioritised replay only (None, and no leaf, otherwise): each slot's priority
    # (|TD error| + eps)^alpha in a sum tree (jaxnav.agent.sumtree), and the largest
    # priority given so far, which a new transition gets.
    priority: chex.Array | None = None  # f32[2P]
    max_priority: chex.Array | None = None  # f32[]

    # The fields of the records (any leading axes, e.g. runs, kept).
    @property
    def obs(self) -> chex.Array:
        return _as_f32(self.records[..., :-_EXTRA])

    @property
    def reward(self) -> chex.Array:
        return _as_f32(self.records[..., -3])

    @property
    def action(self) -> chex.Array:
        return (self.records[..., -2] & 0xFF).astype(jnp.uint8)

    @property
    def terminated(self) -> chex.Array:
        return (self.records[..., -2] & 0x100) != 0

    @property
    def truncated(self) -> chex.Array:
        return (self.records[..., -2] & 0x200) != 0

    @property
    def final_index(self) -> chex.Array:
        return jax.lax.bitcast_convert_type(self.records[..., -1], jnp.int32)


def _as_f32(words: chex.Array) -> chex.Array:
    return jax.lax.bitcast_convert_type(words, jnp.float32)


def _as_u32(x: chex.Array) -> chex.Array:
    return jax.lax.bitcast_convert_type(x, jnp.uint32)


def pack(obs, action, reward, terminated, truncated, final_index) -> chex.Array:
    """Records u32[..., D + 3] of the slot fields (leading axes alike), bit for bit."""
    flags = (
        jnp.asarray(action).astype(jnp.uint32)
        | (jnp.asarray(terminated).astype(jnp.uint32) << 8)
        | (jnp.asarray(truncated).astype(jnp.uint32) << 9)
    )
    words = (
        _as_u32(jnp.asarray(reward, jnp.float32)),
        flags,
        _as_u32(jnp.asarray(final_index, jnp.int32)),
    )
    return jnp.concatenate(
        [_as_u32(jnp.asarray(obs, jnp.float32)), jnp.stack(words, axis=-1)], axis=-1
    )


class Batch(NamedTuple):
    """A sampled minibatch; ``next_obs`` is resolved (following slot, tail or final_obs).

    From :func:`sample_n_step`, ``reward`` is the n-step return, ``next_obs`` the
    observation it bootstraps from and ``discount`` (f32[B]) its gamma^k; None from
    :func:`sample` (one step: the run's gamma)."""

    obs: chex.Array  # f32[B, D]
    action: chex.Array  # i32[B]
    reward: chex.Array  # f32[B]
    next_obs: chex.Array  # f32[B, D]
    terminated: chex.Array  # bool[B]
    discount: chex.Array | None = None


def validate(capacity: int, obs_dim: int, max_steps: int) -> None:
    """Raise ``ValueError`` unless every size is a positive integer."""
    for name, value in (("capacity", capacity), ("obs_dim", obs_dim), ("max_steps", max_steps)):
        try:
            n = operator.index(value)
        except TypeError:
            n = None
        if n is None or isinstance(value, bool) or n < 1:
            raise ValueError(f"replay buffer {name} must be a positive integer, got {value!r}")


def final_rows(capacity: int, max_steps: int) -> int:
    """Rows K of the truncation ring (see the module docstring for why K is enough)."""
    return capacity // max_steps + 2


def init(capacity: int, obs_dim: int, max_steps: int, prioritised: bool = False) -> Buffer:
    """An empty buffer of ``capacity`` slots of ``obs_dim``-float observations, with
    the priorities of prioritised replay if asked."""
    validate(capacity, obs_dim, max_steps)
    k = final_rows(capacity, max_steps)
    extra = {}
    if prioritised:
        extra = {"priority": sumtree.init(capacity), "max_priority": jnp.ones((), jnp.float32)}
    return Buffer(
        records=jnp.zeros((capacity, obs_dim + _EXTRA), jnp.uint32),
        final_obs=jnp.zeros((k, obs_dim), jnp.float32),
        tail=jnp.zeros((obs_dim,), jnp.float32),
        pos=jnp.zeros((), jnp.int32),
        size=jnp.zeros((), jnp.int32),
        n_final=jnp.zeros((), jnp.int32),
        **extra,
    )


def nbytes(capacity: int, obs_dim: int, max_steps: int, prioritised: bool = False) -> int:
    """Bytes of one buffer, without allocating it."""
    b = jax.eval_shape(lambda: init(capacity, obs_dim, max_steps, prioritised))
    return sum(x.size * x.dtype.itemsize for x in jax.tree.leaves(b))


def add(
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
    n = buf.records.shape[0]
    k = buf.final_obs.shape[0]
    p = buf.pos
    fi = buf.n_final % k

    active = jnp.asarray(active, bool)
    store_final = active & jnp.asarray(truncated, bool)
    # A finished run writes nothing: its slot is out of range and the write dropped
    # (rather than the slot read back and written again), so the store stays in place.
    slot = jnp.where(active, p, n)
    record = pack(obs, action.astype(jnp.uint8), reward, terminated, truncated, fi)

    extra = {}
    if buf.priority is not None:  # a new transition: the largest priority so far
        new = jnp.where(active, buf.max_priority, sumtree.get(buf.priority, p))
        extra = {"priority": sumtree.set_priorities(buf.priority, p[None], new[None])}
    return buf.replace(
        records=buf.records.at[slot].set(record, mode="drop"),
        final_obs=buf.final_obs.at[jnp.where(store_final, fi, k)].set(next_obs, mode="drop"),
        tail=jnp.where(active, next_obs, buf.tail),
        pos=jnp.where(active, (p + 1) % n, p),
        size=jnp.where(active, jnp.minimum(buf.size + 1, n), buf.size),
        n_final=buf.n_final + store_final.astype(jnp.int32),
        **extra,
    )


def can_sample(buf: Buffer, min_size: int) -> chex.Array:
    """bool[]: at least ``min_size`` transitions are stored."""
    return buf.size >= min_size


def sample(buf: Buffer, key: chex.PRNGKey, batch_size: int) -> Batch:
    """Uniform sample (with replacement) of filled slots only."""
    idx = jax.random.randint(key, (batch_size,), 0, jnp.maximum(buf.size, 1))
    return batch_at(buf, idx)


def batch_at(buf: Buffer, idx: chex.Array) -> Batch:
    """The one-step :class:`Batch` of slots ``idx`` (i32[B])."""
    n = buf.records.shape[0]
    newest = (buf.pos - 1) % n
    slots = buf.replace(records=buf.records[idx])  # the B records, one gather
    following = buf.replace(records=buf.records[(idx + 1) % n]).obs  # the adjacent ones
    final = buf.final_obs[slots.final_index]
    next_obs = jnp.where(
        (idx == newest)[:, None],
        buf.tail[None, :],
        jnp.where(slots.truncated[:, None], final, following),
    )
    return Batch(
        obs=slots.obs,
        action=slots.action.astype(jnp.int32),
        reward=slots.reward,
        next_obs=next_obs,
        terminated=slots.terminated,
    )


def sample_n_step(buf: Buffer, key: chex.PRNGKey, batch_size: int, n: int, gamma) -> Batch:
    """Uniform sample (the slots :func:`sample` draws from the same key) of n-step
    returns: see the module docstring. ``n`` is static, ``gamma`` may be data."""
    idx = jax.random.randint(key, (batch_size,), 0, jnp.maximum(buf.size, 1))
    return n_step_batch(buf, idx, n, gamma)


def n_step_batch(buf: Buffer, idx: chex.Array, n: int, gamma) -> Batch:
    """The n-step :class:`Batch` starting at slots ``idx`` (i32[B])."""
    size = buf.records.shape[0]
    newest = (buf.pos - 1) % size
    gamma = jnp.asarray(gamma, jnp.float32)
    ret = jnp.zeros(idx.shape, jnp.float32)
    discount = jnp.ones(idx.shape, jnp.float32)
    alive = jnp.ones(idx.shape, bool)
    end = idx

    def at(i):  # the records of slots i
        return buf.replace(records=buf.records[i])

    for k in range(n):
        j = (idx + k) % size
        slot_j = at(j)
        ret = ret + jnp.where(alive, discount * slot_j.reward, 0.0)
        discount = jnp.where(alive, discount * gamma, discount)
        end = jnp.where(alive, j, end)
        alive = alive & ~(slot_j.terminated | slot_j.truncated | (j == newest))
    last, first = at(end), at(idx)
    following = at((end + 1) % size).obs
    final = buf.final_obs[last.final_index]
    next_obs = jnp.where(
        (end == newest)[:, None],
        buf.tail[None, :],
        jnp.where(last.truncated[:, None], final, following),
    )
    return Batch(
        obs=first.obs,
        action=first.action.astype(jnp.int32),
        reward=ret,
        next_obs=next_obs,
        terminated=last.terminated,
        discount=discount,
    )


# ----------------------------------------------------------------------------
# Prioritised replay (Schaul et al. 2016, proportional)
# ----------------------------------------------------------------------------


def sample_prioritised(
    buf: Buffer, key: chex.PRNGKey, batch_size: int, beta
) -> tuple[chex.Array, chex.Array]:
    """(slots i32[B], importance weights f32[B]) of a prioritised buffer: slot i drawn
    with probability P(i) = p_i / sum_k p_k (stratified, :func:`sumtree.sample`), its
    weight w_i = (N P(i))^-beta over N filled slots, divided by the batch's largest
    weight so that weights only scale updates down (Schaul et al., Sec. 3.4)."""
    idx = sumtree.sample(buf.priority, key, batch_size, buf.size)
    prob = sumtree.get(buf.priority, idx) / sumtree.total(buf.priority)
    n = jnp.maximum(buf.size, 1).astype(jnp.float32)
    w = (n * jnp.maximum(prob, jnp.finfo(jnp.float32).tiny)) ** (-jnp.asarray(beta))
    return idx, w / jnp.max(w)


def update_priorities(buf: Buffer, idx: chex.Array, td_error: chex.Array, alpha, eps, apply):
    """The buffer with the priorities of slots ``idx`` set to (|td_error| + eps)^alpha,
    where ``apply`` (bool[]) holds; unchanged otherwise."""
    new = (jnp.abs(td_error) + eps) ** alpha
    new = jnp.where(apply, new, sumtree.get(buf.priority, idx))
    top = jnp.where(apply, jnp.maximum(buf.max_priority, jnp.max(new)), buf.max_priority)
    return buf.replace(priority=sumtree.set_priorities(buf.priority, idx, new), max_priority=top)
