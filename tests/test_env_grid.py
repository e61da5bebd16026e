"""The environment on drawn grid mazes (env.generator=grid): the maze in the state, a
new one every new_maze_every episodes, the sensor and collisions in it, the settings."""

from __future__ import annotations

import csv

import _nav_reference as ref
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.env import from_config
from jaxnav.experiments.evaluation import drawn_policies, evaluate_to_dir, load_run
from jaxnav.experiments.rollout import eval_keys, run_tests
from jaxnav.run.launch import train_new
from jaxnav.world import generators as gen

GRID = {"generator": "grid", "grid_rows": 4, "grid_cols": 4, "min_path_cells": 3}
KEYS = jax.random.split(jax.random.PRNGKey(11), 16)


def maze_of(state, i=None):
    """The state's maze (run i of a batch) as a host-side Maze."""
    m = state.maze if i is None else jax.tree.map(lambda x: x[i], state.maze)
    return jax.tree.map(np.asarray, m)


def test_the_default_state_holds_no_maze():
    env, params = jaxnav.make("square4")
    _, state = env.reset(KEYS[0], params)
    assert state.maze is None and state.maze_episodes is None and state.cell_dist is None
    assert len(jax.tree.leaves(state)) == 7  # pose (2), goal, t, d0, scale, circles


@pytest.mark.slow
def test_reset_draws_a_maze_a_start_cell_and_a_far_goal():
    env, params = jaxnav.make(**GRID)
    assert params.maze.segments.shape == (gen.Grid(4, 4).n_segments, 4)
    obs, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(KEYS, params)
    grid = env.family
    a, b = gen.wall_cells(grid)
    layouts = set()
    for i in range(len(KEYS)):
        maze = maze_of(state, i)
        centres = maze.goal_points
        start = int(np.argmin(np.linalg.norm(centres - np.asarray(state.pos[i]), axis=1)))
        goal = int(np.argmin(np.linalg.norm(centres - np.asarray(state.goal[i]), axis=1)))
        np.testing.assert_allclose(state.pos[i], centres[start], atol=1e-6)
        np.testing.assert_allclose(state.goal[i], centres[goal], atol=1e-6)
        open_ = ~np.asarray(maze.segment_mask[: grid.n_walls])
        assert gen.layout_split(jnp.asarray(open_)) == 0  # the train split by default
        d = _bfs(grid, a, b, open_, start)
        assert d[goal] >= 3
        layouts.add(open_.tobytes())
    assert len(layouts) > len(KEYS) // 2


def _bfs(grid, a, b, open_, src):
    d = np.full(grid.n_cells, -1)
    d[src] = 0
    for _ in range(grid.n_cells):
        for w in np.flatnonzero(open_):
            for u, v in ((a[w], b[w]), (b[w], a[w])):
                if d[u] >= 0 and (d[v] < 0 or d[v] > d[u] + 1):
                    d[v] = d[u] + 1
    return d


def test_the_lidar_in_a_drawn_maze_agrees_with_the_reference_caster():
    env, params = jaxnav.make(**GRID, grid_loops=0.3)
    obs, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(KEYS, params)
    step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, None, None)))
    obs2, state2, *_ = step(KEYS, state, 3, params)
    for o, s in ((obs, state), (obs2, state2)):
        for i in range(len(KEYS)):
            walls, circles = ref.maze_geometry(maze_of(s, i))
            pos = np.asarray(s.pos[i], np.float64)[None]
            want = ref.lidar(pos, np.asarray([s.yaw[i]], np.float64), walls, circles, 24)[0]
            np.testing.assert_allclose(np.asarray(o[i, :24]), want, atol=1e-4)


