"""Maze geometry: the built-in mazes have the spec's sizes, padding and stacking are
harmless, and maze files are validated with one clear line per mistake."""

from __future__ import annotations

import math
from pathlib import Path

import _nav_reference as ref
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
import jaxnav.core.errors
from jaxnav.world.geometry import path_clearance
from jaxnav.world.maps import BUILTIN_MAZES, Maze, MazeError, load_maze_file, make_maze, stack_mazes
from jaxnav.world.sensor import lidar_scan
from jaxnav.world.stages import STAGES

ROOT = Path(__file__).resolve().parents[1]
CORRIDOR = ROOT / "configs" / "mazes" / "corridor.yaml"

# The mazes that stand still (the stages' moving cylinders: tests/test_moving.py).
STILL = [n for n in BUILTIN_MAZES if n not in STAGES]


def polygon_area(walls: np.ndarray) -> float:
    """Shoelace area of an outline given as consecutive wall segments."""
    x1, y1, x2, y2 = walls.T
    return 0.5 * abs(float(np.sum(x1 * y2 - x2 * y1)))


@pytest.fixture(scope="module")
def builtin():
    return {name: make_maze(name) for name in BUILTIN_MAZES}


# ----------------------------------------------------------------------------
# Built-in mazes (spec table "Mazes")
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("name, half", [("square2", 0.925), ("square4", 1.85), ("square8", 3.7)])
def test_square_mazes_have_the_spec_size(builtin, name, half):
    walls = builtin[name].walls()
    assert walls.shape == (4, 4)
    np.testing.assert_allclose(np.unique(np.abs(walls)), [half], atol=1e-6)
    assert polygon_area(walls) == pytest.approx((2 * half) ** 2, rel=1e-6)
    assert builtin[name].obstacles().shape == (0, 3)
    assert not builtin[name].has_obstacles


def test_stage2_cylinders(builtin):
    m = builtin["square4_obstacles"]
    np.testing.assert_allclose(m.walls(), builtin["square4"].walls())
    obs = m.obstacles()
    assert sorted(map(tuple, np.round(obs, 6))) == sorted(
        (sx * 0.6, sy * 0.6, 0.15) for sx in (-1, 1) for sy in (-1, 1)
    )
    assert m.has_obstacles


@pytest.mark.parametrize(
    "name, n_sides", [("triangle", 3), ("pentagon", 5), ("pentagon_obstacles", 5)]
)
def test_polygon_mazes_are_regular_with_square4s_area(builtin, name, n_sides):
    walls = builtin[name].walls()
    assert walls.shape == (n_sides, 4)
    assert polygon_area(walls) == pytest.approx(3.7**2, rel=1e-4)
    sides = np.hypot(walls[:, 2] - walls[:, 0], walls[:, 3] - walls[:, 1])
    np.testing.assert_allclose(sides, sides[0], rtol=1e-5)
    np.testing.assert_allclose(walls[:, :2].mean(axis=0), 0.0, atol=1e-5)  # centred


def test_pentagon_obstacles_places_cylinders_like_stage2(builtin):
    obs = builtin["pentagon_obstacles"].obstacles()
    assert len(obs) == 5
    np.testing.assert_allclose(obs[:, 2], 0.15)
    np.testing.assert_allclose(np.hypot(obs[:, 0], obs[:, 1]), 0.6 * math.sqrt(2), rtol=1e-5)
    walls = builtin["pentagon_obstacles"].walls().astype(np.float64)
    assert ref.in_free_space(obs[:, :2].astype(np.float64), walls, np.zeros((0, 3))).all()


@pytest.mark.parametrize("name", STILL)
def test_every_maze_starts_at_the_origin_facing_x_in_free_space(builtin, name):
    m = builtin[name]
    np.testing.assert_array_equal(np.asarray(m.start), [0.0, 0.0, 0.0])
    walls, circles = ref.maze_geometry(m)
    assert ref.in_free_space(np.zeros((1, 2)), walls, circles, margin=0.13)[0]
    assert int(m.n_goal_points) >= 8


# ----------------------------------------------------------------------------
# Padding and stacking
# ----------------------------------------------------------------------------


