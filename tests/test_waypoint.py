"""The shortest paths of rooms mazes and the waypoint observation, against a NumPy
breadth-first search over the rooms' doors read from the maze's own segments."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from test_env_grid import _bfs

import jaxnav
from jaxnav.core.config import ConfigError, load_config
from jaxnav.planners.dwa import DWA
from jaxnav.world import generators as gen

ROOMS = dict(generator="rooms", rooms_rows=3, rooms_cols=3, rooms_size=2.0, rooms_door=0.6)
NORMALISED = dict(observation="normalised", reward="progress")


def _doors(maze, grid) -> tuple[np.ndarray, np.ndarray]:
    """(bool[E] walls with a door, f32[E, 2] the door's middle), from the segment rows
    by geometry: a wall with a door is two segments, the door the gap between them."""
    e = grid.n_walls
    seg, mask = np.asarray(maze.segments), np.asarray(maze.segment_mask)
    has_door = mask[e : 2 * e]
    middle = (seg[:e, 2:] + seg[e : 2 * e, :2]) / 2
    return has_door, middle


def _room_of(p, grid) -> int:
    col = int(np.clip(math.floor(p[0] / grid.cell + grid.cols / 2), 0, grid.cols - 1))
    row = int(np.clip(math.floor(p[1] / grid.cell + grid.rows / 2), 0, grid.rows - 1))
    return row * grid.cols + col


def _reference_path(maze, grid, pos, goal) -> list[np.ndarray]:
    """The doors the path from ``pos`` to ``goal`` passes, in order, then the goal, in a
    rooms maze without loops (one path: a tree of rooms)."""
    has_door, middle = _doors(maze, grid)
    here, there = _room_of(pos, grid), _room_of(goal, grid)
    dist = _bfs(grid, *gen.wall_cells(grid), has_door, there)
    a, b = gen.wall_cells(grid)
    points = []
    while here != there:
        (w, nxt), *_ = [
            (w, q)
            for w in np.flatnonzero(has_door)
            for p, q in ((a[w], b[w]), (b[w], a[w]))
            if p == here and dist[q] == dist[here] - 1
        ]
        points.append(middle[w])
        here = nxt
    return [*points, np.asarray(goal)]


def _reference_length(maze, grid, pos, goal) -> float:
    line = [np.asarray(pos, np.float64), *_reference_path(maze, grid, pos, goal)]
    return float(sum(np.linalg.norm(q - p) for p, q in zip(line, line[1:])))


def _reference_carrot(maze, grid, pos, goal, lookahead: float) -> np.ndarray:
    """Walk ``lookahead`` metres along the path, piece by piece."""
    line = [np.asarray(pos, np.float64), *_reference_path(maze, grid, pos, goal)]
    left = lookahead
    for p, q in zip(line, line[1:]):
        piece = np.linalg.norm(q - p)
        if piece >= left and piece > 0:
            return p + (q - p) * (left / piece)
        left -= piece
    return line[-1]


def _reference_targets(maze, grid, pos, goal) -> list[np.ndarray]:
    """Every point the shortest path from ``pos`` may head for next: the goal in its
    room, else the door into any neighbouring room one door nearer the goal's."""
    has_door, middle = _doors(maze, grid)
    here, there = _room_of(pos, grid), _room_of(goal, grid)
    if here == there:
        return [np.asarray(goal)]
    dist = _bfs(grid, *gen.wall_cells(grid), has_door, there)
    a, b = gen.wall_cells(grid)
    out = []
    for w in np.flatnonzero(has_door):
        for p, q in ((a[w], b[w]), (b[w], a[w])):
            if p == here and dist[q] == dist[here] - 1:
                out.append(middle[w])
    return out


@pytest.fixture(scope="module")
def rooms_states():
    env, params = jaxnav.make(**ROOMS, **NORMALISED, waypoint=True)
    keys = jax.random.split(jax.random.PRNGKey(7), 12)
    obs, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
    return env, params, obs, state


def _one(tree, i):
    return jax.tree.map(lambda x: np.asarray(x[i]), tree)


@pytest.mark.slow  # 5 s on 2 cores
def test_rooms_cell_distances_are_the_bfs_over_their_doors(rooms_states):
    env, _, _, state = rooms_states
    grid = env.family.grid
    for i in range(state.pos.shape[0]):
        maze = _one(state.maze, i)
        has_door, _ = _doors(maze, grid)
        a, b = gen.wall_cells(grid)
        want = np.stack([_bfs(grid, a, b, has_door, s) for s in range(grid.n_cells)])
        np.testing.assert_array_equal(np.asarray(state.cell_dist[i]), want)


@pytest.mark.slow  # 3 s on 2 cores
def test_the_rooms_path_heads_for_a_door_one_room_nearer_the_goal(rooms_states):
    env, _, _, state = rooms_states
    grid = env.family.grid
    rng = np.random.default_rng(0)
    half = np.array([grid.cols, grid.rows]) * grid.cell / 2
    checked_doors = 0
    geodesic_target = jax.jit(env.family.geodesic_target)  # one compilation, not every op
    for i in range(state.pos.shape[0]):
        maze, dist, goal = _one(state.maze, i), state.cell_dist[i], np.asarray(state.goal[i])
        for p in rng.uniform(-half + 0.1, half - 0.1, (20, 2)).astype(np.float32):
            target, along = geodesic_target(
                jax.tree.map(jnp.asarray, maze), dist, jnp.asarray(p), jnp.asarray(goal)
            )
            options = _reference_targets(maze, grid, p, goal)
            assert any(np.allclose(target, o, atol=1e-5) for o in options), (p, target, options)
            want = _reference_length(maze, grid, p, goal)
            assert float(along) == pytest.approx(want, abs=1e-4)
            assert float(along) >= np.linalg.norm(goal - p) - 1e-4  # never below the line
            checked_doors += _room_of(p, grid) != _room_of(goal, grid)
    assert checked_doors > 100


@pytest.mark.slow  # its fixture is a slow test's
def test_the_waypoint_observation_is_the_next_doors_heading_and_distance(rooms_states):
    env, params, obs, state = rooms_states
    step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, None, None)))
    keys = jax.random.split(jax.random.PRNGKey(8), state.pos.shape[0])
    obs2, state2, *_ = step(keys, state, jnp.int32(3), params)
    n = env.n_beams
    assert obs.shape[-1] == env.obs_size == n + 6
    for o, s in ((obs, state), (obs2, state2)):
        for i in range(s.pos.shape[0]):
            maze, pos, yaw = _one(s.maze, i), np.asarray(s.pos[i]), float(s.yaw[i])
            goal = np.asarray(s.goal[i])
            want = _reference_path(maze, env.family.grid, pos, goal)[0]
            rel = want - pos
            heading = math.remainder(math.atan2(rel[1], rel[0]) - yaw, 2 * math.pi)
            seen = [heading / math.pi, min(np.linalg.norm(rel), 3.5) / 3.5]
            np.testing.assert_allclose(o[i, n + 4 :], seen, atol=3e-5)
            # the goal's heading and distance stay where they were
            rel = goal - pos
            heading = math.remainder(math.atan2(rel[1], rel[0]) - yaw, 2 * math.pi)
            assert o[i, n] == pytest.approx(heading / math.pi, abs=2e-5)


