"""Where a drawn maze's layouts come from (``env.generator``): drawn inside jit by the
family's static shape, or picked from a bank drawn ahead (``env.maze_bank``), and the
restart that moves an environment to its next layout. A mixin of
:class:`jaxnav.env.NavEnv`: the fields and methods it reads are the environment's."""

from __future__ import annotations

import math

import chex
import jax
import jax.numpy as jnp

from jaxnav.core import families
from jaxnav.world.lazy import draw_where
from jaxnav.world.maps import Maze
from jaxnav.world.state import EnvParams, EnvState, new_episode

BANK_BATCH = 256  # layouts of a bank drawn side by side (draw_bank)
_REFRESH_SALT = 0x72656672  # a refreshed bank's key from the run's (refreshed_bank)


def bank_key(key: chex.PRNGKey) -> chex.PRNGKey:
    """The key a training run draws its bank of layouts with, from its own key: folded
    in, so the run's other keys are those of a run without a bank."""
    return jax.random.fold_in(key, 0x62616E6B)


class DrawnLayouts:
    """The drawn-maze side of :class:`jaxnav.env.NavEnv`."""

    generator: str
    split: str
    maze_bank: int
    maze_bank_refresh: int
    new_maze_every: int
    scales_maze: bool
    action_delay: bool
    uses_cell_distances: bool

    @property
    def family(self):
        """The drawn mazes' family as a static, hashable shape from its settings
        (:meth:`jaxnav.core.families.Family.shape`): ``draw(key, split)`` gives a maze and
        its first goal; a family with shortest paths gives their cell distances and
        targets too (``env.reward geodesic``)."""
        return families.get(self.generator).shape(self)

    def draw_maze(self, key: chex.PRNGKey) -> tuple[Maze, chex.Array]:
        """(maze, goal f32[2]): a maze of the family and split, start and goal in it."""
        return self.family.draw(key, self.split)

    def draw_bank(self, key: chex.PRNGKey):
        """``maze_bank`` layouts drawn from ``key``, each as :meth:`_draw` gives it (maze,
        goal, cell distances or None), leaves with a leading axis of ``maze_bank``; drawn
        ``BANK_BATCH`` at a time side by side."""
        family = self.family
        if hasattr(family, "bank"):  # a family that fills a bank its own way (a mix)
            maze, goal = family.bank(key, self.maze_bank, self.split, BANK_BATCH)
            return maze, goal, None
        keys = jax.random.split(key, self.maze_bank)
        return jax.lax.map(self._draw, keys, batch_size=min(self.maze_bank, BANK_BATCH))

    def layout_bytes(self) -> int:
        """Bytes one layout of a bank takes (its maze, goal and cell distances), from
        the shapes alone: nothing is drawn."""
        shapes = jax.eval_shape(self._draw, jax.random.PRNGKey(0))
        return sum(math.prod(x.shape) * x.dtype.itemsize for x in jax.tree.leaves(shapes))

    def with_bank(self, params: EnvParams, key: chex.PRNGKey) -> EnvParams:
        """``params`` with a bank of layouts drawn from ``key`` when ``maze_bank`` is set
        (else unchanged): the episodes played with them pick their layouts from it."""
        if not (self.generates and self.maze_bank):
            return params
        return params.replace(bank=self.draw_bank(key))

    def refreshed_bank(self, bank, key: chex.PRNGKey, before: chex.Array, after: chex.Array):
        """A training run's bank once its env steps went from ``before`` to ``after``
        (i32[]): a new bank drawn from ``fold_in(key, _REFRESH_SALT)`` where they passed
        a multiple of ``maze_bank_refresh``, else ``bank`` itself. The trainers vmap
        their runs, and under vmap only the runs that passed one draw
        (:func:`jaxnav.world.lazy.draw_where`): a step without a refresh costs a sort of
        the runs' flags, no draw."""
        if not (self.generates and self.maze_bank and self.maze_bank_refresh):
            return bank
        every = self.maze_bank_refresh
        due = (after // every) > (before // every)
        k = jax.random.fold_in(key, _REFRESH_SALT)
        return draw_where(self.draw_bank, due, k, bank, chunk=1)

    def _layout(self, key: chex.PRNGKey, params: EnvParams):
        """(A new layout (maze, goal, cell distances or None), its bank index i32[] or
        None): drawn from ``key``, or with a bank in ``params`` one of its layouts picked
        with ``key``: uniformly, or by the bank's cumulative weights
        (``params.bank_cdf``), and then its index is returned."""
        if params.bank is None:
            return self._draw(key), None
        n = jax.tree.leaves(params.bank)[0].shape[0]
        if params.bank_cdf is None:
            i = jax.random.randint(key, (), 0, n)
            index = None
        else:
            u = jax.random.uniform(key, (), jnp.float32)
            i = jnp.minimum(jnp.searchsorted(params.bank_cdf, u, side="right"), n - 1)
            index = i.astype(jnp.int32)
        return jax.tree.map(lambda b: b[i], params.bank), index

    def _draw(self, key: chex.PRNGKey):
        """(maze, goal, its cell distances for the geodesic reward or None). The maze
        keeps one row of its ROBOTIS goal table: drawn mazes never draw goals from it
        (``goal_sampler`` robotis is refused with them), every environment carries its
        layout in its state and every bank holds thousands, and the 256-row table was
        most of a grid layout's bytes."""
        maze, goal = self.draw_maze(key)
        maze = maze.replace(
            robotis_goals=maze.robotis_goals[:1],
            n_robotis_goals=jnp.minimum(maze.n_robotis_goals, 1),
        )
        dist = None
        if self.uses_cell_distances:
            dist = self.family.cell_distances(maze)
        return maze, goal, dist

    def _restart_drawn(self, key, state: EnvState, params: EnvParams):
        """:meth:`restart` with drawn mazes: the next maze from ``fold_in(key, 5)`` once
        the current one has had ``new_maze_every`` episodes; where it has not, no maze is
        drawn (:func:`jaxnav.world.lazy.draw_where`), which changes no number. (:meth:`step`
        runs it only for the environments whose episode ended.)"""
        episodes = state.maze_episodes + 1
        fresh = episodes >= self.new_maze_every
        old = (state.maze, state.goal, state.cell_dist)
        k_maze = jax.random.fold_in(key, 5)
        if params.bank is None:
            maze, new_goal, cell_dist = draw_where(self._draw, fresh, k_maze, old)
            index = None
        else:  # picking from the bank is a gather: no need to skip the unused ones
            new, index = self._layout(k_maze, params)
            maze, new_goal, cell_dist = jax.tree.map(lambda a, b: jnp.where(fresh, a, b), new, old)
            if index is not None:
                index = jnp.where(fresh, index, state.layout)
        episodes = jnp.where(fresh, 0, episodes)
        params = params.replace(maze=maze)
        scale = self._episode_scale(key)
        kept = state.goal
        if self.scales_maze:  # the kept goal moves with the maze, the new one is scaled
            kept, new_goal = kept * (scale / state.scale), new_goal * scale
        goal = jnp.where(fresh, new_goal, kept)
        pos, yaw = self._start_pose(key, params, goal, scale)
        scale = jnp.asarray(scale, jnp.float32)
        state = new_episode(pos, yaw, goal, scale, self.action_delay, maze, episodes)
        state = self._with_world(state.replace(layout=index), params, cell_dist)
        obs = self.observe(key, pos, yaw, goal, params, scale, cell_dist=state.cell_dist)
        return obs, self._first_scans(state, obs)


__all__ = ["BANK_BATCH", "DrawnLayouts", "bank_key"]
