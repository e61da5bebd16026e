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


def _cross(ax, ay, bx, by):
    """z of the 2D cross product (ax, ay) x (bx, by)."""
    return ax * by - ay * bx


def _safe(x: chex.Array) -> chex.Array:
    """x with values too close to 0 replaced by 1 (for division)."""
    return jnp.where(jnp.abs(x) < _EPS, 1.0, x)


# Geometry is written on x and y components of one wall or cylinder at a time, and
# vmapped over the walls: under the caller's vmap every quantity is then a flat
# [batch, walls] or [batch, walls, beams] array. (Arrays with a trailing axis of 2
# per point leave XLA's CPU loops two lanes wide.) The minimum over the walls is a
# reduction, whose result XLA computes once: a chain of element-wise minimums would
# be recomputed inside every consumer, such as each element of an observation.


def _min_over(fn, table: chex.Array, mask: chex.Array):
    """min over the rows i of ``table`` with ``mask[i]`` of ``fn(*table[i])``, inf if none."""
    vals = jax.vmap(fn)(*(table[:, j] for j in range(table.shape[1])))
    mask = mask.reshape(mask.shape + (1,) * (vals.ndim - 1))
    return jnp.min(jnp.where(mask, vals, jnp.inf), axis=0)


def _hypot(x, y):
    return jnp.sqrt(x * x + y * y)


def _norm2(v: chex.Array) -> chex.Array:
    """Length of a 2-vector f32[2]."""
    return _hypot(v[0], v[1])


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
    return ray_distances_dir(
        maze, origin, jnp.stack([jnp.cos(angles), jnp.sin(angles)], axis=-1)
    )


def ray_distances_dir(maze: Maze, origin: chex.Array, d: chex.Array) -> chex.Array:
    """:func:`ray_distances` with the rays given as unit vectors f32[B, 2]."""
    ox, oy = origin[0], origin[1]
    dx, dy = d[:, 0], d[:, 1]  # [B]

    def wall(ax, ay, bx, by):  # origin + t d = a + u e, solved with 2D cross products
        ex, ey = bx - ax, by - ay
        wx, wy = ax - ox, ay - oy
        denom = _cross(dx, dy, ex, ey)
        sd = _safe(denom)
        t = _cross(wx, wy, ex, ey) / sd
        u = _cross(wx, wy, dx, dy) / sd
        hit = (jnp.abs(denom) >= _EPS) & (t >= 0.0) & (u >= -1e-6) & (u <= 1.0 + 1e-6)
        return jnp.where(hit, t, jnp.inf)

    def cylinder(cx, cy, r):  # |f + t d|^2 = r^2 with f = origin - c
        fx, fy = ox - cx, oy - cy
        b = fx * dx + fy * dy
        c = fx * fx + fy * fy - r**2
        # disc = b^2 - c = r^2 - h^2 with h the centre's offset from the ray's line.
        # Computed as (r - h)(r + h): b^2 - c cancels in float32 near a tangent.
        h = jnp.abs(_cross(dx, dy, fx, fy))
        disc = (r - h) * (r + h)
        sq = jnp.sqrt(jnp.maximum(disc, 0.0))
        tc = jnp.where(c > 0.0, -b - sq, -b + sq)  # first root outside, second inside
        return jnp.where((disc >= 0.0) & (tc >= 0.0), tc, jnp.inf)

    t_seg = _min_over(wall, maze.segments, maze.segment_mask)
    t_circ = _min_over(cylinder, maze.circles, maze.circle_mask)
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
    ranges = ray_distances_dir(maze, pos, beam_directions(n_beams, yaw))
    return jnp.clip(ranges, min_range, max_range)


def beam_directions(n_beams: int, yaw: chex.Array) -> chex.Array:
    """Unit vectors f32[n_beams, 2] of the beams at heading ``yaw``.

    The beams' own angles are constants; turning them by ``yaw`` is a rotation, so a
    scan costs one sine and one cosine instead of one per beam.
    """
    a = np.arange(n_beams) * (2 * np.pi / n_beams)
    ca, sa = np.cos(a).astype(np.float32), np.sin(a).astype(np.float32)
    cy, sy = jnp.cos(yaw), jnp.sin(yaw)
    return jnp.stack([cy * ca - sy * sa, sy * ca + cy * sa], axis=-1)


# ----------------------------------------------------------------------------
# Collision along an arc
# ----------------------------------------------------------------------------


