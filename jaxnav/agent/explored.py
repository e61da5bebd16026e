"""What a run has explored while it trains (``run.coverage``): where its robot has been
and when it first reached a goal, for the measures of exploring.

A run's :class:`Explored` holds a bit per cell of a grid over its world (the trainer
gives the grid: the oracle's raster pooled into blocks,
:func:`jaxnav.planners.raster.block_index`) set where the robot stood after any step of
any of its environments, and the env step (all environments together) by which it had
first reached a goal, -1 before. The greedy evaluations write them to eval.csv
(:mod:`jaxnav.run.greedy`): the coverage is the visited share of the world's free cells.
Only read by the host: training's numbers are those of a run without it.
"""

from __future__ import annotations

import chex
import jax.numpy as jnp
from flax import struct

BLOCK = 5  # a cell of the grid: 5 x 5 of the oracle's raster cells (0.25 m)


@struct.dataclass
class Explored:
    visits: chex.Array  # bool[ny, nx] cells the robot has stood in
    first_goal: chex.Array  # i32[] env steps by the first goal reached; -1 before one

    @staticmethod
    def start(ny: int, nx: int) -> Explored:
        return Explored(jnp.zeros((ny, nx), bool), jnp.asarray(-1, jnp.int32))


def visited(
    explored: Explored,
    iy: chex.Array,
    ix: chex.Array,
    reached: chex.Array,
    step: chex.Array,
    per_step: int,
) -> Explored:
    """``explored`` after a rollout: ``iy``, ``ix`` i32[T, E] the cells where each of the
    E environments stood after each of T steps, ``reached`` bool[T, E] whether it reached a
    goal there, ``step`` i32[] the run's env steps before the rollout, ``per_step`` the
    env steps one step of every environment takes (E)."""
    visits = explored.visits.at[iy.reshape(-1), ix.reshape(-1)].set(True)
    any_t = jnp.any(reached, axis=tuple(range(1, reached.ndim)))  # bool[T]
    first_t = jnp.argmax(any_t)
    found = step + (first_t.astype(jnp.int32) + 1) * per_step
    first = jnp.where((explored.first_goal < 0) & jnp.any(any_t), found, explored.first_goal)
    return Explored(visits, first)


def coverage(visits: chex.Array, free: chex.Array) -> chex.Array:
    """f32[...]: the share of the ``free`` cells (bool[ny, nx]) that ``visits``
    (bool[..., ny, nx]) holds."""
    hit = jnp.sum(visits & free, axis=(-2, -1))
    return hit / jnp.maximum(jnp.sum(free), 1)


__all__ = ["BLOCK", "Explored", "coverage", "visited"]
