"""The navigation task: TurtleBot3 maze navigation as a pure, jit-able JAX environment
(gymnax 1.0 style).

``env, params = jaxnav.make("square4")`` then ``env.reset(key, params)`` and
``env.step(key, state, action, params)``. ``EnvParams`` and ``EnvState`` are
immutable pytrees, so everything jits and vmaps, over keys and over params (a
batch of different mazes in one call, see :func:`jaxnav.world.maps.stack_mazes`).

What is simulated (numbers from the spec):

* Motion: constant 0.15 m/s, 5 angular velocities (paper Table 1), exact unicycle
  integration over dt = 0.2 s (the robot moves on a circular arc).
* LiDAR (:mod:`jaxnav.world.sensor`): analytic ray-segment and ray-circle intersection
  (:mod:`jaxnav.world.geometry`), branchless, clipped to [0.12, 3.5] m; optional
  Gaussian range noise applied by the env, not by the caster.
* Collision: the 0.13 m robot disc against every wall and obstacle, exactly, along
  the whole arc of the step (:func:`jaxnav.world.geometry.path_clearance`), so no step
  can cross a wall unnoticed.

ROBOTIS' own simulation differs from this in four ways, each a switch of
:class:`NavEnv`, off by default (docs/paper.md, "ROBOTIS' code in detail"):
``collision="lidar"``, ``goal_sampler="robotis"``, ``beam_layout="gazebo"`` and
``action_delay=True``. ``ROBOTIS_SWITCHES`` lists them with their ROBOTIS values.
* Goals: reaching within 0.2 m pays R+ and draws a new goal, the episode goes on; a
  collision pays R- and terminates the episode; 500 steps truncate it. After either,
  the robot restarts at the maze's start pose and keeps its goal (as TurtleBot3).
  The reward is :func:`jaxnav.world.reward.reward_fn`.
* Observation (ROBOTIS state, :func:`jaxnav.world.sensor.observation`): beam ranges,
  heading to goal, distance to goal, and for mazes with obstacles also the smallest
  range and its beam index.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import chex
import jax
import jax.numpy as jnp

from jaxnav.core import families
from jaxnav.core.config import env_setting_problem
from jaxnav.core.env_rules import (
    env_action_problem,
    env_bank_problem,
    env_broad_phase_problem,
    env_family_problem,
    env_reward_problem,
    env_scan_problem,
    lattice_problem,
)
from jaxnav.core.settings import (
    BURGER_MAX_OMEGA,
    BURGER_MAX_V,
    OWN_PACE,
)
from jaxnav.world import motion
from jaxnav.world.commands import Commands
from jaxnav.world.episode import EpisodeMaze
from jaxnav.world.geometry import (
    displacement,
    norm2,
    wrap_angle,
)
from jaxnav.world.goals import GoalSampler
from jaxnav.world.layouts import DrawnLayouts
from jaxnav.world.lazy import draw_where
from jaxnav.world.maps import (
    BURGER_RADIUS,
)
from jaxnav.world.observer import Observer
from jaxnav.world.reward import nearness, progress_reward, reward_fn, sparse_reward
from jaxnav.world.sensor import goal_heading_distance
from jaxnav.world.state import (
    EnvParams,
    EnvState,
    new_episode,
    step_keys,
)

if TYPE_CHECKING:
    pass

RESTARTS = 32  # drawn mazes: environments restarted together per round (NavEnv.step)

# The ROBOTIS-faithful switches of NavEnv: field -> (jaxnav's default, ROBOTIS' value).
ROBOTIS_SWITCHES = {
    "collision": ("disc", "lidar"),
    "goal_sampler": ("free", "robotis"),
    "beam_layout": ("even", "gazebo"),
    "action_delay": (False, True),
}


@dataclasses.dataclass(frozen=True)
@families.settings_after("generator")
class NavEnv(Commands, EpisodeMaze, GoalSampler, DrawnLayouts, Observer):
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
      restart_goal: "keep" (ROBOTIS': after a collision or the step limit the robot
        retries the goal it missed; with a deterministic policy in a fixed world that
        restart replays the same attempt) or "new" (the restart draws its goal as a
        reset does, from ``fold_in(key, 7)``).
      maze_scale: (low, high): each episode scales the maze (walls, obstacle
        positions, goals, start) by a factor drawn uniformly from this range;
        obstacle radii keep their size. (1, 1) is off.
      motion_pace: (low, high): each episode runs the moving cylinders at a pace drawn
        uniformly from this range times their own (0: standing at their first pose),
        their loops unchanged: a training distribution; a run's test plays them at
        their own pace. (1, 1) is off.
      pace_curriculum: f in (0, 1]: the range ``motion_pace`` draws from moves in a
        straight line to the cylinders' own pace, [1, 1], over the first f of the
        training budget (the trainer sets it, :meth:`at_progress`); 0 is off.
      collision_margin: metres the robot's footprint is padded by in training: a step
        that comes within ``robot_radius + collision_margin`` of a surface ends the
        episode as a collision (paying R-). A run's test, its periodic evaluations and
        the reference drivers count real collisions (``TRAINING_ONLY``). 0 is off.
      wheel_limit: drive each action's (v, omega) as the burger's firmware does
        (:func:`jaxnav.world.kinematics.firmware_limit`: a wheel at most 0.21 m/s).
    Range noise is ``EnvParams.lidar_noise_std``.
      robot: a profile of :mod:`jaxnav.core.robots` (its limits scale the action sets'
        commands and the normalised observation's); lidar_fov: degrees the beams span
        (below 360: from the right edge to the left, both included); goal_ends: the
        goal reached ends the episode (BARN's protocol).

    ROBOTIS-faithful switches (docs/paper.md; all off by default and in both presets):
      collision: "disc" (the exact 0.13 m disc along the step's arc) or "lidar"
        (ROBOTIS: the episode ends when the smallest observed beam reads below
        0.13 m, so a wall between beams can be missed; touching a surface with the
        burger's 0.105 m footprint also ends it, since a kinematic robot would
        otherwise drive through where Gazebo's would be stopped).
      goal_sampler: "free" (the maze's own admissible points, a new goal at least
        ``goal_min_separation`` away) or "robotis" (ROBOTIS' grid and boxes scaled to
        the maze, :attr:`Maze.robotis_goals`; a new goal at least 1 m (times the
        scale) from the last along x or y; the first goal (0.6, 0) times the scale).
      beam_layout: "even" (beam k at 2 pi k / n) or "gazebo" (beam k at 2 pi k / (n - 1):
        Gazebo spreads n samples over [0, 2 pi] inclusive, so the first and last both
        look straight ahead).
      action_delay: apply each action one step late, as ROBOTIS' real-time loop can
        (the reward still scores the chosen action, as ROBOTIS' does); an episode
        starts with the straight action pending.

    The LiDAR's broad phase:
      broad_phase: "none" (every beam tests every wall), "lattice" (a family whose
        walls stand on a lattice, ``grid``, walks it: :mod:`jaxnav.world.lattice`,
        equal to testing every wall up to float32 rounding) or "auto" (the lattice
        wherever a family has one and the mazes are not scaled: 1.2 to 2.0 times the
        environment steps/s of testing every wall on 4x4 to 8x8 grids, bench/worlds.py).

    Procedural mazes (off by default):
      generator: "" (the maze is ``EnvParams.maze``) or a maze family of
        :mod:`jaxnav.core.families` ("grid", "cylinders", "rooms"), drawn inside jit by
        its static shape (:attr:`family`). Each family's own settings (``grid_*``,
        ``cyl_*``, ``rooms_*``, ...) are fields here, declared with the family. The maze
        moves into the state (``EnvState.maze``); ``EnvParams.maze`` is then only a
        template of its shapes. A reset draws a maze, its start and a first goal; every
        ``new_maze_every`` episodes the restart draws the next (otherwise it keeps the
        maze, its start and the goal, as with a fixed maze). ``split`` picks the train
        or the test layouts, never the same. ``maze_bank`` > 0:
        :meth:`with_bank` draws that many layouts (maze, start and goal) ahead into
        ``EnvParams.bank``, and a new layout is then picked from it at random instead
        of drawn (training does; a test draws each of its layouts).
        ``maze_bank_refresh`` > 0: a training run draws a new bank each time its env
        steps pass a multiple of it (:meth:`refreshed_bank`).

    Reward (:mod:`jaxnav.world.reward`):
      reward: "dense" (the paper's: R+, R-, else the heading shaping towards the goal),
        "sparse" (R+ and R- only, 0 otherwise), "geodesic" (grid mazes: the shaping
        heads for the next opening on the shortest path through the maze and D is the
        distance along it, so it never points into a dead end) or "progress" (R+, R-,
        else ``EnvParams.progress_scale`` per metre the step brought the robot closer
        to its goal; ``progress_path`` "geodesic": along the shortest path through a grid
        maze, as the geodesic shaping measures it). Beside any of them,
        ``EnvParams.step_penalty`` and ``proximity_penalty`` are taken from every step
        that neither reaches nor collides (:func:`jaxnav.world.reward.progress_reward`).
      moving_proximity_penalty: with the progress reward in a maze with moving
        cylinders, also taken from such a step, times
        :func:`jaxnav.world.reward.nearness` of the step's least clearance to a moving
        cylinder over ``moving_proximity_distance`` (m): a wider berth for what moves
        than for walls. 0 is off (no computation).

    Actions and observation (beyond the paper; both off by default):
      actions: "paper" (``EnvParams.omegas`` at the constant ``v``) or a set of
        :data:`jaxnav.core.settings.ACTION_SETS`, whose speeds and yaw rates become
        ``EnvParams.speeds`` and ``omegas``.
      observation: "robotis" (the ROBOTIS state) or "normalised" (ranges and the goal's
        distance over the sensor's range, its heading over pi, and the last command over
        the burger's limits: :func:`jaxnav.world.sensor.normalised_state`).
      observe_command: with the normalised observation, whether it holds the last
        command; False: two zeros in its place (the layout kept), so a policy learns
        without it (what it is worth, measured).
      scan_history: with the normalised observation, the k scans before this one follow
        it (newest first; at an episode's start copies of its first scan), so the policy
        can see what moves; with history_changes, each beam's change since each of them
        instead (:func:`jaxnav.world.sensor.history_changes`); with history_turned, the
        changes since each scan seen from the heading now
        (:func:`jaxnav.world.sensor.turned_changes`).
      observe_moving: with the normalised observation, the k nearest moving cylinders'
        position and velocity in the robot's frame follow everything else
        (:func:`jaxnav.world.sensor.moving_features`): what a simulator knows and no
        sensor on the robot gives, to measure what the scan leaves out.
      waypoint: with the normalised observation, the heading and distance to where the
        shortest path through a drawn maze heads next follow the last command
        (``family.geodesic_target``: the next opening on it, or the goal in its cell);
        on a fixed maze, which has no table of shortest paths, the goal itself.
      scan_beams: 0 (the scan has n_beams beams) or a multiple of n_beams: that many
        beams are cast and each observed beam is the least range of its sector
        (:func:`jaxnav.world.sensor.pooled_ranges`), so thin obstacles between the
        observed beams are seen.

    Navigation metrics (:mod:`jaxnav.report.navigation`):
      attempt_limit: steps one goal attempt may take before it counts as a time-out;
        0: the episode's step limit. Only the metrics read it, never the dynamics.

    Moving obstacles: a maze with a ``motion`` (ROBOTIS' stages 3 and 4,
    :mod:`jaxnav.world.stages`) moves its cylinders with the episode's time, t * dt;
    the scan sees them where they are at its time, and collision is tested over the
    whole step against their motion (:func:`jaxnav.world.motion.moving_clearance`).
    ``EnvState.circles`` holds every cylinder, static or moving, at the state's time.
    """

    n_beams: int = 24
    robot: str = "burger"  # jaxnav.core.robots: its limits scale the commands
    lidar_fov: float = 360.0
    goal_ends: bool = False
    obstacle_obs: bool = False
    goal_candidates: int = 16
    beam_dropout: float = 0.0
    odom_noise: tuple[float, float] = (0.0, 0.0)
    random_start: bool = False
    restart_goal: str = "keep"
    maze_scale: tuple[float, float] = (1.0, 1.0)
    motion_pace: tuple[float, float] = OWN_PACE
    pace_curriculum: float = 0.0
    collision_margin: float = 0.0
    wheel_limit: bool = False
    collision: str = "disc"
    goal_sampler: str = "free"
    beam_layout: str = "even"
    action_delay: bool = False
    broad_phase: str = "auto"
    generator: str = ""  # the families' own settings follow (families.settings_after)
    new_maze_every: int = 1
    maze_bank: int = 0
    maze_bank_refresh: int = 0
    split: str = "train"
    reward: str = "dense"
    progress_path: str = "straight"
    attempt_limit: int = 0
    actions: str = "paper"
    observation: str = "robotis"
    scan_beams: int = 0
    scan_history: int = 0
    history_changes: bool = False
    history_turned: bool = False
    observe_moving: int = 0
    waypoint: bool = False
    observe_command: bool = True
    speed_range: tuple[float, float] = (0.0, BURGER_MAX_V)
    max_yaw_rate: float = BURGER_MAX_OMEGA
    beyond_limits: bool = False
    top_speed: float | None = None
    moving_proximity_penalty: float = 0.0
    moving_proximity_distance: float = 0.5
    # derived by make, not a setting: EpisodeMaze.fit_maze's (range, near), m
    grid_fit: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        for f in dataclasses.fields(self):  # the rules of the config's env settings
            problem = env_setting_problem(f.name, getattr(self, f.name))
            if problem:
                raise ValueError(f"{f.name} {problem}")
        problem = env_family_problem(self) if self.generator else None
        problem = problem or env_reward_problem(self) or env_scan_problem(self)
        problem = problem or env_bank_problem(self) or env_broad_phase_problem(self)
        problem = problem or env_action_problem(self)
        if problem:
            raise ValueError(problem)
        for f in dataclasses.fields(self):  # number pairs (a list works too) as tuples
            if isinstance(f.default, tuple):
                kind = str if "str" in str(f.type) else float
                object.__setattr__(self, f.name, tuple(kind(x) for x in getattr(self, f.name)))

    @property
    def generates(self) -> bool:
        """Whether the mazes are drawn (``generator`` set), so the state holds the maze."""
        return bool(self.generator)

    def in_maze(self, params: EnvParams, state: EnvState) -> EnvParams:
        """``params`` with the state's maze when the mazes are drawn (else unchanged)."""
        return params.replace(maze=state.maze) if self.generates else params

    def attempt_steps(self, params: EnvParams) -> int:
        """The attempt limit in steps (host side): ``attempt_limit``, or the episode's
        step limit where it is 0."""
        return int(self.attempt_limit) or int(params.max_steps)

    @property
    def walks_lattice(self) -> bool:
        """Whether the LiDAR walks the drawn mazes' lattice (``broad_phase`` "lattice" or
        "auto"): mazes of a family with a lattice, unscaled, at most
        ``MAX_LATTICE_CELLS`` a side."""
        return self.broad_phase != "none" and lattice_problem(self) is None

    @property
    def uses_cell_distances(self) -> bool:
        """Whether an episode carries its grid maze's cell distances (the geodesic
        shaping, or progress along the shortest path)."""
        if self.waypoint and self.generates:
            return True
        return self.reward == "geodesic" or (
            self.reward == "progress" and self.progress_path == "geodesic"
        )

    # -- API -----------------------------------------------------------------

    def reset(self, key: chex.PRNGKey, params: EnvParams) -> tuple[chex.Array, EnvState]:
        """Robot at the start pose with a freshly drawn goal (and maze, if drawn)."""
        k_goal, k_obs = jax.random.split(key)
        scale = self._episode_scale(key)
        maze = maze_episodes = cell_dist = index = None
        if self.generates:  # a new maze, its start and a goal min_path_cells away
            (maze, goal, cell_dist), index = self._layout(jax.random.fold_in(key, 5), params)
            params = params.replace(maze=maze)
            maze_episodes = jnp.zeros((), jnp.int32)
            goal = goal * scale if self.scales_maze else goal
        else:
            goal = self.reset_goal(k_goal, params, scale)
        pos, yaw = self._start_pose(key, params, goal, scale)
        scale = jnp.asarray(scale, jnp.float32)
        state = new_episode(pos, yaw, goal, scale, self.action_delay, maze, maze_episodes)
        state = self._with_world(
            state.replace(pace=self._episode_pace(key, params), layout=index), params, cell_dist
        )
        obs = self.observe(
            k_obs, pos, yaw, goal, params, scale, cell_dist=state.cell_dist, pace=state.pace
        )
        return obs, self._first_scans(state, obs)

    def _with_world(self, state: EnvState, params: EnvParams, cell_dist=None) -> EnvState:
        """A new episode's state with its cylinders at time 0 and, for the geodesic
        reward, its maze's cell distances (``cell_dist`` if known)."""
        if self.uses_cell_distances and cell_dist is None:
            cell_dist = self.family.cell_distances(params.maze)
        last = jnp.zeros(2, jnp.float32) if self.normalised else None  # at rest
        return state.replace(
            circles=self.circles_at(params, state.scale, 0, state.pace),
            cell_dist=cell_dist,
            last_command=last,
        )

    def step_env(self, key: chex.PRNGKey, state: EnvState, action: chex.Array, params: EnvParams):
        """One control period without the auto-reset."""
        params = self.in_maze(params, state)
        k_goal, k_obs = step_keys(key)
        v, omega = self.driven(params, state, action)
        maze = self.episode_maze(params, state)
        clearance, moving = motion.step_clearances(
            maze, state.pos, state.yaw, omega, v, params.dt, state.t * params.dt
        )
        pos = state.pos + displacement(state.yaw, omega, v, params.dt)
        yaw = wrap_angle(state.yaw + omega * params.dt)
        t = state.t + 1
        time = t * params.dt  # the scan after the step sees the cylinders at this time
        if self.collision == "lidar":  # the scan after the step, as ROBOTIS reads it
            ranges = self.observe(
                k_obs,
                pos,
                yaw,
                state.goal,
                params,
                state.scale,
                time,
                cell_dist=state.cell_dist,
                pace=state.pace,
            )
            nearest = jnp.min(ranges[: self.n_beams])
            collided = (nearest < self._padded(params.robot_radius)) | (
                clearance < self._padded(BURGER_RADIUS)
            )
        else:
            collided = clearance < self._padded(params.robot_radius)
        distance = norm2(state.goal - pos)
        reached = (distance < params.goal_radius) & ~collided
        if self.reward == "sparse":
            reward = sparse_reward(params, reached, collided)
        elif self.reward == "geodesic":  # head for the next opening on the shortest path
            target, distance_along = self.family.geodesic_target(
                params.maze, state.cell_dist, pos, state.goal
            )
            heading, _ = goal_heading_distance(pos, yaw, target)
            reward = reward_fn(
                params, action, heading, distance_along, state.goal_distance0, reached, collided
            )
        elif self.reward == "progress" and self.progress_path == "geodesic":
            _, before = self.family.geodesic_target(
                params.maze, state.cell_dist, state.pos, state.goal
            )
            _, after = self.family.geodesic_target(params.maze, state.cell_dist, pos, state.goal)
            change = self._change(state, v, omega)
            reward = progress_reward(params, before, after, clearance, reached, collided, change)
        elif self.reward == "progress":  # closer to the goal, kept clear of surfaces
            before = norm2(state.goal - state.pos)
            change = self._change(state, v, omega)
            reward = progress_reward(params, before, distance, clearance, reached, collided, change)
        else:
            heading, _ = goal_heading_distance(pos, yaw, state.goal)
            reward = reward_fn(
                params, action, heading, distance, state.goal_distance0, reached, collided
            )
        if self.moving_proximity_penalty and moving is not None:  # a wider berth
            near = nearness(moving - params.robot_radius, self.moving_proximity_distance)
            shaped = reward - self.moving_proximity_penalty * near
            reward = jnp.where(reached | collided, reward, shaped)
        if self.goal_ends:  # the episode ends at its goal, which the restart keeps
            new_goal, terminated = state.goal, collided | reached
        else:
            new_goal, terminated = self.draw_goal(k_goal, state.goal, params, state.scale), collided
        goal = jnp.where(reached, new_goal, state.goal)
        d0 = jnp.where(reached, norm2(new_goal - pos), state.goal_distance0)
        truncated = (t >= params.max_steps) & ~terminated
        new_state = state.replace(
            pos=pos,
            yaw=yaw,
            goal=goal,
            t=t,
            goal_distance0=d0,
            pending_action=action if self.action_delay else None,
            circles=self.circles_at(params, state.scale, t, state.pace),
        )
        last = None
        if self.normalised:  # the command just driven is part of the next observation
            last = jnp.stack([jnp.asarray(v, jnp.float32), omega]).astype(jnp.float32)
            new_state = new_state.replace(last_command=last)
        obs = self.observe(
            k_obs,
            pos,
            yaw,
            goal,
            params,
            state.scale,
            time,
            last,
            state.scans,
            state.cell_dist,
            state.scan_yaws,
            state.pace,
        )
        if self.scan_history:  # this scan joins the history, the oldest leaves
            new_state = self._newer_scans(new_state, obs)
        info = {"goal_reached": reached, "collision": collided}
        return obs, new_state, reward.astype(jnp.float32), terminated, truncated, info

    def _padded(self, radius):
        """A collision radius padded by ``collision_margin`` (unchanged when it is 0)."""
        return radius + self.collision_margin if self.collision_margin else radius

    def restart(
        self, key: chex.PRNGKey, state: EnvState, params: EnvParams
    ) -> tuple[chex.Array, EnvState]:
        """TurtleBot3's restart after a collision or the step limit: the start pose
        (random if ``random_start``), the same goal (a new one with ``restart_goal``
        "new"), step count 0, the moving cylinders back at their first pose. With drawn
        mazes, every ``new_maze_every`` episodes a new maze, start and goal instead."""
        # Without randomised starts the start-pose scan does not depend on the state:
        # under vmap with shared params it is computed once, not per environment.
        if self.generates:
            return self._restart_drawn(key, state, params)
        goal = state.goal
        scale = self._episode_scale(key)
        if self.restart_goal == "new":  # a goal drawn as a reset draws it
            goal = self.reset_goal(jax.random.fold_in(key, 7), params, scale)
        pos, yaw = self._start_pose(key, params, goal, scale)
        scale = jnp.asarray(scale, jnp.float32)
        if self.scales_maze and self.restart_goal == "keep":  # the kept goal moves with the maze
            goal = goal * (scale / state.scale)
        pace = self._episode_pace(key, params)
        obs = self.observe(key, pos, yaw, goal, params, scale, pace=pace)
        state = new_episode(pos, yaw, goal, scale, self.action_delay).replace(pace=pace)
        return obs, self._first_scans(self._with_world(state, params), obs)

    def step(self, key: chex.PRNGKey, state: EnvState, action: chex.Array, params: EnvParams):
        """Step with auto-reset: after a collision or truncation the robot restarts at the
        start pose and keeps its goal (``restart_goal``). ``info["final_obs"]`` is the
        observation before the reset (needed to bootstrap through truncation), and
        ``info["final_pos"]`` where the robot stood then (the exploration bonuses and
        measures that count places read it)."""
        obs_st, st, reward, terminated, truncated, info = self.step_env(key, state, action, params)
        done = terminated | truncated
        info = dict(info, final_obs=obs_st, final_pos=st.pos)
        # The restart observes with the step's own observation key: its range noise
        # (and dropout) is the same draw as the step's, so it costs nothing extra; the
        # two observations are of different poses and never feed one transition.
        k_restart = step_keys(key)[1]
        if self.generates:
            # Each environment restarts in a maze of its own, so its restart scan is its
            # own too: computed only where an episode ended (jaxnav.world.lazy), the
            # step's own observation and state kept elsewhere. The same numbers as
            # computing it everywhere and keeping it where done.
            def restarted(inputs, params):
                return self._restart_drawn(*inputs, params)

            old = (obs_st, st)
            obs, state = draw_where(restarted, done, (k_restart, st), old, RESTARTS, params)
            return obs, state, reward, terminated, truncated, info
        obs_re, st_re = self.restart(k_restart, st, params)
        state = jax.tree.map(lambda a, b: jnp.where(done, a, b), st_re, st)
        obs = jnp.where(done, obs_re, obs_st)
        return obs, state, reward, terminated, truncated, info
