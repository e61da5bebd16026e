"""Occupancy-grid worlds: the LiDAR and the swept disc against a grid of occupied cells,
exactly, branchless, in JAX.

A maze may carry an :class:`Occupancy` beside its walls and cylinders (``Maze.grid``;
None for every other maze, so nothing else changes): an H x W grid of square cells of
side ``res`` whose lower-left corner is ``origin``. An occupied cell is solid: the whole
square (a ROS occupancy map's cell), or a disc of radius ``disc`` <= res / 2 at its
centre (BARN's cylinders, one per cell). Nothing lies outside the grid.

* LiDAR (:func:`grid_ranges`): a beam crosses the lattice lines x = const and y = const
  in turn, and at each crossing enters one cell. The crossings of the ``reach`` lines
  ahead of the beam's origin on each axis are computed at once (no loop, no branch:
  t = (line - u) / d along each axis, the cell entered from the other coordinate there),
  each entered cell is looked up, and the range is the least t at which the beam enters
  a square cell, or meets a disc inside a cell it crosses (a disc lies inside its
  cell, so a beam meets it only while inside that cell). ``reach`` = ceil(range / res) + 1
  lines per axis hold every crossing within the sensor's range, so a scan clipped to it
  is exact.
* Collision (:func:`grid_clearance`): the least distance between the robot centre's path
  over one step (:class:`jaxnav.world.geometry.Arc`) and the occupied cells within
  ``window`` cells of its start. Squares: at the lattice's corners (the path's distance
  to each corner of an occupied cell), the path's ends (their distance to each occupied
  square), and along the lattice lines (where the path crosses a line on an occupied
  cell's side: 0; where the turning circle comes nearest a line: that gap) -- the closed
  form of :func:`jaxnav.world.geometry.arc_segment_clearance` with the lattice's corners
  and lines shared between cells. Discs: the path's distance to each centre less the
  radius. Cells beyond the window are at least ``(window - 1) res`` less the step's
  length away, and the result is capped there: exact wherever it is below that cap
  (:func:`fit` sizes the window so the cap is beyond every distance the environment
  asks about).

``res``, ``disc``, ``reach`` and ``window`` are static (they fix the program), the cells
and the origin are data.
"""

from __future__ import annotations

import math

import chex
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxnav.core.errors import MazeError
from jaxnav.world.geometry import (
    _EPS,
    Arc,
    hypot,
    in_arc,
    point_arc_distance,
    point_segment_distance,
    ray_circle,
)

# Defaults where no environment has sized the walk (fit): ranges exact up to 12 m (a
# Hokuyo UST-10's 10 m and more) and a clearance exact up to 1.4 m from a step's start.
DEFAULT_RANGE = 12.0  # m
DEFAULT_NEAR = 1.4  # m


@struct.dataclass
class Occupancy:
    """An occupancy grid (a pytree; the static fields fix the program).

    Attributes:
      occupied: bool[H, W] which cells are solid; row i spans y in [y0 + i res, y0 +
        (i + 1) res], column j spans x in [x0 + j res, x0 + (j + 1) res].
      origin: f32[2] (x0, y0), the grid's lower-left corner (m).
      res: the cells' side (m).
      disc: 0 (an occupied cell is its whole square) or the radius of the disc at its
        centre that an occupied cell holds (0 < disc <= res / 2).
      reach: lattice lines walked per axis by each beam (:func:`grid_ranges`).
      window: cells either side of the robot's cell tested for collision
        (:func:`grid_clearance`).
    """

    occupied: chex.Array
    origin: chex.Array
    res: float = struct.field(pytree_node=False, default=0.05)
    disc: float = struct.field(pytree_node=False, default=0.0)
    reach: int = struct.field(pytree_node=False, default=1)
    window: int = struct.field(pytree_node=False, default=1)

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W): rows and columns."""
        return tuple(self.occupied.shape[-2:])


def make_occupancy(occupied: np.ndarray, origin, res: float, disc: float = 0.0) -> Occupancy:
    """An :class:`Occupancy` of host arrays, its walk exact up to :data:`DEFAULT_RANGE`
    and its window for clearances up to :data:`DEFAULT_NEAR` (:func:`fit` sizes both for
    an environment)."""
    grid = Occupancy(
        occupied=jnp.asarray(np.asarray(occupied, bool)),
        origin=jnp.asarray(np.asarray(origin, np.float64), jnp.float32),
        res=float(res),
        disc=float(disc),
    )
    return fit(grid, DEFAULT_RANGE, DEFAULT_NEAR)


def sized_for(env, params) -> tuple[float, float]:
    """(range, near) m an occupancy grid is sized for in the environment ``env`` (a
    ``jaxnav.env.NavEnv``) with ``params`` (host side, :func:`fit`): the sensor's range,
    and the robot's radius with its training padding, the proximity distance the
    progress reward reads and the most one step drives."""
    if env.continuous:
        top = float(env.speed_range[1])
    elif params.speeds is not None:
        top = float(jnp.max(jnp.abs(params.speeds)))
    else:
        top = abs(float(params.v))
    extra = 0.0
    if env.reward == "progress" and float(params.proximity_penalty) > 0:
        extra = float(params.proximity_distance)
    near = float(params.robot_radius) + env.collision_margin + extra + top * float(params.dt)
    return float(params.max_range), near


def window_for(near: float, res: float) -> int:
    """The window (cells either side) whose clearance is exact up to ``near`` metres from
    the step's start: cells beyond it are at least (window - 1) res away."""
    return int(math.ceil(near / res - 1e-9)) + 1


