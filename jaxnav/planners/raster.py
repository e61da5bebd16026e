"""A maze on a square raster, inside jit: each cell centre's clearance from the static
walls and cylinders, and the shortest-path distance from a goal through the cells the
robot's disc fits in.

The raster's shape is static (:class:`Raster`, from the largest maze it must hold);
where it lies is the maze's own corner, so one compiled planner serves every maze of a
test. Distances move between 16 neighbours (steps of h, h sqrt 2 and h sqrt 5), so a
distance is at most about 3% longer than the true shortest path. Both fields are read at any
point through :func:`field_upper` and :func:`field_lower`, which use that a distance
field changes by at most the distance moved (it is 1-Lipschitz).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.world.geometry import hypot, min_over, point_segment_distance
from jaxnav.world.maps import Maze
from jaxnav.world.occupancy import point_clearance

PAD = 2  # cells of raster beyond the maze's bounds on every side
# m: an occupancy grid's clearance on the raster is exact up to this (the robot's radius,
# the oracle's margin, a raster cell and its diagonal, for radii up to 0.45 m)
GRID_NEAR = 0.6
ORACLE_CELL = 0.05  # m: the oracle's raster (jaxnav.experiments.baselines)

_DIAGONAL = math.sqrt(2.0)
# 16 neighbours: the 8 around a cell and the 8 a knight's move away, so a way's length
# is within about 3% of the straight line's in any direction (8 neighbours: 8%)
_MOVES = tuple(
    (dy, dx, math.hypot(dy, dx))
    for dy in (-2, -1, 0, 1, 2)
    for dx in (-2, -1, 0, 1, 2)
    if (dy or dx) and max(abs(dy), abs(dx)) == 1 or {abs(dy), abs(dx)} == {1, 2}
)
_ROUNDS = 1  # relaxations per loop iteration (one convergence test each): one fuses best


class Raster(NamedTuple):
    """A raster's static shape: ``ny`` x ``nx`` cells of side ``h`` (m)."""

    nx: int
    ny: int
    h: float


def raster_for(mazes: Sequence[Maze], h: float, scale: float = 1.0) -> Raster:
    """The raster that holds every maze of ``mazes`` (host side), each grown by
    ``scale`` (the largest of ``env.maze_scale``)."""
    sizes = [np.asarray(m.bounds)[2:] - np.asarray(m.bounds)[:2] for m in mazes]
    w, hgt = (float(max(s[i] for s in sizes)) * scale for i in (0, 1))
    return Raster(int(math.ceil(w / h)) + 2 * PAD + 1, int(math.ceil(hgt / h)) + 2 * PAD + 1, h)


def origin_of(maze: Maze, raster: Raster) -> chex.Array:
    """f32[2]: the centre of cell (0, 0) for ``maze``, PAD cells outside its bounds."""
    return maze.bounds[:2] - PAD * raster.h


def centres(raster: Raster, origin: chex.Array) -> tuple[chex.Array, chex.Array]:
    """(x, y) f32[ny, nx] each: the cell centres."""
    xs = origin[0] + raster.h * jnp.arange(raster.nx, dtype=jnp.float32)
    ys = origin[1] + raster.h * jnp.arange(raster.ny, dtype=jnp.float32)
    return jnp.meshgrid(xs, ys)


def clearance_field(maze: Maze, raster: Raster) -> chex.Array:
    """f32[ny, nx]: each cell centre's distance to the nearest static wall or cylinder
    surface (negative inside a cylinder), and to an occupancy grid's occupied cells
    (capped where its window ends, :func:`jaxnav.world.occupancy.point_clearance`)."""
    x, y = centres(raster, origin_of(maze, raster))
    px, py = x.reshape(-1), y.reshape(-1)

    def wall(ax, ay, bx, by):
        return point_segment_distance(px, py, ax, ay, bx, by)

    def circle(cx, cy, r):
        return hypot(px - cx, py - cy) - r

    d = jnp.minimum(
        min_over(wall, maze.segments, maze.segment_mask),
        min_over(circle, maze.circles, maze.circle_mask),
    )
    if maze.grid is not None:
        d = jnp.minimum(d, point_clearance(maze.grid, px, py, GRID_NEAR))
    return d.reshape(raster.ny, raster.nx)


