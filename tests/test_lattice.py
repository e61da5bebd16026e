"""The LiDAR's lattice walk (env.broad_phase) against the float64 NumPy ray caster that
tests every wall, on drawn grid mazes of every size and with cylinders, and how the
environment chooses it."""

from __future__ import annotations

import functools

import _nav_reference as ref
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
from jaxnav.core.config import ConfigError, load_config
from jaxnav.world import generators as gen
from jaxnav.world.lattice import line_bits
from jaxnav.world.maps import Maze
from jaxnav.world.sensor import beam_directions, beam_ranges

TOL = 1e-4  # m, as tests/test_lidar.py
N_BEAMS = 24


def _mazes(grid: gen.Grid, n: int, seed: int) -> Maze:
    """``n`` grid mazes of ``grid``'s shape, stacked, some with loops opened."""
    keys = jax.random.split(jax.random.PRNGKey(seed), n)
    opened = jax.vmap(lambda k: gen.carve(k, grid))(keys)
    return jax.vmap(lambda o: gen.layout_maze(o, grid, jnp.int32(0), jnp.float32(0.0)))(opened)


def _poses(grid: gen.Grid, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Poses in the cells' free interiors; the first quarter at cell centres facing +x,
    so the beams at multiples of 45 degrees pass exactly through the lattice's corners."""
    rng = np.random.default_rng(seed)
    row, col = rng.integers(grid.rows, size=n), rng.integers(grid.cols, size=n)
    centre = np.stack(
        [(col + 0.5 - grid.cols / 2) * grid.cell, (row + 0.5 - grid.rows / 2) * grid.cell], 1
    )
    free = grid.cell / 2 - 0.11
    pos = centre + rng.uniform(-free, free, (n, 2))
    yaw = rng.uniform(-np.pi, np.pi, n)
    pos[: n // 4], yaw[: n // 4] = centre[: n // 4], 0.0
    return pos.astype(np.float32), yaw.astype(np.float32)


@functools.cache
def _casters(grid: gen.Grid):
    walk = jax.jit(jax.vmap(lambda m, p, y: grid.beam_ranges(m, p, beam_directions(N_BEAMS, y))))
    every = jax.jit(jax.vmap(lambda m, p, y: beam_ranges(m, p, y, N_BEAMS)))
    return walk, every


def _reference(maze_i: Maze, pos, yaw) -> np.ndarray:
    walls = np.asarray(maze_i.segments)[np.asarray(maze_i.segment_mask)].astype(np.float64)
    circles = np.asarray(maze_i.circles)[np.asarray(maze_i.circle_mask)].astype(np.float64)
    angles = np.float64(yaw) + 2 * np.pi * np.arange(N_BEAMS) / N_BEAMS
    return ref.ray_distances(np.float64(pos)[None], angles[None], walls, circles)[0]


@pytest.mark.parametrize(
    "grid",
    [
        gen.Grid(2, 2),
        gen.Grid(3, 5, 1.0, 0.3),
        gen.Grid(4, 4, 0.6),
        gen.Grid(8, 8),
        gen.Grid(7, 9, 0.8, 0.5),
        gen.Grid(16, 16),
    ],
    ids=lambda g: f"{g.rows}x{g.cols}-{g.cell}m-loops{g.loops}",
)
def test_the_lattice_walk_reads_the_ranges_the_numpy_caster_reads(grid):
    """Every beam's range, unclipped, within float32 rounding of jaxnav's own caster
    that tests every wall, and within 1e-4 m of the float64 NumPy one away from the
    corners (through a corner jaxnav counts a wall 1e-6 of its length beyond its end,
    the NumPy caster 1e-12: the beams from cell centres are compared with jaxnav's)."""
    n = 96
    mazes = _mazes(grid, n, seed=grid.rows * 31 + grid.cols)
    pos, yaw = _poses(grid, n, seed=grid.rows)
    walk, every = _casters(grid)
    got = np.asarray(walk(mazes, pos, yaw))
    assert np.isfinite(got).all()  # a closed grid: every beam meets a wall
    np.testing.assert_allclose(got, np.asarray(every(mazes, pos, yaw)), rtol=2e-6, atol=2e-6)
    off_centre = range(n // 4, n)
    want = np.stack(
        [_reference(jax.tree.map(lambda x, i=i: x[i], mazes), pos[i], yaw[i]) for i in off_centre]
    )
    np.testing.assert_allclose(got[n // 4 :], want, atol=TOL)


def test_cylinders_in_a_grid_maze_are_seen_too():
    """Cylinders (moving ones stand where they are at the scan's time in the maze the
    scan reads) hide the walls behind them, as the NumPy caster says."""
    grid = gen.Grid(8, 8)
    n = 64
    mazes = _mazes(grid, n, seed=5)
    rng = np.random.default_rng(5)
    circles = np.concatenate(
        [rng.uniform(-3.5, 3.5, (n, 3, 2)), rng.uniform(0.05, 0.3, (n, 3, 1))], -1
    ).astype(np.float32)
    mazes = mazes.replace(circles=jnp.asarray(circles), circle_mask=jnp.ones((n, 3), bool))
    pos, yaw = _poses(grid, 2 * n, seed=6)
    pos, yaw = pos[n:], yaw[n:]  # off the cell centres
    away = np.min(np.hypot(*(pos[:, None, :] - circles[..., :2]).transpose(2, 0, 1)), 1)
    keep = away > circles[..., 2].max(1) + 0.01  # the robot outside every cylinder
    walk, _ = _casters(grid)
    got = np.asarray(walk(mazes, pos, yaw))[keep]
    want = np.stack(
        [
            _reference(jax.tree.map(lambda x, i=i: x[i], mazes), pos[i], yaw[i])
            for i in np.flatnonzero(keep)
        ]
    )
    assert (want < np.asarray(_casters(grid)[1](mazes, pos, yaw))[keep] + 1).all()
    np.testing.assert_allclose(got, want, atol=TOL)


def test_line_bits_name_the_standing_walls_of_each_line():
    """Bit r of vertical line k is the wall row the maze keeps there (its end points on
    that line, between rows r and r + 1), checked wall by wall from the segments."""
    grid = gen.Grid(3, 4, 1.0, 0.4)
    maze = jax.tree.map(lambda x: x[0], _mazes(grid, 1, seed=2))
    vertical, horizontal = (np.asarray(b) for b in line_bits(maze.segment_mask, 3, 4))
    seg, mask = np.asarray(maze.segments), np.asarray(maze.segment_mask)
    x0, y0 = -2.0, -1.5
    want_v, want_h = np.zeros(5, int), np.zeros(4, int)
    for (ax, ay, bx, by), real in zip(seg, mask, strict=True):
        if not real:
            continue
        if ax == bx:  # vertical, from row (min y - y0)
            want_v[round(ax - x0)] |= 2 << round(min(ay, by) - y0)
        else:
            want_h[round(ay - y0)] |= 2 << round(min(ax, bx) - x0)
    np.testing.assert_array_equal(vertical, want_v)
    np.testing.assert_array_equal(horizontal, want_h)


def _env(**kw):
    return jaxnav.make(generator="grid", min_path_cells=2, **kw)


@pytest.mark.slow  # 11 s on 2 cores
def test_auto_walks_the_lattice_of_drawn_grids_only():
    """Grids walk their lattice unless told not to, scaled or too large for its bit
    fields; other families and fixed mazes test every wall."""
    assert _env(grid_rows=2, grid_cols=3)[0].walks_lattice
    assert _env(grid_rows=30, grid_cols=4)[0].walks_lattice
    assert not _env(grid_rows=31, grid_cols=4)[0].walks_lattice
    assert not _env(grid_rows=8, grid_cols=8, broad_phase="none")[0].walks_lattice
    assert not jaxnav.make("square4")[0].walks_lattice
    assert not jaxnav.make(generator="rooms")[0].walks_lattice
    assert not _env(grid_rows=8, grid_cols=8, maze_scale=(0.8, 1.2))[0].walks_lattice


@pytest.mark.slow  # 5 s on 2 cores
def test_an_episode_observes_the_same_scans_either_way():
    """Reset and 30 random steps of 16 environments on 8 x 8 grids: the observations
    with the lattice walked equal those with every wall tested (float32 rounding), the
    rewards and ends likewise."""
    out = []
    for phase in ("lattice", "none"):
        env, params = _env(grid_rows=8, grid_cols=8, broad_phase=phase, observation="normalised")

        def run(key, env=env, params=params):
            obs, state = env.reset(key, params)

            def step(carry, k):
                state = carry
                a = jax.random.randint(k, (), 0, env.num_actions)
                obs, state, r, term, trunc, _ = env.step(k, state, a, params)
                return state, (obs, r, term)

            _, (o, r, d) = jax.lax.scan(step, state, jax.random.split(key, 30))
            return obs, o, r, d

        out.append(jax.jit(jax.vmap(run))(jax.random.split(jax.random.PRNGKey(3), 16)))
    (o0, o1, r1, d1), (p0, p1, r2, d2) = out
    np.testing.assert_allclose(o0, p0, atol=1e-5)
    np.testing.assert_allclose(o1, p1, atol=1e-5)
    np.testing.assert_allclose(r1, r2, rtol=1e-4, atol=1e-4)
    np.testing.assert_array_equal(d1, d2)


@pytest.mark.parametrize(
    "overrides, message",
    [
        (["env.broad_phase=lattice"], "env.broad_phase lattice walks a maze's lattice: it needs"),
        (
            ["env.generator=cylinders", "env.broad_phase=lattice"],
            "it needs env.generator grid",
        ),
        (
            ["env.generator=grid", "env.grid_rows=31", "env.broad_phase=lattice"],
            "at most 30 cells a side",
        ),
        (
            ["env.generator=grid", "env.maze_scale=[0.8,1.2]", "env.broad_phase=lattice"],
            "env.maze_scale is on",
        ),
        (["env.broad_phase=on"], "env.broad_phase"),
    ],
)
def test_a_broad_phase_that_cannot_apply_is_refused_in_one_line(overrides, message):
    with pytest.raises(ConfigError, match=message) as err:
        load_config("smoke", overrides)
    assert "\n" not in str(err.value)