def fit(grid: Occupancy, max_range: float, near: float) -> Occupancy:
    """``grid`` walked only as far as a sensor of range ``max_range`` sees (exact after
    clipping to it) and tested for collision over a window exact up to ``near`` metres
    from a step's start (the robot's radius, padding, proximity distance and the most a
    step drives)."""
    reach = int(math.ceil(max_range / grid.res - 1e-9)) + 1
    return grid.replace(reach=reach, window=window_for(near, grid.res))


# ----------------------------------------------------------------------------
# The LiDAR
# ----------------------------------------------------------------------------


def _lookup(occupied: chex.Array, row: chex.Array, col: chex.Array) -> chex.Array:
    """bool[...]: whether cell (row, col) (i32[...]) is occupied; False off the grid."""
    h, w = occupied.shape
    inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
    return occupied[jnp.clip(row, 0, h - 1), jnp.clip(col, 0, w - 1)] & inside


def _axis_hits(grid: Occupancy, table, u, w, du, dv, ox, oy, dx, dy, vertical: bool):
    """f32[B]: the least distance (m) at which the beams meet a solid cell they enter
    across the ``reach`` lattice lines ahead along one axis (vertical lines: u, du along
    x; horizontal: along y), inf where none. ``table``: the cells flattened row by row,
    one False appended for every cell off the grid.

    Kept as one expression per crossing, reduced at once, so that the compiler fuses
    the walk into one loop with its lookup (no [B, reach] array is written out)."""
    h, wd = grid.shape
    k = jnp.arange(1, grid.reach + 1, dtype=jnp.float32)
    cu = jnp.floor(u)
    ahead = du[:, None] > 0.0
    line = jnp.where(ahead, cu + k[None, :], cu + 1.0 - k[None, :])  # [B, reach]
    parallel = jnp.abs(du) < _EPS
    inv = jnp.where(parallel, 0.0, 1.0 / jnp.where(parallel, 1.0, du))
    t = (line - u) * inv[:, None]  # cells along the beam
    other = jnp.floor(w + t * dv[:, None])
    cell = jnp.where(ahead, line, line - 1.0)
    row, col = (other, cell) if vertical else (cell, other)
    inside = (row >= 0.0) & (row < h) & (col >= 0.0) & (col < wd) & ~parallel[:, None]
    idx = jnp.where(inside, row * wd + col, h * wd).astype(jnp.int32)
    solid = table[idx]
    if grid.disc > 0.0:  # the disc inside each solid cell entered
        cx = grid.origin[0] + (col + 0.5) * grid.res
        cy = grid.origin[1] + (row + 0.5) * grid.res
        hit = ray_circle(ox, oy, dx[:, None], dy[:, None], cx, cy, grid.disc)
        return jnp.min(jnp.where(solid, hit, jnp.inf), axis=1)
    return jnp.min(jnp.where(solid, t, jnp.inf), axis=1) * np.float32(grid.res)