def goal_distance(
    free: chex.Array, goal: chex.Array, goal_radius, origin: chex.Array, raster: Raster
) -> chex.Array:
    """f32[ny, nx]: the shortest path (m) through the ``free`` cells (bool[ny, nx]) from
    each cell to within ``goal_radius`` of ``goal``; inf where none leads there. Cells
    within a cell's width of the goal's radius start at their straight distance to it;
    relaxation then runs until nothing changes."""
    x, y = centres(raster, origin)
    to_goal = jnp.maximum(hypot(x - goal[0], y - goal[1]) - goal_radius, 0.0)
    d0 = jnp.where(free & (to_goal <= raster.h * _DIAGONAL), to_goal, jnp.inf)
    ny, nx = raster.ny, raster.nx

    def relax(d):
        p = jnp.pad(d, 2, constant_values=jnp.inf)
        best = d
        for dy, dx, w in _MOVES:  # out[i, j] = d[i + dy, j + dx] + w h
            best = jnp.minimum(best, p[2 + dy : 2 + dy + ny, 2 + dx : 2 + dx + nx] + w * raster.h)
        return jnp.where(free, best, jnp.inf)

    def again(carry):
        _, changed, i = carry
        return changed & (i < nx * ny)

    def rounds(carry):
        d, _, i = carry
        new = d
        for _ in range(_ROUNDS):
            new = relax(new)
        return new, jnp.any(new < d), i + _ROUNDS

    d, _, _ = jax.lax.while_loop(again, rounds, (d0, jnp.bool_(True), jnp.int32(0)))
    return d


def _corners(origin: chex.Array, raster: Raster, px, py):
    """The 4 cell centres around each point (px, py f32[...]), one at a time: their
    indices (iy, ix) i32[...] each, clipped into the raster, and each point's distance
    to it. Four arrays of the points' shape rather than one with a trailing axis of 4:
    a reduction over so short an axis is a library call of its own on a CPU, an
    elementwise min or max of four fuses with the gathers (and both are exact)."""
    fx = (px - origin[0]) / raster.h
    fy = (py - origin[1]) / raster.h
    x0, y0 = jnp.floor(fx), jnp.floor(fy)
    for x, y in ((x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)):
        ix = jnp.clip(x, 0, raster.nx - 1).astype(jnp.int32)
        iy = jnp.clip(y, 0, raster.ny - 1).astype(jnp.int32)
        cx = origin[0] + raster.h * ix
        cy = origin[1] + raster.h * iy
        yield iy, ix, hypot(px - cx, py - cy)


def field_upper(field: chex.Array, origin: chex.Array, raster: Raster, px, py) -> chex.Array:
    """A distance field read at points (px, py f32[...]): the least over the 4 cell
    centres around each of (the centre's value + the way to it), an upper bound of a
    shortest path from the point (inf where no centre is reached)."""
    return functools.reduce(
        jnp.minimum, (field[iy, ix] + d for iy, ix, d in _corners(origin, raster, px, py))
    )


def field_lower(field: chex.Array, origin: chex.Array, raster: Raster, px, py) -> chex.Array:
    """A clearance field read at points: the largest over the 4 cell centres around
    each of (the centre's value - the way to it), a lower bound of the true clearance
    (exact at a centre)."""
    return functools.reduce(
        jnp.maximum, (field[iy, ix] - d for iy, ix, d in _corners(origin, raster, px, py))
    )


def blocks_of(raster: Raster, block: int) -> tuple[int, int]:
    """(nx, ny) of the grid of ``block`` x ``block`` cells of ``raster`` (cell (i, j) of
    the raster is in block (i // block, j // block))."""
    return -(-raster.nx // block), -(-raster.ny // block)


def block_index(
    pos: chex.Array, origin: chex.Array, raster: Raster, block: int
) -> tuple[chex.Array, chex.Array]:
    """(iy, ix) i32[...] each: the block of ``block`` x ``block`` cells holding each
    point of ``pos`` f32[..., 2] (the cell whose centre is nearest), clipped in."""
    nbx, nby = blocks_of(raster, block)
    ix = jnp.round((pos[..., 0] - origin[0]) / raster.h).astype(jnp.int32) // block
    iy = jnp.round((pos[..., 1] - origin[1]) / raster.h).astype(jnp.int32) // block
    return jnp.clip(iy, 0, nby - 1), jnp.clip(ix, 0, nbx - 1)


def free_blocks(maze: Maze, raster: Raster, block: int, radius: float) -> chex.Array:
    """bool[nby, nx]: the blocks of ``block`` x ``block`` cells holding a cell whose
    centre the robot's disc (``radius``) fits at and reaches from the maze's start (a
    finite shortest path through such cells): the world's free cells, pooled."""
    origin = origin_of(maze, raster)
    free = clearance_field(maze, raster) > radius
    reach = jnp.isfinite(goal_distance(free, maze.start[:2], 0.0, origin, raster))
    nbx, nby = blocks_of(raster, block)
    padded = jnp.zeros((nby * block, nbx * block), bool).at[: raster.ny, : raster.nx].set(reach)
    return padded.reshape(nby, block, nbx, block).any(axis=(1, 3))


__all__ = [
    "ORACLE_CELL",
    "PAD",
    "block_index",
    "blocks_of",
    "free_blocks",
    "Raster",
    "centres",
    "clearance_field",
    "field_lower",
    "field_upper",
    "goal_distance",
    "origin_of",
    "raster_for",
]
