"""Procedural mazes drawn inside jit: the ``grid`` family, its shortest paths and its
train/test split.

A ``grid`` maze is an R x C grid of square cells of side ``cell`` metres, centred at
the origin. Its internal walls are carved by randomised Kruskal (walls visited in a
random order, each opened when it joins two cells not yet connected, the cells'
labels merged in one vectorised step), which gives a perfect maze: every cell
reachable, exactly R*C - 1 open internal walls, one path between any two cells.
``loops`` then opens that fraction of the remaining closed walls (a fixed number,
``round(loops * (E - R*C + 1))`` of the E internal walls), chosen at random, to
make loops. Everything is fixed-shape: ``lax.fori_loop`` over the E walls, no Python
loop over time, so a maze is drawn per episode inside the compiled step and vmaps
over runs.

Cells are numbered ``r * C + c`` (row r from the bottom, column c from the left).
Internal walls are numbered: first the R(C-1) walls between (r, c) and (r, c+1), at
``r * (C-1) + c``, then the (R-1)C walls between (r, c) and (r+1, c), at
``R(C-1) + r * C + c``. A maze as a :class:`jaxnav.world.maps.Maze` has
``2RC + R + C`` segment rows: the E internal walls (a closed one real, an open one a
masked far-away row, as :func:`jaxnav.world.maps.pad_maze` pads), then the 2R + 2C
boundary walls, one per cell side, always real. Its goal points are the cell
centres (``cell / 2`` from every wall) and its start pose the centre of a start cell.

Shortest paths: :func:`cell_distances` is breadth-first search over the open walls,
all sources at once, rounds of relaxation until nothing changes (at most R*C - 1: no
path in a connected graph of R*C cells is longer). Start and goal cells are drawn
uniformly among the pairs at least ``min_path`` steps apart (a pair always exists for
``min_path <= R + C - 2``: corner to opposite corner is that far on any maze, a path
being at least the Manhattan distance).

Train/test split: a maze's split is a function of its layout alone, one bit of a
hash of its open walls (:func:`layout_split`). A draw carves candidate mazes from
successive keys until one of the requested split comes up (two tries on average), so
a train maze and a test maze can never be the same layout.
"""

from __future__ import annotations

from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.world.geometry import hypot, norm2
from jaxnav.world.lattice import lattice_lines, lattice_ranges
from jaxnav.world.maps import _FAR, ROBOTIS_ARENA, Maze

SPLITS = ("train", "test")
# The ROBOTIS goal table a Maze carries (the generated mazes fill it with cell centres).
_ROBOTIS_ROWS = 256
_UNREACHED = 1 << 20  # the distance of a cell not (yet) reached
_SPLIT_SALT = 0x6A09E667  # fixes the layout hash


class Grid(NamedTuple):
    """The static shape of a grid family (hashable: it fixes array shapes), the ``grid``
    family of :mod:`jaxnav.core.families`: :meth:`draw` gives a maze and its first goal,
    :meth:`cell_distances` and :meth:`geodesic_target` its shortest paths."""

    rows: int
    cols: int
    cell: float = 1.0
    loops: float = 0.0
    min_path: int = 1  # cells between the start and the first goal along the maze, at least

    @property
    def n_cells(self) -> int:
        return self.rows * self.cols

    @property
    def n_walls(self) -> int:
        """Internal walls, E = R(C-1) + (R-1)C."""
        return self.rows * (self.cols - 1) + (self.rows - 1) * self.cols

    @property
    def n_segments(self) -> int:
        """Segment rows of the maze: every wall, 2RC + R + C."""
        return 2 * self.n_cells + self.rows + self.cols

    @property
    def n_extra_open(self) -> int:
        """Walls opened beyond the perfect maze's R*C - 1 to make loops."""
        closed = self.n_walls - (self.n_cells - 1)
        return int(round(self.loops * closed))

    @property
    def max_min_path(self) -> int:
        """The longest minimum start-goal path that every maze allows: R + C - 2."""
        return self.rows + self.cols - 2

    def draw(self, key: chex.PRNGKey, split: str = "train") -> tuple[Maze, chex.Array]:
        """(maze, goal f32[2]) of ``split``, the goal ``min_path`` cells away
        (:func:`draw_maze`)."""
        return draw_maze(key, self, split, self.min_path)

    def cell_distances(self, maze: Maze) -> chex.Array:
        """i16[RC, RC]: the cells' distances through a drawn maze
        (:func:`maze_cell_distances`)."""
        return maze_cell_distances(maze, self)

    def geodesic_target(
        self, maze: Maze, cell_dist: chex.Array, pos: chex.Array, goal: chex.Array
    ) -> tuple[chex.Array, chex.Array]:
        """Where the shortest path from ``pos`` to ``goal`` heads next, and its length
        (:func:`geodesic_target`)."""
        return geodesic_target(maze, cell_dist, self, pos, goal)

    def beam_ranges(self, maze: Maze, origin: chex.Array, dirs: chex.Array) -> chex.Array:
        """f32[B]: the exact ranges of rays ``dirs`` f32[B, 2] from ``origin`` in a maze
        of this shape, walking its lattice (:func:`jaxnav.world.lattice.lattice_ranges`)."""
        return lattice_ranges(maze, origin, dirs, self)

    def waypoint(
        self, maze: Maze, cell_dist: chex.Array, pos: chex.Array, goal: chex.Array, lookahead
    ) -> chex.Array:
        """f32[2]: the point ``lookahead`` m along the shortest path from ``pos`` to
        ``goal`` through the openings in the walls' middles (:func:`carrot`)."""
        closed = maze.segment_mask[: self.n_walls]
        points = path_points(cell_dist, self, pos, goal, closed, wall_middles(self))
        return carrot(pos, points, lookahead)


