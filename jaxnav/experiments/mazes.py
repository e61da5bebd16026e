"""Drawn mazes kept and shown: a family's mazes (or a fixed maze's goals) sampled by
``reset``, each with its start, goal and shortest path; written as maze files
(``jaxnav mazes``) or drawn as a sheet of panels (``jaxnav render --samples``).

A family is named by a generator (``grid``) or a config that sets one (``grid4``, a
YAML file); the mazes come from the environment's own ``reset``, so any generator
the environment knows is a family here.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import NamedTuple

import jax
import numpy as np

from jaxnav.core import families
from jaxnav.core.config import Config, load_config
from jaxnav.core.errors import JaxnavError, MazeError
from jaxnav.core.shipped import CONFIG_DIR, resolve_config_path
from jaxnav.env import NavEnv, make
from jaxnav.experiments.scene import render_maze
from jaxnav.report import drawing
from jaxnav.world.maps import BUILTIN_MAZES, Maze, load_maze_file, make_maze
from jaxnav.world.mazefiles import canonical_segments, maze_text
from jaxnav.world.paths import PathFinder


def family_config(name: str) -> Config | None:
    """The config ``name`` stands for (a generator's defaults, a shipped config's name,
    a config file), or None for a maze (built-in or a maze file)."""
    if name in BUILTIN_MAZES:
        return None
    if name in families.names():
        return load_config(None, [f"env.generator={name}"])
    path = resolve_config_path(name)
    shipped = os.path.dirname(os.path.abspath(path)) == str(CONFIG_DIR)
    if not os.path.isfile(path) or not (shipped or _is_config_file(path)):
        return None
    return load_config(path)


def _is_config_file(path: str) -> bool:
    """Whether a YAML file is a config (not a maze file: no outline)."""
    import yaml

    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except (OSError, yaml.YAMLError, UnicodeDecodeError):
        return False  # the maze loader says what is wrong with it
    return isinstance(doc, dict) and "outline" not in doc and "env" in doc


class Sample(NamedTuple):
    """One maze drawn by ``reset``, on the host."""

    maze: Maze  # NumPy leaves, the episode's geometry (scaled if the episode is)
    start: np.ndarray  # f64[3] the robot's pose (x, y, yaw)
    goal: np.ndarray  # f64[2]
    path: np.ndarray  # f64[n, 2] the shortest path of the robot's disc, start to goal
    length: float  # m, inf where the path finder finds none


def sample_env(spec: str, split: str | None = None) -> tuple[NavEnv, object, bool]:
    """(env, params, drawn) of a family (``drawn``: its mazes are drawn) or of a fixed
    maze (its goals are drawn); ``split`` replaces a family's split."""
    cfg = family_config(spec)
    if cfg is None:
        return (*make(make_maze(spec)), False)
    kwargs = cfg.env_kwargs()
    if not cfg.env.generator:
        return (*make(cfg.env.maze, cfg.preset, **kwargs), False)
    if split is not None:
        kwargs["split"] = split
    return (*make(cfg.env.maze, cfg.preset, **kwargs), True)


def sample(env: NavEnv, params, n: int, seed: int) -> list[Sample]:
    """``n`` resets from ``split(PRNGKey(seed), n)``: mazes, starts, goals, paths."""
    keys = jax.random.split(jax.random.PRNGKey(seed), n)

    def one(key):
        _, state = env.reset(key, params)
        maze = env.episode_maze(params, state)
        return maze, state.pos, state.yaw, state.goal

    mazes, pos, yaw, goal = jax.device_get(jax.jit(jax.vmap(one))(keys))
    out = []
    for i in range(n):
        maze = jax.tree.map(lambda a, i=i: np.asarray(a[i]), mazes)
        start = np.array([pos[i, 0], pos[i, 1], yaw[i]], np.float64)
        g = np.asarray(goal[i], np.float64)
        finder = PathFinder(maze.walls(), maze.obstacles(), float(params.robot_radius))
        path = finder.path(start[:2], g)
        length = finder.length(start[:2], g)
        out.append(Sample(maze, start, g, path, length))
    return out


