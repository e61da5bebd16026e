"""The grid maze family: carving, shortest paths, the train/test split."""

from __future__ import annotations

from collections import deque

import jax
import numpy as np
import pytest

from jaxnav.core.families import grid_problem
from jaxnav.world import generators as gen

KEYS = jax.random.split(jax.random.PRNGKey(7), 200)


def bfs(n_cells: int, a: np.ndarray, b: np.ndarray, open_: np.ndarray, src: int) -> np.ndarray:
    """NumPy BFS over the cell graph: distance from ``src`` to every cell (-1 unreached)."""
    nbrs = [[] for _ in range(n_cells)]
    for w in np.flatnonzero(open_):
        nbrs[a[w]].append(b[w])
        nbrs[b[w]].append(a[w])
    dist = np.full(n_cells, -1)
    dist[src] = 0
    queue = deque([src])
    while queue:
        u = queue.popleft()
        for v in nbrs[u]:
            if dist[v] < 0:
                dist[v] = dist[u] + 1
                queue.append(v)
    return dist


def carve_many(grid: gen.Grid, keys=KEYS) -> np.ndarray:
    return np.asarray(jax.jit(jax.vmap(lambda k: gen.carve(k, grid)))(keys))


@pytest.mark.parametrize("rows, cols", [(4, 4), (3, 7), (1, 5), (6, 2)])
def test_a_perfect_maze_is_connected_with_rc_minus_1_open_walls(rows, cols):
    grid = gen.Grid(rows, cols)
    a, b = gen.wall_cells(grid)
    opens = carve_many(grid)
    assert opens.shape == (len(KEYS), grid.n_walls)
    assert (opens.sum(axis=1) == rows * cols - 1).all()
    for open_ in opens:
        assert (bfs(grid.n_cells, a, b, open_, 0) >= 0).all()
    if min(rows, cols) > 1:  # not one maze over and over (a corridor has only one)
        assert len({o.tobytes() for o in opens}) > len(KEYS) // 2


def test_loops_open_a_fixed_number_of_extra_walls_and_stay_connected():
    grid = gen.Grid(5, 5, loops=0.25)
    a, b = gen.wall_cells(grid)
    opens = carve_many(grid)
    closed = grid.n_walls - (grid.n_cells - 1)
    assert grid.n_extra_open == round(0.25 * closed) > 0
    assert (opens.sum(axis=1) == grid.n_cells - 1 + grid.n_extra_open).all()
    for open_ in opens:
        assert (bfs(grid.n_cells, a, b, open_, 0) >= 0).all()
    every = carve_many(gen.Grid(3, 3, loops=1.0))
    assert every.all()  # loops = 1: every internal wall open


def test_the_wall_segments_agree_with_the_carved_cell_graph():
    grid = gen.Grid(4, 5, cell=0.8)
    a, b = gen.wall_cells(grid)
    open_ = carve_many(grid)[0]
    maze = gen.layout_maze(open_, grid, np.int32(0), np.float32(0.0))
    assert maze.segments.shape == (grid.n_segments, 4) == (2 * 20 + 4 + 5, 4)
    walls = maze.walls()
    assert len(walls) == grid.n_walls - open_.sum() + 2 * (4 + 5)
    centres = np.asarray(maze.goal_points)
    for w in range(grid.n_walls):
        # The straight line between the two cells' centres crosses a wall iff it is closed.
        p, q = centres[a[w]], centres[b[w]]
        mid = (p + q) / 2
        hits = [
            np.allclose((s[:2] + s[2:]) / 2, mid, atol=1e-5)
            and abs(np.linalg.norm(s[2:] - s[:2]) - 0.8) < 1e-5
            for s in walls
        ]
        assert sum(hits) == (0 if open_[w] else 1), w
    # The boundary encloses the grid, centred at the origin.
    np.testing.assert_allclose(maze.bounds, [-2.0, -1.6, 2.0, 1.6], atol=1e-6)
    xs = np.concatenate([walls[:, 0], walls[:, 2]])
    ys = np.concatenate([walls[:, 1], walls[:, 3]])
    assert xs.min() == pytest.approx(-2.0) and xs.max() == pytest.approx(2.0)
    assert ys.min() == pytest.approx(-1.6) and ys.max() == pytest.approx(1.6)


def test_every_draw_has_the_same_shapes():
    grid = gen.Grid(4, 4)
    mazes, goals = jax.jit(jax.vmap(lambda k: gen.draw_maze(k, grid, "train", 3)))(KEYS[:8])
    assert mazes.segments.shape == (8, grid.n_segments, 4)
    assert mazes.goal_points.shape == (8, 16, 2) and goals.shape == (8, 2)


@pytest.mark.parametrize("grid", [gen.Grid(4, 4), gen.Grid(3, 6, loops=0.3), gen.Grid(1, 6)])
def test_shortest_paths_agree_with_numpy_bfs(grid):
    a, b = gen.wall_cells(grid)
    opens = carve_many(grid, KEYS[:60])
    dists = np.asarray(jax.jit(jax.vmap(lambda o: gen.cell_distances(o, grid)))(opens))
    for open_, d in zip(opens, dists):
        want = np.stack([bfs(grid.n_cells, a, b, open_, s) for s in range(grid.n_cells)])
        np.testing.assert_array_equal(d, want)


@pytest.mark.slow
def test_start_and_goal_are_at_least_min_path_cells_apart():
    grid = gen.Grid(4, 4, loops=0.2)
    a, b = gen.wall_cells(grid)
    for min_path in (1, 4, grid.max_min_path):
        draws = jax.jit(jax.vmap(lambda k, m=min_path: gen.draw(k, grid, "train", m)))(KEYS)
        for i in range(len(KEYS)):
            s, g = int(draws.start_cell[i]), int(draws.goal_cell[i])
            d = bfs(grid.n_cells, a, b, np.asarray(draws.open[i]), s)
            assert s != g and d[g] == int(draws.path_cells[i]) >= min_path


def test_no_train_maze_equals_a_test_maze():
    grid = gen.Grid(3, 3)  # 192 perfect mazes: thousands of draws repeat each many times
    keys = jax.random.split(jax.random.PRNGKey(3), 3000)
    train = np.asarray(jax.jit(jax.vmap(lambda k: gen.carve_split(k, grid, "train")))(keys))
    test = np.asarray(jax.jit(jax.vmap(lambda k: gen.carve_split(k, grid, "test")))(keys))
    train_set, test_set = {o.tobytes() for o in train}, {o.tobytes() for o in test}
    assert len(train_set) > 50 and len(test_set) > 50  # both splits are varied
    assert not train_set & test_set
    assert (np.asarray(jax.vmap(gen.layout_split)(train)) == 0).all()
    assert (np.asarray(jax.vmap(gen.layout_split)(test)) == 1).all()


@pytest.mark.parametrize(
    "rows, cols, cell, loops, min_path, says",
    [
        (1, 1, 1.0, 0.0, 1, "at least 2 cells"),
        (0, 4, 1.0, 0.0, 1, "env.grid_rows"),
        (4, -1, 1.0, 0.0, 1, "env.grid_cols"),
        (4, 4, 0.2, 0.0, 1, "env.grid_cell"),
        (4, 4, 1.0, 1.5, 1, "env.grid_loops"),
        (4, 4, 1.0, 0.0, 7, "env.min_path_cells"),
    ],
)
def test_bad_grids_are_refused_naming_the_setting(rows, cols, cell, loops, min_path, says):
    assert says in grid_problem(rows, cols, cell, loops, min_path)
    assert grid_problem(4, 4, 1.0, 0.0, 6) is None
