"""Drawing a maze with matplotlib: walls, obstacles, the robot, a goal, LiDAR beams.

Every function draws data it is given onto a matplotlib ``Axes``; nothing here
computes a scan or runs the environment (``jaxnav render`` does that for its
pictures; ``jaxnav.report.fig_trajectory`` puts trajectories on top).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from jaxnav.world.maps import ROBOT_RADIUS, Maze
from jaxnav.world.motion import loop_paths

WALL_COLOR = "#2b2b2b"
OBSTACLE_COLOR = "#8c8c8c"
ROBOT_COLOR = "#1f77b4"
GOAL_COLOR = "#2ca02c"
BEAM_COLOR = "#d62728"
HEADING_COLOR = "#0b2f4f"
PATH_COLOR = "#ff7f0e"


def draw_maze(
    ax,
    maze: Maze,
    *,
    pose: Sequence[float] | None = None,
    goal: Sequence[float] | None = None,
    ranges: Sequence[float] | None = None,
    robot_radius: float = ROBOT_RADIUS,
    goal_radius: float = 0.2,
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
      ranges: LiDAR ranges f[n_beams] seen from ``pose`` (beam k at yaw + 2 pi k / n),
        drawn from the robot to what they hit (None: no beams). A beam that sees
        nothing within ``max_range`` is drawn to max range without a dot.
      show_goal_points: also draw the maze's admissible goal grid, faintly.
      title: axes title; None leaves it alone.
    """
    if np.ndim(maze.segments) != 2:
        raise ValueError("draw_maze draws one maze; index a stacked batch first")
    if show_goal_points:
        pts = np.asarray(maze.goal_points)[: int(maze.n_goal_points)]
        ax.plot(pts[:, 0], pts[:, 1], ".", ms=1.5, color=GOAL_COLOR, alpha=0.35, zorder=1)
    draw_walls(ax, maze)
    if pose is None:
        pose = np.asarray(maze.start, np.float64)
    if len(pose):
        x, y, yaw = (float(v) for v in pose)
        if ranges is not None:
            draw_beams(ax, x, y, yaw, np.asarray(ranges, np.float64), max_range)
        draw_robot(ax, x, y, yaw, robot_radius)
    if goal is not None:
        draw_goal(ax, goal, goal_radius)
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


def draw_walls(ax, maze: Maze) -> None:
    """The maze's walls, polygonal obstacles and cylinders."""
    from matplotlib.patches import Circle, Polygon

    walls, cylinders = maze.walls(), maze.obstacles()
    for loop in _closed_loops(walls)[1:]:  # the first loop is the outline
        ax.add_patch(Polygon(loop, closed=True, fc=OBSTACLE_COLOR, ec="none", zorder=3))
    for cx, cy, r in cylinders:
        ax.add_patch(Circle((cx, cy), r, fc=OBSTACLE_COLOR, ec=WALL_COLOR, lw=1.2, zorder=3))
    if maze.motion is not None:  # moving cylinders at their first pose, and their paths
        paths, radii = loop_paths(maze.motion), np.asarray(maze.motion.radius)
        for path, r in zip(paths, radii):
            if r <= 0:  # a parked placeholder
                continue
            ax.plot(path[:, 0], path[:, 1], ls=":", color=WALL_COLOR, lw=1, zorder=2)
            ax.add_patch(
                Circle(
                    tuple(path[0]),
                    r,
                    fc=OBSTACLE_COLOR,
                    ec=WALL_COLOR,
                    lw=1.2,
                    hatch="//",
                    zorder=3,
                )
            )
    ax.plot(
        np.stack([walls[:, 0], walls[:, 2]]),
        np.stack([walls[:, 1], walls[:, 3]]),
        color=WALL_COLOR,
        lw=3,
        solid_capstyle="round",
        zorder=3,
    )


