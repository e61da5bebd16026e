"""A sum tree over a replay memory's slots, for prioritised replay (Schaul et al. 2016).

One f32 array ``tree[2P]`` (P the smallest power of two at least the capacity): node
1 is the root, node i has children 2i and 2i + 1, and slot s is leaf ``P + s``, so
every node holds the sum of the priorities below it. Setting B priorities and drawing
B slots in proportion to them each take O(B log P), in place of O(capacity) for a
cumulative sum per draw. Pure functions over the array, traceable, so the tree lives
in the trainer's carry like the rest of the buffer.
"""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp


def leaves(capacity: int) -> int:
    """P: leaves of the tree of ``capacity`` slots (a power of two)."""
    return 1 << max(0, (capacity - 1).bit_length())


def init(capacity: int) -> chex.Array:
    """An all-zero tree f32[2P]."""
    return jnp.zeros(2 * leaves(capacity), jnp.float32)


def total(tree: chex.Array) -> chex.Array:
    """f32[]: the sum of every priority (the root)."""
    return tree[1]


def get(tree: chex.Array, slots: chex.Array) -> chex.Array:
    """The priorities of ``slots`` (i32[B])."""
    return tree[tree.shape[0] // 2 + slots]


def set_priorities(tree: chex.Array, slots: chex.Array, values: chex.Array) -> chex.Array:
    """The tree with the priorities of ``slots`` (i32[B]) set to ``values`` (f32[B]) and
    every sum above them recomputed. A slot listed twice takes one of its values, and
    the sums above it are those of the value it took."""
    p = tree.shape[0] // 2
    node = p + slots
    tree = tree.at[node].set(values)
    for _ in range(p.bit_length() - 1):  # up to the root, one level at a time
        node = node // 2
        tree = tree.at[node].set(tree[2 * node] + tree[2 * node + 1])
    return tree


def find(tree: chex.Array, mass: chex.Array) -> chex.Array:
    """The slots (i32[B]) where the cumulative priority passes ``mass`` (f32[B] in
    [0, total)): slot s for mass in [sum of slots before s, that + priority of s)."""
    p = tree.shape[0] // 2
    node = jnp.ones(mass.shape, jnp.int32)
    for _ in range(p.bit_length() - 1):
        left = tree[2 * node]
        go_left = mass < left
        node = jnp.where(go_left, 2 * node, 2 * node + 1)
        mass = jnp.where(go_left, mass, mass - left)
    return node - p


def sample(tree: chex.Array, key: chex.PRNGKey, batch_size: int, size: chex.Array) -> chex.Array:
    """``batch_size`` slots drawn in proportion to their priorities, stratified as in
    Schaul et al. (one draw from each of ``batch_size`` equal parts of the total), each
    among the first ``size`` slots (i32[]; a draw that rounding carries past them takes
    the last)."""
    u = jax.random.uniform(key, (batch_size,))
    mass = (jnp.arange(batch_size) + u) * (total(tree) / batch_size)
    return jnp.clip(find(tree, mass), 0, jnp.maximum(size, 1) - 1)
