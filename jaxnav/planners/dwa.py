"""The dynamic window approach (Fox, Burgard & Thrun, "The dynamic window approach to
collision avoidance", IEEE RAM 1997): the classical local planner that robotics users
run (ROS 1 move_base's ``dwa_local_planner``, ROS 2 Nav2's DWB), as a reference beside
the learned policies.

It sees what a policy sees: the LiDAR scan and the goal's heading and distance in the
observation, nothing of the map. Where the policies are given the path (``env.waypoint``
in a drawn maze) DWA is given it too, the way Nav2 runs a local planner under a global
one: it heads for a carrot ``lookahead`` metres along the maze's shortest path from the
robot's true pose (:meth:`waypoint` of the family) instead of the goal, so that it is
drawn through a door rather than stopping at it.

Every step it takes each velocity the action set can command (with the paper's actions,
the five yaw rates at 0.15 m/s; with a richer set, its (v, omega) pairs: the robot has
no acceleration limit here, so every one is within the window), simulates the arc for
``horizon`` seconds, and drops those that would come within the robot's radius (plus
``margin``) of the obstacles it sees: the scan's returns, joined into wall pieces where
neighbouring beams hit nearly the same range.
Among the rest it maximises

    G(v, omega) = alpha heading + beta clearance + gamma velocity,

each term normalised over the admissible candidates, as Fox et al. do: heading, how
well the robot faces the goal after one control period (pi - |angle to the goal|);
clearance, the smallest distance to an obstacle along the arc, capped; velocity, v.
Where none is admissible it takes the candidate that keeps the most clearance.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import chex
import jax.numpy as jnp

from jaxnav.env import EnvParams, EnvState, NavEnv
from jaxnav.planners import raster as rs
from jaxnav.world import sensor
from jaxnav.world.geometry import displacement, point_segment_distance, wrap_angle
from jaxnav.world.lazy import draw_where


@dataclasses.dataclass(frozen=True)
class DWA:
    """The dynamic window approach for ``env`` (static fields).

    Attributes:
      env: the environment it drives (its action set and sensor layout).
      horizon: how far ahead each velocity is simulated (s).
      samples: points per second of the simulated arc.
      margin: clearance kept beyond the robot's radius (m).
      join: neighbouring beams whose ranges differ by less than this are joined into a
        wall piece (m); beams farther apart leave a gap (a door, or an edge).
      clearance_cap: the clearance term counts distances up to this (m).
      alpha, beta, gamma: the weights of heading, clearance and velocity.
      lookahead: with ``env.waypoint`` in a drawn maze, how far along the shortest path
        the carrot it heads for lies (m).
      velocities: its own candidate commands ((v, omega), ...), sampled as ROS's
        planners sample them, instead of the environment's action set; the environment's
        actions are then continuous and the chosen command is given as one
        (:func:`continuous_action`). None: the action set's.
      global_plan: a raster (:class:`jaxnav.planners.raster.Raster`) on which a global
        planner that knows the map (move_base's navfn, given the whole costmap) finds the
        shortest way to the goal; DWA then heads for the point ``lookahead`` m along it
        instead of the goal. None: no global planner (the goal's own direction).
    """

    env: NavEnv
    horizon: float = 1.5
    samples: int = 10
    margin: float = 0.02
    join: float = 0.3
    clearance_cap: float = 1.0
    alpha: float = 2.0
    beta: float = 0.2
    gamma: float = 0.2
    lookahead: float = 0.5
    velocities: tuple[tuple[float, float], ...] | None = None
    global_plan: rs.Raster | None = None

    def start(self, params: EnvParams, state: EnvState) -> Any:
        """DWA keeps no memory between steps, but its global planner's distance field
        and, with its own samples, the way it last turned in place
        (:meth:`_no_reversal`)."""
        plan = None if self.global_plan is None else self._plan_field(params, state.goal)
        if self.velocities is None:
            return plan
        return plan, jnp.zeros((), jnp.float32), state.pos

    def _no_reversal(self, turn_memory, pos, v, w):
        """(bool[A] the candidates allowed, ROS's oscillation rule): after turning in place
        one way, turning in place the other way is refused until the robot has moved
        ``OSCILLATION_RESET`` m from where that turn began (base_local_planner's
        oscillation_reset_dist, BARN's 0.05 m)."""
        turned, anchor = turn_memory
        turned = jnp.where(jnp.hypot(*(pos - anchor)) > OSCILLATION_RESET, 0.0, turned)
        in_place = v == 0.0
        return ~(in_place & (jnp.sign(w) == -turned) & (turned != 0.0)), (turned, anchor)

    def _remember_turn(self, turn_memory, pos, v, w):
        turned, anchor = turn_memory
        spin = v == 0.0
        anchor = jnp.where(spin & (turned == 0.0), pos, anchor)
        return jnp.where(spin, jnp.sign(w), turned), anchor

    def _plan_field(self, params: EnvParams, goal: chex.Array):
        """(goal f32[2], f32[ny, nx] the shortest way to it from each raster cell)."""
        maze, raster = params.maze, self.global_plan
        free = rs.clearance_field(maze, raster) >= params.robot_radius
        field = rs.goal_distance(free, goal, params.goal_radius, rs.origin_of(maze, raster), raster)
        return goal, field

    def _carrot(self, memory, state: EnvState, params: EnvParams):
        """(memory, carrot f32[2]): the point ``lookahead`` m from the robot in the
        direction (of 32) whose way to the goal is shortest; the field drawn again where
        the goal changed."""
        fresh = jnp.any(memory[0] != state.goal)
        memory = draw_where(
            lambda g, prm: self._plan_field(prm, g), fresh, state.goal, memory, shared=params
        )
        angles = jnp.linspace(-jnp.pi, jnp.pi, 32, endpoint=False)
        around = state.pos + self.lookahead * jnp.stack([jnp.cos(angles), jnp.sin(angles)], -1)
        origin = rs.origin_of(params.maze, self.global_plan)
        d = rs.field_upper(memory[1], origin, self.global_plan, around[:, 0], around[:, 1])
        return memory, jnp.where(jnp.isfinite(jnp.min(d)), around[jnp.argmin(d)], state.goal)

    def plan(
        self, memory: Any, obs: chex.Array, state: EnvState, params: EnvParams
    ) -> tuple[chex.Array, Any]:
        """(action i32[], None): the best admissible velocity for this scan and goal (or
        the path's carrot, where the policies are given the path)."""
        env = self.env
        ranges, heading, distance = env.read_observation(obs, params)
        if env.waypoint and env.generates:  # the global planner's carrot on the path
            carrot = env.family.waypoint(
                state.maze, state.cell_dist, state.pos, state.goal, self.lookahead
            )
            heading, distance = sensor.goal_heading_distance(state.pos, state.yaw, carrot)
        plan, turns = (memory, None) if self.velocities is None else (memory[0], memory[1:])
        if self.global_plan is not None:  # head along the global plan
            plan, carrot = self._carrot(plan, state, params)
            heading, distance = sensor.goal_heading_distance(state.pos, state.yaw, carrot)
        angles = env.beam_angles()
        returned = ranges < params.max_range - 1e-3  # a max-range reading hit nothing
        qx, qy = ranges * jnp.cos(angles), ranges * jnp.sin(angles)  # the robot's frame
        # wall pieces between neighbouring returns of nearly equal range
        nx_, ny_ = jnp.roll(qx, -1), jnp.roll(qy, -1)
        joined = returned & jnp.roll(returned, -1)
        joined = joined & (jnp.abs(ranges - jnp.roll(ranges, -1)) < self.join)
        if env.lidar_fov < 360.0:  # the last beam and the first face across the blind arc
            joined = joined.at[-1].set(False)

        if self.velocities is not None:  # its own samples, driven as continuous commands
            v = jnp.asarray([c[0] for c in self.velocities], jnp.float32)
            w = jnp.asarray([c[1] for c in self.velocities], jnp.float32)
            A = len(self.velocities)
        else:
            A = env.num_actions
            v, w = env.command(params, jnp.arange(A))
            v = jnp.broadcast_to(v, (A,))
        k = max(1, round(self.horizon * self.samples))
        times = self.horizon * (jnp.arange(k, dtype=jnp.float32) + 1) / k  # [k]
        path = jnp.moveaxis(displacement(0.0, w[:, None], v[:, None], times[None, :]), 0, -1)
        px, py = path[..., 0, None], path[..., 1, None]  # [A, k, 1]
        to_points = jnp.where(returned, jnp.hypot(px - qx, py - qy), jnp.inf)
        to_walls = jnp.where(joined, point_segment_distance(px, py, qx, qy, nx_, ny_), jnp.inf)
        clearance = jnp.min(jnp.minimum(to_points, to_walls), axis=(1, 2))  # [A]
        admissible = clearance >= params.robot_radius + self.margin
        if turns is not None:  # ROS's: no turning back and forth in place
            allowed, turns = self._no_reversal(turns, state.pos, v, w)
            admissible = admissible & allowed

        # heading after one control period: the goal's direction seen from there
        p1 = jnp.moveaxis(displacement(0.0, w, v, params.dt), 0, -1)  # [A, 2]
        gx, gy = distance * jnp.cos(heading), distance * jnp.sin(heading)
        to_goal = jnp.arctan2(gy - p1[:, 1], gx - p1[:, 0]) - w * params.dt
        head = jnp.pi - jnp.abs(wrap_angle(to_goal))
        clear = jnp.minimum(clearance, self.clearance_cap)
        score = (
            self.alpha * _normalised(head, admissible)
            + self.beta * _normalised(clear, admissible)
            + self.gamma * _normalised(v, admissible)
        )
        best = jnp.where(
            jnp.any(admissible),
            jnp.argmax(jnp.where(admissible, score, -jnp.inf)),
            jnp.argmax(clearance),
        )
        if self.velocities is not None:
            turns = self._remember_turn(turns, state.pos, v[best], w[best])
            return continuous_action(env, v[best], w[best]), (plan, *turns)
        return best.astype(jnp.int32), plan


def continuous_action(env: NavEnv, v, w) -> chex.Array:
    """f32[2]: the continuous action in [-1, 1]^2 that commands (v, w) in ``env``
    (:meth:`jaxnav.env.NavEnv.command`'s mapping undone)."""
    low, high = env.speed_range
    a0 = 2.0 * (v - low) / (high - low) - 1.0
    return jnp.stack([a0, w / env.max_yaw_rate]).astype(jnp.float32)


# The BARN challenge's DWA (jackal_helper/configs/params/base_local_planner_params.yaml,
# TrajectoryPlannerROS with dwa: true; costmap_common_params.yaml): its velocity samples
# (vx_samples 6 over min_vel_x 0.1 .. max_vel_x 0.5, vtheta_samples 20 over +-max_vel_theta
# 1.57, the in-place turns from min_in_place_vel_theta 0.314 to 1.57), its forward
# simulation (sim_time 2.0 s) and its footprint (0.42 x 0.33 m padded by 0.1 m: a disc of
# its inscribed radius, 0.265 m, must stay clear). Its acceleration limits (acc_lim_x 10,
# acc_lim_theta 20) at 20 Hz leave every sample within the window at jaxnav's 0.2 s.
BARN_VX = tuple(0.1 + 0.4 * i / 5 for i in range(6))
BARN_VTHETA = tuple(-1.57 + 3.14 * i / 19 for i in range(20))
BARN_IN_PLACE = tuple(s * w for w in (0.314, 0.785, 1.57) for s in (-1.0, 1.0))
BARN_VELOCITIES = tuple((v, w) for v in BARN_VX for w in BARN_VTHETA) + tuple(
    (0.0, w) for w in BARN_IN_PLACE
)
BARN_FOOTPRINT = 0.165 + 0.1  # m: the padded footprint's inscribed radius
OSCILLATION_RESET = 0.05  # m: oscillation_reset_dist
BARN_SETTINGS = {  # the environment's continuous commands cover BARN's samples
    "actions": "continuous",
    "speed_range": (0.0, 0.5),
    "max_yaw_rate": 1.57,
}


def barn_dwa(env: NavEnv, robot_radius: float, global_plan: rs.Raster | None = None) -> DWA:
    """DWA with BARN's parameters for ``env`` (its actions :data:`BARN_SETTINGS`), the
    robot a disc of ``robot_radius``; ``global_plan``: the raster of a global planner
    that knows the map, heading for the point 1 m along its way (None: the goal)."""
    return DWA(
        env,
        horizon=2.0,
        samples=10,  # 20 points along 2 s: 5 cm apart at 0.5 m/s
        margin=max(BARN_FOOTPRINT - robot_radius, 0.0),
        lookahead=1.0 if global_plan is not None else 0.5,
        velocities=BARN_VELOCITIES,
        global_plan=global_plan,
    )


def _normalised(x: chex.Array, keep: chex.Array) -> chex.Array:
    """x over the sum of the kept candidates' x (Fox et al.'s normalisation); 0 where
    that sum is 0."""
    total = jnp.sum(jnp.where(keep, x, 0.0))
    return jnp.where(total > 0, x / jnp.where(total > 0, total, 1.0), 0.0)


__all__ = ["BARN_SETTINGS", "BARN_VELOCITIES", "DWA", "barn_dwa", "continuous_action"]
