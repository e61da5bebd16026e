"""Where a test's failed goal attempts ended, on the test maze: a panel per arm, every
seed's collisions (crosses: the pose each collided from) and time-outs (circles:
where the robot stood when its attempt ran out), over all its greedy test episodes.

Clusters show what a success rate cannot: a doorway the policies clip, a corner they
circle in, a moving cylinder's path they cross. Drawn from ``eval/failures.npz``
(``jaxnav evaluate`` writes it for the fixed test mazes; a drawn family's layouts
differ from episode to episode, so they have no one map).
"""

from __future__ import annotations

import math
from pathlib import Path

from jaxnav.report import drawing
from jaxnav.report.fig_common import arm_styles, plt, save_fig
from jaxnav.report.results import display_name
from jaxnav.world.maps import Maze

COLUMNS = 3  # panels to a row


def plot_failures(
    maze: Maze,
    name: str,
    per_arm: dict[str, dict],
    seeds: int,
    episodes: int,
    out: Path,
) -> Path:
    """The failure map of one test maze (``per_arm``: {arm: {"collision": f[K, 2],
    "timeout": f[K, 2]}})."""
    arms = list(per_arm)
    cols = min(COLUMNS, len(arms))
    rows = math.ceil(len(arms) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.4 * cols, 4.6 * rows), squeeze=False)
    styles = arm_styles(arms)
    for ax in axes.flat[len(arms) :]:
        ax.remove()
    for ax, arm in zip(axes.flat, arms):
        drawing.draw_maze(ax, maze, pose=())
        drawing.draw_start(ax, maze)
        hit, late = per_arm[arm]["collision"], per_arm[arm]["timeout"]
        if len(hit):
            ax.scatter(hit[:, 0], hit[:, 1], marker="x", s=28, lw=1.2, color="crimson", zorder=6)
        if len(late):
            ax.scatter(
                late[:, 0], late[:, 1], marker="o", s=26, facecolors="none",
                edgecolors="darkorange", lw=1.2, zorder=6,
            )  # fmt: skip
        ax.set_title(
            f"{display_name(arm)}: {len(hit)} collisions, {len(late)} time-outs",
            fontsize=9,
            color=styles[arm].color,
        )
    fig.suptitle(
        f"{name}: where failed goal attempts ended, {seeds} seeds x {episodes} greedy test "
        "episodes\nx: collision (the pose it collided from), o: time-out",
        fontsize=10,
    )
    fig.tight_layout()
    return save_fig(fig, out, dpi=100, bbox_inches="tight")
