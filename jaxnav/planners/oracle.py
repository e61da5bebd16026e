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
:func:`~jaxnav.world.motion.step_clearance`) and, for the later steps of a plan,
against a raster of the static clearance read as a lower bound, with a margin, and
against the moving cylinders at their exact positions. Where every sequence collides
it takes the one that collides latest. Where nothing moves and the best plan stays
where the robot is (it stands, or only turns), it turns in place towards the shortest
way instead (a rotate recovery: the tree cannot turn round and then drive). The
shortest-path field is computed again only
when the goal or the maze changes (:func:`jaxnav.world.lazy.draw_where`: under vmap
only for the environments whose goal changed).

Where the robot starts inside the orbit of turning cylinders (stage 3), no plan a few
seconds long finds the gap: the oracle is then given its ``openings``, the action
sequences a search in space and time (:func:`jaxnav.planners.search.opening`) found from
the start at time 0 to each goal a reset can set, replayed clean in the environment. At
an episode's start it drives the one of its goal, step by step while the robot is where
the sequence has it, and plans as above from there on.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp

from jaxnav.core.settings import can_stop
from jaxnav.env import EnvParams, EnvState, NavEnv
from jaxnav.planners import raster as rs
from jaxnav.planners.search import Opening
from jaxnav.world import motion
from jaxnav.world.geometry import displacement, wrap_angle
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
        (1.4 s ahead), or (1, 3, 10) (2.8 s) where cylinders move, to see them coming;
        with more than 7 actions two levels, (1, 5) or (1, 13), so the tree stays small
        (:func:`holds_for` gives (1, 20) where cylinders outrun the robot).
      margin: clearance kept from static surfaces beyond the robot's radius after the
        first step (m); the raster's lower bound adds its own slack.
      moving_margin: the same for the moving cylinders (m).
      samples: points checked per simulated step.
      lookahead: how far ahead of a plan's end the field is read to score its heading (m).
      wait_steps: with a stop in the action set, a plan may end at any of its steps and
        the robot stands there; where cylinders move, only where it could stand this many
        control periods without one reaching it.
      delay_cost: metres of way a plan is charged per step it takes to its end, so that
        of two plans to the same place the sooner wins (a plan may wait).
      openings: searched ways out of a start (:class:`jaxnav.planners.search.Opening`),
        one per test maze that needs one; driven where the robot is on one.
    """

    env: NavEnv
    raster: rs.Raster
    holds: tuple[int, ...] | None = None
    margin: float = 0.02
    moving_margin: float = 0.03
    samples: int = 1
    lookahead: float = 0.1
    wait_steps: int = 16
    delay_cost: float = 0.01
    openings: tuple[Opening, ...] = ()

    # -- memory ---------------------------------------------------------------

    def _geometry(self, params: EnvParams, state: EnvState) -> Maze:
        return self.env.episode_maze(params, state)

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
        fresh = jnp.any(state.goal != mem.goal)
        clearance = mem.clearance  # one maze the whole test: the first step's field
        if self.env.generates or self.env.scales_maze:  # each episode may have its own
            new_maze = jnp.any(maze.segments != mem.segments)
            new_maze = new_maze | jnp.any(maze.circles != mem.circles)
            clearance = draw_where(
                lambda m: rs.clearance_field(m, self.raster), new_maze, maze, clearance, chunk=1
            )
            fresh = fresh | new_maze
        origin = rs.origin_of(maze, self.raster)
        inputs = (clearance, state.goal, origin, params.goal_radius, params.robot_radius)
        distance = draw_where(self._distance, fresh, inputs, mem.distance, chunk=1)
        return OracleMemory(maze.segments, maze.circles, state.goal, clearance, distance)

    # -- planning ---------------------------------------------------------------

    def plan(
        self, mem: OracleMemory, obs: chex.Array, state: EnvState, params: EnvParams
    ) -> tuple[chex.Array, OracleMemory]:
        """(action i32[], memory): the first action of the best collision-free plan."""
        del obs  # privileged: it reads the state
        env, dt, r = self.env, params.dt, params.robot_radius
        maze = self._geometry(params, state)
        with jax.named_scope("oracle_fields"):
            mem = self._update(mem, params, state, maze)
        origin = rs.origin_of(maze, self.raster)
        A = env.num_actions
        moving = maze.motion is not None
        holds = self.holds or _default_holds(A, moving)
        L = len(holds)
        v_a, w_a = env.command(params, jnp.arange(A))
        v_a = jnp.broadcast_to(v_a, (A,))

        with jax.named_scope("oracle_exact"):
            # The step about to be driven, checked exactly as the environment will: each
            # action's, or with action_delay the pending action's, after which the plan starts.
            pos, yaw, offset = state.pos[None], state.yaw[None], 0
            t0 = state.t * dt  # the step's start, in the episode's time
            if env.action_delay:
                vp, wp = env.command(params, state.pending_action)
                now = motion.step_clearance(maze, state.pos, state.yaw, wp, vp, dt, t0) >= r
                pos = pos + displacement(yaw, wp, vp, dt).T
                yaw, offset = wrap_angle(yaw + wp * dt), 1
            else:
                now = jax.vmap(
                    lambda v, w: motion.step_clearance(maze, state.pos, state.yaw, w, v, dt, t0)
                )(v_a, w_a)
                now = now >= r  # [A]

        with jax.named_scope("oracle_simulate"):
            # SIMULATE the tree level by level: every node's A actions, each held its steps;
            # a step's points are checked on the raster and against the moving cylinders.
            levels, step = [], offset
            for hold in holds:
                pos = jnp.broadcast_to(pos[:, None, :], (pos.shape[0], A, 2))
                yaw = jnp.broadcast_to(yaw[:, None], pos.shape[:2])
                rec = []  # per step: (unsafe, at the goal, position, yaw)
                for _ in range(hold):
                    frac = (jnp.arange(self.samples, dtype=jnp.float32) + 1) / self.samples
                    pts = pos[..., None, :] + jnp.moveaxis(
                        displacement(yaw[..., None], w_a[:, None], v_a[:, None], frac * dt), 0, -1
                    )  # [N, A, samples, 2]
                    unsafe = self._unsafe(mem, maze, origin, state, params, pts, step)
                    pos, yaw = pts[..., -1, :], wrap_angle(yaw + w_a * dt)
                    at_goal = _length(pos - state.goal) < params.goal_radius
                    rec.append((unsafe, at_goal, pos, yaw))
                    step += 1
                levels.append(
                    [jnp.stack(x, 2).reshape(-1, hold, *x[0].shape[2:]) for x in zip(*rec)]
                )
                pos, yaw = pos.reshape(-1, 2), yaw.reshape(-1)
            # every full sequence's steps: level l's node of sequence s is s // A^(L - 1 - l)
            K = A**L
            seq = jnp.arange(K)
            bad, reach, where, heading = (
                jnp.concatenate([lv[i][seq // A ** (L - 1 - k)] for k, lv in enumerate(levels)], 1)
                for i in range(4)
            )  # [K, T] each, where [K, T, 2]
            if env.action_delay:
                bad = bad | ~now
            else:
                bad = bad.at[:, 0].set(bad[:, 0] | ~now[seq // A ** (L - 1)])
            T = bad.shape[1]
            # the first step that collides, T for none (an elementwise least over steps)
            hit_at = _least(jnp.where(bad, jnp.arange(T), T), 1)

        with jax.named_scope("oracle_score"):
            # SCORE: the goal soonest; else the shortest way left, facing along it. A plan
            # must stay clear to its end, past the goal too (the next goal's plan starts
            # there); with a stop in the action set it may end at any of its steps, where the
            # robot then stands (clear of the cylinders for ``wait`` seconds, if they move).
            ahead = where + self.lookahead * jnp.stack([jnp.cos(heading), jnp.sin(heading)], -1)
            d_end = rs.field_upper(mem.distance, origin, self.raster, where[..., 0], where[..., 1])
            d_ahead = rs.field_upper(
                mem.distance, origin, self.raster, ahead[..., 0], ahead[..., 1]
            )
            d_ahead = jnp.where(jnp.isfinite(d_ahead), d_ahead, d_end + 2 * self.lookahead)
            straight = _length(where - state.goal)  # where the raster has no way
            way = jnp.where(
                jnp.isfinite(d_end), 0.5 * (d_end + d_ahead), 1.0e3 + straight
            )  # [K, T]
            steps = jnp.arange(T)
            if self.can_stop:  # ends at any step clear so far (and, if they move, of cylinders)
                valid = steps[None, :] < hit_at[:, None]
                if moving:
                    valid = valid & ~self._no_wait(maze, state, params, where, offset)
            else:  # clear to its end; the goal counts wherever the plan reaches it
                valid = (hit_at == T)[:, None] & ((steps == T - 1)[None, :] | reach)
            # the goal counts where the plan can go on from it to a valid end
            later = _at_or_after(valid)  # a valid end at or after
            reach_ok = reach & later & (steps[None, :] < hit_at[:, None])
            # the same place reached a step sooner is better: no putting progress off
            score = jnp.where(valid, way + self.delay_cost * steps, jnp.inf)
            score = jnp.where(reach_ok, -1.0e3 + steps[None, :], score)
            cost = _least(score, 1)
            # none stays clear: the plan that collides latest
            fallback = _BIG * (1 + T - hit_at) + jnp.minimum(way[:, -1], 1.0e4)
            cost = jnp.where(jnp.isfinite(cost), cost, fallback)
            best = jnp.argmin(cost)
            choice = best // A ** (L - 1)
            if self.can_stop and not moving:
                plan = (best // A ** (L - 1 - jnp.arange(L))) % A  # each level's action
                still = jnp.all(v_a[plan] == 0)  # the best plan does not leave where it is
                choice = self._turn_to_way(choice, still, mem, origin, state, v_a, w_a, dt)
            for opening in self.openings:  # on a searched way out of the start: its action
                choice = _scripted(opening, state, maze, choice)
        return choice.astype(jnp.int32), mem

    @property
    def can_stop(self) -> bool:
        """Whether the action set holds a stop (the robot can wait where it is)."""
        return can_stop(self.env.actions)

    def _turn_to_way(self, choice, still, mem, origin, state, v_a, w_a, dt) -> chex.Array:
        """The action where nothing moves and the best plan stays where the robot is
        (``still``: it stands or only turns): a turn in place towards where the shortest
        way leads, if one brings the heading nearer to it. Facing away from the way
        beside an obstacle, no plan of the tree turns round and then drives (its first
        level is one step), and a turn alone gains less than it is charged for delay:
        the best plan stood, or turned one way and then back. Staying is never the way
        to a goal that nothing will move out of the way of (a rotate recovery)."""
        angles = jnp.linspace(-jnp.pi, jnp.pi, 16, endpoint=False)
        around = state.pos + self.lookahead * jnp.stack([jnp.cos(angles), jnp.sin(angles)], -1)
        d = rs.field_upper(mem.distance, origin, self.raster, around[:, 0], around[:, 1])
        want = angles[jnp.argmin(d)]
        off = jnp.abs(wrap_angle(want - state.yaw))
        turns = (v_a == 0) & (w_a != 0)
        after = jnp.where(turns, jnp.abs(wrap_angle(want - state.yaw - w_a * dt)), jnp.inf)
        turn = jnp.argmin(after)
        nearer = jnp.isfinite(jnp.min(d)) & (after[turn] < off)
        return jnp.where(still & nearer, turn, choice)

    def _no_wait(self, maze, state, params, where, offset: int) -> chex.Array:
        """bool[K, T]: whether a moving cylinder would come within reach of the robot
        standing where each plan is after each of its steps (``where`` f32[K, T, 2]; the
        plan's step j ends ``offset + j + 1`` steps from now) in the next ``wait``
        seconds (``wait_steps`` of the control period)."""
        T = where.shape[1]
        ahead = jnp.arange(offset + 1, offset + T + self.wait_steps + 1)  # every step's time
        at = jax.vmap(lambda k: motion.positions(maze.motion, (state.t + k) * params.dt))(ahead)
        # the cylinders' centres over the wait after each end: [T, wait, M, 2]
        window = jnp.stack([at[j : j + self.wait_steps] for j in range(T)])
        gap = _length(where[:, :, None, None, :] - window[None])
        gap = _least(gap - maze.motion.radius, 2, 3)
        return gap < params.robot_radius + self.moving_margin

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
            gap = _length(pts[..., None, :] - where) - maze.motion.radius
            bad = bad | (_least(gap, gap.ndim - 1) < r + self.moving_margin)
        return jnp.any(bad, axis=-1)


def _length(v: chex.Array) -> chex.Array:
    """f32[...]: the length of each vector of ``v`` (f32[..., 2]), exactly as
    ``jnp.linalg.norm(v, axis=-1)`` computes it on a CPU, each square rounded before
    their sum, but elementwise, so that it fuses with what is around it instead of
    being a library reduction of its own. The maximum with 0 changes no square; it keeps
    the compiler from contracting a square and the sum into one fused multiply-add,
    which rounds once and would move the last bit."""
    x, y = v[..., 0], v[..., 1]
    return jnp.sqrt(jnp.maximum(x * x, 0.0) + jnp.maximum(y * y, 0.0))


def _least(x: chex.Array, *axes: int) -> chex.Array:
    """The minimum of ``x`` over its trailing ``axes`` (the last ones, in order), taken
    as an elementwise minimum of their slices: exactly ``jnp.min``, but a reduction
    over a few short axes is a library call of its own on a CPU, where the elementwise
    minima fuse into one loop."""
    assert axes == tuple(range(x.ndim - len(axes), x.ndim)), axes
    flat = x.reshape(x.shape[: axes[0]] + (-1,))
    return functools.reduce(jnp.minimum, (flat[..., i] for i in range(flat.shape[-1])))


def _at_or_after(x: chex.Array) -> chex.Array:
    """bool[K, T]: whether ``x`` (bool[K, T]) holds at step t or a later one, as T
    elementwise ors (a reversed cumulative sum over so few steps costs more)."""
    out = [x[:, -1]]
    for t in range(x.shape[1] - 2, -1, -1):
        out.append(x[:, t] | out[-1])
    return jnp.stack(out[::-1], 1)


def _scripted(opening: Opening, state: EnvState, maze: Maze, choice: chex.Array) -> chex.Array:
    """The opening's next action where the robot is on one of its sequences (its world,
    its goal, its step, its position), else ``choice``."""
    goals, poses = jnp.asarray(opening.goals), jnp.asarray(opening.poses)
    actions, length = jnp.asarray(opening.actions), jnp.asarray(opening.length)
    t = jnp.clip(state.t, 0, actions.shape[1] - 1)
    world = jnp.all(jnp.abs(motion.positions(maze.motion, 0.0)[0] - opening.marker) < 1e-5)
    on = (
        world
        & (state.t < length)
        & jnp.all(jnp.abs(goals - state.goal) < 1e-5, axis=-1)
        & jnp.all(jnp.abs(poses[:, t] - state.pos) < 1e-4, axis=-1)
    )
    return jnp.where(jnp.any(on), actions[jnp.argmax(on), t], choice)


def holds_for(env: NavEnv, params: EnvParams, mazes) -> tuple[int, ...] | None:
    """The tree's levels for driving ``mazes`` (``params``: their settings): (1, 20),
    4.2 s ahead, where the set has more than 7 actions and a moving cylinder of one
    of them is faster than the robot's top speed; else None (:func:`_default_holds`).
    The robot cannot outrun such a cylinder, so it must cross the cylinder's sweep
    (stage 3's ring: about 2.5 s at full speed, with the margins) on one plan, from
    where it may stand to where it may stand again; a 2.8 s plan is too short and the
    oracle waits at the sweep's edge for a crossing it never finds."""
    if env.num_actions <= 7:
        return None
    v, _ = env.command(params, jnp.arange(env.num_actions))
    top = float(jnp.max(jnp.abs(v)))
    moving = [maze.motion for maze in mazes if maze.motion is not None]
    return (1, 20) if any(motion.top_speed(m) > top for m in moving) else None


def _default_holds(n_actions: int, moving: bool) -> tuple[int, ...]:
    """The tree's levels (steps each holds its action) for an action set and a world."""
    if n_actions > 7:
        return (1, 13) if moving else (1, 5)
    return (1, 3, 10) if moving else (1, 2, 4)


__all__ = ["Oracle", "OracleMemory", "holds_for"]
