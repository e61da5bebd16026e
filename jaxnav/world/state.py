"""The environment's data: :class:`EnvParams` (everything about the task that is data,
vmappable) and :class:`EnvState` (one robot's episode), and the pure helpers that
start an episode and scale a maze. :class:`jaxnav.env.NavEnv` steps them."""

from __future__ import annotations

import math
from typing import Any

import chex
import jax
import jax.numpy as jnp
from flax import struct

from jaxnav.world.geometry import norm2
from jaxnav.world.maps import ROBOT_RADIUS, Maze

# Paper Table 1: action -> angular velocity (rad/s), positive = counter-clockwise.
PAPER_OMEGAS = (-1.5, -0.75, 0.0, 0.75, 1.5)
STRAIGHT = PAPER_OMEGAS.index(0.0)  # the action pending at an episode start (action_delay)


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
    # f32[A] each action's forward speed (m/s), or None: every action drives at v (the
    # paper's). With an action set (NavEnv.actions) omegas holds its yaw rates.
    speeds: chex.Array | None = None
    progress_scale: float = 10.0  # reward "progress": per metre closer to the goal
    step_penalty: float = 0.0  # taken from every step that neither reaches nor collides
    proximity_penalty: float = 0.0  # taken, scaled, where the path comes near a surface
    proximity_distance: float = 0.3  # m of clearance (beyond the radius) where it starts
    # taken times the change of the driven command from the last step's (each over the
    # burger's limits), with the progress reward and the normalised observation
    change_penalty: float = 0.0
    # f32[2]: the range each episode's pace is drawn from while the training's pace
    # curriculum (NavEnv.pace_curriculum) moves it; None: NavEnv.motion_pace's
    pace_range: chex.Array | None = None
    # Drawn mazes only: layouts drawn ahead (NavEnv.with_bank), (maze, goal, cell
    # distances or None) with a leading axis of NavEnv.maze_bank; None: each new layout
    # is drawn when it is needed.
    bank: Any = None
    # f32[N]: the bank's layouts' cumulative weights (the last 1), a new layout picked
    # by them; None: uniformly. A training run's level replay sets them
    # (jaxnav.agent.levels); the state then records each layout's index (layout).
    bank_cdf: chex.Array | None = None


@struct.dataclass
class EnvState:
    pos: chex.Array  # f32[2]
    yaw: chex.Array  # f32[]
    goal: chex.Array  # f32[2]
    t: chex.Array  # i32[] steps in this episode
    goal_distance0: chex.Array  # f32[] distance to goal when it was drawn (or at reset)
    scale: chex.Array  # f32[] this episode's maze scale (1 unless NavEnv.maze_scale)
    # i32[] the action chosen last step, applied this step; None (no leaf) unless
    # NavEnv.action_delay, so the state is unchanged when the switch is off.
    pending_action: chex.Array | None = None
    # The episode's maze and the episodes begun in it (i32[]) when NavEnv.generator
    # draws the mazes; None (no leaves) with the fixed maze of EnvParams.
    maze: Maze | None = None
    maze_episodes: chex.Array | None = None
    # f32[k, 3]: every circular obstacle (x, y, r), static or moving, where it is at
    # this step (the scan's time); padded rows have r = 0.
    circles: chex.Array | None = None
    # i16[RC, RC]: the drawn grid maze's cell distances, with reward "geodesic" only.
    cell_dist: chex.Array | None = None
    # f32[2]: the last command driven (v, omega), 0 at an episode's start; with the
    # normalised observation only (it is part of it).
    last_command: chex.Array | None = None
    # f32[k, n_beams]: the k scans before this one as observed (normalised), newest
    # first; with NavEnv.scan_history k > 0 only (they are part of the observation).
    scans: chex.Array | None = None
    # f32[k]: the heading each of those scans was taken at; with NavEnv.history_turned
    # only (the observation turns each scan to the heading now).
    scan_yaws: chex.Array | None = None
    # f32[]: this episode's pace of the moving cylinders (NavEnv.motion_pace); None (no
    # leaf) when it is off, so the state is unchanged.
    pace: chex.Array | None = None
    # i32[]: the bank index of the episode's layout, where EnvParams.bank_cdf picks
    # them (a training run's level replay scores layouts by it); else None (no leaf).
    layout: chex.Array | None = None


def step_keys(key: chex.PRNGKey) -> tuple[chex.Array, chex.Array]:
    """(goal key, observation key) of one step."""
    k_goal, k_obs = jax.random.split(key)
    return k_goal, k_obs


def new_episode(
    pos, yaw, goal, scale, action_delay: bool = False, maze=None, maze_episodes=None
) -> EnvState:
    """State at the start of an episode: step count 0, d_0 measured from here."""
    return EnvState(
        pos=pos,
        yaw=yaw,
        goal=goal,
        t=jnp.zeros((), jnp.int32),
        goal_distance0=norm2(goal - pos),
        scale=jnp.asarray(scale, jnp.float32),
        pending_action=jnp.asarray(STRAIGHT, jnp.int32) if action_delay else None,
        maze=maze,
        maze_episodes=maze_episodes,
    )


def scale_maze(maze: Maze, scale: chex.Array) -> Maze:
    """The maze scaled about the origin; circle radii keep their size (moving ones'
    paths scale too, their timing stays)."""
    moving = maze.motion
    if moving is not None:
        moving = moving.replace(points=moving.points * scale, centre=moving.centre * scale)
    return maze.replace(
        motion=moving,
        segments=maze.segments * scale,
        circles=maze.circles.at[:, :2].multiply(scale),
        start=maze.start.at[:2].multiply(scale),
        goal_points=maze.goal_points * scale,
        bounds=maze.bounds * scale,
    )


__all__ = [
    "PAPER_OMEGAS",
    "STRAIGHT",
    "EnvParams",
    "EnvState",
    "new_episode",
    "scale_maze",
    "step_keys",
]
