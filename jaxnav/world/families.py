"""Two procedural maze families drawn inside jit besides ``grid``: ``cylinders`` (round
obstacles in a square room) and ``rooms`` (a grid of square rooms joined by doors).

Like :mod:`jaxnav.world.generators`, every array has a shape fixed by the family's
static settings (:class:`Cylinders`, :class:`Rooms`), so a maze is drawn per episode
inside the compiled step and vmaps over runs, and a maze is a padded
:class:`~jaxnav.world.maps.Maze`.

``cylinders``: a room ``room`` m square, centred at the origin, walled all round, with
``count`` cylinders whose centres lie on a 0.05 m lattice (each cylinder inside the
room) and whose radii are drawn from ``[r_lo, r_hi]`` in 0.01 m steps; cylinders may
overlap. Whether the robot can get through is decided on an occupancy raster of
0.1 m cells: a cell is free when its centre is ``ROBOT_RADIUS + 0.1 / sqrt 2`` m clear
of every surface, so the straight move between two free neighbouring centres (8
neighbours) keeps the 0.13 m disc off every surface (clearance is 1-Lipschitz). The
start and the goals are cell centres ``GOAL_CLEARANCE`` (0.35 m) clear, as a fixed
maze's goals. Shortest paths are a breadth-first relaxation over the free cells
(steps of 1 and sqrt 2 cells) from the start, repeated until nothing changes; the
first goal is drawn among the cells reachable at least ``min_path`` m away along the
raster, later goals among all reachable cells. A raster path is one the robot can
drive, so it is never shorter than the robot's true shortest path; that can be
shorter still through gaps the raster counts as closed (under about 0.4 m). A
candidate layout with no such goal is rejected; a draw tries ``MAX_TRIES``
candidates inside jit (``lax.while_loop`` with that cap).

``rooms``: ``rows`` x ``cols`` square rooms of side ``size`` m, centred at the origin.
The walls between rooms that get a door are a random spanning tree of the rooms
(randomised Kruskal, :func:`jaxnav.world.generators.carve`) plus ``loops`` of the
others, so every room is reachable; a door is a gap ``door`` m wide at a position on
the wall drawn from a 0.05 m lattice, at least 0.05 m from either end. Start and
first goal are in rooms at least ``min_path`` doors apart (room-graph breadth-first
search, :func:`jaxnav.world.generators.cell_distances`), so in different rooms; both
are uniform points 0.35 m clear of their room's walls. Goal points, for later goals,
are a few such points per room. Connectivity holds by construction: a door wider
than the robot, in a convex empty room.

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
import math
from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.core.errors import ConfigError
from jaxnav.core.families import DOOR_MARGIN
from jaxnav.world import generators
from jaxnav.world.generators import SPLITS
from jaxnav.world.maps import (
    _FAR,
    GOAL_CLEARANCE,
    GOAL_START_CLEARANCE,
    ROBOT_RADIUS,
    ROBOTIS_ARENA,
    Maze,
)

RASTER = 0.1  # m, an occupancy raster cell's side (cylinders)
# A raster cell is free when its centre is this clear: a move of at most RASTER *
# sqrt 2 between two free centres then keeps the robot disc off every surface.
PASS_CLEARANCE = ROBOT_RADIUS + RASTER / math.sqrt(2) + 1e-4
LATTICE = 0.05  # m, cylinder centres and door positions lie on this lattice
RADIUS_STEP = 0.01  # m, cylinder radii come in these steps
ROOM_GOAL_SPACING = 0.5  # m between a room's goal points, about
MAX_TRIES = 32  # candidate layouts a draw tries inside jit (cylinders: twice nested)
FALLBACK_TRIES = 2000  # candidates searched on the host for the fallback maze
_ROBOTIS_ROWS = 256  # the ROBOTIS goal table a Maze carries (unused with drawn mazes)
_SALT = np.uint32(0x3C6EF372)
_DIAGONAL = math.sqrt(2.0)
# (row shift, column shift, length in cells) of the 8 raster moves.
_MOVES = tuple(
    (dy, dx, _DIAGONAL if dy and dx else 1.0) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx
)


# ----------------------------------------------------------------------------
# The families' static shapes
# ----------------------------------------------------------------------------


class Cylinders(NamedTuple):
    """The static shape of a cylinders family (hashable: it fixes array shapes), the
    ``cylinders`` family of :mod:`jaxnav.core.families`: :meth:`draw` gives a maze and
    its first goal."""

    count: int
    r_lo: float
    r_hi: float
    room: float  # m, the square room's side
    min_path: float  # m along the raster, start to first goal

    @property
    def n_raster(self) -> int:
        """Raster cells along a side."""
        return math.ceil(self.room / RASTER - 1e-6)

    @property
    def n_sites(self) -> int:
        """Lattice positions along a side for a cylinder's centre."""
        return int(math.floor((self.room - 2 * self.r_hi) / LATTICE + 1e-6)) + 1

    @property
    def n_radii(self) -> int:
        return int(round((self.r_hi - self.r_lo) / RADIUS_STEP)) + 1

    def circles(self, codes: chex.Array) -> chex.Array:
        """f32[N, 3] (x, y, r) of the cylinders' lattice codes i32[N, 3] (ix, iy, ir)."""
        x0 = -self.room / 2 + self.r_hi
        xy = x0 + LATTICE * codes[:, :2].astype(jnp.float32)
        step = (self.r_hi - self.r_lo) / max(self.n_radii - 1, 1)
        r = self.r_lo + step * codes[:, 2].astype(jnp.float32)
        return jnp.concatenate([xy, r[:, None]], axis=1).astype(jnp.float32)

    def cell_centres(self) -> np.ndarray:
        """f32[n*n, 2] the raster cells' centres, row-major from the bottom left."""
        n = self.n_raster
        c = -self.room / 2 + RASTER * (np.arange(n) + 0.5)
        cy, cx = np.meshgrid(c, c, indexing="ij")
        return np.stack([cx.ravel(), cy.ravel()], 1).astype(np.float32)

    def draw(self, key: chex.PRNGKey, split: str = "train") -> tuple[Maze, chex.Array]:
        """(maze, goal f32[2]): a cylinder field of ``split``, the robot at its start facing
        a uniform yaw, and its first goal ``min_path`` m away."""
        k_draw, yaw = _yaw(key)
        return _cylinders_maze_goal(draw_cylinders(k_draw, self, split), self, yaw)

    def candidate(self, key: chex.PRNGKey, split: str) -> CylinderDraw:
        return _cylinder_candidate(key, self, split)

    def settings_text(self) -> str:
        """The settings that make its mazes, for a refusal."""
        return "env.cyl_count, env.cyl_radius, env.cyl_room and env.cyl_min_path"


