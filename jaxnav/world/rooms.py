"""The ``rooms`` maze family drawn inside jit (``env.generator: rooms``): a grid of
square rooms joined by doors.

Like :mod:`jaxnav.world.generators`, every array has a shape fixed by the family's
static settings (:class:`Rooms`), so a maze is drawn per episode inside the compiled
step and vmaps over runs, and a maze is a padded :class:`~jaxnav.world.maps.Maze`.

``rows`` x ``cols`` square rooms of side ``size`` m, centred at the origin.
The walls between rooms that get a door are a random spanning tree of the rooms
(randomised Kruskal, :func:`jaxnav.world.generators.carve`) plus ``loops`` of the
others, so every room is reachable; a door is a gap ``door`` m wide at a position on
the wall drawn from a 0.05 m lattice, at least 0.05 m from either end. Start and
first goal are in rooms at least ``min_path`` doors apart (room-graph breadth-first
search, :func:`jaxnav.world.generators.cell_distances`), so in different rooms; both
are uniform points 0.35 m clear of their room's walls. Goal points, for later goals,
are a few such points per room. Connectivity holds by construction: a door wider
than the robot, in a convex empty room.

The split and the fallback of a draw that exhausts its candidates:
:mod:`jaxnav.world.draws`.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.core.families import DOOR_MARGIN
from jaxnav.world import generators
from jaxnav.world.draws import (
    LATTICE,
    ROBOTIS_ROWS,
    draw_with_fallback,
    hash_split,
    start_yaw,
)
from jaxnav.world.generators import SPLITS
from jaxnav.world.maps import _FAR, GOAL_CLEARANCE, ROBOTIS_ARENA, Maze

ROOM_GOAL_SPACING = 0.5  # m between a room's goal points, about


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
        k_draw, yaw = start_yaw(key)
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
    doors = draw_with_fallback(family, k_layout, split)
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
        robotis_goals=jnp.resize(goal_points, (ROBOTIS_ROWS, 2)),
        n_robotis_goals=jnp.asarray(min(goal_points.shape[0], ROBOTIS_ROWS), jnp.int32),
        robotis_scale=jnp.asarray(size / ROBOTIS_ARENA, jnp.float32),
    )


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


@functools.partial(jax.jit, static_argnums=1)
def _rooms_maze_goal(d: RoomsDraw, family: Rooms, yaw) -> tuple[Maze, chex.Array]:
    return rooms_maze(d, family, yaw), d.goal
