"""Where a test's failed goal attempts ended, on the test maze: a panel per arm, every
seed's collisions (crosses: the pose each collided from) and time-outs (circles:
where the robot stood when its attempt ran out), over all its greedy test episodes.

Clusters show what a success rate cannot: a doorway the policies clip, a corner they
circle in, a moving cylinder's path they cross. Failures that ended at the same place
(a greedy policy replaying one failure at every restart) are one marker, larger, with
their count beside it (:func:`stacked`), so every failure the title counts is seen.
Drawn from ``eval/failures.npz`` (``jaxnav evaluate`` writes it for the fixed test
mazes; a drawn family's layouts differ from episode to episode, so they have no one
map).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from jaxnav.report import drawing
from jaxnav.report.fig_common import arm_styles, plt, save_fig
from jaxnav.report.results import display_name
from jaxnav.world.maps import Maze

COLUMNS = 3  # panels to a row
SAME_PLACE_M = 0.02  # failures that ended closer than this are drawn as one marker


def stacked(points: np.ndarray, within: float = SAME_PLACE_M) -> tuple[np.ndarray, np.ndarray]:
    """(places f[K, 2], counts i[K]): ``points`` f[N, 2] merged where they lie within
    ``within`` metres of a place already taken (in order), each place its first point."""
    places: list[np.ndarray] = []
    counts: list[int] = []
    for p in np.asarray(points, np.float64).reshape(-1, 2):
        near = [i for i, q in enumerate(places) if np.hypot(*(p - q)) < within]
        if near:
            counts[near[0]] += 1
        else:
            places.append(p)
            counts.append(1)
    return np.asarray(places, np.float64).reshape(-1, 2), np.asarray(counts, np.int64)


def _mark(ax, points: np.ndarray, ink: str, **style) -> None:
    """``points`` as markers, one per place, sized by and labelled with its count (in
    ``ink``)."""
    places, counts = stacked(points)
    if not len(places):
        return
    size = style.pop("s") * np.sqrt(counts)
    ax.scatter(places[:, 0], places[:, 1], s=size, zorder=6, **style)
    for (x, y), n in zip(places, counts):
        if n > 1:
            ax.annotate(
                str(n), (x, y), xytext=(4, 4), textcoords="offset points", fontsize=7,
                color=ink, zorder=7,
            )  # fmt: skip


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
        _mark(ax, hit, "crimson", marker="x", s=28, lw=1.2, color="crimson")
        _mark(
            ax, late, "darkorange", marker="o", s=26, facecolors="none",
            edgecolors="darkorange", lw=1.2,
        )  # fmt: skip
        ax.set_title(
            f"{display_name(arm)}: {len(hit)} collisions, {len(late)} time-outs",
            fontsize=9,
            color=styles[arm].color,
        )
    fig.suptitle(
        f"{name}: where failed goal attempts ended, {seeds} seeds x {episodes} greedy test "
        "episodes\nx: collision (the pose it collided from), o: time-out; a number: that "
        "many ended there",
        fontsize=10,
    )
    fig.tight_layout()
    return save_fig(fig, out, dpi=100, bbox_inches="tight")