def test_walls_and_obstacles_return_only_real_rows(builtin):
    stacked = stack_mazes([builtin[n] for n in STILL])
    assert stacked.segments.shape[1] == 5 and stacked.circles.shape[1] == 5
    for i, name in enumerate(STILL):
        one = jax.tree.map(lambda x, i=i: x[i], stacked)
        np.testing.assert_array_equal(one.walls(), builtin[name].walls())
        np.testing.assert_array_equal(one.obstacles(), builtin[name].obstacles())
    # square4 stores one masked circle so reductions are never empty; it is not real.
    assert builtin["square4"].circles.shape == (1, 3)
    assert builtin["square4"].obstacles().shape == (0, 3)


def test_stack_mazes_pads_to_a_common_shape_and_vmaps(builtin):
    names = ["square4", "triangle", "square4_obstacles", "pentagon_obstacles"]
    mazes = [builtin[n] for n in names]
    stacked = stack_mazes(mazes)
    n = len(names)
    assert isinstance(stacked, Maze)
    assert stacked.segments.shape == (n, 5, 4) and stacked.segment_mask.shape == (n, 5)
    assert stacked.circles.shape == (n, 5, 3) and stacked.circle_mask.shape == (n, 5)
    G = max(m.goal_points.shape[0] for m in mazes)
    assert stacked.goal_points.shape == (n, G, 2)
    np.testing.assert_array_equal(
        np.asarray(stacked.n_goal_points), [int(m.n_goal_points) for m in mazes]
    )
    np.testing.assert_array_equal(np.asarray(stacked.segment_mask).sum(1), [4, 3, 4, 5])
    np.testing.assert_array_equal(np.asarray(stacked.circle_mask).sum(1), [0, 0, 4, 5])

    # Padding is harmless: scans and swept clearances agree with the unpadded mazes.
    pos, yaw = jnp.asarray([0.3, -0.4]), jnp.float32(0.7)
    omegas = jnp.asarray(ref.OMEGAS, jnp.float32)

    @jax.jit
    def sense(m):
        clear = jax.vmap(lambda w: path_clearance(m, pos, yaw, w, 0.15, 0.2))(omegas)
        return lidar_scan(m, pos, yaw, 24), clear

    scan, clear = jax.vmap(sense)(stacked)
    for i in (0, 2):  # both padded in walls and circles (one compile each)
        want_scan, want_clear = sense(mazes[i])
        np.testing.assert_allclose(np.asarray(scan[i]), np.asarray(want_scan), rtol=1e-6)
        np.testing.assert_allclose(np.asarray(clear[i]), np.asarray(want_clear), rtol=1e-6)
    assert not np.allclose(scan[0], scan[2])  # the cylinders show up


# ----------------------------------------------------------------------------
# Maze files
# ----------------------------------------------------------------------------

GOOD = """\
name: room
outline: [[-2, -1.5], [2, -1.5], [2, 1.5], [-2, 1.5], [-2, -1.5]]
obstacles:
  - circle: [0.8, 0.5, 0.2]
  - polygon: [[-1.2, -0.4], [-0.7, -0.4], [-0.7, 0.4], [-1.2, 0.4], [-1.2, -0.4]]
start: [0.0, -0.8, 1.5707963]
"""