def grid_ranges(grid: Occupancy, origin: chex.Array, dirs: chex.Array) -> chex.Array:
    """f32[B]: the distance along each ray (origin f32[2], unit directions f32[B, 2]) to
    the first occupied cell's surface (inf if none within the walk's reach)."""
    per = np.float32(1.0 / grid.res)
    ox, oy = origin[0], origin[1]
    u = (ox - grid.origin[0]) * per
    w = (oy - grid.origin[1]) * per
    dx, dy = dirs[:, 0], dirs[:, 1]
    table = jnp.concatenate([grid.occupied.reshape(-1), jnp.zeros(1, bool)])
    t = jnp.minimum(
        _axis_hits(grid, table, u, w, dx, dy, ox, oy, dx, dy, vertical=True),
        _axis_hits(grid, table, w, u, dy, dx, ox, oy, dx, dy, vertical=False),
    )
    # the cell the beams start in
    own = _lookup(grid.occupied, jnp.floor(w).astype(jnp.int32), jnp.floor(u).astype(jnp.int32))
    if grid.disc > 0.0:
        cx = grid.origin[0] + (jnp.floor(u) + 0.5) * grid.res
        cy = grid.origin[1] + (jnp.floor(w) + 0.5) * grid.res
        inner = ray_circle(ox, oy, dx, dy, cx, cy, grid.disc)
        return jnp.minimum(t, jnp.where(own, inner, jnp.inf))
    return jnp.where(own, 0.0, t)


# ----------------------------------------------------------------------------
# The swept disc
# ----------------------------------------------------------------------------


def _point_path(path: Arc, px, py) -> chex.Array:
    """Distance from points (px, py f32[...]) to the centre's path over the step."""
    line = point_segment_distance(px, py, path.x0, path.y0, path.x1, path.y1)
    return jnp.where(path.straight, line, point_arc_distance(path, px, py))


def _window(grid: Occupancy, x, y):
    """The cells within ``window`` of the one holding (x, y): their occupancy
    bool[n, n] (rows, cols; n = 2 window + 1) and the window's lower-left cell (row,
    col) i32[] each."""
    k = grid.window
    per = np.float32(1.0 / grid.res)
    r0 = jnp.floor((y - grid.origin[1]) * per).astype(jnp.int32) - k
    c0 = jnp.floor((x - grid.origin[0]) * per).astype(jnp.int32) - k
    idx = jnp.arange(2 * k + 1, dtype=jnp.int32)
    occ = _lookup(grid.occupied, (r0 + idx)[:, None], (c0 + idx)[None, :])
    return occ, r0, c0


def _reach(path: Arc) -> chex.Array:
    """f32[]: the farthest the path gets from its start (the chord for a turn of at most
    pi, else the circle's diameter)."""
    chord = hypot(path.x1 - path.x0, path.y1 - path.y0)
    return jnp.where(path.straight | path.half_turn, chord, jnp.maximum(chord, 2 * path.rad))


