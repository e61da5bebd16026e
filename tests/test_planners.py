"""The reference drivers: the oracle's raster against NumPy, the oracle driving through
the test without failing where it has time, DWA's choices on hand-made scans, and the
command that drives either through any world."""

from __future__ import annotations

import csv
import io
import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _nav_reference import clearance as np_clearance
from _nav_reference import maze_geometry
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from jaxnav import make
from jaxnav.commands.evaluate import main as evaluate_main
from jaxnav.core.config import load_config
from jaxnav.experiments.baselines import evaluate_world, planner_problem, world_config
from jaxnav.planners import raster as rs
from jaxnav.planners.dwa import DWA
from jaxnav.report.navigation import seed_metrics
from jaxnav.report.results import read_results
from jaxnav.world.maps import make_maze

H = 0.1  # a coarse raster keeps the NumPy references small


@pytest.mark.parametrize("name", ["square4_obstacles", "stage4", "pentagon_obstacles"])
def test_clearance_field_is_each_cell_centres_distance_to_the_nearest_surface(name):
    maze = make_maze(name)
    raster = rs.raster_for([maze], H)
    field = np.asarray(jax.jit(rs.clearance_field, static_argnums=1)(maze, raster))
    x, y = (np.asarray(a) for a in rs.centres(raster, rs.origin_of(maze, raster)))
    walls, circles = maze_geometry(maze)
    pts = np.stack([x.ravel(), y.ravel()], axis=1)
    np.testing.assert_allclose(field.ravel(), np_clearance(pts, walls, circles), atol=2e-5)


def _numpy_goal_distance(free: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """Dijkstra over the same moves (8 neighbours and the knight's), a cell at a time."""
    ny, nx = free.shape
    idx = np.arange(ny * nx).reshape(ny, nx)
    rows, cols, w = [], [], []
    for dy, dx in itertools.product(range(-2, 3), repeat=2):
        if not ((max(abs(dy), abs(dx)) == 1) or {abs(dy), abs(dx)} == {1, 2}):
            continue
        a = idx[max(0, -dy) : ny - max(0, dy), max(0, -dx) : nx - max(0, dx)]
        b = idx[max(0, dy) : ny - max(0, -dy), max(0, dx) : nx - max(0, -dx)]
        ok = free.ravel()[a.ravel()] & free.ravel()[b.ravel()]
        rows += list(a.ravel()[ok])
        cols += list(b.ravel()[ok])
        w += [math.hypot(dy, dx) * H] * int(ok.sum())
    n = ny * nx
    graph = coo_matrix((w + [0.0] * 0, (rows, cols)), shape=(n + 1, n + 1)).tolil()
    start = np.flatnonzero(np.isfinite(seeds.ravel()))
    for s in start:  # a source node joined to every seed cell at its seed distance
        graph[n, s] = max(seeds.ravel()[s], 1e-12)
    d = dijkstra(graph.tocsr(), indices=n)[:n]
    return d.reshape(ny, nx)


def test_goal_distance_equals_dijkstra_on_the_same_moves():
    maze = make_maze("stage4")
    raster = rs.raster_for([maze], H)
    clearance = rs.clearance_field(maze, raster)
    origin = rs.origin_of(maze, raster)
    free = np.asarray(clearance >= 0.2)
    goal = jnp.asarray([1.9, -0.5])
    field = np.asarray(
        jax.jit(rs.goal_distance, static_argnums=4)(jnp.asarray(free), goal, 0.2, origin, raster)
    )
    x, y = (np.asarray(a) for a in rs.centres(raster, origin))
    to_goal = np.maximum(np.hypot(x - 1.9, y + 0.5) - 0.2, 0.0)
    seeds = np.where(free & (to_goal <= H * math.sqrt(2)), to_goal, np.inf)
    expected = _numpy_goal_distance(free, seeds)
    np.testing.assert_allclose(field, expected, rtol=1e-5, atol=1e-5)
    assert np.isfinite(field).sum() > 0.5 * free.sum()  # the free space is mostly one piece


def test_reading_a_field_bounds_the_clearance_from_below_and_a_way_from_above():
    maze = make_maze("square4_obstacles")
    raster = rs.raster_for([maze], H)
    clearance = rs.clearance_field(maze, raster)
    origin = rs.origin_of(maze, raster)
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1.8, 1.8, size=(500, 2))
    low = np.asarray(rs.field_lower(clearance, origin, raster, pts[:, 0], pts[:, 1]))
    walls, circles = maze_geometry(maze)
    assert np.all(low <= np_clearance(pts, walls, circles) + 1e-5)
    # a way from a point: at least the straight line to the goal's disc
    free = clearance >= 0.15
    goal = jnp.asarray([1.2, 1.2])
    field = rs.goal_distance(free, goal, 0.2, origin, raster)
    up = np.asarray(rs.field_upper(field, origin, raster, pts[:, 0], pts[:, 1]))
    straight = np.maximum(np.hypot(pts[:, 0] - 1.2, pts[:, 1] - 1.2) - 0.2, 0.0)
    assert np.all(up[np.isfinite(up)] >= straight[np.isfinite(up)] - 1e-5)


def _metrics(text: str, maze: str, name: str, seeds: int) -> list[dict[str, float]]:
    res = read_results(text)
    return [seed_metrics(res[(maze, name, k)]) for k in range(seeds)]


