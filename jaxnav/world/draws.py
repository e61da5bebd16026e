"""What the drawn maze families (``cylinders`` and ``rooms``, :mod:`jaxnav.world.cylinders`,
:mod:`jaxnav.world.rooms`) share: the lattices and caps of a draw, the train/test split
of a layout, candidates tried with a cap inside jit, and the fallback.

Train/test split, as for ``grid``: a layout's split is one bit of a hash of the
layout alone (the cylinders' lattice codes, order-free; the doors' positions), and a
draw tries candidates until one of the requested split comes up. If a draw exhausts
its ``MAX_TRIES`` candidates (for settings the config accepts, about 2^-32 for the
split), it returns the family's fallback: the first valid maze of that split from
fixed keys, found once on the host when the program is traced (:func:`fallback`).
So a draw never loops for ever, never puts the robot in an obstacle and never gives
a layout of the other split; a family too crowded to give any valid maze is refused
with one line when the fallback is searched.
"""

from __future__ import annotations

import functools
from typing import Any

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.core.errors import ConfigError

LATTICE = 0.05  # m, cylinder centres and door positions lie on this lattice
MAX_TRIES = 32  # candidate layouts a draw tries inside jit (cylinders: twice nested)
FALLBACK_TRIES = 2000  # candidates searched on the host for the fallback maze
ROBOTIS_ROWS = 256  # the ROBOTIS goal table a Maze carries (unused with drawn mazes)
_SALT = np.uint32(0x3C6EF372)


def _fmix(h: chex.Array) -> chex.Array:
    """murmur3's finaliser on u32: every input bit flips about half the output bits."""
    h = h ^ (h >> 16)
    h = h * jnp.uint32(0x85EBCA6B)
    h = h ^ (h >> 13)
    h = h * jnp.uint32(0xC2B2AE35)
    return h ^ (h >> 16)


def hash_split(codes: chex.Array, ordered: bool) -> chex.Array:
    """i32[]: 0 (train) or 1 (test), a hash bit of a layout's codes u32[K]. ``ordered``:
    the codes' positions count (doors on numbered walls); else the layout is the
    multiset of its codes (cylinders in any order)."""
    codes = codes.astype(jnp.uint32)
    if ordered:
        codes = codes * jnp.uint32(0x9E3779B1) + jnp.arange(codes.shape[0], dtype=jnp.uint32)
    h = _fmix(jnp.sum(_fmix(codes ^ jnp.uint32(_SALT)), dtype=jnp.uint32))
    return (h >> 31).astype(jnp.int32)


def first_valid(candidate, key: chex.PRNGKey) -> tuple[chex.ArrayTree, chex.Array]:
    """(the first candidate whose ``.ok`` holds among ``candidate(fold_in(key, i))``, i <
    MAX_TRIES, or the last one tried; whether one held)."""

    def again(carry):
        i, c = carry
        return ~c.ok & (i < MAX_TRIES - 1)

    def next_(carry):
        i, _ = carry
        return i + 1, candidate(jax.random.fold_in(key, i + 1))

    _, c = jax.lax.while_loop(again, next_, (jnp.int32(0), candidate(jax.random.fold_in(key, 0))))
    return c, c.ok


@functools.partial(jax.jit, static_argnums=(1, 2))
def search(key: chex.PRNGKey, family: Any, split: str):
    """(candidate, ok): the first valid candidate maze of ``split`` among MAX_TRIES
    (:func:`first_valid`), jitted once per family and split, so the host's fallback
    search and an eager draw share one compiled program."""
    return first_valid(functools.partial(family.candidate, split=split), key)


@functools.lru_cache(maxsize=32)
def fallback(family: Any, split: str):
    """The family's fallback draw of ``split`` (NumPy arrays): the first valid candidate
    from fixed keys, searched on the host with :func:`search`'s compiled program (also
    while another program is being traced). A family with none in FALLBACK_TRIES
    candidates is a ConfigError naming its settings."""
    keys = [np.asarray([_SALT, i], np.uint32) for i in range(FALLBACK_TRIES // MAX_TRIES)]
    compiled = search.lower(keys[0], family, split).compile()
    for key in keys:
        c, ok = compiled(key)
        if bool(ok):
            return jax.tree.map(np.asarray, c)
    raise ConfigError(
        f"config: {family.settings_text()} leave no valid {split} maze in {FALLBACK_TRIES} tries "
        "(make the mazes less crowded or the minimum path shorter)"
    )


def draw_with_fallback(family: Any, key: chex.PRNGKey, split: str):
    """A valid candidate of ``split`` drawn inside jit, or the family's fallback."""
    c, ok = search(key, family, split)
    return _or_fallback(c, ok, fallback(family, split))


@jax.jit
def _or_fallback(c, ok, safe):
    return jax.tree.map(lambda a, b: jnp.where(ok, a, b), c, safe)


def start_yaw(key: chex.PRNGKey) -> tuple[chex.PRNGKey, chex.Array]:
    """(the draw's key, the start's uniform yaw f32[]) of a maze's key."""
    k_draw, k_yaw = jax.random.split(key)
    return k_draw, jax.random.uniform(k_yaw, (), jnp.float32, -jnp.pi, jnp.pi)


__all__ = [
    "FALLBACK_TRIES",
    "LATTICE",
    "MAX_TRIES",
    "ROBOTIS_ROWS",
    "draw_with_fallback",
    "fallback",
    "first_valid",
    "hash_split",
    "search",
    "start_yaw",
]
