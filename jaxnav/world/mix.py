"""A mix of worlds (``env.generator: mix``): each episode's layout comes from one of
several sources at given weights, drawn inside the compiled program from a bank.

A source is a registered maze family (``rooms``, ``cylinders``, ``grid``, each drawn
with the environment's own settings for it: ``env.rooms_*``, ...), or a fixed maze (a
built-in name such as ``square4_obstacles`` or ``stage4``, or a maze file), whose
layouts are the maze itself with a goal drawn from its goal points and the robot at
its start facing a uniform yaw. ``env.mix_worlds`` names them and ``env.mix_weights``
weighs them (equal weights if left empty).

Every source's layout is padded to one shape (the most wall segments, cylinders, goal
points and moving cylinders of any source; :func:`jaxnav.world.maps.pad_maze`), so
layouts of every kind stack in one bank and an environment's state holds any of them.
A bank (``env.maze_bank`` N, which a mix needs) holds each source's share of N by its
weight, each drawn with its own family's draw (:meth:`Mix.bank`); an episode picks a
layout of the bank uniformly, so each source comes up at its weight. Drawing one
layout alone (:meth:`Mix.draw`, a test's drawn split) picks the source first and
keeps that source's layout (every source is computed: under ``vmap`` a branch is a
select).

A family's ``split`` (train or test layouts) holds for its layouts in a mix; a fixed
maze has no split: it is in a mix, or kept apart as a world the policies never saw.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.world.maps import Maze, make_maze, pad_maze
from jaxnav.world.motion import pad_motion, parked

# The goal points a fixed maze brings to a mix at most, thinned evenly (a maze file
# may hold 4096; every layout of the bank is padded to the largest source's count).
FIXED_GOAL_POINTS = 512


@functools.lru_cache(maxsize=64)
def _fixed_maze(name: str) -> Maze:
    """A fixed maze as a mix keeps it: loaded once, its goal points thinned to at most
    FIXED_GOAL_POINTS, its ROBOTIS table to one row (drawn mazes never read it), its
    own first goal dropped (a mix draws every goal)."""
    with jax.ensure_compile_time_eval():  # first called while a draw is traced
        maze = jax.tree.map(np.asarray, make_maze(name))
    n = int(maze.n_goal_points)
    pts = np.asarray(maze.goal_points)[:n]
    if n > FIXED_GOAL_POINTS:
        pts = pts[np.linspace(0, n - 1, FIXED_GOAL_POINTS).round().astype(int)]
    return jax.tree.map(
        np.asarray,
        maze.replace(
            goal_points=np.asarray(pts, np.float32),
            n_goal_points=np.int32(len(pts)),
            robotis_goals=np.asarray(maze.robotis_goals)[:1],
            n_robotis_goals=np.int32(min(int(maze.n_robotis_goals), 1)),
            goal=None,
        ),
    )


class FixedWorld(NamedTuple):
    """A fixed maze as a source of a mix (hashable: its name)."""

    name: str

    def draw(self, key: chex.PRNGKey, split: str = "train") -> tuple[Maze, chex.Array]:
        """(maze, goal f32[2]): the maze, the robot at its start facing a uniform yaw,
        a goal drawn uniformly from its goal points (``split`` does not apply)."""
        maze = jax.tree.map(jnp.asarray, _fixed_maze(self.name))
        k_goal, k_yaw = jax.random.split(key)
        i = jax.random.randint(k_goal, (), 0, maze.n_goal_points)
        yaw = jax.random.uniform(k_yaw, (), jnp.float32, -jnp.pi, jnp.pi)
        return maze.replace(start=maze.start.at[2].set(yaw)), maze.goal_points[i]


class Shape(NamedTuple):
    """The padded shape every layout of a mix takes."""

    segments: int
    circles: int
    goal_points: int
    robotis: int
    moving: tuple[int, int] | None  # (cylinders, keyframes) where any source moves


def _trimmed(maze: Maze) -> Maze:
    """A family's layout as a mix keeps it: one ROBOTIS row, as a fixed maze's."""
    return maze.replace(
        robotis_goals=maze.robotis_goals[:1],
        n_robotis_goals=jnp.minimum(maze.n_robotis_goals, 1),
    )


class Mix(NamedTuple):
    """The static shape of a mix (hashable: it fixes array shapes): ``sources`` (family
    shapes or :class:`FixedWorld`), their ``names`` and ``weights`` (summing to 1)."""

    sources: tuple
    names: tuple[str, ...]
    weights: tuple[float, ...]

    def _source_draw(self, i: int, key: chex.PRNGKey, split: str) -> tuple[Maze, chex.Array]:
        maze, goal = self.sources[i].draw(key, split)
        return _trimmed(maze), goal

    @property
    def shape(self) -> Shape:
        return _shape(self)

    def padded(self, maze: Maze) -> Maze:
        """One layout of any source in the mix's shape (unbatched)."""
        s = self.shape
        out = pad_maze(maze, s.segments, s.circles, s.goal_points)
        if s.moving is None:
            return out.replace(motion=None)
        n, k = s.moving
        motion = parked(k) if maze.motion is None else maze.motion
        return out.replace(motion=pad_motion(motion, n, k))

    def draw(self, key: chex.PRNGKey, split: str = "train") -> tuple[Maze, chex.Array]:
        """(maze, goal f32[2]): one layout: a source drawn at its weight, then its layout."""
        k_pick, k_draw = jax.random.split(key)
        which = jax.random.choice(k_pick, len(self.sources), p=jnp.asarray(self.weights))
        layouts = [self.padded_draw(i, k_draw, split) for i in range(len(self.sources))]
        stacked = jax.tree.map(lambda *xs: jnp.stack(xs), *layouts)
        return jax.tree.map(lambda x: x[which], stacked)

    def padded_draw(self, i: int, key: chex.PRNGKey, split: str) -> tuple[Maze, chex.Array]:
        maze, goal = self._source_draw(i, key, split)
        return self.padded(maze), goal

    def shares(self, n: int) -> tuple[int, ...]:
        """Each source's layouts in a bank of ``n``: its weight's share, rounded by the
        largest remainders (so they sum to ``n``), at least one each where ``n`` allows."""
        exact = np.asarray(self.weights) * n
        counts = np.floor(exact).astype(int)
        order = np.argsort(-(exact - counts), kind="stable")
        counts[order[: n - counts.sum()]] += 1
        while n >= len(counts) and (counts == 0).any():  # every source in the bank
            counts[np.argmax(counts)] -= 1
            counts[np.argmin(counts)] += 1
        return tuple(int(c) for c in counts)

    def bank(self, key: chex.PRNGKey, n: int, split: str, batch: int):
        """``n`` layouts (maze, goal), leaves with a leading axis of ``n``: each source's
        share (:meth:`shares`), its layouts drawn from keys of its own
        (``fold_in(key, i)``), ``batch`` side by side."""
        parts = []
        for i, count in enumerate(self.shares(n)):
            if count == 0:
                continue
            keys = jax.random.split(jax.random.fold_in(key, i), count)
            draw = functools.partial(self.padded_draw, i, split=split)
            parts.append(jax.lax.map(draw, keys, batch_size=min(count, batch)))
        return jax.tree.map(lambda *xs: jnp.concatenate(xs), *parts)