@pytest.mark.slow  # 3 s on 2 cores
@pytest.mark.parametrize("world", ["square4", "square4_obstacles"])
def test_the_oracle_reaches_every_goal_it_has_time_for(world):
    """The yardstick: a driver that cannot fail where the world allows, through the
    same test and counting as the policies."""
    cfg = load_config(None, [f"env.maze={world}", "env.max_steps=150"])
    text = evaluate_world("oracle", cfg, n_seeds=2, n_episodes=2).text
    for m in _metrics(text, world, "oracle", 2):
        assert m["success"] == 1.0 and m["collision"] == 0.0
        assert m["spl"] > 0.85  # its paths are near the shortest (jaxnav.world.paths)


@pytest.mark.slow
@pytest.mark.parametrize(
    "world", ["stage4", "cylinders", "grid4", "paper_obstacles env.action_delay=true"]
)
def test_the_oracle_drives_the_shipped_worlds(world):
    name, *overrides = world.split()
    cfg = world_config(name, overrides)
    text, names, *_ = evaluate_world("oracle", cfg, n_seeds=4, n_episodes=2)
    for maze in names:
        success = [m["success"] for m in _metrics(text, maze, "oracle", 4)]
        assert np.mean(success) >= 0.97, (maze, success)


def _obs(env, params, ranges, heading, distance):
    return jnp.concatenate([jnp.asarray(ranges, jnp.float32), jnp.asarray([heading, distance])])


def test_dwa_turns_towards_a_goal_it_sees_clear():
    env, params = make("square4")
    dwa = DWA(env)
    obs = _obs(env, params, np.full(env.n_beams, 3.5), math.pi / 2, 2.0)  # goal to the left
    action, _ = dwa.plan(None, obs, None, params)
    assert float(params.omegas[int(action)]) == 1.5
    obs = _obs(env, params, np.full(env.n_beams, 3.5), 0.0, 2.0)  # straight ahead
    action, _ = dwa.plan(None, obs, None, params)
    assert float(params.omegas[int(action)]) == 0.0


def test_dwa_leaves_the_straight_path_into_a_wall_it_sees():
    """A wall 0.3 m ahead across the front beams and the goal beyond it: driving
    straight (or turning gently) would hit it within the horizon, so DWA turns hard."""
    env, params = make("square4")
    dwa = DWA(env)
    angles = 2 * np.pi * np.arange(env.n_beams) / env.n_beams
    ahead = np.cos(angles) > 0.3
    ranges = np.where(ahead, 0.3 / np.maximum(np.cos(angles), 1e-3), 3.5).clip(0.12, 3.5)
    obs = _obs(env, params, ranges, 0.05, 2.0)
    action, _ = dwa.plan(None, obs, None, params)
    assert abs(float(params.omegas[int(action)])) == 1.5


def test_a_world_is_a_config_or_a_maze_and_bad_names_are_one_line(capsys):
    assert world_config("stage4").run.test_mazes == ("stage4", "stage4_humble")  # the config
    assert world_config("square4_obstacles").env.maze == "square4_obstacles"  # a maze
    assert evaluate_main(["--baseline", "oracle", "nosuch"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown maze 'nosuch'" in err[0]
    assert evaluate_main(["--baseline", "oracle", "square4", "--robustness"]) == 2
    assert "do not apply" in capsys.readouterr().err
    # a list of test mazes the world's test would not drive is refused, not ignored
    assert evaluate_main(["--baseline", "oracle", "stage4", "run.test_mazes=[square4]"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--baseline drives its WORLD's own test" in err[0]
    assert evaluate_main(["--baseline", "oracle", "square4", "env.maze_scale=[0.8,1.2]"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot plan with env.maze_scale" in err[0]
    env, _ = make("square4", maze_scale=(0.8, 1.2))
    assert planner_problem("dwa", env) is None  # DWA reads only the scan


@pytest.mark.slow  # 4 s on 2 cores
def test_evaluate_baseline_writes_its_results_and_tables(tmp_path, capsys):
    out = tmp_path / "oracle"
    args = ["--baseline", "dwa", "square2", "env.max_steps=60", "--seeds", "2"]
    assert evaluate_main([*args, "--episodes", "1", "--out", str(out)]) == 0
    rows = list(csv.DictReader(io.StringIO((out / "results.csv").read_text())))
    assert {(r["strategy"], r["seed"], r["maze"]) for r in rows} == {
        ("dwa", "0", "square2"),
        ("dwa", "1", "square2"),
    }
    assert "| square2 | DWA |" in (out / "tables.md").read_text()
    assert "dwa" in capsys.readouterr().out


def test_the_oracle_turns_round_where_an_obstacle_blocks_the_way_it_faces():
    """Facing away from its way beside a cylinder, with a stop in its action set, no
    plan of the oracle's tree turns round and then drives: it stood there for the rest
    of the episode. Where nothing moves it turns in place towards the way instead."""
    from jaxnav.env import from_config
    from jaxnav.experiments.baselines import planner_of

    env, params = from_config(world_config("drive_obstacles"))  # square4_obstacles, vw
    oracle = planner_of("oracle", env, [params.maze], params)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    pos, goal = jnp.array([0.8018632, 0.9227877]), jnp.array([-0.8, 0.1])
    state = state.replace(
        pos=pos, yaw=jnp.float32(-1.05), goal=goal, goal_distance0=jnp.linalg.norm(goal - pos)
    )
    mem = oracle.start(params, state)
    plan, step = jax.jit(oracle.plan), jax.jit(env.step_env)
    for t in range(60):
        action, mem = plan(mem, None, state, params)
        _, state, _, _, _, info = step(jax.random.PRNGKey(t), state, action, params)
        if bool(info["goal_reached"]) or bool(info["collision"]):
            break
    assert bool(info["goal_reached"]) and not bool(info["collision"]), t