def grid_family(env) -> Grid:
    """The grid family of ``env``'s settings (an EnvConfig or a ``jaxnav.env.NavEnv``)."""
    return Grid(env.grid_rows, env.grid_cols, env.grid_cell, env.grid_loops, env.min_path_cells)


# ----------------------------------------------------------------------------
# The cell graph
# ----------------------------------------------------------------------------


def wall_cells(grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """The two cells (a, b) i32[E] each internal wall separates, in wall order."""
    r, c = grid.rows, grid.cols
    rr, cc = np.meshgrid(np.arange(r), np.arange(c - 1), indexing="ij")
    a_h = (rr * c + cc).ravel()
    rr, cc = np.meshgrid(np.arange(r - 1), np.arange(c), indexing="ij")
    a_v = (rr * c + cc).ravel()
    a = np.concatenate([a_h, a_v]).astype(np.int32)
    b = np.concatenate([a_h + 1, a_v + c]).astype(np.int32)
    return a, b


def carve(key: chex.PRNGKey, grid: Grid) -> chex.Array:
    """bool[E]: which internal walls are open (randomised Kruskal, then the loops)."""
    a, b = (jnp.asarray(x) for x in wall_cells(grid))
    k_order, k_loops = jax.random.split(key)
    order = jax.random.permutation(k_order, grid.n_walls)

    def visit(i, carry):
        label, open_ = carry
        w = order[i]
        la, lb = label[a[w]], label[b[w]]
        join = la != lb
        label = jnp.where(join & (label == la), lb, label)
        return label, open_.at[w].set(join)

    label0 = jnp.arange(grid.n_cells, dtype=jnp.int32)
    open0 = jnp.zeros(grid.n_walls, bool)
    _, open_ = jax.lax.fori_loop(0, grid.n_walls, visit, (label0, open0))
    k = grid.n_extra_open
    if k:  # the k closed walls of highest random priority
        priority = jnp.where(open_, -1.0, jax.random.uniform(k_loops, (grid.n_walls,)))
        _, extra = jax.lax.top_k(priority, k)
        open_ = open_.at[extra].set(True)
    return open_


def cell_neighbours(grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """(neighbour i32[RC, 4], wall i32[RC, 4]): each cell's right, left, upper and lower
    neighbour and the internal wall between them; a missing one (the grid's edge) is
    the cell itself through wall -1."""
    r, c = grid.rows, grid.cols
    v0 = r * (c - 1)
    nbr = np.tile(np.arange(r * c)[:, None], (1, 4)).astype(np.int32)
    wall = np.full((r * c, 4), -1, np.int32)
    for row in range(r):
        for col in range(c):
            i = row * c + col
            if col < c - 1:
                nbr[i, 0], wall[i, 0] = i + 1, row * (c - 1) + col
            if col > 0:
                nbr[i, 1], wall[i, 1] = i - 1, row * (c - 1) + col - 1
            if row < r - 1:
                nbr[i, 2], wall[i, 2] = i + c, v0 + row * c + col
            if row > 0:
                nbr[i, 3], wall[i, 3] = i - c, v0 + (row - 1) * c + col
    return nbr, wall


def cell_distances(open_: chex.Array, grid: Grid) -> chex.Array:
    """i32[RC, RC]: path length in cells between every two cells through the open walls
    (breadth-first, all sources at once: each round every cell takes its open
    neighbours' distances plus one, a gather rather than a scatter, until a round
    changes nothing); a large number for unreachable pairs."""
    nbr, wall = cell_neighbours(grid)
    n = grid.n_cells
    passable = jnp.asarray(wall >= 0) & open_[jnp.asarray(np.maximum(wall, 0))]  # [RC, 4]
    d0 = jnp.where(jnp.eye(n, dtype=bool), 0, _UNREACHED).astype(jnp.int32)

    def expand(carry):
        i, d, _ = carry
        via = jnp.where(passable[None], d[:, jnp.asarray(nbr)] + 1, _UNREACHED)  # [RC, RC, 4]
        new = jnp.minimum(d, via.min(-1))
        return i + 1, new, jnp.any(new != d)

    def again(carry):
        i, _, changed = carry
        return changed & (i < n - 1)

    _, d, _ = jax.lax.while_loop(again, expand, (jnp.int32(0), d0, jnp.bool_(n > 1)))
    return d


def layout_split(open_: chex.Array) -> chex.Array:
    """i32[]: 0 (train) or 1 (test), a hash bit of the layout (its open walls) alone."""
    e = open_.shape[-1]
    consts = jax.random.bits(jax.random.PRNGKey(_SPLIT_SALT), (e,), jnp.uint32)
    h = jnp.bitwise_xor.reduce(jnp.where(open_, consts, jnp.uint32(0)), axis=-1)
    # murmur3's finaliser: every bit of h decides the top bit.
    h = h ^ (h >> 16)
    h = h * jnp.uint32(0x85EBCA6B)
    h = h ^ (h >> 13)
    h = h * jnp.uint32(0xC2B2AE35)
    h = h ^ (h >> 16)
    return (h >> 31).astype(jnp.int32)


def carve_split(key: chex.PRNGKey, grid: Grid, split: str) -> chex.Array:
    """bool[E]: a maze of ``split`` ("train" or "test"): candidates carved from
    ``fold_in(key, i)``, i = 0, 1, ..., until one's :func:`layout_split` matches."""
    want = SPLITS.index(split)

    def candidate(i):
        return carve(jax.random.fold_in(key, i), grid)

    def again(carry):
        _, open_ = carry
        return layout_split(open_) != want

    def next_(carry):
        i, _ = carry
        return i + 1, candidate(i + 1)

    _, open_ = jax.lax.while_loop(again, next_, (jnp.int32(0), candidate(0)))
    return open_


# ----------------------------------------------------------------------------
# The maze of a layout
# ----------------------------------------------------------------------------


def _geometry(grid: Grid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(internal wall segments f32[E, 4], boundary segments f32[2R+2C, 4], cell centres
    f32[RC, 2]), the grid centred at the origin."""
    r, c, s = grid.rows, grid.cols, grid.cell
    x0, y0 = -c * s / 2, -r * s / 2
    a, b = wall_cells(grid)
    ar, ac = a // c, a % c
    horizontal_neighbour = b == a + 1  # a vertical wall at the cell's right side
    x_right, y_top = x0 + (ac + 1) * s, y0 + (ar + 1) * s
    x_left, y_bottom = x0 + ac * s, y0 + ar * s
    inner = np.where(
        horizontal_neighbour[:, None],
        np.stack([x_right, y_bottom, x_right, y_top], 1),
        np.stack([x_left, y_top, x_right, y_top], 1),
    )
    xs, ys = lattice_lines(r, c, s)  # the lines the LiDAR's lattice walk reads
    bottom = np.stack([xs[:-1], np.full(c, ys[0]), xs[1:], np.full(c, ys[0])], 1)
    top = np.stack([xs[:-1], np.full(c, ys[-1]), xs[1:], np.full(c, ys[-1])], 1)
    left = np.stack([np.full(r, xs[0]), ys[:-1], np.full(r, xs[0]), ys[1:]], 1)
    right = np.stack([np.full(r, xs[-1]), ys[:-1], np.full(r, xs[-1]), ys[1:]], 1)
    boundary = np.concatenate([bottom, top, left, right])
    centre_y, centre_x = y0 + s * (np.arange(r) + 0.5), x0 + s * (np.arange(c) + 0.5)
    cy, cx = np.meshgrid(centre_y, centre_x, indexing="ij")
    centres = np.stack([cx.ravel(), cy.ravel()], 1)
    return inner.astype(np.float32), boundary.astype(np.float32), centres.astype(np.float32)


def layout_maze(open_: chex.Array, grid: Grid, start_cell: chex.Array, yaw: chex.Array) -> Maze:
    """The :class:`Maze` of a carved layout, the robot in ``start_cell`` facing ``yaw``."""
    inner, boundary, centres = (jnp.asarray(x) for x in _geometry(grid))
    segments = jnp.concatenate([jnp.where(open_[:, None], _FAR, inner), boundary])
    mask = jnp.concatenate([~open_, jnp.ones(len(boundary), bool)])
    size = max(grid.rows, grid.cols) * grid.cell
    half = jnp.asarray([grid.cols, grid.rows], jnp.float32) * (grid.cell / 2)
    start = jnp.concatenate([centres[start_cell], jnp.reshape(yaw, (1,))]).astype(jnp.float32)
    return Maze(
        segments=segments.astype(jnp.float32),
        segment_mask=mask,
        circles=jnp.asarray([[_FAR, _FAR, 0.0]], jnp.float32),
        circle_mask=jnp.zeros(1, bool),
        start=start,
        goal_points=centres,
        n_goal_points=jnp.asarray(grid.n_cells, jnp.int32),
        bounds=jnp.concatenate([-half, half]),
        n_obstacles=jnp.asarray(0, jnp.int32),
        robotis_goals=jnp.resize(centres, (_ROBOTIS_ROWS, 2)),
        n_robotis_goals=jnp.asarray(grid.n_cells, jnp.int32),
        robotis_scale=jnp.asarray(size / ROBOTIS_ARENA, jnp.float32),
    )


class Draw(NamedTuple):
    """One drawn maze: its layout, start and goal cells and the path between them."""

    open: chex.Array  # bool[E] open internal walls
    start_cell: chex.Array  # i32[]
    goal_cell: chex.Array  # i32[]
    path_cells: chex.Array  # i32[] shortest path from start to goal, in cells


def draw(key: chex.PRNGKey, grid: Grid, split: str = "train", min_path: int = 1) -> Draw:
    """A maze of ``split`` and a start and goal cell pair drawn uniformly among those at
    least ``min_path`` cells apart (at least 1: different cells)."""
    k_maze, k_pair = jax.random.split(key)
    open_ = carve_split(k_maze, grid, split)
    dist = cell_distances(open_, grid)
    n = grid.n_cells
    ok = dist >= max(min_path, 1)
    ok &= dist < _UNREACHED
    priority = jnp.where(ok, jax.random.uniform(k_pair, (n, n)), -1.0)
    pair = jnp.argmax(priority.ravel())
    s, g = pair // n, pair % n
    return Draw(open_, s.astype(jnp.int32), g.astype(jnp.int32), dist[s, g])


def draw_maze(
    key: chex.PRNGKey, grid: Grid, split: str = "train", min_path: int = 1
) -> tuple[Maze, chex.Array]:
    """(maze, goal f32[2]): a maze of ``split`` with the robot at the centre of its start
    cell facing a uniform yaw, and the centre of a goal cell ``min_path`` cells away."""
    k_draw, k_yaw = jax.random.split(key)
    d = draw(k_draw, grid, split, min_path)
    yaw = jax.random.uniform(k_yaw, (), jnp.float32, -jnp.pi, jnp.pi)
    maze = layout_maze(d.open, grid, d.start_cell, yaw)
    return maze, maze.goal_points[d.goal_cell]


# ----------------------------------------------------------------------------
# Shortest paths inside a drawn maze (the geodesic reward)
# ----------------------------------------------------------------------------


def maze_cell_distances(maze: Maze, grid: Grid) -> chex.Array:
    """i16[RC, RC]: :func:`cell_distances` of a grid maze, read from its closed walls
    (its first E segment rows are the internal walls, real when closed)."""
    open_ = ~maze.segment_mask[: grid.n_walls]
    return cell_distances(open_, grid).astype(jnp.int16)


def _cell_of(p: chex.Array, grid: Grid) -> tuple[chex.Array, chex.Array]:
    """(row, column) i32[] of the cell holding the point ``p`` (clipped to the grid)."""
    col = jnp.floor(p[0] / grid.cell + grid.cols / 2).astype(jnp.int32)
    row = jnp.floor(p[1] / grid.cell + grid.rows / 2).astype(jnp.int32)
    return jnp.clip(row, 0, grid.rows - 1), jnp.clip(col, 0, grid.cols - 1)


def _centre(row, col, grid: Grid) -> chex.Array:
    return jnp.stack([(col + 0.5 - grid.cols / 2), (row + 0.5 - grid.rows / 2)]) * grid.cell


def _next_cell(
    r, c, there, cell_dist: chex.Array, closed: chex.Array, grid: Grid
) -> tuple[chex.Array, chex.Array, chex.Array, chex.Array]:
    """(move, wall, row, col) of the step from cell (r, c) to the neighbour one step
    nearer the cell ``there``: the first of right, left, up, down (move 0-3) through an
    open wall; move -1 where there is none (in ``there``, or cut off)."""
    cols, rows = grid.cols, grid.rows
    d = cell_dist[r * cols + c, there].astype(jnp.int32)
    h0 = 0  # walls between (r, c) and (r, c + 1) start here, then the vertical ones
    v0 = rows * (cols - 1)
    # (row step, col step, wall index, exists) for right, left, up, down
    moves = (
        (0, 1, h0 + r * (cols - 1) + c, c < cols - 1),
        (0, -1, h0 + r * (cols - 1) + c - 1, c > 0),
        (1, 0, v0 + r * cols + c, r < rows - 1),
        (-1, 0, v0 + (r - 1) * cols + c, r > 0),
    )
    best = best_wall = jnp.asarray(-1)
    for i, (dr, dc, wall, exists) in enumerate(moves):
        wall = jnp.clip(wall, 0, max(grid.n_walls - 1, 0))
        n = jnp.clip(r + dr, 0, rows - 1) * cols + jnp.clip(c + dc, 0, cols - 1)
        ok = exists & ~closed[wall] & (cell_dist[n, there].astype(jnp.int32) == d - 1)
        best_wall = jnp.where((best < 0) & ok, wall, best_wall)
        best = jnp.where((best < 0) & ok, i, best)
    row_step = jnp.asarray([0, 0, 1, -1])[jnp.maximum(best, 0)]
    col_step = jnp.asarray([1, -1, 0, 0])[jnp.maximum(best, 0)]
    return best, best_wall, r + row_step, c + col_step


def geodesic_target(
    maze: Maze,
    cell_dist: chex.Array,
    grid: Grid,
    pos: chex.Array,
    goal: chex.Array,
    closed: chex.Array | None = None,
    portals: chex.Array | None = None,
) -> tuple[chex.Array, chex.Array]:
    """(target f32[2], distance f32[]): where the shortest path from ``pos`` to ``goal``
    through the maze heads next, and how long it is.

    In the goal's cell the target is the goal and the distance the straight line.
    Elsewhere the target is the opening into the neighbouring cell one step nearer the
    goal (the first of right, left, up, down when several are). ``closed`` (bool[E],
    default: the grid maze's wall rows) says which walls are shut.

    A grid maze's openings are its walls' middles, and the distance runs from ``pos``
    to the opening, on to the goal cell's centre through the centres of the cells
    between, then to the goal. With ``portals`` (f32[E, 2]: where each wall's opening
    is, a rooms maze's doors) the distance runs from ``pos`` through the openings of
    the path, one after the other, to the goal: a path's true length where the rooms
    are convex.
    """
    r, c = _cell_of(pos, grid)
    gr, gc = _cell_of(goal, grid)
    there = gr * grid.cols + gc
    d = cell_dist[r * grid.cols + c, there].astype(jnp.int32)
    if closed is None:
        closed = maze.segment_mask[: grid.n_walls]
    best, best_wall, r1, c1 = _next_cell(r, c, there, cell_dist, closed, grid)
    in_goal_cell = (d == 0) | (best < 0)
    if portals is None:
        step = jnp.asarray([[0.0, 1.0], [0.0, -1.0], [1.0, 0.0], [-1.0, 0.0]])
        portal = _centre(r, c, grid) + 0.5 * grid.cell * step[jnp.maximum(best, 0)][::-1]
        goal_offset = norm2(goal - _centre(gr, gc, grid))
        along = norm2(portal - pos) + (d - 0.5) * grid.cell + goal_offset
    else:
        portal = portals[jnp.maximum(best_wall, 0)]

        def onward(carry, _):  # from the opening into (row, col) to the next one
            row, col, point, length = carry
            move, wall, row2, col2 = _next_cell(row, col, there, cell_dist, closed, grid)
            going = move >= 0
            nxt = jnp.where(going, portals[jnp.maximum(wall, 0)], point)
            length = length + jnp.where(going, norm2(nxt - point), 0.0)
            return (jnp.where(going, row2, row), jnp.where(going, col2, col), nxt, length), None

        start = (r1, c1, portal, norm2(portal - pos))
        (_, _, last, length), _ = jax.lax.scan(onward, start, None, grid.n_cells - 1)
        along = length + norm2(goal - last)
    target = jnp.where(in_goal_cell, goal, portal)
    return target, jnp.where(in_goal_cell, norm2(goal - pos), along)


def path_points(
    cell_dist: chex.Array,
    grid: Grid,
    pos: chex.Array,
    goal: chex.Array,
    closed: chex.Array,
    portals: chex.Array,
) -> chex.Array:
    """f32[RC, 2]: the points the shortest path from ``pos`` to ``goal`` runs through,
    in order: the openings (``portals`` f32[E, 2]) from each cell into the next one
    nearer the goal's cell (the first of right, left, up, down when several are), then
    the goal, repeated to fill the rows."""
    r, c = _cell_of(pos, grid)
    gr, gc = _cell_of(goal, grid)
    there = gr * grid.cols + gc

    def onward(carry, _):
        row, col = carry
        move, wall, row2, col2 = _next_cell(row, col, there, cell_dist, closed, grid)
        going = move >= 0
        point = jnp.where(going, portals[jnp.maximum(wall, 0)], goal)
        return (jnp.where(going, row2, row), jnp.where(going, col2, col)), point

    _, points = jax.lax.scan(onward, (r, c), None, grid.n_cells)
    return points


def carrot(pos: chex.Array, points: chex.Array, lookahead: float) -> chex.Array:
    """f32[2]: the point ``lookahead`` metres along the polyline from ``pos`` through
    ``points`` (f32[K, 2]), or its last point where the polyline is shorter: the
    pure-pursuit carrot of a path follower."""
    starts = jnp.concatenate([pos[None], points[:-1]])
    lengths = hypot(points[:, 0] - starts[:, 0], points[:, 1] - starts[:, 1])
    before = jnp.cumsum(lengths) - lengths  # along the polyline to each piece's start
    on = (before + lengths >= lookahead) & (lengths > 0)
    i = jnp.argmax(on)
    t = jnp.clip((lookahead - before[i]) / jnp.maximum(lengths[i], 1e-9), 0.0, 1.0)
    point = starts[i] + t * (points[i] - starts[i])
    return jnp.where(jnp.any(on), point, points[-1])


def wall_middles(grid: Grid) -> chex.Array:
    """f32[E, 2]: the middle of every internal wall of a grid (an open wall's opening)."""
    inner = _geometry(grid)[0]
    return jnp.asarray((inner[:, :2] + inner[:, 2:]) / 2)


__all__ = [
    "SPLITS",
    "Draw",
    "Grid",
    "carve",
    "carve_split",
    "carrot",
    "cell_distances",
    "cell_neighbours",
    "draw",
    "draw_maze",
    "grid_family",
    "layout_maze",
    "geodesic_target",
    "layout_split",
    "maze_cell_distances",
    "path_points",
    "wall_cells",
    "wall_middles",
]
