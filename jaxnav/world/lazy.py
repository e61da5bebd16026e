"""Draw only where a draw is needed, under vmap too.

An environment that restarts inside a vmapped step computes its restart for every
environment and keeps it where the episode ended: a ``jnp.where`` over two branches
that both run. For a drawn maze that is a whole maze generation per environment per
step, most of them thrown away. :func:`draw_where` is ``where(fresh, draw(key), old)``
with a batching rule (``jax.custom_batching.custom_vmap``) that, over a batch, draws
only for the environments whose ``fresh`` is set: their indices are gathered, ``CHUNK``
at a time, drawn together and scattered back, in a loop that runs as many times as
there are chunks of them (none in a step where no episode needs a new maze).

Each environment's draw uses its own key, so the numbers are exactly those of the
plain ``where``: what changes is only how much is computed, never what a run draws, and
never in a way that depends on the other runs of the batch.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

CHUNK = 64  # environments drawn together per round of the loop


def _where(fresh, new, old):
    return jax.tree.map(lambda a, b: jnp.where(fresh, a, b), new, old)


def draw_where(draw: Callable[..., Any], fresh, key, old, chunk: int = CHUNK, shared=None):
    """``where(fresh, draw(key), old)`` leaf by leaf, drawing only where ``fresh`` is set
    when vmapped (``old`` has ``draw(key)``'s structure). ``key`` may be any pytree of
    the draw's inputs (a PRNG key, or the maze and goal a field is computed from).
    ``chunk``: environments drawn together per round (1 where one draw is costly and
    few environments need one at a time). ``shared``: a pytree of inputs the draw takes
    as its second argument, ``draw(key, shared)``, passed whole where it is the same for
    the batch (the environment's params: never copied per environment). The draw must
    close over no traced value: pass those in ``key`` or ``shared``."""

    def call(key, shared):
        return draw(key) if shared is None else draw(key, shared)

    @jax.custom_batching.custom_vmap
    def pick(fresh, key, old, shared):
        return _where(fresh, call(key, shared), old)

    @pick.def_vmap
    def _batched(axis_size, in_batched, fresh, key, old, shared):
        fresh_b, key_b, old_b, shared_b = in_batched

        def batch(x, is_batched):
            return x if is_batched else jnp.broadcast_to(x, (axis_size, *jnp.shape(x)))

        fresh = batch(fresh, fresh_b)
        key = jax.tree.map(batch, key, key_b)
        old = jax.tree.map(batch, old, old_b)
        axes = jax.tree.map(lambda b: 0 if b else None, shared_b)
        out = _draw_needed(call, fresh, key, old, axis_size, chunk, shared, axes)
        return out, jax.tree.map(lambda _: True, out)

    return pick(fresh, key, old, shared)


def _draw_needed(draw, fresh, key, old, n: int, chunk: int, shared=None, axes=None):
    """Over a batch of ``n``: ``old`` with ``draw(key[i], shared)`` at every i where
    ``fresh``; ``axes``: per leaf of ``shared``, 0 where it is batched, else None."""
    if n == 1:
        # One environment: a branch. A loop of at most one round would have its draw
        # hoisted out of it by the compiler (its inputs do not change from round to
        # round) and computed at every call.
        def one():
            return jax.vmap(draw, in_axes=(0, axes))(key, shared)

        return jax.lax.cond(fresh[0], one, lambda: old)
    m = min(chunk, n)
    count = jnp.sum(fresh.astype(jnp.int32))
    needing = jnp.argsort(~fresh, stable=True)  # the fresh ones first, in batch order
    rounds = -(-n // m)
    needing = jnp.concatenate([needing, jnp.zeros(rounds * m - n, needing.dtype)])

    def again(carry):
        r, _ = carry
        return r * m < count

    def draw_round(carry):
        r, out = carry
        pos = r * m + jnp.arange(m)
        idx = jax.lax.dynamic_slice(needing, (r * m,), (m,))
        idx = jnp.where(pos < count, idx, n)  # past the fresh ones: dropped below
        at = jnp.minimum(idx, n - 1)
        picked = jax.tree.map(lambda s, a: s if a is None else s[at], shared, axes)
        new = jax.vmap(draw, in_axes=(0, axes))(jax.tree.map(lambda k: k[at], key), picked)
        out = jax.tree.map(lambda o, x: o.at[idx].set(x, mode="drop"), out, new)
        return r + 1, out

    _, out = jax.lax.while_loop(again, draw_round, (jnp.int32(0), old))
    return out


__all__ = ["CHUNK", "draw_where"]
