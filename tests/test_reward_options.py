"""The reward options: sparse (R+ and R- only) and geodesic (the shaping follows the
shortest path through a grid maze), against hand-computed values and a NumPy
breadth-first search."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from test_env_grid import _bfs

import jaxnav
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.world import generators as gen


def test_the_sparse_reward_pays_only_goals_and_collisions():
    env, params = jaxnav.make("square2", reward="sparse")
    _, state = env.reset(jax.random.PRNGKey(0), params)
    step = jax.jit(env.step)
    key = jax.random.PRNGKey(1)
    seen = set()
    for i in range(600):
        key, k = jax.random.split(key)
        _, state, r, term, _, info = step(k, state, jnp.int32((i // 7) % 5), params)
        want = 1000.0 if bool(info["goal_reached"]) else -150.0 if bool(term) else 0.0
        assert float(r) == want
        seen.add(want)
    assert {0.0, -150.0} <= seen  # the walk met walls


# A 2 x 2 grid of 1 m cells: cells 0 (bottom left), 1 (bottom right), 2, 3 above them.
# Internal walls: 0 between cells 0-1, 1 between 2-3, 2 between 0-2, 3 between 1-3.
# Open 1, 2, 3: a U from cell 0 up, across and down to cell 1; wall 0 closed.
U = jnp.asarray([False, True, True, True])
GRID = gen.Grid(2, 2, 1.0)


def _u_maze():
    maze = gen.layout_maze(U, GRID, jnp.int32(0), jnp.float32(0.0))
    return maze, gen.maze_cell_distances(maze, GRID)


@pytest.mark.parametrize(
    "pos, target, along",
    [
        ((-0.5, -0.5), (-0.5, 0.0), 3.0),  # cell 0's centre: up, then three cells
        ((-0.5, -0.3), (-0.5, 0.0), 2.8),
        ((-0.2, -0.5), (-0.5, 0.0), np.hypot(0.3, 0.5) + 2.5),  # the wall is to its right
        ((-0.5, 0.5), (0.0, 0.5), 2.0),  # cell 2: right
        ((0.5, 0.5), (0.5, 0.0), 1.0),  # cell 3: down
        ((0.5, -0.2), (0.5, -0.5), 0.3),  # the goal's cell: the goal itself
    ],
)
def test_the_geodesic_target_and_distance_by_hand(pos, target, along):
    maze, dist = _u_maze()
    goal = jnp.asarray([0.5, -0.5])
    t, d = gen.geodesic_target(maze, dist, GRID, jnp.asarray(pos, jnp.float32), goal)
    np.testing.assert_allclose(np.asarray(t), target, atol=1e-6)
    assert float(d) == pytest.approx(along, abs=1e-5)


@pytest.mark.slow
def test_the_geodesic_distance_between_cell_centres_is_the_bfs_path():
    grid = gen.Grid(5, 4, 0.8, 0.2)
    a, b = gen.wall_cells(grid)
    for seed in range(4):
        d = gen.draw(jax.random.PRNGKey(seed), grid)
        maze = gen.layout_maze(d.open, grid, jnp.int32(0), jnp.float32(0.0))
        dist = gen.maze_cell_distances(maze, grid)
        centres = np.asarray(maze.goal_points)
        open_ = np.asarray(d.open)
        goal_cell = seed * 3
        want = _bfs(grid, a, b, open_, goal_cell)
        for cell in range(grid.n_cells):
            _, along = gen.geodesic_target(
                maze, dist, grid, jnp.asarray(centres[cell]), jnp.asarray(centres[goal_cell])
            )
            assert float(along) == pytest.approx(grid.cell * want[cell], abs=1e-5)


@pytest.mark.slow  # 4 s on 2 cores
def test_a_geodesic_step_rewards_turning_towards_the_opening():
    """In cell 0 facing the closed wall to the goal's side, the dense reward pays for
    turning at the goal, the geodesic one for turning up towards the opening."""
    env, params = jaxnav.make(generator="grid", grid_rows=2, grid_cols=2, reward="geodesic")
    maze, dist = _u_maze()
    _, state = env.reset(jax.random.PRNGKey(0), params)
    state = state.replace(
        maze=maze,
        cell_dist=dist,
        pos=jnp.asarray([-0.5, -0.5]),
        yaw=jnp.float32(0.0),
        goal=jnp.asarray([0.5, -0.5]),
    )
    rewards = [
        float(env.step_env(jax.random.PRNGKey(1), state, jnp.int32(a), params)[2]) for a in range(5)
    ]
    assert int(np.argmax(rewards)) == 4  # +1.5 rad/s: counter-clockwise, up
    dense_env, _ = jaxnav.make(generator="grid", grid_rows=2, grid_cols=2)
    dense = [
        float(
            dense_env.step_env(
                jax.random.PRNGKey(1), state.replace(cell_dist=None), jnp.int32(a), params
            )[2]
        )
        for a in range(5)
    ]
    assert int(np.argmax(dense)) == 2  # straight at the goal, into the wall


@pytest.mark.parametrize(
    "override, names",
    [
        (["env.reward=geodesic"], "env.reward geodesic needs env.generator grid"),
        (["env.reward=shaped"], "env.reward"),
    ],
)
def test_bad_reward_settings_are_one_line(override, names):
    with pytest.raises(ConfigError, match=f"config: {names}") as e:
        load_config("smoke", override)
    assert "\n" not in str(e.value)
    load_config("smoke", ["env.generator=grid", "env.reward=geodesic"])


def test_progress_along_the_shortest_path_pays_for_heading_to_the_opening():
    """In cell 0 of the U, driving straight up (towards the opening, away from the goal
    behind the wall) is 0.03 m of progress along the shortest path, and a loss along the
    straight line: both by hand."""
    settings = dict(generator="grid", grid_rows=2, grid_cols=2, reward="progress",
                    progress_scale=5.0, proximity_penalty=0.0, step_penalty=0.0)  # fmt: skip
    maze, dist = _u_maze()
    up = dict(maze=maze, pos=jnp.asarray([-0.5, -0.5]), yaw=jnp.float32(np.pi / 2),
              goal=jnp.asarray([0.5, -0.5]))  # fmt: skip
    rewards = {}
    for path in ("geodesic", "straight"):
        env, params = jaxnav.make(progress_path=path, **settings)
        _, state = env.reset(jax.random.PRNGKey(0), params)
        assert (state.cell_dist is not None) == (path == "geodesic")
        state = state.replace(**up, cell_dist=dist if path == "geodesic" else None)
        rewards[path] = float(env.step_env(jax.random.PRNGKey(1), state, jnp.int32(2), params)[2])
    assert rewards["geodesic"] == pytest.approx(5.0 * 0.03, abs=1e-4)  # 3.0 m -> 2.97 m
    assert rewards["straight"] == pytest.approx(5.0 * (1.0 - np.hypot(1.0, 0.03)), abs=1e-4)


def test_progress_along_the_shortest_path_needs_the_progress_reward_on_a_grid():
    for overrides in (
        ["env.progress_path=geodesic"],
        ["preset=modern", "env.progress_path=geodesic"],
    ):
        with pytest.raises(ConfigError, match="progress_path geodesic needs"):
            load_config("smoke", overrides)
    cfg = load_config("drive_grid4", ["env.progress_path=geodesic"])
    assert cfg.env.progress_path == "geodesic"
