"""A maze scene: walls, obstacles, the robot at a pose, a goal drawn by ``reset`` and
what the LiDAR beams see, cast by the environment's own sensor. The drawing itself
is :mod:`jaxnav.report.drawing`; ``jaxnav render`` and the Gymnasium
wrapper's ``render()`` use this module.
"""

from __future__ import annotations

import os

import jax
import numpy as np

from jaxnav.core import families
from jaxnav.env import make
from jaxnav.report import drawing
from jaxnav.world import motion
from jaxnav.world.maps import ROBOT_RADIUS, Maze, make_maze
from jaxnav.world.sensor import lidar_scan


def draw_maze(ax, maze: Maze, *, n_beams: int = 0, min_range: float = 0.12, **kw):
    """:func:`jaxnav.report.drawing.draw_maze` with ``n_beams`` LiDAR beams cast from the pose."""
    pose = kw.get("pose")
    if pose is None and np.ndim(maze.segments) == 2:
        pose = np.asarray(maze.start, np.float64)
    if n_beams > 0 and pose is not None and len(pose):
        x, y, yaw = (float(v) for v in pose)
        scan = jax.jit(lidar_scan, static_argnums=3)  # one compile beats op-by-op dispatch
        max_range = kw.get("max_range", 3.5)
        pos, yaw32 = np.array([x, y], np.float32), np.float32(yaw)
        seen = motion.frozen_at(maze, 0.0)  # the moving cylinders at their first pose
        kw["ranges"] = np.asarray(scan(seen, pos, yaw32, n_beams, min_range, max_range))
    return drawing.draw_maze(ax, maze, **kw)


def render_maze(
    maze_name: str,
    out: str,
    n_beams: int = 24,
    seed: int = 0,
    dpi: int = 100,
    env_kwargs: dict | None = None,
) -> None:
    """Draw a maze with its start pose, a goal drawn by ``reset(seed)``, and the beams.
    With ``env_kwargs`` naming a generator (``jaxnav.env.make`` keywords), the maze is
    the one ``reset(seed)`` draws, and ``maze_name`` only its title."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    drawn = bool(env_kwargs and env_kwargs.get("generator"))
    if drawn:
        kwargs = dict(env_kwargs, n_beams=max(n_beams, 1))
        env, params = make(prepare=False, **kwargs)
    else:
        env, params = make(make_maze(maze_name), n_beams=max(n_beams, 1))
    _, state = jax.jit(env.reset)(jax.random.PRNGKey(seed), params)
    maze = jax.tree.map(np.asarray, state.maze) if drawn else params.maze
    fig = Figure(figsize=(6, 6), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    xmin, ymin, xmax, ymax = (float(v) for v in np.asarray(maze.bounds))
    title = f"{_display_name(maze_name)}: {xmax - xmin:.2f} m x {ymax - ymin:.2f} m, " + (
        contents(maze)
    )
    if drawn:
        family = families.get(env.generator).title(env)
        title = f"{_display_name(maze_name)}: {family}, {env.split} maze of seed {seed}"
    draw_maze(ax, maze, goal=np.asarray(state.goal), n_beams=n_beams, title=title)
    rows = _legend(fig, maze, n_beams, float(params.goal_radius))
    fig.tight_layout(rect=(0, 0.045 * rows, 1, 1))  # the legend below the x label
    fig.savefig(out)


def contents(maze) -> str:
    """What stands inside a maze's outline, in words: its inner walls (free wall
    segments), blocks (polygonal obstacles) and cylinders, standing and moving ("8
    blocks, 2 moving cylinders"; "no obstacles")."""
    blocks, walls = drawing.inner_walls(maze.walls())
    standing = int(np.asarray(maze.circle_mask).sum())
    moving = 0
    if maze.motion is not None:
        moving = int((np.asarray(maze.motion.radius) > 0).sum())
    parts = []
    things = (walls, "inner wall"), (blocks, "block"), (standing, "cylinder")
    for n, what in (*things, (moving, "moving cylinder")):
        if n:
            parts.append(f"{n} {what}{'s' if n != 1 else ''}")
    return ", ".join(parts) or "no obstacles"


def _legend(fig, maze, n_beams: int, goal_radius: float) -> int:
    """The legend under the axes, every kind of thing drawn named; its rows."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    def marker(m, color, label, **kw):
        return Line2D([], [], ls="", marker=m, color=color, label=label, **kw)

    handles = [
        marker("o", drawing.ROBOT_COLOR, f"robot at start (r = {ROBOT_RADIUS} m)", ms=9),
        marker("*", drawing.GOAL_COLOR, f"goal (reached within {goal_radius} m)", ms=12),
    ]
    if n_beams:
        handles.append(
            Line2D([], [], color=drawing.BEAM_COLOR, lw=1, label=f"{n_beams} LiDAR beams")
        )
    if maze.motion is not None and (np.asarray(maze.motion.radius) > 0).any():
        handles += [
            Patch(
                fc=drawing.OBSTACLE_COLOR,
                ec=drawing.WALL_COLOR,
                hatch="//",
                label="moving cylinder, at its first pose",
            ),  # fmt: skip
            Line2D([], [], ls=":", color=drawing.WALL_COLOR, lw=1, label="its loop"),
        ]
    ncol = 3
    fig.legend(
        handles=handles,
        loc="lower center",
        ncol=ncol,
        fontsize=8,
        frameon=False,
        handletextpad=0.3,
        columnspacing=1.2,
    )
    return -(-len(handles) // ncol)


def _display_name(name: str) -> str:
    base = os.path.basename(name)
    return os.path.splitext(base)[0] if base.endswith((".yaml", ".yml")) else name