class Rooms(NamedTuple):
    """The static shape of a rooms family (hashable: it fixes array shapes), the ``rooms``
    family of :mod:`jaxnav.core.families`: :meth:`draw` gives a maze and its first goal."""

    rows: int
    cols: int
    size: float  # m, a room's side
    door: float  # m, a door's width
    loops: float = 0.0
    min_path: int = 1  # doors between the start's room and the first goal's, at least

    @property
    def grid(self) -> generators.Grid:
        """The room graph as a grid family: a room is a cell, a door an open wall."""
        return generators.Grid(self.rows, self.cols, self.size, self.loops)

    @property
    def n_offsets(self) -> int:
        """Lattice positions of a door along its wall."""
        return int(math.floor((self.size - self.door - 2 * DOOR_MARGIN) / LATTICE + 1e-6)) + 1

    @property
    def n_segments(self) -> int:
        """Segment rows: two per wall between rooms (either side of its door), then the
        boundary, one per room side."""
        g = self.grid
        return 2 * g.n_walls + 2 * (self.rows + self.cols)

    @property
    def per_side(self) -> int:
        """Goal points along a room's side (a room has per_side^2)."""
        return int((self.size - 2 * GOAL_CLEARANCE) // ROOM_GOAL_SPACING) + 1

    def draw(self, key: chex.PRNGKey, split: str = "train") -> tuple[Maze, chex.Array]:
        """(maze, goal f32[2]): a rooms maze of ``split``, the robot at its start facing a
        uniform yaw, and its first goal ``min_path`` doors away."""
        k_draw, yaw = _yaw(key)
        return _rooms_maze_goal(draw_rooms(k_draw, self, split), self, yaw)

    def candidate(self, key: chex.PRNGKey, split: str) -> _Doors:
        return _rooms_candidate(key, self, split)

    def doors(self, maze: Maze) -> tuple[chex.Array, chex.Array]:
        """(bool[E] the walls without a door, f32[E, 2] each door's middle) of a drawn
        rooms maze, read from its segment rows: a wall with a door is two rows, the door
        the gap between them."""
        e = self.grid.n_walls
        middle = 0.5 * (maze.segments[:e, 2:] + maze.segments[e : 2 * e, :2])
        return ~maze.segment_mask[e : 2 * e], middle

    def cell_distances(self, maze: Maze) -> chex.Array:
        """i16[RC, RC]: doors between every two rooms of a drawn rooms maze, read from
        its segment rows (:meth:`doors`)."""
        closed, _ = self.doors(maze)
        return generators.cell_distances(~closed, self.grid).astype(jnp.int16)

    def geodesic_target(
        self, maze: Maze, cell_dist: chex.Array, pos: chex.Array, goal: chex.Array
    ) -> tuple[chex.Array, chex.Array]:
        """Where the shortest path from ``pos`` to ``goal`` heads next (the door into
        the next room on it, or the goal in its room), and its length
        (:func:`jaxnav.world.generators.geodesic_target`, rooms for cells, doors for
        openings)."""
        closed, doors = self.doors(maze)
        return generators.geodesic_target(
            maze, cell_dist, self.grid, pos, goal, closed=closed, portals=doors
        )

    def waypoint(
        self, maze: Maze, cell_dist: chex.Array, pos: chex.Array, goal: chex.Array, lookahead
    ) -> chex.Array:
        """f32[2]: the point ``lookahead`` m along the shortest path from ``pos`` to
        ``goal`` through the doors (:func:`jaxnav.world.generators.carrot`)."""
        closed, doors = self.doors(maze)
        points = generators.path_points(cell_dist, self.grid, pos, goal, closed, doors)
        return generators.carrot(pos, points, lookahead)

    def settings_text(self) -> str:
        """The settings that make its mazes, for a refusal."""
        return "env.rooms_rows, env.rooms_cols, env.rooms_size and env.rooms_door"


# ----------------------------------------------------------------------------
# Shared pieces: the layout hash, candidates with a cap, the fallback
# ----------------------------------------------------------------------------


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
def search(key: chex.PRNGKey, family: Cylinders | Rooms, split: str):
    """(candidate, ok): the first valid candidate maze of ``split`` among MAX_TRIES
    (:func:`first_valid`), jitted once per family and split, so the host's fallback
    search and an eager draw share one compiled program."""
    return first_valid(functools.partial(family.candidate, split=split), key)


@functools.lru_cache(maxsize=32)
def fallback(family: Cylinders | Rooms, split: str):
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


def _draw(family: Cylinders | Rooms, key: chex.PRNGKey, split: str):
    """A valid candidate of ``split`` drawn inside jit, or the family's fallback."""
    c, ok = search(key, family, split)
    return _or_fallback(c, ok, fallback(family, split))


@jax.jit
def _or_fallback(c, ok, safe):
    return jax.tree.map(lambda a, b: jnp.where(ok, a, b), c, safe)


# ----------------------------------------------------------------------------
# Cylinders
# ----------------------------------------------------------------------------


def cylinder_codes(key: chex.PRNGKey, family: Cylinders) -> chex.Array:
    """i32[N, 3]: each cylinder's lattice code (ix, iy, ir), uniform."""
    k_xy, k_r = jax.random.split(key)
    xy = jax.random.randint(k_xy, (family.count, 2), 0, family.n_sites)
    r = jax.random.randint(k_r, (family.count, 1), 0, family.n_radii)
    return jnp.concatenate([xy, r], axis=1).astype(jnp.int32)


def cylinder_split(codes: chex.Array, family: Cylinders) -> chex.Array:
    """i32[]: the split (0 train, 1 test) of a cylinder layout, in any order."""
    ix, iy, ir = codes[..., 0], codes[..., 1], codes[..., 2]
    flat = (ix * family.n_sites + iy) * family.n_radii + ir
    return hash_split(flat, ordered=False)


def clearance_raster(circles: chex.Array, family: Cylinders) -> chex.Array:
    """f32[n*n]: each raster cell centre's distance to the nearest wall or cylinder."""
    p = jnp.asarray(family.cell_centres())
    half = family.room / 2
    walls = jnp.min(jnp.concatenate([p + half, half - p], axis=1), axis=1)
    d = jnp.linalg.norm(p[:, None, :] - circles[None, :, :2], axis=-1) - circles[None, :, 2]
    return jnp.minimum(walls, jnp.min(d, axis=1))


def raster_distances(free: chex.Array, source: chex.Array, n: int) -> chex.Array:
    """f32[n*n]: shortest path in cells (moves of 1 and sqrt 2 between the 8 neighbours)
    from cell ``source`` to every cell through the ``free`` cells bool[n*n]; inf where
    unreached. Relaxation rounds until nothing changes (at most n*n)."""
    free = free.reshape(n, n)
    d0 = jnp.full(n * n, jnp.inf, jnp.float32).at[source].set(0.0).reshape(n, n)

    def relax(d):
        p = jnp.pad(d, 1, constant_values=jnp.inf)
        best = d
        for dy, dx, w in _MOVES:  # out[i, j] = d[i + dy, j + dx] + w
            best = jnp.minimum(best, p[1 + dy : 1 + dy + n, 1 + dx : 1 + dx + n] + w)
        return jnp.where(free, best, jnp.inf)

    def again(carry):
        _, changed, i = carry
        return changed & (i < n * n)

    def round_(carry):
        d, _, i = carry
        new = relax(d)
        return new, jnp.any(new < d), i + 1

    d, _, _ = jax.lax.while_loop(again, round_, (d0, jnp.bool_(True), jnp.int32(0)))
    return d.reshape(-1)


class CylinderDraw(NamedTuple):
    """One drawn cylinder field: its layout, start and goal cells, the goal points."""

    codes: chex.Array  # i32[N, 3] lattice codes
    start: chex.Array  # i32[] raster cell
    goal: chex.Array  # i32[] raster cell
    path: chex.Array  # f32[] shortest path start to goal along the raster, m
    goals: chex.Array  # bool[n*n] goal points: reachable, clear, away from the start
    ok: chex.Array  # bool[] of the split, with a goal min_path away


class _Layout(NamedTuple):
    codes: chex.Array  # i32[N, 3]
    ok: chex.Array  # bool[] of the split


def _cylinder_candidate(key: chex.PRNGKey, family: Cylinders, split: str) -> CylinderDraw:
    """A candidate cylinder field of ``split``, a start cell and a goal cell."""
    want = SPLITS.index(split)
    k_layout, k_start, k_goal = jax.random.split(key, 3)

    def layout(k):
        codes = cylinder_codes(k, family)
        return _Layout(codes, cylinder_split(codes, family) == want)

    codes = first_valid(layout, k_layout)[0]
    centres = jnp.asarray(family.cell_centres())
    clear = clearance_raster(family.circles(codes.codes), family)
    eligible = clear >= GOAL_CLEARANCE
    n2 = family.n_raster**2
    start = jnp.argmax(jnp.where(eligible, jax.random.uniform(k_start, (n2,)), -1.0))
    dist = raster_distances(clear >= PASS_CLEARANCE, start, family.n_raster) * RASTER
    away = jnp.linalg.norm(centres - centres[start], axis=1) >= GOAL_START_CLEARANCE
    goals = eligible & jnp.isfinite(dist) & away
    first = goals & (dist >= family.min_path)
    goal = jnp.argmax(jnp.where(first, jax.random.uniform(k_goal, (n2,)), -1.0))
    ok = codes.ok & eligible[start] & first[goal]
    return CylinderDraw(codes.codes, start, goal, dist[goal], goals, ok)


def draw_cylinders(key: chex.PRNGKey, family: Cylinders, split: str = "train") -> CylinderDraw:
    """A cylinder field of ``split`` with a start and a first goal ``min_path`` m away."""
    return _draw(family, key, split)


def cylinders_maze(d: CylinderDraw, family: Cylinders, yaw: chex.Array) -> Maze:
    """The :class:`Maze` of a drawn cylinder field, the robot at its start facing ``yaw``."""
    h = family.room / 2
    corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]], np.float32)
    walls = jnp.asarray(np.concatenate([corners, np.roll(corners, -1, axis=0)], axis=1))
    centres = jnp.asarray(family.cell_centres())
    n2 = centres.shape[0]
    idx = jnp.nonzero(d.goals, size=n2, fill_value=jnp.argmax(d.goals))[0]
    goal_points = centres[idx]
    n_goals = jnp.sum(d.goals).astype(jnp.int32)
    start = jnp.concatenate([centres[d.start], jnp.reshape(yaw, (1,))]).astype(jnp.float32)
    return Maze(
        segments=walls,
        segment_mask=jnp.ones(4, bool),
        circles=family.circles(d.codes),
        circle_mask=jnp.ones(family.count, bool),
        start=start,
        goal_points=goal_points,
        n_goal_points=n_goals,
        bounds=jnp.asarray([-h, -h, h, h], jnp.float32),
        n_obstacles=jnp.asarray(family.count, jnp.int32),
        robotis_goals=jnp.resize(goal_points, (_ROBOTIS_ROWS, 2)),
        n_robotis_goals=jnp.minimum(n_goals, _ROBOTIS_ROWS),
        robotis_scale=jnp.asarray(family.room / ROBOTIS_ARENA, jnp.float32),
    )


