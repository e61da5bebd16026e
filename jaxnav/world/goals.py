"""Where goals and episode starts are drawn: the environment's goal sampler, as a
mixin of :class:`jaxnav.env.NavEnv` (its fields ``goal_sampler``, ``goal_candidates``,
``random_start`` and ``maze_scale`` decide; ``params`` is its ``EnvParams``).

* ``free``: a goal is one of the maze's admissible points (free space with a clearance,
  :attr:`jaxnav.world.maps.Maze.goal_points`), drawn uniformly, at least
  ``goal_min_separation`` from the last one when one of the tries is.
* ``robotis``: ROBOTIS' respawnGoal.py: its grid and boxes scaled to the maze, a new goal
  at least 1 m (times the scale) from the last along x or y, the first at (0.6, 0).
"""

from __future__ import annotations

from typing import Any

import chex
import jax
import jax.numpy as jnp

from jaxnav.world.geometry import hypot
from jaxnav.world.maps import ROBOTIS_FIRST_GOAL, ROBOTIS_GOAL_SEPARATION


class GoalSampler:
    """Goal and start-pose draws of :class:`jaxnav.env.NavEnv` (a mixin: the fields it
    reads are the environment's)."""

    goal_sampler: str
    goal_candidates: int
    random_start: bool
    maze_scale: tuple[float, float]

    @property
    def scales_maze(self) -> bool:
        return self.maze_scale != (1.0, 1.0)

    def draw_goal(
        self, key: chex.PRNGKey, away_from: chex.Array, params: Any, scale: chex.Array = 1.0
    ) -> chex.Array:
        """A new goal f32[2] away from the last one, ``away_from``, by ``goal_sampler``."""
        if self.goal_sampler == "robotis":
            maze = params.maze
            s = maze.robotis_scale * scale
            cx, cy = self._candidates(key, maze.robotis_goals, maze.n_robotis_goals, scale)
            # ROBOTIS: |dx| >= 1 or |dy| >= 1. The points are on a 0.1 s grid, so a
            # threshold of 0.95 s decides exactly, whatever the float rounding.
            sep = (ROBOTIS_GOAL_SEPARATION - 0.05) * s
            far = (jnp.abs(cx - away_from[0]) >= sep) | (jnp.abs(cy - away_from[1]) >= sep)
            i = jnp.argmax(far)
            return jnp.stack([cx[i], cy[i]])
        return self.draw_free_point(key, away_from, params, scale)

    def draw_free_point(
        self, key: chex.PRNGKey, away_from: chex.Array, params: Any, scale: chex.Array = 1.0
    ) -> chex.Array:
        """A free-space point f32[2] at least goal_min_separation from ``away_from`` if possible.

        Tries ``goal_candidates`` points of the maze's admissible goal set, drawn
        uniformly (32 random bits modulo the count, a bias below 1e-6), and keeps the
        first far enough away; if none is, the first (still in free space).
        """
        maze = params.maze
        cx, cy = self._candidates(key, maze.goal_points, maze.n_goal_points, scale)
        far = hypot(cx - away_from[0], cy - away_from[1]) >= params.goal_min_separation
        i = jnp.argmax(far)
        return jnp.stack([cx[i], cy[i]])

    def _candidates(self, key, points, n_points, scale) -> tuple[chex.Array, chex.Array]:
        """``goal_candidates`` rows of the first ``n_points`` of ``points``, uniformly."""
        bits = jax.random.bits(key, (self.goal_candidates,), jnp.uint32)
        idx = (bits % n_points.astype(jnp.uint32)).astype(jnp.int32)
        cx, cy = points[:, 0][idx], points[:, 1][idx]
        if self.scales_maze:
            cx, cy = cx * scale, cy * scale
        return cx, cy

    def first_goal(self, key, start, params: Any, scale) -> chex.Array:
        """The goal of a reset: the maze file's own goal if it has one, else drawn away
        from the start, or ROBOTIS' fixed first one."""
        if params.maze.goal is not None:
            return params.maze.goal * scale
        if self.goal_sampler == "robotis":
            return jnp.asarray(ROBOTIS_FIRST_GOAL) * (params.maze.robotis_scale * scale)
        return self.draw_goal(key, start, params, scale)

    def reset_goal(self, key, params: Any, scale) -> chex.Array:
        """The goal a reset sets: :meth:`first_goal` away from the maze's start, scaled
        with the maze when ``maze_scale`` is on."""
        start = params.maze.start[:2]
        start = start * scale if self.scales_maze else start
        return self.first_goal(key, start, params, scale)

    def _episode_scale(self, key: chex.PRNGKey) -> chex.Array | float:
        """This episode's maze scale, from ``fold_in(key, 3)``; the constant 1 when off."""
        if not self.scales_maze:
            return 1.0  # a constant: the start scan stays independent of the state
        lo, hi = self.maze_scale
        return jax.random.uniform(jax.random.fold_in(key, 3), (), jnp.float32, lo, hi)

    def _start_pose(self, key, params, goal, scale) -> tuple[chex.Array, chex.Array]:
        """Start pose of a new episode: the maze's start (scaled), unless randomised."""
        start = params.maze.start
        pos, yaw = start[:2], start[2]
        if self.scales_maze:
            pos = pos * scale
        if self.random_start:  # a free point (goal clearance) away from the goal
            k_pos, k_yaw = jax.random.split(jax.random.fold_in(key, 4))
            pos = self.draw_free_point(k_pos, goal, params, scale)
            yaw = jax.random.uniform(k_yaw, (), jnp.float32, -jnp.pi, jnp.pi)
        return pos, yaw