def write(tmp_path, text, name="maze.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_a_good_maze_file_loads_with_circle_and_polygon_obstacles(tmp_path):
    m = load_maze_file(write(tmp_path, GOOD))
    assert m.walls().shape == (8, 4)  # 4 outline edges + 4 box edges
    np.testing.assert_allclose(m.obstacles(), [[0.8, 0.5, 0.2]], atol=1e-6)
    np.testing.assert_allclose(np.asarray(m.start), [0.0, -0.8, math.pi / 2], atol=1e-6)
    assert int(m.n_obstacles) == 2 and m.has_obstacles
    goals = np.asarray(m.goal_points)[: int(m.n_goal_points)].astype(np.float64)
    walls, circles = ref.maze_geometry(m)
    assert ref.in_free_space(goals, walls, circles, margin=0.34).all()
    box = (goals[:, 0] > -1.2) & (goals[:, 0] < -0.7) & (np.abs(goals[:, 1]) < 0.4)
    assert not box.any()
    # make_maze and jaxnav.make take the path too, and the env runs in it.
    env, params = jaxnav.make(str(tmp_path / "maze.yaml"))
    assert env.obstacle_obs and env.obs_size == 28 and params.maze.walls().shape == (8, 4)


def test_default_start_is_the_outline_centroid(tmp_path):
    m = load_maze_file(write(tmp_path, "outline: [[0, 0], [4, 0], [4, 2], [0, 2], [0, 0]]\n"))
    np.testing.assert_allclose(np.asarray(m.start), [2.0, 1.0, 0.0])


def test_the_example_corridor_maze_loads():
    m = make_maze(str(CORRIDOR))
    assert m.walls().shape == (10, 4) and m.obstacles().shape == (1, 3)
    walls, circles = ref.maze_geometry(m)
    start = np.asarray(m.start[:2], np.float64)[None]
    assert ref.in_free_space(start, walls, circles, margin=0.13)[0]
    assert int(m.n_goal_points) > 100


SQUARE = "[[-2, -2], [2, -2], [2, 2], [-2, 2], [-2, -2]]"
BAD_FILES = {
    "outline not closed": (
        "outline: [[-2, -2], [2, -2], [2, 2], [-2, 2]]\n",
        "outline is not closed",
    ),
    "self-intersecting outline": (
        "outline: [[0, 0], [4, 0], [4, 4], [1, 4], [3, -1], [0, 0]]\n",
        "outline crosses itself",
    ),
    # a bow tie: its two halves' signed areas cancel, and it was said to enclose none
    "bow-tie outline": (
        "outline: [[0, 0], [4, 4], [4, 0], [0, 4], [0, 0]]\n",
        "outline crosses itself",
    ),
    "flat outline": (
        "outline: [[0, 0], [1, 0], [2, 0], [0, 0]]\n",
        "outline encloses no area (its vertices lie on one line)",
    ),
    "start outside": (f"outline: {SQUARE}\nstart: [3.0, 0.0, 0.0]\n", "start pose is not inside"),
    "start touching a wall": (
        f"outline: {SQUARE}\nstart: [1.9, 0.0, 0.0]\n",
        "start pose is within the robot radius",
    ),
    "start inside an obstacle": (
        f"outline: {SQUARE}\nobstacles:\n"
        "  - polygon: [[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]\n",
        "start pose is not inside the free space",
    ),
    "obstacle outside outline": (
        f"outline: {SQUARE}\nobstacles:\n  - circle: [5.0, 0.0, 0.2]\n",
        "obstacle 0 is not inside the outline",
    ),
    "no room for goals": (
        "outline: [[-0.4, -0.4], [0.4, -0.4], [0.4, 0.4], [-0.4, 0.4], [-0.4, -0.4]]\n",
        "no room left for goals",
    ),
    "not valid YAML": ("outline: [[0, 0], [1, 0]\n  bad: : ]\n", "not valid YAML"),
    "unknown key": (f"outline: {SQUARE}\nfloor: 3\n", "unknown key 'floor'"),
    "missing outline": ("obstacles: []\n", "missing 'outline'"),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_a_bad_maze_file_is_rejected_with_one_clear_line(tmp_path, case):
    text, expected = BAD_FILES[case]
    path = write(tmp_path, text)
    with pytest.raises(MazeError) as err:
        make_maze(path)
    msg = str(err.value)
    assert expected in msg, msg
    assert "\n" not in msg and msg.startswith(f"maze file {path}: ")


def test_each_mistake_has_its_own_message(tmp_path):
    messages = set()
    same = ("start inside an obstacle", "bow-tie outline")  # = "start outside", a crossing
    cases = [c for c in BAD_FILES if c not in same]
    for i, (text, _) in enumerate(BAD_FILES[c] for c in cases):
        with pytest.raises(MazeError) as err:
            make_maze(write(tmp_path, text, f"m{i}.yaml"))
        messages.add(str(err.value).split(": ", 1)[1])
    assert len(messages) == len(cases)


def test_a_missing_file_or_unknown_name_is_one_line():
    with pytest.raises(MazeError, match=r"^maze file /no/such/maze.yaml: no such file$"):
        make_maze("/no/such/maze.yaml")
    with pytest.raises(MazeError) as err:
        make_maze("sqaure4")
    assert "unknown maze 'sqaure4'" in str(err.value) and "square4" in str(err.value)
    assert "\n" not in str(err.value)
    assert issubclass(MazeError, ValueError)
    assert MazeError is jaxnav.core.errors.MazeError  # the one error type, caught by every command
    assert issubclass(MazeError, jaxnav.core.errors.JaxnavError)