# ----------------------------------------------------------------------------
# Rooms
# ----------------------------------------------------------------------------


class RoomsDraw(NamedTuple):
    """One drawn rooms maze: its doors, and the start and goal rooms and points."""

    open: chex.Array  # bool[E] walls between rooms with a door
    offsets: chex.Array  # i32[E] each door's lattice position along its wall
    start_room: chex.Array  # i32[]
    goal_room: chex.Array  # i32[]
    path_rooms: chex.Array  # i32[] doors between the two rooms along the room graph
    start: chex.Array  # f32[2]
    goal: chex.Array  # f32[2]
    ok: chex.Array  # bool[] of the split


def rooms_split(open_: chex.Array, offsets: chex.Array) -> chex.Array:
    """i32[]: the split (0 train, 1 test) of a rooms layout: its doors and where they are."""
    return hash_split(jnp.where(open_, offsets + 1, 0), ordered=True)


class _Doors(NamedTuple):
    open: chex.Array  # bool[E]
    offsets: chex.Array  # i32[E]
    ok: chex.Array  # bool[] of the split


def _rooms_candidate(key: chex.PRNGKey, family: Rooms, split: str) -> _Doors:
    """A candidate rooms layout (valid by construction but for its split)."""
    grid = family.grid
    k_carve, k_doors = jax.random.split(key)
    open_ = generators.carve(k_carve, grid)
    offsets = jax.random.randint(k_doors, (grid.n_walls,), 0, family.n_offsets).astype(jnp.int32)
    return _Doors(open_, offsets, rooms_split(open_, offsets) == SPLITS.index(split))


