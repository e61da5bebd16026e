"""Kept mazes: ``jaxnav mazes`` writes drawn mazes as maze files that load back
exactly, start and goal included, and refuses bad arguments in one line."""

from __future__ import annotations

import jax
import numpy as np
import pytest
import yaml

from jaxnav.commands.mazes import main
from jaxnav.core.errors import MazeError
from jaxnav.env import make
from jaxnav.world import generators
from jaxnav.world.maps import make_maze
from jaxnav.world.mazefiles import canonical_segments, number

N = 3


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("kept") / "mazes"
    assert main(["grid", "--n", str(N), "--split", "test", "--seed", "7", "--out", str(out)]) == 0
    return out


def drawn(n, seed, split="test"):
    """The mazes, starts and goals reset draws from split(PRNGKey(seed), n), by hand."""
    env, params = make(generator="grid", split=split)
    for key in jax.random.split(jax.random.PRNGKey(seed), n):
        _, state = env.reset(key, params)
        yield state


@pytest.mark.slow  # 4 s on 2 cores
def test_kept_mazes_load_back_exactly(written, capsys):
    files = sorted(p.name for p in written.iterdir())
    assert files == [f"maze_{i:03d}.yaml" for i in range(N)]
    for i, state in enumerate(drawn(N, 7)):
        maze = make_maze(str(written / files[i]))
        walls = np.asarray(state.maze.segments)[np.asarray(state.maze.segment_mask)]
        np.testing.assert_array_equal(canonical_segments(maze.walls()), canonical_segments(walls))
        assert maze.walls().shape == walls.shape  # no wall split or added
        assert len(maze.obstacles()) == 0
        np.testing.assert_array_equal(maze.start[:2], state.pos)
        np.testing.assert_array_equal(maze.start[2], state.yaw)
        np.testing.assert_array_equal(maze.goal, state.goal)


def test_a_kept_maze_is_played_from_its_start_to_its_goal(written):
    env, params = make(str(written / "maze_001.yaml"))
    state = list(drawn(N, 7))[1]
    for seed in range(3):
        _, s = env.reset(jax.random.PRNGKey(seed), params)
        np.testing.assert_array_equal(s.goal, state.goal)
        np.testing.assert_array_equal(s.pos, state.pos)


def test_the_shortest_path_lies_between_the_straight_line_and_the_cell_path(written):
    grid = generators.Grid(4, 4)
    for i, state in enumerate(drawn(N, 7)):
        doc = yaml.safe_load((written / f"maze_{i:03d}.yaml").read_text())
        length = doc["shortest_path_m"]
        straight = float(np.linalg.norm(np.asarray(doc["goal"]) - np.asarray(doc["start"][:2])))
        # cells on the way from the start's cell to the goal's, breadth-first
        open_ = np.asarray(state.maze.segment_mask)[: grid.n_walls] == 0
        cells = np.asarray(generators.cell_distances(open_, grid))
        centres = np.asarray(state.maze.goal_points)
        a = int(np.argmin(np.linalg.norm(centres - np.asarray(state.pos), axis=1)))
        b = int(np.argmin(np.linalg.norm(centres - np.asarray(state.goal), axis=1)))
        assert straight - 1e-9 <= length <= cells[a, b] * grid.cell + 1e-9


@pytest.mark.parametrize(
    "argv, message",
    [
        (["grid", "--n", "0"], "--n must be at least 1 (got 0)"),
        (["caves", "--n", "2"], "unknown maze family 'caves'"),
        (["square4", "--n", "2"], "'square4' is a fixed maze"),
        (["smoke", "--n", "2"], "config 'smoke' sets no generator"),
    ],
)
def test_bad_arguments_are_refused_in_one_line(tmp_path, capsys, argv, message):
    out = tmp_path / "out"
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxnav mazes: error: ") and message in err and err.count("\n") == 1
    assert not out.exists()


def test_a_folder_with_files_is_kept_without_overwrite(written, capsys):
    before = {p.name: p.read_bytes() for p in written.iterdir()}
    assert main(["grid", "--n", "1", "--out", str(written)]) == 2
    assert "exists and is not empty (--overwrite replaces it)" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in written.iterdir()} == before


def test_overwrite_replaces_the_whole_folder(tmp_path, capsys):
    out = tmp_path / "m"
    out.mkdir()
    (out / "old.txt").write_text("old")
    assert main(["grid", "--n", "1", "--seed", "7", "--out", str(out), "--overwrite"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["maze_000.yaml"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m"]  # no temporary left
    assert "wrote 1 maze file to" in capsys.readouterr().out


def test_numbers_read_back_exactly():
    for x in (1e-05, -2.7944014072418213, 0.1, 3.0, 1.5e20, np.float32(0.1)):
        assert yaml.safe_load(number(x)) == float(x)


WALLED = """\
outline: [[-2, -1], [2, -1], [2, 1], [-2, 1], [-2, -1]]
walls: [[0, -1, 0, 0.5]]
start: [-1, 0, 0]
goal: [1, 0]
"""


def test_a_maze_file_with_free_walls_and_a_goal(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(WALLED)
    maze = make_maze(str(path))
    assert [0, -1, 0, 0.5] in maze.walls().tolist()
    np.testing.assert_array_equal(maze.goal, [1, 0])
    for bad, message in [
        ("walls: [[0, -1, 0, 3]]", "wall 0 is not inside the outline"),
        ("walls: [[0, 0, 0, 0]]", "a wall has no length"),
        ("walls: [[0, 0, 1]]", "walls must be a list of [x1, y1, x2, y2] segments"),
        ("goal: [0.05, 0]", "goal is not in the free space"),
        ("goal: [3, 0]", "goal is not in the free space"),
        ("shortest_path_m: -1", "shortest_path_m must be a number"),
    ]:
        key = bad.split(":")[0]
        lines = [ln for ln in WALLED.splitlines() if not ln.startswith(key)]
        path.write_text("\n".join([*lines, bad]) + "\n")
        with pytest.raises(MazeError) as e:
            make_maze(str(path))
        assert message in str(e.value) and "\n" not in str(e.value), bad