def draw_moving(ax, circles: np.ndarray, every: int = 25) -> None:
    """Moving cylinders over an episode, ``circles`` [T, k, 3] (each step's cylinders):
    every ``every``-th step faded, darker as time goes on, the last one solid."""
    from matplotlib.patches import Circle

    circles = np.asarray(circles, np.float64)
    steps = list(range(0, len(circles), every))
    for i, t in enumerate(steps):
        alpha = 0.15 + 0.35 * i / max(len(steps) - 1, 1)
        for cx, cy, r in circles[t]:
            if r > 0:
                ax.add_patch(
                    Circle((cx, cy), r, fc=OBSTACLE_COLOR, ec="none", alpha=alpha, zorder=2)
                )
    for cx, cy, r in circles[-1]:
        if r > 0:
            ax.add_patch(Circle((cx, cy), r, fc=OBSTACLE_COLOR, ec=WALL_COLOR, lw=1.2, zorder=3))


def draw_robot(ax, x: float, y: float, yaw: float, robot_radius: float = ROBOT_RADIUS) -> None:
    """The robot's disc with an arrow for its heading."""
    from matplotlib.patches import Circle, FancyArrow

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


def draw_start(ax, maze: Maze) -> None:
    """The maze's start pose as a grey square with an arrow (not a robot disc: for
    figures where paths show the robot)."""
    sx, sy, syaw = (float(v) for v in np.asarray(maze.start, np.float64))
    ax.plot([sx], [sy], marker="s", color="0.3", ms=5, zorder=4)
    ax.annotate(
        "",
        xy=(sx + 0.3 * math.cos(syaw), sy + 0.3 * math.sin(syaw)),
        xytext=(sx, sy),
        arrowprops=dict(arrowstyle="->", color="0.3", lw=1.2),
        zorder=4,
    )


def draw_goal(ax, goal: Sequence[float], goal_radius: float) -> None:
    """A goal: a star inside the circle within which it counts as reached."""
    from matplotlib.patches import Circle

    gx, gy = (float(v) for v in goal)
    ax.add_patch(
        Circle((gx, gy), goal_radius, fill=False, ec=GOAL_COLOR, ls="--", lw=1.2, zorder=4)
    )
    ax.plot([gx], [gy], "*", ms=14, color=GOAL_COLOR, mec="white", zorder=6)


def draw_path(ax, points: np.ndarray, label: str | None = None) -> None:
    """A path (f[n, 2] points, start to goal) as a dashed line; a path with NaN
    points (none found) is not drawn."""
    pts = np.asarray(points, np.float64)
    if len(pts) < 2 or np.isnan(pts).any():
        return
    ax.plot(pts[:, 0], pts[:, 1], "--", color=PATH_COLOR, lw=1.6, zorder=4, label=label)


def inner_walls(walls: np.ndarray) -> tuple[int, int]:
    """What stands inside a maze's outline besides cylinders: (its blocks, the polygonal
    obstacles: closed loops after the outline's; its free wall segments, in no loop)."""
    loops = _closed_loops(walls)
    in_loops = sum(len(loop) for loop in loops)
    return max(len(loops) - 1, 0), len(walls) - in_loops


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


def draw_beams(ax, x: float, y: float, yaw: float, ranges: np.ndarray, max_range: float):
    """LiDAR beams from (x, y) at heading ``yaw``; a dot where a beam hits something."""
    from matplotlib.collections import LineCollection

    n_beams = len(ranges)
    ang = yaw + 2 * np.pi * np.arange(n_beams) / n_beams
    ends = np.stack([x + ranges * np.cos(ang), y + ranges * np.sin(ang)], axis=1)
    lines = [[(x, y), tuple(e)] for e in ends]
    ax.add_collection(LineCollection(lines, colors=BEAM_COLOR, linewidths=0.8, alpha=0.6, zorder=2))
    hit = ranges < max_range
    ax.plot(ends[hit, 0], ends[hit, 1], ".", ms=4, color=BEAM_COLOR, zorder=4)
