"""Maze pictures: the command line writes a PNG and fails cleanly on a bad maze."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from jaxnav.commands.render import main
from jaxnav.experiments.scene import draw_maze
from jaxnav.world.maps import make_maze, stack_mazes

ROOT = Path(__file__).resolve().parents[1]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_render_writes_a_png(tmp_path, capsys):
    out = tmp_path / "maze.png"
    assert main(["square4_obstacles", "--out", str(out), "--beams", "24", "--seed", "1"]) == 0
    data = out.read_bytes()
    assert data.startswith(PNG_MAGIC) and len(data) > 10_000
    assert "wrote" in capsys.readouterr().out


def test_render_writes_the_format_its_extension_names(tmp_path, capsys):
    out = tmp_path / "maze.SVG"
    assert main(["square4", "--out", str(out), "--beams", "0"]) == 0
    assert capsys.readouterr().out == f"wrote {out}\n"
    assert b"<svg" in out.read_bytes()[:400]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["maze.SVG"]


@pytest.mark.parametrize(
    "name, message",
    [
        ("x.txt", "'.txt' is not an image format; the extension picks the format, one of "),
        ("x", "it has no extension"),
        ("folder", "exists and is not a file"),
        ("old.png", "exists already (--overwrite replaces it)"),
        ("no/x.png", "does not exist"),
    ],
)
def test_render_refuses_a_path_it_cannot_write_in_one_line(tmp_path, capsys, name, message):
    (tmp_path / "folder").mkdir()
    (tmp_path / "old.png").write_bytes(b"old")
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(["square4", "--out", str(tmp_path / name)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1
    assert captured.err.startswith("jaxnav render: error: ") and message in captured.err
    if name == "x.txt":
        assert ".png" in captured.err and ".svg" in captured.err and ".pgf" not in captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written
    assert (tmp_path / "old.png").read_bytes() == b"old"


def test_render_replaces_a_picture_with_overwrite(tmp_path, capsys):
    out = tmp_path / "maze.png"
    out.write_bytes(b"old")
    assert main(["square2", "--out", str(out), "--beams", "0", "--overwrite"]) == 0
    assert out.read_bytes().startswith(PNG_MAGIC)
    assert capsys.readouterr().out == f"wrote {out}\n"


def test_draw_maze_draws_walls_obstacles_robot_goal_and_beams():
    maze = make_maze(str(ROOT / "configs" / "mazes" / "corridor.yaml"))
    ax = Figure().add_subplot()
    assert draw_maze(ax, maze, goal=(1.0, 2.6), n_beams=36, title="corridor") is ax
    # box polygon, cylinder, goal circle, robot disc, heading arrow
    assert len(ax.patches) == 5
    assert len(ax.collections) == 1 and len(ax.collections[0].get_segments()) == 36
    assert ax.get_title() == "corridor" and ax.get_aspect() == 1.0
    xmin, xmax = ax.get_xlim()
    assert xmin < -3.0 and xmax > 1.6  # the whole outline is in view
    # Without a robot: only the maze.
    ax2 = Figure().add_subplot()
    draw_maze(ax2, maze, pose=(), show_goal_points=True)
    assert len(ax2.patches) == 2


def test_draw_maze_refuses_a_stacked_batch():
    stacked = stack_mazes([make_maze("square4"), make_maze("triangle")])
    with pytest.raises(ValueError, match="one maze"):
        draw_maze(Figure().add_subplot(), stacked)


def test_bad_maze_file_is_one_line_on_stderr_with_exit_code_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("outline: [[0, 0], [1, 0], [1, 1]]\n")
    assert main([str(bad), "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert (
        err.count("\n") == 1
        and err.startswith("jaxnav render: error: maze file")
        and "not closed" in err
    )
    assert not (tmp_path / "x.png").exists()


@pytest.mark.slow  # 3 s on 2 cores
def test_unknown_maze_name_exits_2_without_a_traceback(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "jaxnav.commands.render",
            "sqaure4",
            "--out",
            str(tmp_path / "x.png"),
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=120,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        "jaxnav render: error: unknown maze 'sqaure4'"
    ), proc.stderr
    assert "Traceback" not in proc.stderr
    assert np.all([not p.exists() for p in tmp_path.iterdir()])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["grid", "grid4"])
def test_render_draws_a_maze_of_a_generator_or_a_config(name, tmp_path, capsys):
    out = tmp_path / "grid.png"
    assert main([name, "--out", str(out), "--seed", "2"]) == 0
    assert out.read_bytes().startswith(PNG_MAGIC)
    assert "wrote" in capsys.readouterr().out


@pytest.mark.slow  # 3 s on 2 cores
def test_render_draws_a_sheet_of_sampled_mazes_with_their_paths(tmp_path, capsys):
    out = tmp_path / "sheet.png"
    assert main(["grid", "--samples", "4", "--out", str(out), "--seed", "2"]) == 0
    data = out.read_bytes()
    assert data.startswith(PNG_MAGIC) and len(data) > 20_000
    assert capsys.readouterr().out == f"wrote {out}\n"


def test_a_sheet_panel_shows_the_start_goal_and_shortest_path():
    from jaxnav.experiments.mazes import sample, sample_env

    env, params, drawn = sample_env("square4_obstacles")
    (s,) = sample(env, params, 1, 0)
    assert not drawn
    np.testing.assert_array_equal(s.path[0], s.start[:2])
    np.testing.assert_array_equal(s.path[-1], s.goal)
    assert s.length == pytest.approx(np.linalg.norm(np.diff(s.path, axis=0), axis=1).sum())
    assert s.length >= np.linalg.norm(s.goal - s.start[:2]) - 1e-9


@pytest.mark.parametrize("n", ["0", "-3"])
def test_render_refuses_fewer_than_one_sample_in_one_line(tmp_path, capsys, n):
    out = tmp_path / "sheet.png"
    assert main(["grid", "--samples", n, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == f"jaxnav render: error: --samples must be at least 1 (got {n})\n"
    assert not out.exists()


def test_worlds_draws_every_picture_of_the_worlds_page_and_refuses_in_one_line(
    tmp_path, capsys, monkeypatch
):
    from jaxnav.commands import render
    from jaxnav.experiments.mazes import WORLD_PICTURES

    page = (ROOT / "docs" / "worlds.md").read_text()
    shown = set(re.findall(r"worlds/(\w+)\.png", page))
    assert shown and shown <= set(WORLD_PICTURES)  # every picture the page shows is drawn
    drawn = []
    monkeypatch.setattr(
        render,
        "render_world_pictures",
        lambda folder: drawn.append(folder) or render.world_picture_paths(folder),
    )
    folder = tmp_path / "worlds"
    assert main(["--worlds", str(folder)]) == 0
    assert drawn == [folder] and capsys.readouterr().out.count("wrote ") == len(WORLD_PICTURES)
    folder.mkdir()
    (folder / "stage3.png").write_bytes(b"earlier")
    for argv, message in [
        (["--worlds", str(folder)], "stage3.png exists already (--overwrite replaces it)"),
        (["--worlds", str(tmp_path / "no" / "worlds")], "does not exist"),
        (["square4", "--worlds", str(folder)], "give no MAZE or --samples"),
        ([], "give a MAZE to draw (or --worlds DIR)"),
    ]:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    assert main(["--worlds", str(folder), "--overwrite"]) == 0


@pytest.mark.slow
def test_the_worlds_pictures_are_what_render_worlds_draws(tmp_path):
    from jaxnav.experiments.mazes import render_world_pictures

    for path in render_world_pictures(tmp_path):
        assert path.read_bytes() == (ROOT / "docs" / "worlds" / path.name).read_bytes(), path.name


def test_a_rendered_maze_names_what_stands_in_it_and_its_legend_every_thing_drawn():
    """``jaxnav render`` of a maze with inner walls said "0 obstacles"; stage 4's dotted
    loops of its moving cylinders were in no legend, and the legend hid the x label."""
    from matplotlib.figure import Figure

    from jaxnav.experiments.scene import _legend, contents
    from jaxnav.world.maps import make_maze

    assert contents(make_maze("stage4")) == "8 blocks, 2 moving cylinders"
    office = "configs/mazes/heldout/office.yaml"
    assert contents(make_maze(office)) == "4 inner walls, 2 blocks, 1 cylinder"
    assert contents(make_maze("square4_obstacles")) == "4 cylinders"
    assert contents(make_maze("square4")) == "no obstacles"
    fig = Figure()
    fig.add_subplot()
    _legend(fig, make_maze("stage4"), 24, 0.2)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "its loop" in labels and any("moving cylinder" in t for t in labels)
    fig = Figure()
    fig.add_subplot()
    _legend(fig, make_maze("square4"), 24, 0.2)
    assert not any("loop" in t.get_text() for t in fig.legends[0].get_texts())