@pytest.mark.slow  # its fixture is a slow test's
def test_the_carrot_walks_along_the_path_at_many_points(rooms_states):
    env, _, _, state = rooms_states
    grid = env.family.grid
    rng = np.random.default_rng(1)
    half = np.array([grid.cols, grid.rows]) * grid.cell / 2
    waypoint = jax.jit(env.family.waypoint)  # one compilation, not every op eagerly
    for i in range(state.pos.shape[0]):
        maze, dist, goal = _one(state.maze, i), state.cell_dist[i], np.asarray(state.goal[i])
        jmaze = jax.tree.map(jnp.asarray, maze)
        for p in rng.uniform(-half + 0.1, half - 0.1, (10, 2)).astype(np.float32):
            for lookahead in (0.2, 0.5, 2.5, 50.0):
                got = waypoint(jmaze, dist, jnp.asarray(p), jnp.asarray(goal), lookahead)
                want = _reference_carrot(maze, grid, p, goal, lookahead)
                np.testing.assert_allclose(got, want, atol=2e-5)


def test_on_a_fixed_maze_the_waypoint_is_the_goal():
    env, params = jaxnav.make("square4", **NORMALISED, waypoint=True)
    obs, _ = env.reset(jax.random.PRNGKey(0), params)
    n = env.n_beams
    np.testing.assert_allclose(obs[n + 4 : n + 6], obs[n : n + 2], atol=1e-6)