def draw_rooms(key: chex.PRNGKey, family: Rooms, split: str = "train") -> RoomsDraw:
    """A rooms maze of ``split`` with start and first goal ``min_path`` doors apart."""
    k_layout, k_pair, k_start, k_goal = jax.random.split(key, 4)
    doors = _draw(family, k_layout, split)
    grid = family.grid
    dist = generators.cell_distances(doors.open, grid)
    n = grid.n_cells
    far = (dist >= max(family.min_path, 1)) & (dist < generators._UNREACHED)
    pair = jnp.argmax(jnp.where(far, jax.random.uniform(k_pair, (n, n)), -1.0).ravel())
    s, g = pair // n, pair % n
    centres = jnp.asarray(generators._geometry(grid)[2])
    reach = family.size / 2 - GOAL_CLEARANCE  # a point this far from its room's centre

    def point(k, room):
        return centres[room] + jax.random.uniform(k, (2,), jnp.float32, -reach, reach)

    return RoomsDraw(
        open=doors.open,
        offsets=doors.offsets,
        start_room=s.astype(jnp.int32),
        goal_room=g.astype(jnp.int32),
        path_rooms=dist[s, g],
        start=point(k_start, s),
        goal=point(k_goal, g),
        ok=doors.ok,
    )


def rooms_maze(d: RoomsDraw, family: Rooms, yaw: chex.Array) -> Maze:
    """The :class:`Maze` of a drawn rooms maze, the robot at its start facing ``yaw``."""
    grid = family.grid
    inner, boundary, centres = (jnp.asarray(x) for x in generators._geometry(grid))
    a, b = inner[:, :2], inner[:, 2:]
    along = (b - a) / family.size  # unit vector along each wall
    mid = family.door / 2 + DOOR_MARGIN + LATTICE * d.offsets.astype(jnp.float32)
    lo = a + along * (mid - family.door / 2)[:, None]
    hi = a + along * (mid + family.door / 2)[:, None]
    first = jnp.where(d.open[:, None], jnp.concatenate([a, lo], 1), inner)
    second = jnp.where(d.open[:, None], jnp.concatenate([hi, b], 1), _FAR)
    segments = jnp.concatenate([first, second, boundary]).astype(jnp.float32)
    mask = jnp.concatenate([jnp.ones(grid.n_walls, bool), d.open, jnp.ones(len(boundary), bool)])
    m = family.per_side
    span = family.size / 2 - GOAL_CLEARANCE
    ticks = np.linspace(-span, span, m) if m > 1 else np.zeros(1)
    ty, tx = np.meshgrid(ticks, ticks, indexing="ij")
    offsets = np.stack([tx.ravel(), ty.ravel()], 1).astype(np.float32)
    goal_points = (centres[:, None, :] + offsets[None]).reshape(-1, 2)
    half = jnp.asarray([family.cols, family.rows], jnp.float32) * (family.size / 2)
    size = max(family.rows, family.cols) * family.size
    return Maze(
        segments=segments,
        segment_mask=mask,
        circles=jnp.asarray([[_FAR, _FAR, 0.0]], jnp.float32),
        circle_mask=jnp.zeros(1, bool),
        start=jnp.concatenate([d.start, jnp.reshape(yaw, (1,))]).astype(jnp.float32),
        goal_points=goal_points,
        n_goal_points=jnp.asarray(goal_points.shape[0], jnp.int32),
        bounds=jnp.concatenate([-half, half]),
        n_obstacles=jnp.asarray(0, jnp.int32),
        robotis_goals=jnp.resize(goal_points, (_ROBOTIS_ROWS, 2)),
        n_robotis_goals=jnp.asarray(min(goal_points.shape[0], _ROBOTIS_ROWS), jnp.int32),
        robotis_scale=jnp.asarray(size / ROBOTIS_ARENA, jnp.float32),
    )