@pytest.mark.slow
def test_collisions_are_with_the_state_maze():
    env, params = jaxnav.make(**GRID)
    _, state = env.reset(KEYS[0], params)
    maze = maze_of(state)
    grid = env.family
    a, b = gen.wall_cells(grid)
    open_ = ~maze.segment_mask[: grid.n_walls]
    # A wall between two side-by-side cells, closed in one maze and open in the other.
    w = int(np.flatnonzero(b == a + 1)[0])
    x_wall = float(maze.goal_points[a[w], 0]) + grid.cell / 2
    pos = jnp.asarray([x_wall - 0.14, float(maze.goal_points[a[w], 1])], jnp.float32)
    here = state.replace(pos=pos, yaw=jnp.float32(0.0))  # facing +x, the wall 0.14 m ahead
    flipped = np.array(open_)
    flipped[w] = not flipped[w]
    other = gen.layout_maze(jnp.asarray(flipped), grid, jnp.int32(0), jnp.float32(0.0))
    hit = {}
    for name, m in (("state", state.maze), ("flipped", other)):
        *_, info = env.step_env(KEYS[1], here.replace(maze=m), 2, params)
        hit[name] = bool(info["collision"])
    assert hit["state"] == (not open_[w]) and hit["flipped"] == bool(open_[w])


@pytest.mark.parametrize("every", [1, 3])
def test_a_new_maze_every_new_maze_every_episodes(every):
    env, params = jaxnav.make(**GRID, new_maze_every=every)
    _, state = env.reset(KEYS[0], params)
    restart = jax.jit(env.restart)
    seen = [maze_of(state).segments.tobytes()]
    goals = [np.asarray(state.goal)]
    for k in range(6):
        _, state = restart(KEYS[k + 1], state, params)
        seen.append(maze_of(state).segments.tobytes())
        goals.append(np.asarray(state.goal))
        np.testing.assert_allclose(state.pos, maze_of(state).start[:2], atol=1e-6)
    changes = [seen[i] != seen[i - 1] for i in range(1, len(seen))]
    assert changes == [(i % every) == 0 for i in range(1, len(seen))]
    for i in range(1, len(seen)):  # the goal is kept while the maze is
        if not changes[i - 1]:
            np.testing.assert_array_equal(goals[i], goals[i - 1])


@pytest.mark.slow
def test_the_test_split_draws_test_layouts():
    env, params = jaxnav.make(**GRID, split="test")
    _, state = jax.vmap(env.reset, in_axes=(0, None))(KEYS, params)
    open_ = ~np.asarray(state.maze.segment_mask[:, : env.family.n_walls])
    assert (np.asarray(jax.vmap(gen.layout_split)(jnp.asarray(open_))) == 1).all()


@pytest.mark.parametrize(
    "override, names",
    [
        (["env.grid_rows=1", "env.grid_cols=1"], "env.grid_rows x env.grid_cols"),
        (["env.grid_rows=-2"], "env.grid_rows"),
        (["env.min_path_cells=7"], "env.min_path_cells"),
        (["env.grid_cell=0.2"], "env.grid_cell"),
        (["env.split=val"], "env.split"),
        (["env.goal_sampler=robotis"], "env.goal_sampler"),
    ],
)
def test_bad_grid_settings_are_one_line_naming_the_setting(override, names):
    with pytest.raises(ConfigError, match=f"config: {names}") as e:
        load_config("smoke", ["env.generator=grid", *override])
    assert "\n" not in str(e.value)


def test_bad_generator_is_refused():
    with pytest.raises(ConfigError, match="config: env.generator"):
        load_config("smoke", ["env.generator=caves"])
    # without a generator a grid's settings would do nothing: refused, as nothing reads them
    with pytest.raises(ConfigError, match=r"env.grid_rows \(1\) is a setting of grid mazes"):
        load_config("smoke", ["env.grid_rows=1", "env.grid_cols=1"])


