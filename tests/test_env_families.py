"""The environment on drawn cylinder fields and rooms (env.generator cylinders, rooms):
the maze in the state, the LiDAR in it against the reference caster, a new maze every
new_maze_every episodes, the settings refused at load, the shipped configs."""

from __future__ import annotations

import csv

import _nav_reference as ref
import jax
import numpy as np
import pytest

import jaxnav
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.core.shipped import builtin_configs
from jaxnav.env import from_config
from jaxnav.world import cylinders, maps, rooms

CYLINDERS = {"generator": "cylinders", "cyl_count": 6, "cyl_min_path": 1.2}
ROOMS = {"generator": "rooms", "rooms_rows": 2, "rooms_cols": 3, "rooms_door": 0.5}
FAMILIES = {"cylinders": CYLINDERS, "rooms": ROOMS}
KEYS = jax.random.split(jax.random.PRNGKey(13), 8)


def maze_of(state, i=None):
    m = state.maze if i is None else jax.tree.map(lambda x: x[i], state.maze)
    return jax.tree.map(np.asarray, m)


@pytest.fixture(scope="module", params=["cylinders", "rooms"])
def resets(request):
    """(env, params, obs, state) of a batch of resets in the family."""
    env, params = jaxnav.make(**FAMILIES[request.param])
    obs, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(KEYS, params)
    return env, params, obs, state


def test_the_lidar_in_a_drawn_maze_agrees_with_the_reference_caster(resets):
    env, params, obs, state = resets
    step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, None, None)))
    obs2, state2, *_ = step(KEYS, state, 1, params)
    for o, s in ((obs, state), (obs2, state2)):
        for i in range(len(KEYS)):
            walls, circles = ref.maze_geometry(maze_of(s, i))
            pos = np.asarray(s.pos[i], np.float64)[None]
            want = ref.lidar(pos, np.asarray([s.yaw[i]], np.float64), walls, circles, 24)[0]
            np.testing.assert_allclose(np.asarray(o[i, :24]), want, atol=1e-4)


def test_a_reset_puts_robot_and_goal_clear_of_everything_in_a_new_maze(resets):
    _, _, _, state = resets
    layouts = set()
    for i in range(len(KEYS)):
        maze = maze_of(state, i)
        walls, circles = ref.maze_geometry(maze)
        pts = np.stack([state.pos[i], state.goal[i]]).astype(np.float64)
        assert (ref.clearance(pts, walls, circles) >= maps.GOAL_CLEARANCE - 1e-5).all()
        np.testing.assert_allclose(state.pos[i], maze.start[:2])
        layouts.add(maze.segments.tobytes() + maze.circles.tobytes())
    assert len(layouts) == len(KEYS)


def test_make_takes_the_family_from_its_settings():
    env, params = jaxnav.make(**CYLINDERS, cyl_radius=[0.1, 0.25])  # a list works too
    assert env.family == cylinders.Cylinders(6, 0.1, 0.25, 4.0, 1.2)
    assert hash(env) is not None and env.obstacle_obs  # cylinders are obstacles
    assert params.maze.circles.shape == (6, 3) and params.R_minus == -150.0
    env, params = jaxnav.make(**ROOMS)
    assert env.family == rooms.Rooms(2, 3, 2.0, 0.5, 0.0, 1) and not env.obstacle_obs
    assert params.maze.segments.shape == (env.family.n_segments, 4)