@pytest.mark.slow  # 3 s on 2 cores
def test_a_grid_maze_has_a_waypoint_too():
    grid = dict(generator="grid", grid_rows=3, grid_cols=3)
    env, params = jaxnav.make(**grid, **NORMALISED, waypoint=True)
    obs, state = env.reset(jax.random.PRNGKey(3), params)
    target, _ = env.family.geodesic_target(state.maze, state.cell_dist, state.pos, state.goal)
    rel = np.asarray(target - state.pos)
    assert float(obs[-1]) == pytest.approx(min(np.linalg.norm(rel), 3.5) / 3.5, abs=1e-6)
    # the path's first point is that opening (a grid's openings: its walls' middles)
    points = gen.path_points(
        state.cell_dist,
        env.family,
        state.pos,
        state.goal,
        state.maze.segment_mask[: env.family.n_walls],
        gen.wall_middles(env.family),
    )
    np.testing.assert_allclose(points[0], target, atol=1e-6)


@pytest.mark.parametrize(
    "overrides, says",
    [
        (["env.generator=rooms", "env.waypoint=true"], "env.waypoint is part of the normalised"),
        (
            ["preset=modern", "env.waypoint=true"],
            "env.waypoint follows the maze's shortest paths: it needs env.generator grid or rooms",
        ),
        (
            ["preset=modern", "env.generator=cylinders", "env.waypoint=true"],
            "needs env.generator grid or rooms",
        ),
    ],
)
def test_a_waypoint_without_its_needs_is_one_line(overrides, says):
    with pytest.raises(ConfigError, match=says):
        load_config("smoke", overrides)


def test_progress_along_the_shortest_path_works_in_rooms_now():
    cfg = load_config("drive_rooms", ["env.progress_path=geodesic", "env.waypoint=true"])
    env, params = jaxnav.env.from_config(cfg)
    assert env.uses_cell_distances and env.obs_size == env.n_beams + 6


@pytest.mark.slow  # 3 s on 2 cores
def test_dwa_heads_for_the_paths_carrot_where_the_policies_see_the_path(rooms_states):
    """Given the path, DWA's choice is its choice for a goal at the path's carrot."""
    env, params, obs, state = rooms_states
    plain = dataclasses.replace(env, waypoint=False)
    n = env.n_beams
    for i in range(state.pos.shape[0]):
        s = _one(state, i)
        s = jax.tree.map(jnp.asarray, s)
        carrot = env.family.waypoint(s.maze, s.cell_dist, s.pos, s.goal, 0.5)
        want = _reference_carrot(_one(state.maze, i), env.family.grid, s.pos, s.goal, 0.5)
        np.testing.assert_allclose(carrot, want, atol=2e-5)
        mine, _ = DWA(env).plan(None, obs[i], s, params)
        o = obs[i, : n + 4]
        rel = np.asarray(carrot - s.pos)
        heading = math.remainder(math.atan2(rel[1], rel[0]) - float(s.yaw), 2 * math.pi)
        o = o.at[n].set(heading / math.pi).at[n + 1].set(min(np.linalg.norm(rel), 3.5) / 3.5)
        theirs, _ = DWA(plain).plan(None, o, s.replace(goal=carrot), params)
        assert int(mine) == int(theirs)