def grid_clearance(grid: Occupancy, path: Arc) -> chex.Array:
    """f32[]: the least distance between the centre's path over one step and any
    occupied cell within the window, capped at what the window guarantees ((window - 1)
    res less the farthest the path gets from its start)."""
    res = grid.res
    occ, r0, c0 = _window(grid, path.x0, path.y0)
    n = occ.shape[0]
    idx = jnp.arange(n + 1, dtype=jnp.float32)
    xs = grid.origin[0] + (c0.astype(jnp.float32) + idx) * res  # lattice lines [n + 1]
    ys = grid.origin[1] + (r0.astype(jnp.float32) + idx) * res
    cap = (grid.window - 1) * res - _reach(path)
    if grid.disc > 0.0:
        cx = 0.5 * (xs[:-1] + xs[1:])
        cy = 0.5 * (ys[:-1] + ys[1:])
        d = _point_path(path, cx[None, :], cy[:, None]) - grid.disc
        return jnp.minimum(jnp.min(jnp.where(occ, d, jnp.inf)), cap)
    pad = jnp.pad(occ, 1)  # [n + 2, n + 2]: pad[i + 1, j + 1] is cell (i, j)
    # the corners of occupied cells
    corner = pad[:-1, :-1] | pad[1:, :-1] | pad[:-1, 1:] | pad[1:, 1:]  # [n + 1, n + 1]
    d_corner = jnp.min(jnp.where(corner, _point_path(path, xs[None, :], ys[:, None]), jnp.inf))
    # the path's ends to each occupied square
    half = 0.5 * res
    cx, cy = 0.5 * (xs[:-1] + xs[1:]), 0.5 * (ys[:-1] + ys[1:])

    def to_squares(px, py):
        gx = jnp.maximum(jnp.abs(px - cx[None, :]) - half, 0.0)
        gy = jnp.maximum(jnp.abs(py - cy[:, None]) - half, 0.0)
        return jnp.min(jnp.where(occ, hypot(gx, gy), jnp.inf))

    d_ends = jnp.minimum(to_squares(path.x0, path.y0), to_squares(path.x1, path.y1))
    d_lines = jnp.minimum(
        _line_contacts(path, xs, ys, pad, res, vertical=True),
        _line_contacts(path, ys, xs, pad.T, res, vertical=False),
    )
    return jnp.minimum(jnp.minimum(jnp.minimum(d_corner, d_ends), d_lines), cap)


def _line_contacts(path: Arc, lines, across, pad, res: float, vertical: bool) -> chex.Array:
    """f32[]: the path's contacts with the occupied cells' sides on the window's lattice
    lines of one direction (``lines`` f32[n + 1] their positions, ``across`` the other
    direction's, ``pad`` the window's occupancy padded by a free cell, transposed for
    horizontal lines so that its second axis runs across the lines): 0 where the path
    crosses a line on an occupied cell's side, the gap where the turning circle comes
    nearest a line there (and the nearest point is on the arc), else inf."""
    if vertical:
        a0, b0, a1, b1, ca, cb = path.x0, path.y0, path.x1, path.y1, path.cx, path.cy
    else:
        a0, b0, a1, b1, ca, cb = path.y0, path.x0, path.y1, path.x1, path.cy, path.cx
    n1 = lines.shape[0]
    per = np.float32(1.0 / res)
    j = jnp.arange(n1)

    def side(b):  # bool[n + 1]: the line's cell side at coordinate b (f32[n + 1]) is solid
        i = jnp.floor((b - across[0]) * per).astype(jnp.int32) + 1  # pad row
        i = jnp.clip(i, 0, pad.shape[0] - 1)
        return pad[i, j] | pad[i, j + 1]

    def at(a, b):  # the point on the line, as (x, y)
        return (a, b) if vertical else (b, a)

    # straight path: where the segment crosses each line
    da = a1 - a0
    s = (lines - a0) / jnp.where(jnp.abs(da) < _EPS, 1.0, da)
    crosses = (jnp.abs(da) >= _EPS) & (s >= 0.0) & (s <= 1.0)
    straight = jnp.where(crosses & side(b0 + s * (b1 - b0)), 0.0, jnp.inf)
    # arc: the circle's crossings of each line, and its nearest approach to it
    h = lines - ca
    rad = path.rad
    cut = jnp.sqrt(jnp.maximum(rad * rad - h * h, 0.0))
    curved = jnp.full(lines.shape, jnp.inf)
    for sgn in (-1.0, 1.0):
        b = cb + sgn * cut
        on = (jnp.abs(h) < rad) & in_arc(path, *at(lines, b)) & side(b)
        curved = jnp.where(on, 0.0, curved)
    foot = (
        (jnp.abs(h) >= rad) & in_arc(path, *at(lines, cb)) & side(jnp.broadcast_to(cb, lines.shape))
    )
    curved = jnp.minimum(curved, jnp.where(foot, jnp.abs(h) - rad, jnp.inf))
    return jnp.min(jnp.where(path.straight, straight, curved))


# ----------------------------------------------------------------------------
# Clearance of points (the oracle's raster)
# ----------------------------------------------------------------------------