@pytest.mark.slow
def test_two_seeds_train_on_a_new_4x4_maze_every_episode(tmp_path):
    cfg = load_config(
        "smoke",
        [
            "env.generator=grid",
            "env.min_path_cells=3",
            "strategies=[ebe]",
            "seeds=2",
            "episodes=6",
            "env.max_steps=60",
            "run.chunk_steps=200",
        ],
    )
    env, _ = from_config(cfg)
    assert env.generates and env.new_maze_every == 1
    out = tmp_path / "run"
    train_new(cfg, out, quiet=True)
    for name in ("config.yaml", "metrics.csv", "explore.csv", "params.npz", "summary.json"):
        assert (out / name).is_file(), name
    with open(out / "metrics.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 * 6
    assert all(np.isfinite(float(r["return"])) for r in rows)
    assert load_config(str(out / "config.yaml")) == cfg
    # The test plays the fixed test mazes by name, then drawn mazes of the test split.
    evaluated = evaluate_to_dir(out, ["square4"], 2)
    with open(evaluated / "results.csv") as f:
        results = list(csv.DictReader(f))
    learned = [r for r in results if r["strategy"] == "ebe"]
    greedy = [r["maze"] for r in learned if r["mode"] == "greedy"]
    assert greedy == ["square4"] * 4 + ["grid:train"] * 4 + ["grid:test"] * 4
    assert len(learned) == 2 * 3 * 2 * 2  # modes x mazes x seeds x episodes
    # The oracle and DWA drive the same test, greedily, once per seed.
    for planner in ("oracle", "dwa"):
        rows = [r["maze"] for r in results if r["strategy"] == planner]
        assert sorted(rows) == sorted(greedy), planner
    tables = (evaluated / "tables.md").read_text()
    assert "## Generalisation gap" in tables and "| grid | EBE |" in tables
    drawn = drawn_policies(load_run(out))
    assert drawn.env.generates and drawn.env.split == "test"
    assert "Trained on `4 x 4 grid mazes (train split)`" in (evaluated / "tables.md").read_text()
    # Every attempt is counted in drawn mazes too, and the rollout keeps each test
    # episode's maze: the first is the one the test's reset draws.
    for r in results:
        ends = ("successes", "collisions", "timeouts", "cut")
        assert int(r["attempts"]) == sum(int(r[k]) for k in ends)
        assert int(r["successes"]) == int(r["goals"]) and int(r["collisions"]) == int(r["collided"])
    res = run_tests(drawn, [drawn.env_params.maze], 2, navigation=True)[0]
    for i in range(2):
        _, state = drawn.env.reset(
            jax.random.split(eval_keys(drawn.labels)[i])[0], drawn.env_params
        )
        np.testing.assert_array_equal(res.mazes.segments[i, 0], state.maze.segments)
        np.testing.assert_array_equal(res.mazes.segment_mask[i, 0], state.maze.segment_mask)
        np.testing.assert_array_equal(res.steps.pos[i, 0], state.pos)


@pytest.mark.slow
def test_a_checkpoint_restores_the_drawn_maze_with_the_state(tmp_path):
    from jaxnav.core import rundir
    from jaxnav.run.checkpoint import chunk_slots, leaf_names
    from jaxnav.run.training import Run

    cfg = load_config(
        None,
        [
            "env.generator=grid",
            "strategies=[ebe]",
            "seeds=2",
            "episodes=4",
            "env.max_steps=50",
            "run.chunk_steps=60",
            "dqn.batch_size=16",
        ],
    )
    out = tmp_path / "run"
    run = Run(cfg, out, quiet=True)
    rundir.create(out)
    ts = run.fresh_state()
    before = run.shard.get(ts.step).copy()
    ts, _ = run.chunk(ts, np.int32(run.steps_needed(ts)))
    run.save(ts, [], [], chunk_slots(before, run.shard.get(ts.step), cfg.buffer_capacity))
    live = run.shard.get(ts)
    restored = Run(cfg, out, quiet=True)
    again = restored.shard.get(restored.restored_state())
    assert live.env_state.maze.segments.shape == (2, gen.Grid(4, 4).n_segments, 4)
    # everything but the ring of finished episodes, which a checkpoint leaves out
    # (its episodes are in metrics.csv already)
    names = leaf_names(live)
    assert names == leaf_names(again)
    for name, a, b in zip(names, jax.tree.leaves(live), jax.tree.leaves(again), strict=True):
        if not name.startswith(".metrics.ep_"):
            np.testing.assert_array_equal(a, b, err_msg=name)