def _point_segment_distance(px, py, ax, ay, bx, by) -> chex.Array:
    abx, aby = bx - ax, by - ay
    den = jnp.maximum(abx * abx + aby * aby, _EPS)
    t = jnp.clip(((px - ax) * abx + (py - ay) * aby) / den, 0.0, 1.0)
    return _hypot(px - (ax + t * abx), py - (ay + t * aby))


def path_clearance(
    maze: Maze, pos: chex.Array, yaw: chex.Array, omega: chex.Array, v: float, dt: float
) -> chex.Array:
    """Smallest distance from the robot centre's path over one step to any surface.

    The centre moves on the exact unicycle path: a straight segment when omega = 0,
    otherwise an arc of radius v / |omega| swept by omega * dt. The robot collides
    during the step iff this is below its radius.
    """
    x0, y0 = pos[0], pos[1]
    disp = _displacement(yaw, omega, v, dt)
    x1, y1 = x0 + disp[0], y0 + disp[1]
    straight = jnp.abs(omega) < 1e-6

    # Arc path: centre C, signed radius R, from p0 to p1, sweep omega dt.
    w = jnp.where(straight, 1.0, omega)
    R = v / w
    cx, cy = x0 - R * jnp.sin(yaw), y0 + R * jnp.cos(yaw)
    rad = jnp.abs(R)
    u0x, u0y, u1x, u1y = x0 - cx, y0 - cy, x1 - cx, y1 - cy
    sgn = jnp.sign(w)
    half_turn = jnp.abs(w * dt) <= jnp.pi

    def in_arc(px, py):  # is the direction of p from C within the swept arc?
        # Turning by sgn from u0: after u0 (angle in [0, pi]) and before u1 (the
        # remaining angle in [0, pi]); both for sweeps up to pi, either beyond.
        rx, ry = px - cx, py - cy
        after = sgn * _cross(u0x, u0y, rx, ry) >= 0.0
        before = sgn * _cross(rx, ry, u1x, u1y) >= 0.0
        return jnp.where(half_turn, after & before, after | before)

    def point_arc_distance(px, py):
        rho = _hypot(px - cx, py - cy)
        ends = jnp.minimum(_hypot(px - x0, py - y0), _hypot(px - x1, py - y1))
        return jnp.where(in_arc(px, py), jnp.abs(rho - rad), ends)

    def wall(ax, ay, bx, by):
        d_ends = jnp.minimum(
            _point_segment_distance(x0, y0, ax, ay, bx, by),
            _point_segment_distance(x1, y1, ax, ay, bx, by),
        )
        # Straight path: segment-segment distance, 0 if they cross.
        d = jnp.minimum(
            d_ends,
            jnp.minimum(
                _point_segment_distance(ax, ay, x0, y0, x1, y1),
                _point_segment_distance(bx, by, x0, y0, x1, y1),
            ),
        )
        ex, ey = x1 - x0, y1 - y0
        abx, aby = bx - ax, by - ay
        o1 = _cross(ex, ey, ax - x0, ay - y0)
        o2 = _cross(ex, ey, bx - x0, by - y0)
        o3 = _cross(abx, aby, x0 - ax, y0 - ay)
        o4 = _cross(abx, aby, x1 - ax, y1 - ay)
        d_line = jnp.where((o1 * o2 < 0) & (o3 * o4 < 0), 0.0, d)

        # Arc: the wall's end points, the foot F of C on the wall's line, and the
        # crossings of the wall's line with the circle.
        d_segpts = jnp.minimum(point_arc_distance(ax, ay), point_arc_distance(bx, by))
        ab2 = jnp.maximum(abx * abx + aby * aby, _EPS)
        tau = ((cx - ax) * abx + (cy - ay) * aby) / ab2
        fx, fy = ax + tau * abx, ay + tau * aby
        h = _hypot(fx - cx, fy - cy)
        d_foot = jnp.where(
            (h >= rad) & (tau >= 0.0) & (tau <= 1.0) & in_arc(fx, fy), h - rad, jnp.inf
        )
        half = jnp.sqrt(jnp.maximum(rad**2 - h**2, 0.0)) / jnp.sqrt(ab2)
        hits = False
        for sgn_q in (-1.0, 1.0):
            tq = tau + sgn_q * half
            qx, qy = ax + tq * abx, ay + tq * aby
            hits |= (h < rad) & (tq >= 0.0) & (tq <= 1.0) & in_arc(qx, qy)
        d_arc = jnp.where(hits, 0.0, jnp.minimum(jnp.minimum(d_ends, d_segpts), d_foot))
        return jnp.where(straight, d_line, d_arc)

    def cylinder(qx, qy, r):
        d_line = _point_segment_distance(qx, qy, x0, y0, x1, y1)
        return jnp.where(straight, d_line, point_arc_distance(qx, qy)) - r

    return jnp.minimum(
        _min_over(wall, maze.segments, maze.segment_mask),
        _min_over(cylinder, maze.circles, maze.circle_mask),
    )


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
        ranges = ray_distances_dir(maze, pos, beam_directions(self.n_beams, yaw))
        return self._obs_from_ranges(key, ranges, pos, yaw, goal, params)

    def _obs_from_ranges(self, key, ranges, pos, yaw, goal, params) -> chex.Array:
        std = params.lidar_noise_std
        if not (isinstance(std, (int, float)) and std == 0.0):  # no draw for a constant 0
            ranges = ranges + std * jax.random.normal(key, ranges.shape)
        ranges = jnp.clip(ranges, params.min_range, params.max_range)
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

        Tries ``goal_candidates`` points of the maze's admissible goal set, drawn
        uniformly (32 random bits modulo the count, a bias below 1e-6), and keeps the
        first far enough away; if none is, the first (still in free space).
        """
        points = params.maze.goal_points
        bits = jax.random.bits(key, (self.goal_candidates,), jnp.uint32)
        idx = (bits % params.maze.n_goal_points.astype(jnp.uint32)).astype(jnp.int32)
        cx, cy = points[:, 0][idx], points[:, 1][idx]
        if self.scales_maze:
            cx, cy = cx * scale, cy * scale
        far = _hypot(cx - away_from[0], cy - away_from[1]) >= params.goal_min_separation
        i = jnp.argmax(far)
        return jnp.stack([cx[i], cy[i]])

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
        k_goal, k_obs = _step_keys(key)
        omega = jnp.asarray(params.omegas)[action]
        maze = self.maze_at(params, state.scale)
        collided = path_clearance(
            maze, state.pos, state.yaw, omega, params.v, params.dt
        ) < params.robot_radius
        pos = state.pos + _displacement(state.yaw, omega, params.v, params.dt)
        yaw = wrap_angle(state.yaw + omega * params.dt)
        distance = _norm2(state.goal - pos)
        reached = (distance < params.goal_radius) & ~collided
        heading, _ = goal_heading_distance(pos, yaw, state.goal)
        reward = reward_fn(
            params, action, heading, distance, state.goal_distance0, reached, collided
        )
        new_goal = self.draw_goal(k_goal, state.goal, params, state.scale)
        goal = jnp.where(reached, new_goal, state.goal)
        d0 = jnp.where(reached, _norm2(new_goal - pos), state.goal_distance0)
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
        obs_st, st, reward, terminated, truncated, info = self.step_env(
            key, state, action, params
        )
        done = terminated | truncated
        # The restart observes with the step's own observation key: its range noise
        # (and dropout) is the same draw as the step's, so it costs nothing extra; the
        # two observations are of different poses and never feed one transition.
        obs_re, st_re = self.restart(_step_keys(key)[1], st, params)
        state = jax.tree.map(lambda a, b: jnp.where(done, a, b), st_re, st)
        obs = jnp.where(done, obs_re, obs_st)
        info = dict(info, final_obs=obs_st)
        return obs, state, reward, terminated, truncated, info


def _step_keys(key: chex.PRNGKey) -> tuple[chex.Array, chex.Array]:
    """(goal key, observation key) of one step."""
    k_goal, k_obs = jax.random.split(key)
    return k_goal, k_obs


def _new_episode(pos, yaw, goal, scale) -> EnvState:
    """State at the start of an episode: step count 0, d_0 measured from here."""
    return EnvState(
        pos=pos,
        yaw=yaw,
        goal=goal,
        t=jnp.zeros((), jnp.int32),
        goal_distance0=_norm2(goal - pos),
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
    return heading, _norm2(rel)


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
    "ray_distances_dir",
    "beam_directions",
    "path_clearance",
    "reward_fn",
    "psi",
    "wrap_angle",
    "goal_heading_distance",
    "GOAL_START_CLEARANCE",
]