def point_clearance(
    grid: Occupancy, px: chex.Array, py: chex.Array, near: float = 0.0
) -> chex.Array:
    """f32[P]: each point's (px, py f32[P]) distance to the nearest occupied cell's
    surface within a window around it (the grid's, or wider to be exact up to ``near``
    m), capped at (window - 1) res (negative inside a disc; 0 inside a square)."""
    res = grid.res
    k = max(grid.window, window_for(near, res))
    per = np.float32(1.0 / res)
    r0 = jnp.floor((py - grid.origin[1]) * per).astype(jnp.int32) - k  # [P]
    c0 = jnp.floor((px - grid.origin[0]) * per).astype(jnp.int32) - k
    idx = jnp.arange(2 * k + 1, dtype=jnp.int32)
    rows = r0[:, None, None] + idx[None, :, None]  # [P, n, 1]
    cols = c0[:, None, None] + idx[None, None, :]  # [P, 1, n]
    occ = _lookup(grid.occupied, rows, cols)  # [P, n, n]
    cx = grid.origin[0] + (cols.astype(jnp.float32) + 0.5) * res
    cy = grid.origin[1] + (rows.astype(jnp.float32) + 0.5) * res
    dx, dy = px[:, None, None] - cx, py[:, None, None] - cy
    if grid.disc > 0.0:
        d = hypot(dx, dy) - grid.disc
    else:
        half = 0.5 * res
        d = hypot(jnp.maximum(jnp.abs(dx) - half, 0.0), jnp.maximum(jnp.abs(dy) - half, 0.0))
    d = jnp.min(jnp.where(occ, d, jnp.inf), axis=(1, 2))
    return jnp.minimum(d, (k - 1) * res)


def stack_grids(grids: list) -> Occupancy | None:
    """Mazes' occupancy grids (each an :class:`Occupancy` or None) padded with free cells
    to one shape and stacked (a maze without one gets an empty grid), or None when none
    has one."""
    if all(g is None for g in grids):
        return None
    real = [g for g in grids if g is not None]
    if len({(g.res, g.disc) for g in real}) > 1:
        raise MazeError(
            "mazes of occupancy grids of different resolutions or cell shapes cannot be "
            "tested together: give them in separate tests"
        )
    h = max(g.shape[0] for g in real)
    w = max(g.shape[1] for g in real)
    template = real[0]
    rows = []
    for g in grids:
        occ = jnp.zeros((h, w), bool) if g is None else g.occupied
        occ = jnp.pad(occ, ((0, h - occ.shape[0]), (0, w - occ.shape[1])))
        origin = jnp.full(2, 1.0e4, jnp.float32) if g is None else g.origin
        rows.append((occ, origin))
    return template.replace(
        occupied=jnp.stack([r[0] for r in rows]),
        origin=jnp.stack([r[1] for r in rows]),
        reach=max(g.reach for g in real),
        window=max(g.window for g in real),
    )


# ----------------------------------------------------------------------------
# Host side: the grid as walls and cylinders (drawing, shortest paths, MuJoCo)
# ----------------------------------------------------------------------------


def grid_walls(grid: Occupancy) -> np.ndarray:
    """f64[N, 4]: a square-cell grid's outline as wall segments (x1, y1, x2, y2): the
    cell sides between an occupied cell and a free one (or the grid's edge), joined
    along each lattice line where they run on; none for a disc grid."""
    if grid.disc > 0.0:
        return np.zeros((0, 4))
    occ = np.pad(np.asarray(grid.occupied, bool), 1)  # free beyond the grid
    x0, y0 = (float(v) for v in np.asarray(grid.origin, np.float64))
    res = grid.res
    out = []
    # vertical lines x = x0 + k res (k = 0..W): between columns k - 1 and k of each row
    vertical = occ[1:-1, :-1] != occ[1:-1, 1:]  # [H, W + 1]
    for k, i0, i1 in _runs(vertical.T):
        x = x0 + k * res
        out.append((x, y0 + i0 * res, x, y0 + i1 * res))
    horizontal = occ[:-1, 1:-1] != occ[1:, 1:-1]  # [H + 1, W]
    for k, j0, j1 in _runs(horizontal):
        y = y0 + k * res
        out.append((x0 + j0 * res, y, x0 + j1 * res, y))
    return np.asarray(out, np.float64).reshape(-1, 4)


