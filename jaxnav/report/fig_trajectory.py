"""A test maze with every arm's path over one test episode: walls and obstacles, the
start pose, the goals each arm reached, the goal it was heading for, where it
collided. The title names the test mode the episode was played in."""

from __future__ import annotations

from pathlib import Path

from matplotlib.patches import Circle

from jaxnav.report import drawing
from jaxnav.report.fig_common import ArmStyle, arm_styles, mode_title, plt, save_fig
from jaxnav.report.results import display_name
from jaxnav.world.maps import Maze


def trajectory_figure(
    maze: Maze, name: str, episodes: dict[str, dict], seed: int, goal_radius: float, mode: str
):
    """The figure of :func:`plot_trajectory`."""
    fig, ax = plt.subplots(figsize=(5.6, 5.6))
    drawing.draw_maze(ax, maze, pose=())
    drawing.draw_start(ax, maze)
    styles = arm_styles(list(episodes))
    for arm, ep in episodes.items():
        _draw_path(ax, arm, ep, goal_radius, styles[arm])
    first = next(iter(episodes.values()), {})
    if "circles" in first:  # moving cylinders: where they were along the first arm's path
        drawing.draw_moving(ax, first["circles"])
    _marker_legend(ax)
    ax.set_title(f"{name}: first test episode, seed {seed}\n{mode_title(mode)}", fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=8, ncol=1, frameon=False)
    fig.tight_layout()
    return fig


def plot_trajectory(
    maze: Maze,
    name: str,
    episodes: dict[str, dict],
    seed: int,
    goal_radius: float,
    out: Path,
    mode: str = "greedy",
) -> Path:
    """One test maze with every arm's path over one test episode played in ``mode``
    (``greedy`` or ``exploring``, as results.csv names it; the title says which)."""
    fig = trajectory_figure(maze, name, episodes, seed, goal_radius, mode)
    return save_fig(fig, out, dpi=100, bbox_inches="tight")


def _draw_path(ax, arm: str, ep: dict, goal_radius: float, style: ArmStyle) -> None:
    """One arm's path, the goals it reached, the goal it was heading for, a crash."""
    c = style.color
    pos = ep["pos"]
    end = "collided" if ep["collided"] else "no collision"
    ax.plot(
        pos[:, 0],
        pos[:, 1],
        color=c,
        ls=style.linestyle,
        lw=1.3,
        alpha=0.9,
        zorder=5,
        label=f"{display_name(arm)}: return {ep['return']:.0f}, {ep['goals']} goals, {end}",
    )
    hit = ep["reached"]
    if hit.any():
        g = ep["goal"][hit]
        ax.scatter(
            g[:, 0], g[:, 1], marker="*", s=130, color=c, edgecolors="black", lw=0.6, zorder=7
        )
        for gx, gy in g:  # the goal counts as reached inside this circle
            ax.add_patch(
                Circle((gx, gy), goal_radius, facecolor=c, edgecolor="none", alpha=0.15, zorder=2)
            )
    if not hit[-1]:  # the goal it was still heading for
        gx, gy = ep["goal"][-1]
        ax.add_patch(
            Circle((gx, gy), goal_radius, facecolor="none", edgecolor=c, lw=1.5, ls="--", zorder=6)
        )
    if ep["collided"]:  # at the pose before the colliding step; edge: whose
        ax.scatter(
            [pos[-1, 0]],
            [pos[-1, 1]],
            marker="X",
            s=130,
            color="red",
            edgecolors=c,
            lw=1.6,
            zorder=8,
        )


def _marker_legend(ax) -> None:
    """Legend entries for the markers (drawn empty, in grey)."""
    ax.scatter(
        [], [], marker="*", s=100, color="0.7", edgecolors="black", lw=0.6, label="goal reached"
    )
    ax.scatter(
        [],
        [],
        marker="o",
        s=60,
        facecolors="none",
        edgecolors="0.4",
        linestyle="--",
        label="goal not yet reached",
    )
    ax.scatter([], [], marker="X", s=80, color="red", edgecolors="0.4", lw=1.2, label="collision")