def test_a_reset_is_the_same_for_the_same_key():
    env, params = jaxnav.make(**ROOMS)
    reset = jax.jit(env.reset)
    (o1, s1), (o2, s2) = reset(KEYS[0], params), reset(KEYS[0], params)
    for a, b in zip(jax.tree.leaves((o1, s1)), jax.tree.leaves((o2, s2)), strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("every", [1, 2])
def test_a_new_cylinder_field_every_new_maze_every_episodes(every):
    env, params = jaxnav.make(**CYLINDERS, new_maze_every=every)
    _, state = env.reset(KEYS[0], params)
    restart = jax.jit(env.restart)
    seen = [maze_of(state).circles.tobytes()]
    for k in range(4):
        _, state = restart(KEYS[k + 1], state, params)
        seen.append(maze_of(state).circles.tobytes())
        np.testing.assert_allclose(state.pos, maze_of(state).start[:2], atol=1e-6)
    changes = [seen[i] != seen[i - 1] for i in range(1, len(seen))]
    assert changes == [(i % every) == 0 for i in range(1, len(seen))]


@pytest.mark.parametrize(
    "generator, override, names",
    [
        ("cylinders", ["env.cyl_count=0"], "env.cyl_count"),
        ("cylinders", ["env.cyl_count=40"], "env.cyl_count: 40 cylinders"),
        ("cylinders", ["env.cyl_radius=[0.3, 0.1]"], "env.cyl_radius"),
        ("cylinders", ["env.cyl_radius=[0.1, 1.9]"], "env.cyl_radius high"),
        ("cylinders", ["env.cyl_room=-2"], "env.cyl_room"),
        ("cylinders", ["env.cyl_min_path=3"], "env.cyl_min_path"),
        ("cylinders", ["env.cyl_min_path=-1"], "env.cyl_min_path"),
        ("rooms", ["env.rooms_door=0.2"], "env.rooms_door"),
        ("rooms", ["env.rooms_door=0.26"], "env.rooms_door"),
        ("rooms", ["env.rooms_door=1.95"], "env.rooms_door"),
        ("rooms", ["env.rooms_size=-1"], "env.rooms_size"),
        ("rooms", ["env.rooms_rows=1", "env.rooms_cols=1"], "env.rooms_rows x env.rooms_cols"),
        ("rooms", ["env.min_path_cells=3"], "env.min_path_cells"),
        ("rooms", ["env.goal_sampler=robotis"], "env.goal_sampler"),
        ("rooms", ["env.rooms_door=0.4", "env.maze_scale=[0.6, 1]"], "env.maze_scale"),
        ("cylinders", ["env.maze_scale=[0.9, 1.2]"], "env.maze_scale"),
    ],
)
def test_bad_family_settings_are_one_line_naming_the_setting(generator, override, names):
    with pytest.raises(ConfigError, match=f"config: {names}") as e:
        load_config("smoke", [f"env.generator={generator}", *override])
    assert "\n" not in str(e.value)


def test_a_bad_setting_on_the_command_line_is_one_line_and_a_failure(tmp_path, capsys):
    from jaxnav.commands.train import main

    code = main(["cylinders", "--out", str(tmp_path / "run"), "env.cyl_room=0.5"])
    err = capsys.readouterr().err.strip()
    assert code != 0 and "env.cyl_room must be in [1.5, 16] m" in err and "\n" not in err
    assert not (tmp_path / "run").exists()


def test_a_drawn_family_may_grow_with_maze_scale():
    load_config("cylinders", ["env.maze_scale=[1, 1.5]"])
    load_config("rooms", ["env.maze_scale=[0.5, 1.5]"])  # 0.6 m doors stay 0.3 m wide


def test_the_shipped_configs_load_and_are_listed():
    assert {"cylinders", "rooms"} <= set(builtin_configs())
    cyl, rooms = load_config("cylinders"), load_config("rooms")
    assert cyl.env.generator == "cylinders" and rooms.env.generator == "rooms"
    # A family's settings are refused unless it is drawn (they would do nothing), and
    # before its joint limits are checked (40 cylinders is beyond them).
    for key in ("env.cyl_count=40", "env.rooms_door=1.95"):
        with pytest.raises(ConfigError, match="which this config does not draw"):
            load_config("smoke", [key])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cylinders", "rooms"])
def test_a_short_run_trains_and_tests_on_its_drawn_family(name, tmp_path):
    from jaxnav.experiments.evaluation import evaluate_to_dir
    from jaxnav.run.launch import train_new

    cfg = load_config(
        name,
        [
            "strategies=[ebe]",
            "seeds=2",
            "episodes=4",
            "env.max_steps=40",
            "run.chunk_steps=100",
        ],
    )
    env, _ = from_config(cfg)
    assert env.generates and env.generator == name
    out = tmp_path / "run"
    train_new(cfg, out, quiet=True)
    with open(out / "metrics.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 * 4 and all(np.isfinite(float(r["return"])) for r in rows)
    evaluated = evaluate_to_dir(out, ["square4"], 2)
    with open(evaluated / "results.csv") as f:
        mazes = {r["maze"] for r in csv.DictReader(f)}
    assert mazes == {"square4", f"{name}:train", f"{name}:test"}
    assert "(train split)" in (evaluated / "tables.md").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cylinders", "rooms"])
def test_render_draws_a_maze_of_the_family(name, tmp_path, capsys):
    from jaxnav.commands.render import main

    out = tmp_path / f"{name}.png"
    assert main([name, "--out", str(out)]) == 0
    assert out.stat().st_size > 1000 and "wrote" in capsys.readouterr().out