# ----------------------------------------------------------------------------
# The families of jaxnav.core.families
# ----------------------------------------------------------------------------


def cylinders_family(env) -> Cylinders:
    """The cylinders family of ``env``'s settings (an EnvConfig or a ``jaxnav.env.NavEnv``)."""
    lo, hi = env.cyl_radius
    return Cylinders(env.cyl_count, float(lo), float(hi), env.cyl_room, env.cyl_min_path)


def rooms_family(env) -> Rooms:
    """The rooms family of ``env``'s settings (an EnvConfig or a ``jaxnav.env.NavEnv``)."""
    return Rooms(
        env.rooms_rows,
        env.rooms_cols,
        env.rooms_size,
        env.rooms_door,
        env.rooms_loops,
        env.min_path_cells,
    )


def _yaw(key: chex.PRNGKey) -> tuple[chex.PRNGKey, chex.Array]:
    """(the draw's key, the start's uniform yaw f32[]) of a maze's key."""
    k_draw, k_yaw = jax.random.split(key)
    return k_draw, jax.random.uniform(k_yaw, (), jnp.float32, -jnp.pi, jnp.pi)


# Jitted so that an eager draw (the template of jaxnav.env.make) is one program each.
@functools.partial(jax.jit, static_argnums=1)
def _cylinders_maze_goal(d: CylinderDraw, family: Cylinders, yaw) -> tuple[Maze, chex.Array]:
    return cylinders_maze(d, family, yaw), jnp.asarray(family.cell_centres())[d.goal]


@functools.partial(jax.jit, static_argnums=1)
def _rooms_maze_goal(d: RoomsDraw, family: Rooms, yaw) -> tuple[Maze, chex.Array]:
    return rooms_maze(d, family, yaw), d.goal


__all__ = [
    "PASS_CLEARANCE",
    "RASTER",
    "CylinderDraw",
    "Cylinders",
    "Rooms",
    "RoomsDraw",
    "clearance_raster",
    "cylinder_codes",
    "cylinder_split",
    "cylinders_family",
    "cylinders_maze",
    "draw_cylinders",
    "draw_rooms",
    "fallback",
    "first_valid",
    "hash_split",
    "raster_distances",
    "rooms_family",
    "rooms_maze",
    "rooms_split",
]
