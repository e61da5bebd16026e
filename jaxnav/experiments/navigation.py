"""The navigation metrics of test rollouts: each run's goal attempts, the shortest
path of each (in the maze its episode was played in) and each episode's sums, the
columns :data:`jaxnav.report.navigation.COUNT_COLUMNS` of results.csv.

The attempts come from the rollout's :class:`~jaxnav.experiments.rollout.Steps`;
an episode's maze is the test maze, or, with drawn mazes or ``maze_scale``, the one
the rollout recorded at the episode's first step. Shortest paths are
:class:`jaxnav.world.paths.PathFinder`'s, one per distinct maze (shared by every
run, mode and episode that met it).
"""

from __future__ import annotations

import numpy as np

from jaxnav.experiments.rollout import Rollout
from jaxnav.report.navigation import (
    COLLISION,
    TIMEOUT,
    Attempts,
    episode_counts,
    run_attempts,
)
from jaxnav.world.maps import Maze
from jaxnav.world.paths import PathFinder


class ShortestPaths:
    """Path finders by maze geometry: every maze met once gets one raster."""

    def __init__(self, radius: float):
        self.radius = radius
        self._finders: dict[bytes, PathFinder] = {}

    def finder(self, walls: np.ndarray, circles: np.ndarray) -> PathFinder:
        key = walls.tobytes() + b"|" + circles.tobytes()
        if key not in self._finders:
            self._finders[key] = PathFinder(walls, circles, self.radius)
        return self._finders[key]


def _real(segments, segment_mask, circles, circle_mask) -> tuple[np.ndarray, np.ndarray]:
    seg, circ = np.asarray(segments), np.asarray(circles)
    return (
        seg[np.asarray(segment_mask)].astype(np.float64),
        circ[np.asarray(circle_mask)].astype(np.float64),
    )


def attempt_paths(
    res: Rollout, maze: Maze, n_episodes: int, paths: ShortestPaths, limit: int
) -> list[tuple[Attempts, np.ndarray]]:
    """Per run of a navigation rollout (``run_tests(..., navigation=True)``) in the
    test maze ``maze``: its goal attempts under the attempt limit ``limit`` (steps) and
    the shortest path of each (m) in the maze its episode was played in."""
    out = []
    for r in range(len(res.steps.episode)):
        att = run_attempts(res.steps, r, n_episodes, limit)
        shortest = np.zeros(len(att.episode))
        for e in np.unique(att.episode):
            if res.mazes is None:
                walls, circles = _real(
                    maze.segments, maze.segment_mask, maze.circles, maze.circle_mask
                )
            else:
                m = res.mazes
                walls, circles = _real(
                    m.segments[r, e], m.segment_mask[r, e], m.circles[r, e], m.circle_mask[r, e]
                )
            mine = att.episode == e
            shortest[mine] = paths.finder(walls, circles).lengths(att.start[mine], att.goal[mine])
        out.append((att, shortest))
    return out


def navigation_counts(
    res: Rollout,
    maze: Maze,
    n_episodes: int,
    step_m: float,
    dt: float,
    paths: ShortestPaths,
    limit: int,
) -> list[dict[str, np.ndarray]]:
    """Per run of a navigation rollout (``run_tests(..., navigation=True)``) in the
    test maze ``maze``: each episode's sums over its attempts ({column: f[E]}) under
    the attempt limit ``limit`` (steps)."""
    return [
        episode_counts(att, shortest, step_m, dt, n_episodes)
        for att, shortest in attempt_paths(res, maze, n_episodes, paths, limit)
    ]


def failure_points(res: Rollout, n_episodes: int, limit: int) -> list[dict[str, np.ndarray]]:
    """Per run of a navigation rollout: where its failed attempts ended, {"collision":
    f[K, 2], "timeout": f[K, 2]} (the robot's position at the attempt's last step; a
    collision's is the pose it collided from)."""
    out = []
    for r in range(len(res.steps.episode)):
        att = run_attempts(res.steps, r, n_episodes, limit)
        out.append(
            {
                "collision": att.end[att.outcome == COLLISION],
                "timeout": att.end[att.outcome == TIMEOUT],
            }
        )
    return out
