"""The ``cylinders`` maze family drawn inside jit (``env.generator: cylinders``): round
obstacles in a square room.

Like :mod:`jaxnav.world.generators`, every array has a shape fixed by the family's
static settings (:class:`Cylinders`), so a maze is drawn per episode inside the compiled
step and vmaps over runs, and a maze is a padded :class:`~jaxnav.world.maps.Maze`.

A room ``room`` m square, centred at the origin, walled all round, with
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

from jaxnav.world.draws import (
    LATTICE,
    ROBOTIS_ROWS,
    draw_with_fallback,
    first_valid,
    hash_split,
    start_yaw,
)
from jaxnav.world.generators import SPLITS
from jaxnav.world.maps import (
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
RADIUS_STEP = 0.01  # m, cylinder radii come in these steps
_DIAGONAL = math.sqrt(2.0)
# (row shift, column shift, length in cells) of the 8 raster moves.
_MOVES = tuple(
    (dy, dx, _DIAGONAL if dy and dx else 1.0) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx
)


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
        k_draw, yaw = start_yaw(key)
        return _cylinders_maze_goal(draw_cylinders(k_draw, self, split), self, yaw)

    def candidate(self, key: chex.PRNGKey, split: str) -> CylinderDraw:
        return _cylinder_candidate(key, self, split)

    def settings_text(self) -> str:
        """The settings that make its mazes, for a refusal."""
        return "env.cyl_count, env.cyl_radius, env.cyl_room and env.cyl_min_path"


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
    return draw_with_fallback(family, key, split)


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
        robotis_goals=jnp.resize(goal_points, (ROBOTIS_ROWS, 2)),
        n_robotis_goals=jnp.minimum(n_goals, ROBOTIS_ROWS),
        robotis_scale=jnp.asarray(family.room / ROBOTIS_ARENA, jnp.float32),
    )


def cylinders_family(env) -> Cylinders:
    """The cylinders family of ``env``'s settings (an EnvConfig or a ``jaxnav.env.NavEnv``)."""
    lo, hi = env.cyl_radius
    return Cylinders(env.cyl_count, float(lo), float(hi), env.cyl_room, env.cyl_min_path)


# Jitted so that an eager draw (the template of jaxnav.env.make) is one program each.
@functools.partial(jax.jit, static_argnums=1)
def _cylinders_maze_goal(d: CylinderDraw, family: Cylinders, yaw) -> tuple[Maze, chex.Array]:
    return cylinders_maze(d, family, yaw), jnp.asarray(family.cell_centres())[d.goal]