def _runs(edges: np.ndarray):
    """(line, first, end) of every run of True along the second axis of bool[L, M]."""
    for k, row in enumerate(edges):
        d = np.diff(np.concatenate([[0], row.astype(np.int8), [0]]))
        for a, b in zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]):
            yield k, int(a), int(b)


def grid_circles(grid: Occupancy) -> np.ndarray:
    """f64[M, 3]: a disc grid's occupied cells as cylinders (x, y, r); none for squares."""
    if grid.disc <= 0.0:
        return np.zeros((0, 3))
    rows, cols = np.nonzero(np.asarray(grid.occupied, bool))
    x0, y0 = (float(v) for v in np.asarray(grid.origin, np.float64))
    cx = x0 + (cols + 0.5) * grid.res
    cy = y0 + (rows + 0.5) * grid.res
    return np.stack([cx, cy, np.full(len(cx), grid.disc)], axis=1)


def host_clearance(grid: Occupancy, pts: np.ndarray) -> np.ndarray:
    """f64[P]: host side, a lower bound of each point's (f64[P, 2]) distance to the
    occupied cells' surfaces, exact for discs and within res / sqrt 2 for squares (the
    nearest cell centre's distance less the half diagonal), +inf without any cell;
    0 inside a square."""
    from scipy.spatial import cKDTree

    rows, cols = np.nonzero(np.asarray(grid.occupied, bool))
    if len(rows) == 0:
        return np.full(len(pts), np.inf)
    x0, y0 = (float(v) for v in np.asarray(grid.origin, np.float64))
    centres = np.stack([x0 + (cols + 0.5) * grid.res, y0 + (rows + 0.5) * grid.res], axis=1)
    d, _ = cKDTree(centres).query(pts)
    if grid.disc > 0.0:
        return d - grid.disc
    inside = _host_solid(grid, pts)
    return np.where(inside, 0.0, np.maximum(d - grid.res / math.sqrt(2.0), 0.0))


def exact_clearance(grid: Occupancy, pts: np.ndarray) -> np.ndarray:
    """f64[P]: host side, each point's exact distance to the occupied cells' surfaces
    (for a few points: the cells near each are searched one point at a time)."""
    from scipy.spatial import cKDTree

    rows, cols = np.nonzero(np.asarray(grid.occupied, bool))
    if len(rows) == 0:
        return np.full(len(pts), np.inf)
    x0, y0 = (float(v) for v in np.asarray(grid.origin, np.float64))
    centres = np.stack([x0 + (cols + 0.5) * grid.res, y0 + (rows + 0.5) * grid.res], axis=1)
    tree = cKDTree(centres)
    nearest, _ = tree.query(pts)
    out = np.empty(len(pts))
    for k, (p, d1) in enumerate(zip(pts, nearest)):
        near = centres[tree.query_ball_point(p, d1 + grid.res)]  # every cell at most d1 away
        dx, dy = np.abs(near[:, 0] - p[0]), np.abs(near[:, 1] - p[1])
        if grid.disc > 0.0:
            out[k] = np.min(np.hypot(dx, dy)) - grid.disc
        else:
            half = grid.res / 2
            out[k] = np.min(np.hypot(np.maximum(dx - half, 0), np.maximum(dy - half, 0)))
    return out


def _host_solid(grid: Occupancy, pts: np.ndarray) -> np.ndarray:
    """bool[P]: the points lie in an occupied cell (its square)."""
    occ = np.asarray(grid.occupied, bool)
    x0, y0 = (float(v) for v in np.asarray(grid.origin, np.float64))
    j = np.floor((pts[:, 0] - x0) / grid.res).astype(np.int64)
    i = np.floor((pts[:, 1] - y0) / grid.res).astype(np.int64)
    ok = (i >= 0) & (i < occ.shape[0]) & (j >= 0) & (j < occ.shape[1])
    out = np.zeros(len(pts), bool)
    out[ok] = occ[i[ok], j[ok]]
    return out


__all__ = [
    "DEFAULT_NEAR",
    "DEFAULT_RANGE",
    "Occupancy",
    "fit",
    "grid_circles",
    "grid_clearance",
    "grid_ranges",
    "grid_walls",
    "exact_clearance",
    "host_clearance",
    "make_occupancy",
    "point_clearance",
    "sized_for",
    "stack_grids",
    "window_for",
]
