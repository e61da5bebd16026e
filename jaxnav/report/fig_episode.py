"""An animated GIF of one recorded test episode: the robot, its LiDAR beams, the goal
and its trail, step by step; the title names the test mode it was played in."""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.patches import Circle
from PIL import Image

from jaxnav.core import rundir
from jaxnav.report import drawing
from jaxnav.report.fig_common import plt, strategy_colors
from jaxnav.report.results import arm_strategy, display_name
from jaxnav.world.maps import Maze

FOOTPRINT = 0.105  # m, TurtleBot3 burger disc (the 0.13 m collision radius is drawn dashed)
GIF_MAX_BYTES = 1_000_000
GIF_MAX_FRAMES = 60


def animate_episode(
    maze: Maze,
    name: str,
    ep: dict,
    strategy: str,
    seed: int,
    goal_radius: float,
    out: Path,
    max_frames: int = GIF_MAX_FRAMES,
    mode: str = "greedy",
) -> Path:
    """An animated GIF of one test episode played in ``mode``: robot, LiDAR beams,
    goal, trail.

    One figure draw per frame; no tick labels (they cost most of a frame), a 1 m
    scale bar instead. Halves the frames until < 1 MB.
    """
    n = ep["length"]
    while True:
        stride = max(1, math.ceil(n / max_frames))
        frames = list(range(0, n, stride))
        if frames[-1] != n - 1:
            frames.append(n - 1)
        fig, update = episode_figure(maze, name, ep, strategy, seed, goal_radius, mode)
        gif = _gif_bytes(fig, update, frames, dpi=75)
        plt.close(fig)
        if len(gif) <= GIF_MAX_BYTES or max_frames <= 10:
            rundir.atomic_write_bytes(out, gif)
            return out
        max_frames //= 2


def _gif_bytes(fig, update, frames: Sequence[int], dpi: int, fps: int = 10) -> bytes:
    """An animated GIF of ``fig`` after ``update(t)`` for each frame t (as PillowWriter)."""
    width, height = (int(round(x * dpi)) for x in fig.get_size_inches())
    images = []
    for t in frames:
        update(t)
        buf = io.BytesIO()
        fig.savefig(buf, format="rgba", dpi=dpi)
        images.append(
            Image.frombuffer("RGBA", (width, height), buf.getbuffer(), "raw", "RGBA", 0, 1)
        )
    out = io.BytesIO()
    images[0].save(
        out, format="GIF", save_all=True, append_images=images[1:], duration=1000 // fps, loop=0
    )
    return out.getvalue()


def episode_figure(
    maze: Maze, name: str, ep: dict, strategy: str, seed: int, goal_radius, mode: str = "greedy"
):
    """The animation's figure and its ``update(t)``, which moves the artists to step t."""
    n = ep["length"]
    n_beams = ep["ranges"].shape[1]
    beam_idx = np.arange(0, n_beams, max(1, n_beams // 36))  # at most ~36 drawn beams
    beam_ang = 2 * np.pi * beam_idx / n_beams
    cum_ret = np.cumsum(ep["reward"])
    cum_goals = np.cumsum(ep["reached"])
    fig, ax = plt.subplots(figsize=(4.0, 4.2))
    drawing.draw_maze(ax, maze, pose=())
    ax.set_axis_off()
    x0, x1 = ax.get_xlim()
    y0, _ = ax.get_ylim()
    ax.plot([x0 + 0.02 * (x1 - x0), x0 + 0.02 * (x1 - x0) + 1.0], [y0, y0], color="black", lw=2)
    ax.text(x0 + 0.02 * (x1 - x0) + 0.5, y0, "1 m", ha="center", va="bottom", fontsize=7)
    ((color, _),) = strategy_colors([arm_strategy(strategy)]).values()
    (trail,) = ax.plot([], [], color=color, lw=1.0, alpha=0.7, zorder=4)
    beams = [ax.plot([], [], color="tab:red", lw=0.5, alpha=0.5, zorder=2)[0] for _ in beam_idx]
    body = Circle((0, 0), FOOTPRINT, facecolor=color, edgecolor="black", lw=0.8, zorder=6)
    ax.add_patch(body)
    (nose,) = ax.plot([], [], color="black", lw=1.2, zorder=7)
    goal = Circle(
        (0, 0), goal_radius, facecolor="limegreen", edgecolor="darkgreen", alpha=0.6, zorder=5
    )
    ax.add_patch(goal)
    moving = []  # the cylinders where they are at each frame's step (moving mazes)
    if "circles" in ep:
        moving = [
            ax.add_patch(Circle((cx, cy), r, fc="dimgray", ec="black", lw=0.8, zorder=3))
            for cx, cy, r in np.asarray(ep["circles"][0])
        ]
    title = ax.set_title("two\nlines", fontsize=8)  # room for the real title
    fig.tight_layout()
    mode_line = f"test mode: {mode}"

    def update(t):
        p, yaw = ep["pos"][t], ep["yaw"][t]
        trail.set_data(ep["pos"][: t + 1, 0], ep["pos"][: t + 1, 1])
        for line, a, r in zip(beams, beam_ang, ep["ranges"][t, beam_idx]):
            line.set_data([p[0], p[0] + r * np.cos(yaw + a)], [p[1], p[1] + r * np.sin(yaw + a)])
        body.center = (p[0], p[1])
        nose.set_data(
            [p[0], p[0] + FOOTPRINT * np.cos(yaw)], [p[1], p[1] + FOOTPRINT * np.sin(yaw)]
        )
        goal.center = tuple(ep["goal"][t])
        for patch, (cx, cy, _) in zip(moving, np.asarray(ep["circles"][t]) if moving else ()):
            patch.center = (cx, cy)
        crash = " - collision" if ep["collided"] and t == n - 1 else ""
        title.set_text(
            f"{name}, {display_name(strategy)} seed {seed}\n"
            f"{mode_line}, step {t + 1}/{n}: return {cum_ret[t]:.0f}, "
            f"goals {int(cum_goals[t])}{crash}"
        )

    return fig, update