@functools.lru_cache(maxsize=32)
def _shape(mix: Mix) -> Shape:
    """The largest arrays of any source's layout (from shapes alone: nothing drawn)."""
    shapes = [
        jax.eval_shape(functools.partial(mix._source_draw, i, split="train"), jax.random.PRNGKey(0))
        for i in range(len(mix.sources))
    ]
    mazes = [m for m, _ in shapes]
    moving = [m.motion for m in mazes if m.motion is not None]
    still = parked()
    return Shape(
        segments=max(m.segments.shape[0] for m in mazes),
        circles=max(max(m.circles.shape[0] for m in mazes), 1),
        goal_points=max(m.goal_points.shape[0] for m in mazes),
        robotis=1,
        moving=(
            (
                max(x.radius.shape[0] for x in moving),
                max(*(x.times.shape[-1] for x in moving), still.times.shape[-1]),
            )
            if moving
            else None
        ),
    )


def mix_family(env: Any) -> Mix:
    """The mix of ``env``'s settings (an EnvConfig or a ``jaxnav.env.NavEnv``): each
    name of ``env.mix_worlds`` a registered family (drawn with ``env``'s settings for
    it) or a fixed maze, weighed by ``env.mix_weights`` (equal if empty)."""
    from jaxnav.core import families

    sources = []
    for name in env.mix_worlds:
        if name in families.names():
            sources.append(families.get(name).shape(env))
        else:
            sources.append(FixedWorld(name))
    weights = np.asarray(env.mix_weights or [1.0] * len(sources), np.float64)
    weights = tuple(float(w) for w in weights / weights.sum())
    return Mix(tuple(sources), tuple(env.mix_worlds), weights)


__all__ = ["FIXED_GOAL_POINTS", "FixedWorld", "Mix", "Shape", "mix_family"]
