"""What the robot observes: the LiDAR scan (as many beams as observed, or finer beams
pooled to them) with range noise and dropout, the goal's heading and distance from the
(noisy) odometry, and, in the normalised observation, the last command and the scans
before. A mixin of :class:`jaxnav.env.NavEnv`: the fields and methods it reads
(``n_beams``, ``maze_at``, ...) are the environment's."""

from __future__ import annotations

import math

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.world import motion, sensor
from jaxnav.world.commands import command_scale
from jaxnav.world.geometry import wrap_angle
from jaxnav.world.spaces import Box
from jaxnav.world.state import EnvParams, EnvState


class Observer:
    """The observation side of :class:`jaxnav.env.NavEnv`."""

    n_beams: int
    obstacle_obs: bool
    observation: str
    scan_beams: int
    scan_history: int
    history_changes: bool
    history_turned: bool
    observe_moving: int
    waypoint: bool
    observe_command: bool
    generates: bool
    beam_layout: str
    beam_dropout: float
    odom_noise: tuple[float, float]
    maze_scale: tuple[float, float]
    walks_lattice: bool
    robot: str
    lidar_fov: float

    @property
    def normalised(self) -> bool:
        """Whether the observation is the normalised one (it holds the last command)."""
        return self.observation == "normalised"

    @property
    def obs_size(self) -> int:
        if self.normalised:
            extra = (2 if self.waypoint else 0) + 4 * self.observe_moving
            return self.n_beams * (1 + self.scan_history) + 4 + extra
        return self.n_beams + 2 + (2 if self.obstacle_obs else 0)

    @property
    def scan_layout(self) -> tuple[int, int, int]:
        """Where the normalised observation holds the scan and its history: (beams,
        the values between the scan and its history, earlier scans). The scan comes
        first, then heading, distance, the last command (and the waypoint), then the
        history, then the moving cylinders' features (:meth:`observe`)."""
        return self.n_beams, 4 + (2 if self.waypoint else 0), self.scan_history

    def observation_space(self, params: EnvParams) -> Box:
        if self.normalised:
            low = [0.0] * self.n_beams + [-1.0, 0.0, -1.0, -1.0]
            low += [-1.0, 0.0] if self.waypoint else []
            low += [-1.0 if self.history_changes else 0.0] * (self.n_beams * self.scan_history)
            low += [-1.0] * (4 * self.observe_moving)
            high = [1.0] * self.obs_size
            return Box(np.asarray(low, np.float32), np.asarray(high, np.float32), (self.obs_size,))
        bounds = np.asarray(jax.device_get(params.maze.bounds))  # host side, not under jit
        big = float(np.max(bounds[..., 2:] - bounds[..., :2])) * self.maze_scale[1]
        low = [params.min_range] * self.n_beams + [-math.pi, 0.0]
        high = [params.max_range] * self.n_beams + [math.pi, 2 * big]
        if self.obstacle_obs:
            low += [params.min_range, 0.0]
            high += [params.max_range, float(self.n_beams - 1)]
        return Box(np.asarray(low, np.float32), np.asarray(high, np.float32), (self.obs_size,))

    def observe(
        self,
        key: chex.PRNGKey,
        pos: chex.Array,
        yaw: chex.Array,
        goal: chex.Array,
        params: EnvParams,
        scale: chex.Array = 1.0,
        time: chex.Array = 0.0,
        last_command: chex.Array | None = None,
        scans: chex.Array | None = None,
        cell_dist: chex.Array | None = None,
        scan_yaws: chex.Array | None = None,
        pace: chex.Array | None = None,
    ) -> chex.Array:
        """The observation f32[obs_size], the moving cylinders (if any) where they are at
        ``time`` (s into the episode): the ROBOTIS state [ranges, heading, distance(, min
        range, argmin beam)], or the normalised one with ``last_command`` (v, omega)
        and, with ``waypoint``, the next point of the shortest path (a drawn maze's, from
        its ``cell_dist``; on a fixed maze the goal); ``pace``: the episode's pace of the
        moving cylinders (None: their own)."""
        moving = self.maze_at(params, scale, pace=pace)  # its cylinders still on their loops
        maze = motion.frozen_at(moving, time)  # and where they are at ``time``
        if self.scan_beams:  # a finer scan, the least range of each sector observed
            fine = self.beam_ranges(maze, pos, yaw, self.scan_beams)
            ranges = sensor.pooled_ranges(fine, self.n_beams)
        else:
            ranges = self.beam_ranges(maze, pos, yaw, self.n_beams, self.beam_layout == "gazebo")
        if self.normalised:
            last = last_command  # zeros at rest, or in its place when it is not observed
            if last_command is None or not self.observe_command:
                last = jnp.zeros(2, jnp.float32)
            waypoint = None
            if self.waypoint:
                waypoint = goal
                if self.generates:
                    waypoint, _ = self.family.geodesic_target(params.maze, cell_dist, pos, goal)
            obs = sensor.normalised_observation(
                key,
                ranges,
                pos,
                yaw,
                goal,
                last,
                noise_std=params.lidar_noise_std,
                min_range=params.min_range,
                max_range=params.max_range,
                dropout=self.beam_dropout,
                odom_std=self.odom_noise,
                waypoint=waypoint,
                scale=command_scale(self.robot),
            )
            if self.scan_history:  # the scans before (at an episode's start: this one)
                if scans is None:
                    scans = jnp.tile(obs[: self.n_beams], (self.scan_history, 1))
                    scan_yaws = jnp.broadcast_to(yaw, (self.scan_history,))
                if self.history_turned:  # each beam's change, the scans seen from here
                    turned = wrap_angle(yaw - scan_yaws)
                    scans = sensor.turned_changes(obs[: self.n_beams], scans, turned)
                elif self.history_changes:  # or each beam's change since each of them
                    scans = sensor.history_changes(obs[: self.n_beams], scans)
                obs = jnp.concatenate([obs, scans.reshape(-1)])
            if self.observe_moving:  # where the moving cylinders are and go: privileged
                obs = jnp.concatenate([obs, self._moving(pos, yaw, params, moving.motion, time)])
            return obs
        return sensor.observation(
            key,
            ranges,
            pos,
            yaw,
            goal,
            noise_std=params.lidar_noise_std,
            min_range=params.min_range,
            max_range=params.max_range,
            dropout=self.beam_dropout,
            odom_std=self.odom_noise,
            obstacle_obs=self.obstacle_obs,
        )

    def _moving(self, pos, yaw, params: EnvParams, moving, time) -> chex.Array:
        """f32[4 observe_moving]: the nearest moving cylinders of the episode's
        ``moving`` (its :class:`jaxnav.world.motion.Motion`, or None) as the simulator
        knows them (:func:`jaxnav.world.sensor.moving_features`); zeros where none move."""
        if moving is None:
            return jnp.zeros(4 * self.observe_moving, jnp.float32)
        now = motion.positions(moving, time)
        soon = motion.positions(moving, time + params.dt)
        return sensor.moving_features(
            pos, yaw, now, soon, params.dt, self.observe_moving, params.max_range
        )

    def beam_ranges(
        self, maze, pos: chex.Array, yaw: chex.Array, n_beams: int, inclusive: bool = False
    ) -> chex.Array:
        """True, unclipped ranges f32[n_beams] from pose (pos, yaw): every wall tested
        (:func:`jaxnav.world.sensor.beam_ranges`), or the drawn maze's lattice walked
        (:attr:`walks_lattice`)."""
        if self.walks_lattice:
            dirs = sensor.beam_directions(n_beams, yaw, inclusive)
            return self.family.beam_ranges(maze, pos, dirs)
        return sensor.beam_ranges(maze, pos, yaw, n_beams, inclusive, self.lidar_fov)

    def beam_angles(self) -> chex.Array:
        """f32[n_beams]: each observed beam's angle from ahead (the robot's frame)."""
        return sensor.beam_angles(self.n_beams, self.beam_layout == "gazebo", self.lidar_fov)

    def read_observation(
        self, obs: chex.Array, params: EnvParams
    ) -> tuple[chex.Array, chex.Array, chex.Array]:
        """(ranges m f32[n_beams], heading rad f32[], distance m f32[]) of an observation:
        what a driver that sees only the scan and the goal reads (:mod:`jaxnav.planners.dwa`).
        The normalised observation's distance is capped at the sensor's range."""
        n = self.n_beams
        if self.normalised:
            return obs[:n] * params.max_range, obs[n] * jnp.pi, obs[n + 1] * params.max_range
        return obs[:n], obs[n], obs[n + 1]

    def _first_scans(self, state: EnvState, obs: chex.Array) -> EnvState:
        """An episode's first state with its scan history: copies of its first scan."""
        if not self.scan_history:
            return state
        state = state.replace(scans=jnp.tile(obs[: self.n_beams], (self.scan_history, 1)))
        if self.history_turned:  # and the heading they were taken at
            state = state.replace(scan_yaws=jnp.full(self.scan_history, state.yaw, jnp.float32))
        return state

    def _newer_scans(self, state: EnvState, obs: chex.Array) -> EnvState:
        """The state after a step (``state``: its pose already the new one) with the
        step's observed scan first in the history, the oldest dropped."""
        state = state.replace(scans=jnp.concatenate([obs[None, : self.n_beams], state.scans[:-1]]))
        if self.history_turned:
            now = jnp.asarray(state.yaw, jnp.float32)[None]
            yaws = jnp.concatenate([now, state.scan_yaws[:-1]])
            state = state.replace(scan_yaws=yaws)
        return state


__all__ = ["Observer"]
