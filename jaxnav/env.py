"""TurtleBot3 maze navigation as a pure, jit-able JAX environment (gymnax 1.0 style).

``env, params = jaxnav.make("square4")`` then ``env.reset(key, params)`` and
``env.step(key, state, action, params)``. ``EnvParams`` and ``EnvState`` are
immutable pytrees, so everything jits and vmaps, over keys and over params (a
batch of different mazes in one call, see :func:`jaxnav.maps.stack_mazes`).

What is simulated (numbers from the spec):

* Motion: constant 0.15 m/s, 5 angular velocities (paper Table 1), exact unicycle
  integration over dt = 0.2 s (the robot moves on a circular arc).
* LiDAR (:func:`lidar_scan`): analytic ray-segment and ray-circle intersection,
  branchless, clipped to [0.12, 3.5] m; optional Gaussian range noise applied by the
  env, not by the caster.
* Collision: the 0.13 m robot disc against every wall and obstacle, exactly, along
  the whole arc of the step, so no step can cross a wall unnoticed.
* Goals: reaching within 0.2 m pays R+ and draws a new goal, the episode goes on; a
  collision pays R- and terminates the episode; 500 steps truncate it. After either,
  the robot restarts at the maze's start pose and keeps its goal (as TurtleBot3).
* Observation (ROBOTIS state): beam ranges, heading to goal, distance to goal, and
  for mazes with obstacles also the smallest range and its beam index.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import chex
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxnav.maps import GOAL_START_CLEARANCE, ROBOT_RADIUS, Maze, make_maze

# Paper Table 1: action -> angular velocity (rad/s), positive = counter-clockwise.
PAPER_OMEGAS = (-1.5, -0.75, 0.0, 0.75, 1.5)

_EPS = 1e-9


def wrap_angle(a: chex.Array) -> chex.Array:
    """Wrap angles to [-pi, pi)."""
    return (a + jnp.pi) % (2 * jnp.pi) - jnp.pi


def _cross(a: chex.Array, b: chex.Array) -> chex.Array:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _safe(x: chex.Array) -> chex.Array:
    """x with values too close to 0 replaced by 1 (for division)."""
    return jnp.where(jnp.abs(x) < _EPS, 1.0, x)


# ----------------------------------------------------------------------------
# LiDAR
# ----------------------------------------------------------------------------


def ray_distances(maze: Maze, origin: chex.Array, angles: chex.Array) -> chex.Array:
    """Exact distance along each ray to the first wall or obstacle (inf if none).

    Args:
      maze: the maze (single, unbatched).
      origin: f32[2] ray origin.
      angles: f32[B] world-frame ray directions.
    Returns:
      f32[B] distances.
    """
    d = jnp.stack([jnp.cos(angles), jnp.sin(angles)], axis=-1)  # [B, 2]
    dd = d[:, None, :]  # [B, 1, 2]

    # Ray-segment: origin + t d = a + u e, solved with 2D cross products.
    a = maze.segments[None, :, :2]  # [1, S, 2]
    e = maze.segments[None, :, 2:] - a
    w = a - origin
    denom = _cross(dd, e)  # [B, S]
    sd = _safe(denom)
    t = _cross(w, e) / sd
    u = _cross(w, dd) / sd
    hit = (
        (jnp.abs(denom) >= _EPS)
        & (t >= 0.0)
        & (u >= -1e-6)
        & (u <= 1.0 + 1e-6)
        & maze.segment_mask[None, :]
    )
    t_seg = jnp.min(jnp.where(hit, t, jnp.inf), axis=-1)

    # Ray-circle: |f + t d|^2 = r^2 with f = origin - c; first root outside, second inside.
    f = origin - maze.circles[None, :, :2]  # [1, C, 2]
    r = maze.circles[None, :, 2]
    b = jnp.sum(f * dd, axis=-1)  # [B, C]
    c = jnp.sum(f * f, axis=-1) - r**2
    # disc = b^2 - c = r^2 - h^2 with h the centre's offset from the ray's line.
    # Computed as (r - h)(r + h): b^2 - c cancels in float32 near a tangent.
    h = jnp.abs(_cross(dd, f))
    disc = (r - h) * (r + h)
    sq = jnp.sqrt(jnp.maximum(disc, 0.0))
    tc = jnp.where(c > 0.0, -b - sq, -b + sq)
    hit_c = (disc >= 0.0) & (tc >= 0.0) & maze.circle_mask[None, :]
    t_circ = jnp.min(jnp.where(hit_c, tc, jnp.inf), axis=-1)
    return jnp.minimum(t_seg, t_circ)


def beam_angles(n_beams: int) -> jax.Array:
    """Beam k points at yaw + 2 pi k / n_beams (counter-clockwise from ahead)."""
    return jnp.arange(n_beams, dtype=jnp.float32) * (2 * math.pi / n_beams)


def lidar_scan(
    maze: Maze,
    pos: chex.Array,
    yaw: chex.Array,
    n_beams: int = 24,
    min_range: float = 0.12,
    max_range: float = 3.5,
) -> chex.Array:
    """LiDAR ranges f32[n_beams] from pose (pos, yaw), clipped to [min_range, max_range]."""
    ranges = ray_distances(maze, pos, yaw + beam_angles(n_beams))
    return jnp.clip(ranges, min_range, max_range)


# ----------------------------------------------------------------------------
# Collision along an arc
# ----------------------------------------------------------------------------


def _point_segment_distance(p: chex.Array, a: chex.Array, b: chex.Array) -> chex.Array:
    ab = b - a
    t = jnp.clip(jnp.sum((p - a) * ab, -1) / jnp.maximum(jnp.sum(ab * ab, -1), _EPS), 0.0, 1.0)
    return jnp.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def _segment_segment_distance(p0, p1, a, b) -> chex.Array:
    """Distance between segment p0p1 and segments ab (broadcast over a, b)."""
    d = jnp.minimum(
        jnp.minimum(_point_segment_distance(p0, a, b), _point_segment_distance(p1, a, b)),
        jnp.minimum(_point_segment_distance(a, p0, p1), _point_segment_distance(b, p0, p1)),
    )
    o1 = _cross(p1 - p0, a - p0)
    o2 = _cross(p1 - p0, b - p0)
    o3 = _cross(b - a, p0 - a)
    o4 = _cross(b - a, p1 - a)
    crossing = (o1 * o2 < 0) & (o3 * o4 < 0)
    return jnp.where(crossing, 0.0, d)


def path_clearance(
    maze: Maze, pos: chex.Array, yaw: chex.Array, omega: chex.Array, v: float, dt: float
) -> chex.Array:
    """Smallest distance from the robot centre's path over one step to any surface.

    The centre moves on the exact unicycle path: a straight segment when omega = 0,
    otherwise an arc of radius v / |omega| swept by omega * dt. The robot collides
    during the step iff this is below its radius.
    """
    segs = maze.segments
    a, b = segs[:, :2], segs[:, 2:]
    circ, rc = maze.circles[:, :2], maze.circles[:, 2]
    p0 = pos
    p1 = pos + _displacement(yaw, omega, v, dt)

    # Straight path.
    d_seg_line = _segment_segment_distance(p0, p1, a, b)
    d_circ_line = _point_segment_distance(circ, p0, p1) - rc

    # Arc path: centre C, signed radius R, start angle alpha0, sweep delta.
    w = jnp.where(jnp.abs(omega) < 1e-6, 1.0, omega)
    R = v / w
    C = pos + R * jnp.stack([-jnp.sin(yaw), jnp.cos(yaw)])
    rad = jnp.abs(R)
    alpha0 = jnp.arctan2(p0[1] - C[1], p0[0] - C[0])
    sweep = w * dt  # |sweep| < pi for every action

    def in_arc(phi):
        s = wrap_angle(phi - alpha0) * jnp.sign(sweep)
        return (s >= 0.0) & (s <= jnp.abs(sweep))

    def point_arc_distance(x):  # x [..., 2]
        rel = x - C
        rho = jnp.linalg.norm(rel, axis=-1)
        phi = jnp.arctan2(rel[..., 1], rel[..., 0])
        ends = jnp.minimum(jnp.linalg.norm(x - p0, axis=-1), jnp.linalg.norm(x - p1, axis=-1))
        return jnp.where(in_arc(phi), jnp.abs(rho - rad), ends)

    d_ends = jnp.minimum(_point_segment_distance(p0, a, b), _point_segment_distance(p1, a, b))
    d_segpts = jnp.minimum(point_arc_distance(a), point_arc_distance(b))
    # Interior critical points: the foot F of C on each wall's line.
    ab = b - a
    ab2 = jnp.maximum(jnp.sum(ab * ab, -1), _EPS)
    tau = jnp.sum((C - a) * ab, -1) / ab2
    F = a + tau[:, None] * ab
    h = jnp.linalg.norm(F - C, axis=-1)
    phiF = jnp.arctan2(F[:, 1] - C[1], F[:, 0] - C[0])
    d_foot = jnp.where(
        (h >= rad) & (tau >= 0.0) & (tau <= 1.0) & in_arc(phiF), h - rad, jnp.inf
    )
    # The wall's line crosses the circle: a crossing on both the wall and the arc is a hit.
    half = jnp.sqrt(jnp.maximum(rad**2 - h**2, 0.0)) / jnp.sqrt(ab2)
    hits = jnp.zeros_like(h, dtype=bool)
    for sgn in (-1.0, 1.0):
        tq = tau + sgn * half
        q = a + tq[:, None] * ab
        phiq = jnp.arctan2(q[:, 1] - C[1], q[:, 0] - C[0])
        hits |= (h < rad) & (tq >= 0.0) & (tq <= 1.0) & in_arc(phiq)
    d_seg_arc = jnp.where(hits, 0.0, jnp.minimum(jnp.minimum(d_ends, d_segpts), d_foot))
    d_circ_arc = point_arc_distance(circ) - rc

    straight = jnp.abs(omega) < 1e-6
    d_seg = jnp.where(straight, d_seg_line, d_seg_arc)
    d_circ = jnp.where(straight, d_circ_line, d_circ_arc)
    d_seg = jnp.where(maze.segment_mask, d_seg, jnp.inf)
    d_circ = jnp.where(maze.circle_mask, d_circ, jnp.inf)
    return jnp.minimum(jnp.min(d_seg), jnp.min(d_circ))


def _displacement(yaw, omega, v, dt):
    """Exact unicycle displacement: chord of length v dt sinc(omega dt / 2), mid heading."""
    half = 0.5 * omega * dt
    chord = v * dt * jnp.sinc(half / jnp.pi)  # jnp.sinc(x) = sin(pi x) / (pi x)
    mid = yaw + half
    return chord * jnp.stack([jnp.cos(mid), jnp.sin(mid)])


# ----------------------------------------------------------------------------
# Reward
# ----------------------------------------------------------------------------


def psi(x: chex.Array) -> chex.Array:
    """Orientation shaping wave: 1 facing the goal, 0 at 90 degrees, -1 behind."""
    return 1.0 - (2.0 / jnp.pi) * jnp.abs(wrap_angle(x))


def reward_fn(
    params: "EnvParams",
    action: chex.Array,
    heading: chex.Array,
    distance: chex.Array,
    goal_distance0: chex.Array,
    reached: chex.Array,
    collided: chex.Array,
) -> chex.Array:
    """R+ on reaching the goal, R- on collision, else 5 psi(delta - phi_a) D.

    phi_a = (omega_a / omega_max) * span is the direction action a turns towards, so
    the action that turns towards the goal earns the largest shaping reward.
    D is the current distance d_c (paper) or 2^(d_c / d_0) (ROBOTIS).
    """
    omegas = jnp.asarray(params.omegas)
    phi = omegas[action] / jnp.max(jnp.abs(omegas)) * params.reward_span
    d_paper = distance
    d_robotis = jnp.exp2(distance / jnp.maximum(goal_distance0, 1e-6))
    D = jnp.where(params.reward_distance_exp, d_robotis, d_paper)
    shaping = 5.0 * psi(heading - phi) * D
    return jnp.where(collided, params.R_minus, jnp.where(reached, params.R_plus, shaping))


# ----------------------------------------------------------------------------
# Params, state, spaces
# ----------------------------------------------------------------------------


@struct.dataclass
class EnvParams:
    """Everything about the task that is data (vmappable). Defaults: paper preset."""

    maze: Maze
    omegas: chex.Array = struct.field(default_factory=lambda: jnp.asarray(PAPER_OMEGAS))
    v: float = 0.15  # m/s
    dt: float = 0.2  # s
    robot_radius: float = ROBOT_RADIUS  # m
    goal_radius: float = 0.2  # m
    min_range: float = 0.12  # m
    max_range: float = 3.5  # m
    lidar_noise_std: float = 0.0  # m; 0.01 reproduces Gazebo's LDS-01 model
    max_steps: int = 500
    R_plus: float = 1000.0
    R_minus: float = -150.0
    reward_span: float = math.pi / 2  # paper text; ROBOTIS code pi / 4
    reward_distance_exp: bool = False  # False: D = d_c (paper); True: 2^(d_c/d_0)
    goal_min_separation: float = 1.0  # m, a new goal is drawn this far from the last


@struct.dataclass
class EnvState:
    pos: chex.Array  # f32[2]
    yaw: chex.Array  # f32[]
    goal: chex.Array  # f32[2]
    t: chex.Array  # i32[] steps in this episode
    goal_distance0: chex.Array  # f32[] distance to goal when it was drawn (or at reset)
    scale: chex.Array  # f32[] this episode's maze scale (1 unless NavEnv.maze_scale)


@dataclasses.dataclass(frozen=True)
class Discrete:
    n: int
    shape: tuple = ()
    dtype: Any = jnp.int32

    def sample(self, key: chex.PRNGKey) -> chex.Array:
        return jax.random.randint(key, (), 0, self.n, dtype=self.dtype)

    def contains(self, x) -> bool:
        x = np.asarray(x)
        return bool(x.shape == () and 0 <= int(x) < self.n)


@dataclasses.dataclass(frozen=True)
class Box:
    low: Any
    high: Any
    shape: tuple
    dtype: Any = jnp.float32

    def sample(self, key: chex.PRNGKey) -> chex.Array:
        return jax.random.uniform(key, self.shape, self.dtype, self.low, self.high)

    def contains(self, x) -> bool:
        x = np.asarray(x)
        return bool(
            x.shape == self.shape and np.all(x >= self.low) and np.all(x <= self.high)
        )


PRESETS: dict[str, dict[str, Any]] = {
    "paper": dict(R_plus=1000.0, R_minus=-150.0, reward_span=math.pi / 2, reward_distance_exp=False),
    # ROBOTIS stage 1 uses R- = -200 and stage 2 -150; make() picks by the maze.
    "robotis": dict(R_plus=200.0, R_minus=-200.0, reward_span=math.pi / 4, reward_distance_exp=True),
}


# ----------------------------------------------------------------------------
# Environment
# ----------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class NavEnv:
    """The environment. Its fields fix array shapes, so they are static, not params.

    Attributes:
      n_beams: LiDAR beams in the observation (24 as in ROBOTIS; 360 works).
      obstacle_obs: append (min range, its beam index) to the observation (stage 2).
      goal_candidates: goal points tried per draw (fixed, for jit).

    Realism for a real robot (all off by default and in both presets; an option that
    is off adds no computation and leaves every random draw unchanged):
      beam_dropout: probability that a beam returns nothing (reads max_range), per
        beam and step, as a real LDS-01 drops returns on dark or shiny surfaces.
      odom_noise: (position m, yaw rad) standard deviations of Gaussian noise on the
        pose the robot uses for the goal's heading and distance (odometry error).
      random_start: start each episode at a random free pose with a uniform yaw
        instead of the maze's start pose.
      maze_scale: (low, high): each episode scales the maze (walls, obstacle
        positions, goals, start) by a factor drawn uniformly from this range;
        obstacle radii keep their size. (1, 1) is off.
    Range noise is ``EnvParams.lidar_noise_std``.
    """

    n_beams: int = 24
    obstacle_obs: bool = False
    goal_candidates: int = 16
    beam_dropout: float = 0.0
    odom_noise: tuple[float, float] = (0.0, 0.0)
    random_start: bool = False
    maze_scale: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self):
        if self.n_beams < 1:
            raise ValueError("n_beams must be at least 1")
        if not 0.0 <= self.beam_dropout < 1.0:
            raise ValueError("beam_dropout must be in [0, 1)")
        if len(self.odom_noise) != 2 or min(self.odom_noise) < 0:
            raise ValueError("odom_noise must be two non-negative standard deviations")
        lo, hi = self.maze_scale
        if not 0.5 <= lo <= hi <= 2.0:
            raise ValueError("maze_scale must be (low, high) with 0.5 <= low <= high <= 2")
        object.__setattr__(self, "odom_noise", tuple(float(x) for x in self.odom_noise))
        object.__setattr__(self, "maze_scale", (float(lo), float(hi)))

    @property
    def scales_maze(self) -> bool:
        return self.maze_scale != (1.0, 1.0)

    @property
    def num_actions(self) -> int:
        return len(PAPER_OMEGAS)

    @property
    def obs_size(self) -> int:
        return self.n_beams + 2 + (2 if self.obstacle_obs else 0)

    def action_space(self, params: EnvParams | None = None) -> Discrete:
        return Discrete(self.num_actions)

    def observation_space(self, params: EnvParams) -> Box:
        bounds = np.asarray(jax.device_get(params.maze.bounds))  # host side, not under jit
        big = float(np.max(bounds[..., 2:] - bounds[..., :2])) * self.maze_scale[1]
        low = [params.min_range] * self.n_beams + [-math.pi, 0.0]
        high = [params.max_range] * self.n_beams + [math.pi, 2 * big]
        if self.obstacle_obs:
            low += [params.min_range, 0.0]
            high += [params.max_range, float(self.n_beams - 1)]
        return Box(np.asarray(low, np.float32), np.asarray(high, np.float32), (self.obs_size,))

    # -- observation ---------------------------------------------------------

    def maze_at(self, params: EnvParams, scale: chex.Array) -> Maze:
        """The maze of an episode: ``params.maze``, scaled if ``maze_scale`` is on."""
        if not self.scales_maze:
            return params.maze
        return scale_maze(params.maze, scale)

    def observe(
        self,
        key: chex.PRNGKey,
        pos: chex.Array,
        yaw: chex.Array,
        goal: chex.Array,
        params: EnvParams,
        scale: chex.Array = 1.0,
    ) -> chex.Array:
        """ROBOTIS state: [ranges, heading, distance(, min range, argmin beam)]."""
        maze = self.maze_at(params, scale)
        ranges = ray_distances(maze, pos, yaw + beam_angles(self.n_beams))
        return self._obs_from_ranges(key, ranges, pos, yaw, goal, params)

    def _obs_from_ranges(self, key, ranges, pos, yaw, goal, params) -> chex.Array:
        noise = params.lidar_noise_std * jax.random.normal(key, ranges.shape)
        ranges = jnp.clip(ranges + noise, params.min_range, params.max_range)
        if self.beam_dropout > 0.0:
            lost = jax.random.bernoulli(jax.random.fold_in(key, 1), self.beam_dropout, ranges.shape)
            ranges = jnp.where(lost, params.max_range, ranges)
        if self.odom_noise != (0.0, 0.0):  # the goal is seen from the odometry pose
            k_pos, k_yaw = jax.random.split(jax.random.fold_in(key, 2))
            pos = pos + self.odom_noise[0] * jax.random.normal(k_pos, (2,))
            yaw = yaw + self.odom_noise[1] * jax.random.normal(k_yaw)
        heading, distance = goal_heading_distance(pos, yaw, goal)
        parts = [ranges, heading[None], distance[None]]
        if self.obstacle_obs:
            parts += [jnp.min(ranges)[None], jnp.argmin(ranges).astype(jnp.float32)[None]]
        return jnp.concatenate(parts).astype(jnp.float32)

    # -- goals ---------------------------------------------------------------

    def draw_goal(
        self, key: chex.PRNGKey, away_from: chex.Array, params: EnvParams, scale: chex.Array = 1.0
    ) -> chex.Array:
        """A free-space goal at least goal_min_separation from ``away_from`` if possible.

        Tries ``goal_candidates`` points of the maze's admissible goal set and keeps the
        first far enough away; if none is, the first (still in free space).
        """
        maze = self.maze_at(params, scale)
        idx = jax.random.randint(key, (self.goal_candidates,), 0, maze.n_goal_points)
        cand = maze.goal_points[idx]
        far = jnp.linalg.norm(cand - away_from, axis=-1) >= params.goal_min_separation
        return cand[jnp.argmax(far)]

    # -- API -----------------------------------------------------------------

    def _episode_start(self, key, params, goal, scale):
        """Scale and start pose of a new episode (the maze's start unless randomised)."""
        start = params.maze.start
        pos, yaw = start[:2], start[2]
        if self.scales_maze:
            lo, hi = self.maze_scale
            scale = jax.random.uniform(jax.random.fold_in(key, 3), (), jnp.float32, lo, hi)
            pos = pos * scale
        else:
            scale = 1.0  # a constant: the start scan stays independent of the state
        if self.random_start:  # a free point (goal clearance) away from the goal
            k_pos, k_yaw = jax.random.split(jax.random.fold_in(key, 4))
            pos = self.draw_goal(k_pos, goal, params, scale)
            yaw = jax.random.uniform(k_yaw, (), jnp.float32, -jnp.pi, jnp.pi)
        return pos, yaw, jnp.asarray(scale, jnp.float32)

    def reset(self, key: chex.PRNGKey, params: EnvParams) -> tuple[chex.Array, EnvState]:
        """Robot at the start pose with a freshly drawn goal."""
        k_goal, k_obs = jax.random.split(key)
        scale = 1.0
        start = params.maze.start[:2]
        if self.scales_maze:  # the same draw as _episode_start's
            lo, hi = self.maze_scale
            scale = jax.random.uniform(jax.random.fold_in(key, 3), (), jnp.float32, lo, hi)
            start = start * scale
        goal = self.draw_goal(k_goal, start, params, scale)
        pos, yaw, scale = self._episode_start(key, params, goal, scale)
        state = _new_episode(pos, yaw, goal, scale)
        return self.observe(k_obs, pos, yaw, goal, params, scale), state

    def step_env(
        self, key: chex.PRNGKey, state: EnvState, action: chex.Array, params: EnvParams
    ):
        """One control period without the auto-reset."""
        k_goal, k_obs = jax.random.split(key)
        omega = jnp.asarray(params.omegas)[action]
        maze = self.maze_at(params, state.scale)
        collided = path_clearance(
            maze, state.pos, state.yaw, omega, params.v, params.dt
        ) < params.robot_radius
        pos = state.pos + _displacement(state.yaw, omega, params.v, params.dt)
        yaw = wrap_angle(state.yaw + omega * params.dt)
        distance = jnp.linalg.norm(state.goal - pos)
        reached = (distance < params.goal_radius) & ~collided
        heading, _ = goal_heading_distance(pos, yaw, state.goal)
        reward = reward_fn(
            params, action, heading, distance, state.goal_distance0, reached, collided
        )
        new_goal = self.draw_goal(k_goal, state.goal, params, state.scale)
        goal = jnp.where(reached, new_goal, state.goal)
        d0 = jnp.where(reached, jnp.linalg.norm(new_goal - pos), state.goal_distance0)
        t = state.t + 1
        terminated = collided
        truncated = (t >= params.max_steps) & ~terminated
        new_state = EnvState(
            pos=pos, yaw=yaw, goal=goal, t=t, goal_distance0=d0, scale=state.scale
        )
        obs = self.observe(k_obs, pos, yaw, goal, params, state.scale)
        info = {"goal_reached": reached, "collision": collided}
        return obs, new_state, reward.astype(jnp.float32), terminated, truncated, info

    def restart(
        self, key: chex.PRNGKey, state: EnvState, params: EnvParams
    ) -> tuple[chex.Array, EnvState]:
        """TurtleBot3's restart after a collision or the step limit: the start pose
        (random if ``random_start``), the same goal, step count 0."""
        # Without randomised starts the start-pose scan does not depend on the state:
        # under vmap with shared params it is computed once, not per environment.
        goal = state.goal
        pos, yaw, scale = self._episode_start(key, params, goal, state.scale)
        if self.scales_maze:  # the kept goal moves with the maze
            goal = goal * (scale / state.scale)
        obs = self.observe(key, pos, yaw, goal, params, scale)
        return obs, _new_episode(pos, yaw, goal, scale)

    def step(
        self, key: chex.PRNGKey, state: EnvState, action: chex.Array, params: EnvParams
    ):
        """Step with auto-reset: after a collision or truncation the robot restarts at the
        start pose and keeps its goal. ``info["final_obs"]`` is the observation before
        the reset (needed to bootstrap through truncation)."""
        k_step, k_reset = jax.random.split(key)
        obs_st, st, reward, terminated, truncated, info = self.step_env(
            k_step, state, action, params
        )
        done = terminated | truncated
        obs_re, st_re = self.restart(k_reset, st, params)
        state = jax.tree.map(lambda a, b: jnp.where(done, a, b), st_re, st)
        obs = jnp.where(done, obs_re, obs_st)
        info = dict(info, final_obs=obs_st)
        return obs, state, reward, terminated, truncated, info


def _new_episode(pos, yaw, goal, scale) -> EnvState:
    """State at the start of an episode: step count 0, d_0 measured from here."""
    return EnvState(
        pos=pos,
        yaw=yaw,
        goal=goal,
        t=jnp.zeros((), jnp.int32),
        goal_distance0=jnp.linalg.norm(goal - pos),
        scale=jnp.asarray(scale, jnp.float32),
    )


def scale_maze(maze: Maze, scale: chex.Array) -> Maze:
    """The maze scaled about the origin; circle radii keep their size."""
    return maze.replace(
        segments=maze.segments * scale,
        circles=maze.circles.at[:, :2].multiply(scale),
        start=maze.start.at[:2].multiply(scale),
        goal_points=maze.goal_points * scale,
        bounds=maze.bounds * scale,
    )


def goal_heading_distance(pos, yaw, goal):
    """Heading delta (goal direction minus yaw, in [-pi, pi)) and distance to the goal."""
    rel = goal - pos
    heading = wrap_angle(jnp.arctan2(rel[1], rel[0]) - yaw)
    return heading, jnp.linalg.norm(rel)


_PARAM_FIELDS = {f.name for f in dataclasses.fields(EnvParams)} - {"maze"}
_ENV_FIELDS = {f.name for f in dataclasses.fields(NavEnv)}


def make(
    maze: str | Maze = "square4", preset: str = "paper", **overrides: Any
) -> tuple[NavEnv, EnvParams]:
    """Build the environment and its params.

    Args:
      maze: a built-in maze name, a path to a maze YAML file, or a ``Maze``.
      preset: ``"paper"`` (default) or ``"robotis"`` reward constants.
      **overrides: any ``EnvParams`` field (``R_plus=200``, ``lidar_noise_std=0.01``)
        or ``NavEnv`` field (``n_beams=360``, ``obstacle_obs=True``).
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset '{preset}' (choose from {', '.join(PRESETS)})")
    maze_obj = make_maze(maze) if isinstance(maze, str) else maze
    has_obstacles = maze_obj.has_obstacles
    unknown = set(overrides) - _PARAM_FIELDS - _ENV_FIELDS
    if unknown:
        raise ValueError(f"unknown environment parameter '{sorted(unknown)[0]}'")
    values = dict(PRESETS[preset])
    if preset == "robotis" and has_obstacles:
        values["R_minus"] = -150.0
    env_kwargs = {"obstacle_obs": has_obstacles}
    for k, v in overrides.items():
        (env_kwargs if k in _ENV_FIELDS else values)[k] = v
    if "omegas" in values:
        values["omegas"] = jnp.asarray(values["omegas"], jnp.float32)
    env = NavEnv(**env_kwargs)
    return env, EnvParams(maze=maze_obj, **values)


__all__ = [
    "EnvParams",
    "EnvState",
    "NavEnv",
    "make",
    "lidar_scan",
    "ray_distances",
    "path_clearance",
    "reward_fn",
    "psi",
    "wrap_angle",
    "goal_heading_distance",
    "GOAL_START_CLEARANCE",
]
