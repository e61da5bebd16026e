"""The maze an episode drives in: the maze scaled by the episode's factor
(``maze_scale``), its moving cylinders at the episode's pace (``motion_pace``) and,
at a time, where they are then. A mixin of :class:`jaxnav.env.NavEnv`: the fields and
methods it reads (``motion_pace``, ``scales_maze``, ``in_maze``) are the
environment's."""

from __future__ import annotations

import dataclasses

import chex
import jax
import jax.numpy as jnp

from jaxnav.core.errors import ConfigError
from jaxnav.core.settings import paces_motion
from jaxnav.world import motion, occupancy
from jaxnav.world.maps import Maze
from jaxnav.world.state import EnvParams, EnvState, scale_maze


class EpisodeMaze:
    """The scaled, paced and moving maze of :class:`jaxnav.env.NavEnv`'s episodes."""

    motion_pace: tuple[float, float]
    pace_curriculum: float
    scales_maze: bool
    grid_fit: tuple[float, float]  # (range, near) m an occupancy grid is sized for

    def fit_maze(self, maze: Maze) -> Maze:
        """``maze`` with its occupancy grid (if any) walked as far as this environment's
        sensor sees and tested for collision as near as it asks
        (:func:`jaxnav.world.occupancy.fit`); unchanged without a grid."""
        if maze.grid is None or self.grid_fit == (0.0, 0.0):
            return maze
        return maze.replace(grid=occupancy.fit(maze.grid, *self.grid_fit))

    def maze_at(self, params: EnvParams, scale: chex.Array, time=None, pace=None) -> Maze:
        """The maze of an episode: ``params.maze``, scaled if ``maze_scale`` is on, its
        cylinders moving at the episode's ``pace`` (``EnvState.pace``; None: their own);
        at ``time`` (s) its moving cylinders join the static ones where they are then."""
        maze = scale_maze(params.maze, scale) if self.scales_maze else params.maze
        if pace is not None and maze.motion is not None:
            maze = maze.replace(motion=motion.paced(maze.motion, pace))
        return maze if time is None else motion.frozen_at(maze, time)

    def episode_maze(self, params: EnvParams, state: EnvState) -> Maze:
        """The maze of ``state``'s episode: its drawn maze (if drawn), scaled and paced as
        the episode is, its moving cylinders still on their loops."""
        return self.maze_at(self.in_maze(params, state), state.scale, pace=state.pace)

    def circles_at(
        self, params: EnvParams, scale: chex.Array, t: chex.Array, pace=None
    ) -> chex.Array:
        """f32[k, 3]: every cylinder (static, then moving) after ``t`` steps."""
        return self.maze_at(params, scale, t * params.dt, pace).circles

    @property
    def paces_motion(self) -> bool:
        """Whether each episode draws its moving cylinders' pace (``motion_pace``)."""
        return paces_motion(self.motion_pace)

    def _episode_pace(self, key: chex.PRNGKey, params: EnvParams) -> chex.Array | None:
        """This episode's pace of the moving cylinders, from ``fold_in(key, 6)``, drawn
        from ``params.pace_range`` where the pace curriculum has set it, else from
        ``motion_pace``; None when ``motion_pace`` is off (no draw, no leaf in the state)."""
        if not self.paces_motion:
            return None
        lo, hi = self.motion_pace if params.pace_range is None else params.pace_range
        return jax.random.uniform(jax.random.fold_in(key, 6), (), jnp.float32, lo, hi)

    def at_progress(self, params: EnvParams, progress: chex.Array) -> EnvParams:
        """``params`` for episodes begun at ``progress`` (f32[], the share of the
        training budget done): with ``pace_curriculum`` f, the pace range moves in a
        straight line from ``motion_pace`` to the cylinders' own pace, [1, 1], over the
        first f of the budget and stays there; without it, ``params`` unchanged."""
        if not self.pace_curriculum:
            return params
        w = jnp.clip(jnp.asarray(progress, jnp.float32) / self.pace_curriculum, 0.0, 1.0)
        start = jnp.asarray(self.motion_pace, jnp.float32)
        return params.replace(pace_range=start + w * (1.0 - start))


def fitted(env, params: EnvParams, name) -> tuple:
    """(env, params) with the maze's occupancy grid, if any, walked and windowed for this
    robot and sensor (``NavEnv.grid_fit``, :func:`jaxnav.world.occupancy.sized_for`);
    unchanged without a grid. A grid cannot be scaled (``env.maze_scale``)."""
    if params.maze.grid is None:
        return env, params
    if env.scales_maze:
        raise ConfigError(f"env.maze_scale scales walls and cylinders: maze {name!r} is a grid")
    env = dataclasses.replace(env, grid_fit=occupancy.sized_for(env, params))
    return env, params.replace(maze=env.fit_maze(params.maze))
