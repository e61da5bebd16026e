"""The oracle: a privileged planner that shows what the robot, its action set and its
time limits allow in a world.

It reads what no policy sees: the maze, where the moving cylinders will be, and the
goal. Every step it simulates each sequence of actions of a small tree (one action
for ``holds[0]`` steps, then one for ``holds[1]`` steps, ...; with the paper's five
actions and holds (1, 2, 4), 125 sequences 1.4 s ahead) with the environment's own
kinematics (:meth:`jaxnav.env.NavEnv.command`, :func:`jaxnav.world.geometry.displacement`),
forbids every sequence that would collide, and drives the first action of the best:
one that reaches the goal soonest, else the one that ends nearest to it along the
shortest path around the walls (:mod:`jaxnav.planners.raster`), facing along it.

Collisions are checked exactly for the step about to be driven (the environment's own
:func:`~jaxnav.world.geometry.path_clearance` and
:func:`~jaxnav.world.motion.moving_clearance`) and, for the later steps of a plan,
against a raster of the static clearance read as a lower bound, with a margin, and
against the moving cylinders at their exact positions. Where every sequence collides
it takes the one that collides latest. The shortest-path field is computed again only
when the goal or the maze changes (:func:`jaxnav.world.lazy.draw_where`: under vmap
only for the environments whose goal changed).
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp

from jaxnav.env import EnvParams, EnvState, NavEnv
from jaxnav.planners import raster as rs
from jaxnav.world import motion
from jaxnav.world.geometry import displacement, path_clearance, wrap_angle
from jaxnav.world.lazy import draw_where
from jaxnav.world.maps import Maze

_BIG = 1.0e6


class OracleMemory(NamedTuple):
    """What the oracle keeps between steps: the maze and goal its fields are of."""

    segments: chex.Array  # f32[S, 4] the static walls the clearance field is of
    circles: chex.Array  # f32[C, 3] the static cylinders
    goal: chex.Array  # f32[2] the goal the distance field is of
    clearance: chex.Array  # f32[ny, nx] static clearance of each cell centre (m)
    distance: chex.Array  # f32[ny, nx] shortest path to the goal (m), inf if none


@dataclasses.dataclass(frozen=True)
class Oracle:
    """The privileged planner for ``env`` (its fields are static: they fix shapes).

    Attributes:
      env: the environment it drives (its action set, wheel limit, action delay).
      raster: the raster its fields live on (:func:`jaxnav.planners.raster.raster_for`).
      holds: steps each level of a candidate sequence holds its action; None: (1, 2, 4)
        (1.4 s ahead), or (1, 3, 10) (2.8 s) where cylinders move, to see them coming.
      margin: clearance kept from static surfaces beyond the robot's radius after the
        first step (m); the raster's lower bound adds its own slack.
      moving_margin: the same for the moving cylinders (m).
      samples: points checked per simulated step.
      lookahead: how far ahead of a plan's end the field is read to score its heading (m).
    """

    env: NavEnv
    raster: rs.Raster
    holds: tuple[int, ...] | None = None
    margin: float = 0.02
    moving_margin: float = 0.03
    samples: int = 1
    lookahead: float = 0.1

    # -- memory ---------------------------------------------------------------

    def _geometry(self, params: EnvParams, state: EnvState) -> Maze:
        return self.env.maze_at(self.env.in_maze(params, state), state.scale)

    def _distance(self, inputs):
        clearance, goal, origin, goal_radius, radius = inputs
        # the field's way keeps a cell's width more than the plans' check needs, so
        # every way it shows is one a plan can drive
        free = clearance >= radius + self.margin + self.raster.h
        return rs.goal_distance(free, goal, goal_radius, origin, self.raster)

    def start(self, params: EnvParams, state: EnvState) -> OracleMemory:
        """The memory at a test's first step: the fields of its maze and goal."""
        maze = self._geometry(params, state)
        clearance = rs.clearance_field(maze, self.raster)
        origin = rs.origin_of(maze, self.raster)
        distance = self._distance(
            (clearance, state.goal, origin, params.goal_radius, params.robot_radius)
        )
        return OracleMemory(maze.segments, maze.circles, state.goal, clearance, distance)

    def _update(self, mem: OracleMemory, params: EnvParams, state: EnvState, maze: Maze):
        """The memory for this step: fields computed again where the maze or goal changed."""
        new_maze = jnp.any(maze.segments != mem.segments) | jnp.any(maze.circles != mem.circles)
        new_goal = jnp.any(state.goal != mem.goal)
        clearance = draw_where(
            lambda m: rs.clearance_field(m, self.raster), new_maze, maze, mem.clearance, chunk=1
        )
        origin = rs.origin_of(maze, self.raster)
        inputs = (clearance, state.goal, origin, params.goal_radius, params.robot_radius)
        distance = draw_where(self._distance, new_maze | new_goal, inputs, mem.distance, chunk=1)
        return OracleMemory(maze.segments, maze.circles, state.goal, clearance, distance)

    # -- planning ---------------------------------------------------------------

    def plan(
        self, mem: OracleMemory, obs: chex.Array, state: EnvState, params: EnvParams
    ) -> tuple[chex.Array, OracleMemory]:
        """(action i32[], memory): the first action of the best collision-free plan."""
        del obs  # privileged: it reads the state
        env, dt, r = self.env, params.dt, params.robot_radius
        maze = self._geometry(params, state)
        mem = self._update(mem, params, state, maze)
        origin = rs.origin_of(maze, self.raster)
        holds = self.holds or ((1, 3, 10) if maze.motion is not None else (1, 2, 4))
        A, L = env.num_actions, len(holds)
        v_a, w_a = env.command(params, jnp.arange(A))
        v_a = jnp.broadcast_to(v_a, (A,))

        # The step about to be driven, checked exactly as the environment will: each
        # action's, or with action_delay the pending action's, after which the plan starts.
        pos, yaw, offset = state.pos[None], state.yaw[None], 0
        if env.action_delay:
            vp, wp = env.command(params, state.pending_action)
            now = self._exact_clearance(maze, state, vp, wp, dt) >= r
            pos = pos + displacement(yaw, wp, vp, dt).T
            yaw, offset = wrap_angle(yaw + wp * dt), 1
        else:
            now = jax.vmap(lambda v, w: self._exact_clearance(maze, state, v, w, dt))(v_a, w_a)
            now = now >= r  # [A]

        # SIMULATE the tree level by level: every node's A actions, each held its steps;
        # a step's points are checked on the raster and against the moving cylinders.
        bad, reach, step = [], [], offset
        for hold in holds:
            pos = jnp.broadcast_to(pos[:, None, :], (pos.shape[0], A, 2))
            yaw = jnp.broadcast_to(yaw[:, None], pos.shape[:2])
            bad_l, reach_l = [], []
            for _ in range(hold):
                frac = (jnp.arange(self.samples, dtype=jnp.float32) + 1) / self.samples
                pts = pos[..., None, :] + jnp.moveaxis(
                    displacement(yaw[..., None], w_a[:, None], v_a[:, None], frac * dt), 0, -1
                )  # [N, A, samples, 2]
                bad_l.append(self._unsafe(mem, maze, origin, state, params, pts, step))
                pos, yaw = pts[..., -1, :], wrap_angle(yaw + w_a * dt)
                reach_l.append(jnp.linalg.norm(pos - state.goal, axis=-1) < params.goal_radius)
                step += 1
            bad.append(jnp.stack(bad_l, -1).reshape(-1, hold))
            reach.append(jnp.stack(reach_l, -1).reshape(-1, hold))
            pos, yaw = pos.reshape(-1, 2), yaw.reshape(-1)
        # every full sequence's steps: level l's node of sequence s is s // A^(L - l)
        K = A**L
        seq = jnp.arange(K)
        bad = jnp.concatenate([b[seq // A ** (L - 1 - k)] for k, b in enumerate(bad)], axis=1)
        reach = jnp.concatenate([x[seq // A ** (L - 1 - k)] for k, x in enumerate(reach)], axis=1)
        if env.action_delay:
            bad = bad | ~now
        else:
            bad = bad.at[:, 0].set(bad[:, 0] | ~now[seq // A ** (L - 1)])
        T = bad.shape[1]
        hit_at = jnp.where(jnp.any(bad, axis=1), jnp.argmax(bad, axis=1), T)
        reach_at = jnp.where(jnp.any(reach, axis=1), jnp.argmax(reach, axis=1), T)

        # SCORE: the goal soonest; else the shortest way left, facing along it. A plan
        # must stay clear to its end, past the goal too: the next goal's plan starts there.
        ahead = pos + self.lookahead * jnp.stack([jnp.cos(yaw), jnp.sin(yaw)], -1)
        d_end = rs.field_upper(mem.distance, origin, self.raster, pos[:, 0], pos[:, 1])
        d_ahead = rs.field_upper(mem.distance, origin, self.raster, ahead[:, 0], ahead[:, 1])
        d_ahead = jnp.where(jnp.isfinite(d_ahead), d_ahead, d_end + 2 * self.lookahead)
        straight = jnp.linalg.norm(pos - state.goal, axis=-1)  # where the raster has no way
        way = jnp.where(jnp.isfinite(d_end), 0.5 * (d_end + d_ahead), 1.0e3 + straight)
        cost = jnp.where(reach_at < T, -1.0e3 + reach_at, way)
        cost = jnp.where(hit_at == T, cost, _BIG * (1 + T - hit_at) + jnp.minimum(way, 1.0e4))
        choice = jnp.argmin(cost) // A ** (L - 1)
        return choice.astype(jnp.int32), mem

    def _unsafe(self, mem, maze, origin, state, params, pts, step: int) -> chex.Array:
        """bool[...]: whether each step's points (pts f32[..., samples, 2], the plan's
        ``step``-th step) come too close to a static surface (on the raster) or to a
        moving cylinder (where it is then)."""
        r = params.robot_radius
        static = rs.field_lower(mem.clearance, origin, self.raster, pts[..., 0], pts[..., 1])
        bad = static < r + self.margin
        if maze.motion is not None:
            frac = (jnp.arange(self.samples, dtype=jnp.float32) + 1) / self.samples
            times = (state.t + step + frac) * params.dt  # [samples]
            where = jax.vmap(lambda t: motion.positions(maze.motion, t))(times)  # [samples, M, 2]
            gap = jnp.linalg.norm(pts[..., None, :] - where, axis=-1) - maze.motion.radius
            bad = bad | (jnp.min(gap, axis=-1) < r + self.moving_margin)
        return jnp.any(bad, axis=-1)

    def _exact_clearance(self, maze: Maze, state: EnvState, v, omega, dt) -> chex.Array:
        """The smallest distance from the robot's centre to any surface over the next
        step, as :meth:`jaxnav.env.NavEnv.step_env` computes it."""
        clearance = path_clearance(maze, state.pos, state.yaw, omega, v, dt)
        if maze.motion is not None:
            moving = motion.moving_clearance(
                maze.motion, state.pos, state.yaw, omega, v, dt, state.t * dt
            )
            clearance = jnp.minimum(clearance, moving)
        return clearance


__all__ = ["Oracle", "OracleMemory"]
