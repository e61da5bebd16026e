"""draw_where: the same numbers as a plain where over a draw, however the batch is
made, while drawing only for the environments that need a new maze."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
from jaxnav.world import lazy


def _setup(n):
    env, _ = jaxnav.make(generator="grid", grid_rows=3, grid_cols=4, min_path_cells=2)
    old = jax.vmap(env.draw_maze)(jax.random.split(jax.random.PRNGKey(3), n))
    return env, old, jax.random.split(jax.random.PRNGKey(5), n)


@pytest.mark.slow
@pytest.mark.parametrize("mask", ["none", "some", "all"])
def test_vmapped_draw_where_equals_where_over_every_draw(mask, monkeypatch):
    n = 70  # more than one chunk of lazy.CHUNK when all are fresh
    monkeypatch.setattr(lazy, "CHUNK", 16)
    env, old, keys = _setup(n)
    rng = np.random.default_rng(0)
    fresh = {"none": np.zeros(n, bool), "some": rng.random(n) < 0.3, "all": np.ones(n, bool)}[mask]
    fresh = jnp.asarray(fresh)
    got = jax.jit(jax.vmap(lambda f, k, o: lazy.draw_where(env.draw_maze, f, k, o)))(
        fresh, keys, old
    )
    want = jax.vmap(lambda f, k, o: lazy._where(f, env.draw_maze(k), o))(fresh, keys, old)
    for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


@pytest.mark.slow
def test_unbatched_and_nested_batches_draw_the_same():
    env, old, keys = _setup(6)
    fresh = jnp.asarray([True, False, True, False, False, True])
    one = lazy.draw_where(env.draw_maze, fresh[0], keys[0], jax.tree.map(lambda x: x[0], old))
    np.testing.assert_array_equal(np.asarray(one[1]), np.asarray(env.draw_maze(keys[0])[1]))
    nest = lambda x: x.reshape(2, 3, *x.shape[1:])  # noqa: E731
    inner = jax.vmap(lambda f, k, o: lazy.draw_where(env.draw_maze, f, k, o))
    got = jax.jit(jax.vmap(inner))(nest(fresh), nest(keys), jax.tree.map(nest, old))
    want = jax.vmap(lambda f, k, o: lazy._where(f, env.draw_maze(k), o))(fresh, keys, old)
    for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want)):
        np.testing.assert_array_equal(np.asarray(a).reshape(np.shape(b)), np.asarray(b))


@pytest.mark.slow
def test_a_few_fresh_environments_in_a_small_batch_draw_as_where_does(monkeypatch):
    monkeypatch.setattr(lazy, "CHUNK", 2)  # three rounds for the five fresh ones
    env, old, keys = _setup(8)
    fresh = jnp.asarray([True, False, True, True, False, True, False, True])
    got = jax.jit(jax.vmap(lambda f, k, o: lazy.draw_where(env.draw_maze, f, k, o)))(
        fresh, keys, old
    )
    want = jax.vmap(lambda f, k, o: lazy._where(f, env.draw_maze(k), o))(fresh, keys, old)
    for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
