"""The LiDAR of a grid maze, walking the lattice its walls stand on: a broad phase.

Testing every wall costs a scan O(walls): an 8 x 8 grid has 144 wall rows, a 16 x 16
grid 544, so its scan costs 30 to 200 times an empty room's (4 walls). But a grid
maze's walls can only stand on the C + 1 vertical and R + 1 horizontal lines of its
lattice, one cell side each. A beam crosses each line once, at a distance that one
multiplication gives (the beam's reciprocal direction is computed once); where it
crosses, the cell side it meets is a row of a bit field, one integer per line, read
with a shift. So a scan costs O(R + C) per beam, with no division and no gather, and
the answer is the one testing every wall gives: the first crossing whose cell side
stands. (``python bench/worlds.py --part lidar``: an 8 x 8 grid's scan 3.5 times an
empty room's, not 64; a 16 x 16 grid's 5.3 times.)

As :func:`jaxnav.world.geometry.ray_segment` does, a crossing counts within 1e-6 of a
wall's length beyond either end (a beam through a corner where only one of two cell
sides stands hits it). Distances agree with
:func:`jaxnav.world.geometry.ray_distances_dir` to float32 rounding
(``t = (line - o) * (1 / d)``, not ``/ d``): the two casters are not bit-identical, so
a configuration uses one throughout (:attr:`jaxnav.env.NavEnv.broad_phase`; ``auto``:
the lattice for every drawn grid maze). Cylinders, if the maze has any, are tested one
by one as before.

Bit fields hold one line's cell sides in an int32, so a lattice walk needs at most
:data:`MAX_LATTICE_CELLS` rows and columns.
"""

from __future__ import annotations

import functools

import chex
import jax.numpy as jnp
import numpy as np

from jaxnav.core.settings import MAX_LATTICE_CELLS
from jaxnav.world.geometry import _EPS, min_over, ray_circle

__all__ = ["MAX_LATTICE_CELLS", "lattice_ranges", "line_bits"]
_U_TOL = 1e-6  # ray_segment's tolerance on the crossing's position along a wall


def line_bits(mask: chex.Array, rows: int, cols: int) -> tuple[chex.Array, chex.Array]:
    """Which cell sides stand, one int32 per lattice line (i32[C + 1], i32[R + 1]): bit
    r + 1 of vertical line k is the wall between row r's cells k - 1 and k (k = 0 and C:
    the boundary), bit c + 1 of horizontal line k the wall below column c's cell in row k
    (bit 0 and the bits above R or C stand for no cell side: nothing stands there).

    ``mask`` bool[2RC + R + C] is a grid maze's ``segment_mask`` in its row order
    (:mod:`jaxnav.world.generators`: internal walls, then bottom, top, left, right)."""
    r, c = rows, cols
    e = r * (c - 1) + (r - 1) * c
    m = mask.astype(jnp.int32)
    row_bit = jnp.left_shift(1, jnp.arange(1, r + 1, dtype=jnp.int32))
    col_bit = jnp.left_shift(1, jnp.arange(1, c + 1, dtype=jnp.int32))
    between_cols = m[: r * (c - 1)].reshape(r, c - 1)  # [row, col]: line col + 1, bit row
    between_rows = m[r * (c - 1) : e].reshape(r - 1, c)  # [row, col]: line row + 1, bit col
    bottom, top = m[e : e + c], m[e + c : e + 2 * c]
    left, right = m[e + 2 * c : e + 2 * c + r], m[e + 2 * c + r :]
    vertical = jnp.concatenate(
        [
            jnp.sum(left * row_bit)[None],
            jnp.sum(between_cols * row_bit[:, None], axis=0),
            jnp.sum(right * row_bit)[None],
        ]
    )
    horizontal = jnp.concatenate(
        [
            jnp.sum(bottom * col_bit)[None],
            jnp.sum(between_rows * col_bit[None, :], axis=1),
            jnp.sum(top * col_bit)[None],
        ]
    )
    return vertical, horizontal


def _first_crossing(lines, bits, o_a, d_a, o_b, d_b, start_b, cell: float):
    """f32[B]: the distance along each beam to the first of ``lines`` (positions along
    axis a, f32[L]) it crosses where that line's cell side stands (inf if none).

    The beams start at (o_a, o_b) with directions (d_a f32[B], d_b f32[B]) along the two
    axes; bit r + 1 of a line's field ``bits`` i32[L] stands for its cell side r, of side
    ``cell`` from ``start_b`` (:func:`line_bits`)."""
    parallel = jnp.abs(d_a) * cell < _EPS  # ray_segment: |cross(d, e)| below EPS
    inv = jnp.where(parallel, jnp.nan, 1.0 / jnp.where(parallel, 1.0, d_a))  # NaN: no hit
    t = (lines - o_a)[:, None] * inv[None, :]  # [L, B]: the beams the minor axis
    per_cell = np.float32(1.0 / cell)
    q = ((o_b - start_b) * per_cell) + t * (d_b * per_cell)[None, :]  # in cells along b
    # The cell side a crossing meets, and the one above it too within the tolerance of
    # a corner: bits below = floor(q - tol) + 1 and above it (0 and 31: no cell side).
    below = jnp.floor(q - _U_TOL)
    both = (q + _U_TOL >= below + 1.0).astype(jnp.int32)
    shift = jnp.where(below < -1.0, 31.0, jnp.minimum(below + 1.0, 31.0)).astype(jnp.int32)
    window = jnp.left_shift(1 + 2 * both, shift)
    hit = ((bits[:, None] & window) != 0) & (t >= 0.0)
    return jnp.min(jnp.where(hit, t, jnp.inf), axis=0)


def lattice_ranges(maze, origin: chex.Array, dirs: chex.Array, grid) -> chex.Array:
    """f32[B]: exact distance along each ray to the first wall or cylinder of a grid
    maze (inf if none), as :func:`jaxnav.world.geometry.ray_distances_dir` gives it.

    Args:
      maze: a maze of ``grid``'s shape (:func:`jaxnav.world.generators.layout_maze`),
        unscaled.
      origin: f32[2] the rays' origin.
      dirs: f32[B, 2] unit ray directions.
      grid: the family's :class:`jaxnav.world.generators.Grid`.
    """
    xs, ys = lattice_lines(grid.rows, grid.cols, grid.cell)
    vertical, horizontal = line_bits(maze.segment_mask, grid.rows, grid.cols)
    ox, oy = origin[0], origin[1]
    dx, dy = dirs[:, 0], dirs[:, 1]
    cell = float(grid.cell)
    t_v = _first_crossing(jnp.asarray(xs), vertical, ox, dx, oy, dy, ys[0], cell)
    t_h = _first_crossing(jnp.asarray(ys), horizontal, oy, dy, ox, dx, xs[0], cell)
    t_c = min_over(functools.partial(ray_circle, ox, oy, dx, dy), maze.circles, maze.circle_mask)
    return jnp.minimum(jnp.minimum(t_v, t_h), t_c)


@functools.cache
def lattice_lines(rows: int, cols: int, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """The lattice's vertical lines' x and horizontal lines' y (f32[C + 1], f32[R + 1]),
    the values the maze's wall rows hold (the grid centred at the origin)."""
    x0, y0 = -cols * cell / 2, -rows * cell / 2
    xs = (x0 + cell * np.arange(cols + 1)).astype(np.float32)
    ys = (y0 + cell * np.arange(rows + 1)).astype(np.float32)
    return xs, ys
