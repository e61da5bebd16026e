"""A count bonus on a coarse grid of positions: the intrinsic reward of strategy ``count``.

Count-based exploration rewards a visit by the inverse square root of how often its
state has been visited, n(phi(s)), with phi a coarse discretisation (Tang et al. 2017,
"#Exploration"; Bellemare et al. 2016 with pseudo-counts; in mapless LiDAR navigation
Zhelo et al. 2018 reward curiosity for the same reason). Here phi is the cell of a grid
of ``exploration.count_cell`` metres over the maze's bounds that holds the robot's
position after a step, and

    bonus(s') = exploration.count_scale / sqrt(n(phi(s'))),

with n counting every step of the run, all its environments together. A rollout's
steps are counted first and then rewarded, each with the count after the rollout (the
counts move once per update, as the network does). The position is privileged (the
policy observes only the scan and the goal), which is what makes this bonus the field's
strong reference for exploring a fixed world rather than a method for a robot.
"""

from __future__ import annotations

import math

import chex
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxnav.agent.bonus import Bonus, Steps
from jaxnav.world.maps import make_maze


@struct.dataclass
class CountState:
    counts: chex.Array  # i32[ny, nx] visits of each cell so far


def grid_of(bounds, cell: float) -> tuple[np.ndarray, int, int]:
    """(the grid's corner f32[2], nx, ny) covering ``bounds`` (xmin, ymin, xmax, ymax)
    with square cells of ``cell`` metres."""
    lo, hi = np.asarray(bounds[:2], np.float64), np.asarray(bounds[2:], np.float64)
    nx, ny = (max(1, math.ceil((hi[i] - lo[i]) / cell)) for i in (0, 1))
    return lo.astype(np.float32), nx, ny


def cells(pos: chex.Array, corner, cell: float, nx: int, ny: int) -> chex.Array:
    """i32[...]: the flat cell index (row-major, y then x) of positions f32[..., 2],
    clipped into the grid."""
    ix = jnp.clip(jnp.floor((pos[..., 0] - corner[0]) / cell), 0, nx - 1).astype(jnp.int32)
    iy = jnp.clip(jnp.floor((pos[..., 1] - corner[1]) / cell), 0, ny - 1).astype(jnp.int32)
    return iy * nx + ix


def make(config, env) -> Bonus:
    """The count bonus for a config's runs (a fixed maze, ``env.maze``)."""
    del env
    cell = config.exploration.count_cell
    corner, nx, ny = grid_of(np.asarray(make_maze(config.env.maze).bounds), cell)

    def init(key: chex.PRNGKey, obs: chex.Array) -> CountState:
        del key, obs
        return CountState(counts=jnp.zeros((ny, nx), jnp.int32))

    def reward(state: CountState, steps: Steps, hyper) -> tuple[chex.Array, CountState]:
        idx = cells(steps.pos, corner, cell, nx, ny)  # i32[T, E]
        counts = state.counts.reshape(-1).at[idx.reshape(-1)].add(1)
        n = counts[idx].astype(jnp.float32)
        return hyper.count_scale / jnp.sqrt(n), CountState(counts.reshape(ny, nx))

    def learn(state: CountState, steps: Steps, key: chex.PRNGKey) -> CountState:
        del steps, key
        return state

    return Bonus(init, reward, learn)


__all__ = ["CountState", "cells", "grid_of", "make"]
