"""Pictures of a maze: walls, obstacles, the robot at its start pose, a goal, LiDAR beams.

Command line (writes a PNG with matplotlib's Agg backend)::

    python -m jaxnav.render square4_obstacles --out maze.png --beams 24 --seed 0
    python -m jaxnav.render configs/mazes/corridor.yaml

:func:`draw_maze` draws onto any matplotlib ``Axes``, so plots of trajectories can
put a maze underneath.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Sequence

import numpy as np

from jaxnav.maps import ROBOT_RADIUS, Maze, MazeError, make_maze

WALL_COLOR = "#2b2b2b"
OBSTACLE_COLOR = "#8c8c8c"
ROBOT_COLOR = "#1f77b4"
GOAL_COLOR = "#2ca02c"
BEAM_COLOR = "#d62728"
HEADING_COLOR = "#0b2f4f"


def draw_maze(
    ax,
    maze: Maze,
    *,
    pose: Sequence[float] | None = None,
    goal: Sequence[float] | None = None,
    n_beams: int = 0,
    robot_radius: float = ROBOT_RADIUS,
    goal_radius: float = 0.2,
    min_range: float = 0.12,
    max_range: float = 3.5,
    show_goal_points: bool = False,
    title: str | None = None,
):
    """Draw one (unbatched) maze on ``ax`` and return ``ax``.

    Args:
      ax: a matplotlib Axes.
      maze: the maze; its real walls and cylinders are drawn.
      pose: robot pose (x, y, yaw) to draw as a disc with a heading arrow; default the
        maze's start pose. Pass ``()`` to draw no robot.
      goal: goal (x, y), drawn as a star inside its reach circle; None draws none.
      n_beams: LiDAR beams to draw from the robot to what they hit (0: none). A beam
        that sees nothing within ``max_range`` is drawn to max range without a dot.
      show_goal_points: also draw the maze's admissible goal grid, faintly.
      title: axes title; None leaves it alone.
    """
    from matplotlib.patches import Circle, FancyArrow, Polygon

    if np.ndim(maze.segments) != 2:
        raise ValueError("draw_maze draws one maze; index a stacked batch first")
    walls, cylinders = maze.walls(), maze.obstacles()

    if show_goal_points:
        pts = np.asarray(maze.goal_points)[: int(maze.n_goal_points)]
        ax.plot(pts[:, 0], pts[:, 1], ".", ms=1.5, color=GOAL_COLOR, alpha=0.35, zorder=1)
    for loop in _closed_loops(walls)[1:]:  # the first loop is the outline
        ax.add_patch(Polygon(loop, closed=True, fc=OBSTACLE_COLOR, ec="none", zorder=3))
    for cx, cy, r in cylinders:
        ax.add_patch(Circle((cx, cy), r, fc=OBSTACLE_COLOR, ec=WALL_COLOR, lw=1.2, zorder=3))
    ax.plot(
        np.stack([walls[:, 0], walls[:, 2]]),
        np.stack([walls[:, 1], walls[:, 3]]),
        color=WALL_COLOR,
        lw=3,
        solid_capstyle="round",
        zorder=3,
    )

    if pose is None:
        pose = np.asarray(maze.start, np.float64)
    if len(pose):
        x, y, yaw = (float(v) for v in pose)
        if n_beams > 0:
            _draw_beams(ax, maze, x, y, yaw, n_beams, min_range, max_range)
        ax.add_patch(Circle((x, y), robot_radius, fc=ROBOT_COLOR, ec="white", alpha=0.9, zorder=5))
        L = 2.4 * robot_radius  # the arrow pokes out of the disc: heading at a glance
        ax.add_patch(
            FancyArrow(
                x,
                y,
                L * math.cos(yaw),
                L * math.sin(yaw),
                width=0.025,
                head_width=0.09,
                head_length=0.08,
                length_includes_head=True,
                color=HEADING_COLOR,
                zorder=6,
            )
        )
    if goal is not None:
        gx, gy = (float(v) for v in goal)
        ax.add_patch(
            Circle((gx, gy), goal_radius, fill=False, ec=GOAL_COLOR, ls="--", lw=1.2, zorder=4)
        )
        ax.plot([gx], [gy], "*", ms=14, color=GOAL_COLOR, mec="white", zorder=6)

    xmin, ymin, xmax, ymax = (float(v) for v in np.asarray(maze.bounds))
    pad = 0.05 * max(xmax - xmin, ymax - ymin)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if title is not None:
        ax.set_title(title)
    return ax


def _closed_loops(walls: np.ndarray) -> list[np.ndarray]:
    """Split consecutive wall segments into closed polygons (outline first, then
    polygonal obstacles, as maps.py lays them out); open runs are left out."""
    loops, start = [], 0
    for i in range(len(walls)):
        if np.allclose(walls[i, 2:], walls[start, :2], atol=1e-6):
            loops.append(walls[start : i + 1, :2])
            start = i + 1
        elif i + 1 < len(walls) and not np.allclose(walls[i, 2:], walls[i + 1, :2], atol=1e-6):
            start = i + 1  # a break without closing: not a polygon
    return loops


def _draw_beams(ax, maze, x, y, yaw, n_beams, min_range, max_range):
    import jax
    from matplotlib.collections import LineCollection

    from jaxnav.env import lidar_scan

    scan = jax.jit(lidar_scan, static_argnums=3)  # one compile beats op-by-op dispatch
    pos = np.array([x, y], np.float32)
    ranges = np.asarray(scan(maze, pos, np.float32(yaw), n_beams, min_range, max_range))
    ang = yaw + 2 * np.pi * np.arange(n_beams) / n_beams
    ends = np.stack([x + ranges * np.cos(ang), y + ranges * np.sin(ang)], axis=1)
    lines = [[(x, y), tuple(e)] for e in ends]
    ax.add_collection(LineCollection(lines, colors=BEAM_COLOR, linewidths=0.8, alpha=0.6, zorder=2))
    hit = ranges < max_range
    ax.plot(ends[hit, 0], ends[hit, 1], ".", ms=4, color=BEAM_COLOR, zorder=4)


def render_maze(maze_name: str, out: str, n_beams: int = 24, seed: int = 0, dpi: int = 100) -> None:
    """Draw a maze with its start pose, a goal drawn by ``reset(seed)``, and the beams."""
    import jax
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from jaxnav.env import make

    maze = make_maze(maze_name)
    env, params = make(maze, n_beams=max(n_beams, 1))
    _, state = jax.jit(env.reset)(jax.random.PRNGKey(seed), params)
    fig = Figure(figsize=(6, 6), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    xmin, ymin, xmax, ymax = (float(v) for v in np.asarray(maze.bounds))
    n_obs = int(maze.n_obstacles)
    title = (
        f"{_display_name(maze_name)}: {xmax - xmin:.2f} m x {ymax - ymin:.2f} m, "
        f"{n_obs} obstacle{'s' if n_obs != 1 else ''}"
    )
    draw_maze(ax, maze, goal=np.asarray(state.goal), n_beams=n_beams, title=title)
    _legend(ax, n_beams, float(params.goal_radius))
    fig.tight_layout()
    fig.savefig(out)


def _legend(ax, n_beams: int, goal_radius: float) -> None:
    from matplotlib.lines import Line2D

    def marker(m, color, label, **kw):
        return Line2D([], [], ls="", marker=m, color=color, label=label, **kw)

    handles = [
        marker("o", ROBOT_COLOR, f"robot at start (r = {ROBOT_RADIUS} m)", ms=9),
        marker("*", GOAL_COLOR, f"goal (reached within {goal_radius} m)", ms=12),
    ]
    if n_beams:
        handles.append(Line2D([], [], color=BEAM_COLOR, lw=1, label=f"{n_beams} LiDAR beams"))
    ax.legend(
        handles=handles,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.09),
        ncol=3,
        fontsize=8,
        frameon=False,
        handletextpad=0.3,
        columnspacing=1.2,
    )


def _display_name(name: str) -> str:
    import os

    base = os.path.basename(name)
    return os.path.splitext(base)[0] if base.endswith((".yaml", ".yml")) else name


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m jaxnav.render",
        description="Draw a maze (built-in name or YAML file) with the robot, a goal and "
        "its LiDAR beams.",
    )
    parser.add_argument(
        "maze", help="built-in maze name (e.g. square4_obstacles) or a maze .yaml file"
    )
    parser.add_argument("--out", default="maze.png", help="output PNG (default: maze.png)")
    parser.add_argument("--beams", type=int, default=24, help="LiDAR beams to draw (default: 24)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the goal draw (default: 0)")
    args = parser.parse_args(argv)
    if args.beams < 0:
        print("error: --beams must be 0 or more", file=sys.stderr)
        return 2
    try:
        render_maze(args.maze, args.out, args.beams, args.seed)
    except MazeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"error: cannot write {args.out}: {e.strerror or e}", file=sys.stderr)
        return 1
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