def write_mazes(spec: str, n: int, split: str, seed: int, out: Path, overwrite: bool) -> Path:
    """``n`` mazes of the family ``spec`` written as ``out/maze_000.yaml``, ... (a new
    folder, put in place whole; an existing one only with ``overwrite``). Each file
    is read back before it counts: its walls, obstacles, start and goal must come
    back exactly. Raises JaxnavError (one line) for a bad spec or a maze the format
    cannot hold."""
    if n < 1:
        raise JaxnavError(f"--n must be at least 1 (got {n})")
    if out.exists() and not out.is_dir():
        raise JaxnavError(f"{out} exists and is not a folder: choose another path")
    if out.is_dir() and any(out.iterdir()) and not overwrite:
        raise JaxnavError(f"{out} exists and is not empty (--overwrite replaces it)")
    if not out.absolute().parent.is_dir():
        raise JaxnavError(f"cannot write {out}: the folder {out.absolute().parent} does not exist")
    cfg = family_config(spec)
    if cfg is None or not cfg.env.generator:
        if cfg is not None:
            what = f"config '{spec}' sets no generator"
        elif spec in BUILTIN_MAZES or os.path.isfile(resolve_config_path(spec)):
            what = f"'{spec}' is a fixed maze"
        else:
            what = f"unknown maze family '{spec}'"
        raise JaxnavError(
            f"{what}: give a maze generator ({', '.join(families.names())}) or a "
            "config that sets env.generator (e.g. grid4)"
        )
    env, params, _ = sample_env(spec, split)
    width = max(3, len(str(n - 1)))
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.absolute().parent))
    try:
        for i, s in enumerate(sample(env, params, n, seed)):
            path = tmp / f"maze_{i:0{width}d}.yaml"
            name = f"{spec} {split} maze {i} of seed {seed}"
            length = s.length if np.isfinite(s.length) else None
            try:
                text = maze_text(s.maze.walls(), s.maze.obstacles(), s.start, s.goal, length, name)
            except ValueError as e:
                raise JaxnavError(
                    f"maze {i} of {spec} cannot be written as a maze file: {e}"
                ) from None
            path.write_text(text)
            _check_round_trip(path, s, i)
        old = None
        if out.exists():  # moved aside, not deleted, until the new folder is in place
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.absolute().parent))
            os.replace(out, old / out.name)
        os.replace(tmp, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out


def _check_round_trip(path: Path, s: Sample, i: int) -> None:
    """The file read back gives the sample's walls, obstacles, start and goal exactly."""
    try:
        back = load_maze_file(str(path))
    except MazeError as e:
        raise JaxnavError(f"maze {i} does not load back as a maze file: {e}") from None
    same = (
        np.array_equal(canonical_segments(back.walls()), canonical_segments(s.maze.walls()))
        and np.array_equal(back.obstacles(), s.maze.obstacles())
        and np.array_equal(np.asarray(back.start), s.start.astype(np.float32))
        and np.array_equal(np.asarray(back.goal), s.goal.astype(np.float32))
    )
    if not same:
        raise JaxnavError(f"maze {i} does not read back exactly from its maze file")


SHEET_MAX = 400  # panels on one sheet
PANEL_MB = 0.2  # about what one 260 x 260 pixel RGBA panel costs matplotlib to draw


def _mb(mb: float) -> str:
    return f"{mb / 1000:.1f} GB" if mb >= 1000 else f"{mb:.0f} MB"


def render_sheet(spec: str, out: str, n: int, seed: int = 0, split: str | None = None) -> None:
    """A sheet of ``n`` panels: mazes of the family ``spec`` (or goals in a fixed
    maze) drawn by ``reset`` from ``split(PRNGKey(seed), n)``, each with the robot at
    its start, its goal and its shortest path."""
    import math

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if n < 1:
        raise JaxnavError(f"--samples must be at least 1 (got {n})")
    if n > SHEET_MAX:  # a 2.6-inch panel each: memory grows with n, legibility does not
        raise JaxnavError(
            f"--samples {n}: a sheet of {n} panels would take about {_mb(n * PANEL_MB)} to "
            f"draw; a sheet holds at most {SHEET_MAX} panels (about "
            f"{_mb(SHEET_MAX * PANEL_MB)}): write many drawn mazes as files with jaxnav "
            "mazes instead"
        )
    env, params, drawn = sample_env(spec, split)
    samples = sample(env, params, n, seed)
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(2.6 * cols, 2.6 * rows + 0.5), dpi=100)
    FigureCanvasAgg(fig)
    for i, s in enumerate(samples):
        ax = fig.add_subplot(rows, cols, i + 1)
        drawing.draw_maze(
            ax, s.maze, pose=s.start, goal=s.goal, goal_radius=float(params.goal_radius)
        )
        drawing.draw_path(ax, s.path)
        length = f"{s.length:.2f} m" if np.isfinite(s.length) else "no path"
        ax.set_title(f"{i}: shortest path {length}", fontsize=8)
        ax.set_xlabel("")
        ax.set_ylabel("")
        ax.tick_params(labelsize=6)
    what = f"{env.split} mazes of {spec}" if drawn else f"goals in {spec}"
    fig.suptitle(
        f"{n} {what}, seed {seed}: start (robot), goal (star), shortest path of the "
        "robot's disc (dashed)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(out)


def render_named(name: str, out: str, n_beams: int = 24, seed: int = 0) -> None:
    """One maze drawn with the robot, a goal and its beams
    (:func:`jaxnav.experiments.scene.render_maze`): a built-in maze or maze file, or the
    maze a family or config (its maze, or its family's draw of ``seed``) stands for."""
    cfg = family_config(name)
    if cfg is None:
        render_maze(name, out, n_beams, seed)
    else:
        env_kwargs = cfg.env_kwargs() if cfg.env.generator else None
        shown = name if cfg.env.generator else cfg.env.maze
        render_maze(shown, out, n_beams, seed, env_kwargs=env_kwargs)


# The pictures of docs/worlds.md (``jaxnav render --worlds docs/worlds``): file stem ->
# (what is drawn, the seed of its draw, a sheet of that many panels or None).
WORLD_PICTURES: dict[str, tuple[str, int, int | None]] = {
    "stage3": ("stage3", 0, None),
    "stage4": ("stage4", 0, None),
    "stage3_humble": ("stage3_humble", 0, None),
    "stage4_humble": ("stage4_humble", 0, None),
    "grid4": ("grid4", 3, None),
    "cylinders": ("cylinders", 3, None),
    "rooms": ("rooms", 3, None),
    "grid4_samples": ("grid4", 0, 8),
}


def world_picture_paths(folder: Path) -> list[Path]:
    return [folder / f"{stem}.png" for stem in WORLD_PICTURES]


def render_world_pictures(folder: Path) -> list[Path]:
    """Every picture of docs/worlds.md into ``folder``: the built-in stages and a maze
    of each family, and a sheet of grid mazes with their shortest paths."""
    folder.mkdir(parents=True, exist_ok=True)
    for path, (name, seed, samples) in zip(world_picture_paths(folder), WORLD_PICTURES.values()):
        if samples is None:
            render_named(name, str(path), seed=seed)
        else:
            render_sheet(name, str(path), samples, seed)
    return world_picture_paths(folder)
