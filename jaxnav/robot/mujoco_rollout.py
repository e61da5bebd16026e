"""A NumPy policy (:class:`jaxnav.robot.deploy.Policy`) driving the burger in MuJoCo.

The model is :mod:`jaxnav.robot.mujoco_model`'s; this module is the robot's I/O and
jaxnav's test episodes around it, in NumPy (no JAX):

* LiDAR: 360 rays at 1 degree, counter-clockwise from ahead, cast by
  ``mj_multiRay`` from the LiDAR's site in its own frame (it tilts with the robot);
  Gaussian range noise (sigma 0.01 m by default, as Gazebo's LDS-01 model); a ray
  with no surface within 3.5 m reads +inf, one closer than 0.12 m -inf (REP 117),
  and the policy's own adapter turns the scan into its observation.
* Odometry: the pose of the base footprint (the middle of the wheel axle).
* Wheels: a command (v, omega) is the two wheel servos' speed setpoints for one
  control period of physics; with ``wheel_limit`` first clipped as the burger's
  firmware clips it (:func:`jaxnav.world.kinematics.firmware_limit`).
* Collision: any MuJoCo contact between a robot geom and a wall or obstacle (checked
  every physics step) ends the episode with R-; the robot restarts at the maze's
  start pose and keeps its goal, as in jaxnav.

The episode protocol is jaxnav's (:mod:`jaxnav.experiments.rollout`): control every
dt = 0.2 s (physics at 200 Hz), a goal within 0.2 m pays R+ and a new goal is drawn
from the maze's goal set as :meth:`jaxnav.env.NavEnv.draw_goal` draws it (:func:`draw_goal`),
``max_steps`` steps truncate an episode, N consecutive episodes per policy and maze,
the reward of the run's preset (:func:`reward`, jaxnav's reward in NumPy). Goals and
noise come from a NumPy generator seeded by (seed, maze) (:func:`sim_rng`), shared by
both strategies of a seed. The run's constants (:class:`Task`) and goal set
(:class:`Goals`) are read from its config by :mod:`jaxnav.experiments.sim2sim`.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from jaxnav.core.settings import BURGER_MAX_OMEGA, BURGER_MAX_V
from jaxnav.robot.deploy import Policy
from jaxnav.robot.mujoco_model import (
    MAZE_GROUP,
    TIMESTEP,
    MazeGeometry,
    load_model,
    mujoco_module,
    wheel_speeds,
)
from jaxnav.robot.scan import goal_heading_distance, yaw_from_quaternion
from jaxnav.world.kinematics import firmware_limit
from jaxnav.world.polygons import point_segment_distance

N_RAYS = 360  # rays at 2 pi / 360, counter-clockwise from straight ahead
LIDAR_NOISE_STD = 0.01  # m, Gazebo's LDS-01 model
SIM_SALT = 0x5125  # mixed into each (seed, maze) generator


class Burger:
    """A burger in a maze in MuJoCo: place it, scan, drive it, read its pose.

    Attributes:
      model, data: the MuJoCo model and its state.
      min_range, max_range: the LiDAR's range (m).
      wheel_limit: commands are clipped as the burger's firmware clips them.
    """

    def __init__(
        self,
        maze: MazeGeometry,
        timestep: float = TIMESTEP,
        min_range: float = 0.12,
        max_range: float = 3.5,
        wheel_limit: bool = False,
    ):
        mj = mujoco_module()
        self._mj = mj
        self.model = load_model(maze, timestep)
        self.data = mj.MjData(self.model)
        self.min_range, self.max_range = float(min_range), float(max_range)
        self.wheel_limit = bool(wheel_limit)
        m = self.model
        name = lambda kind, n: mj.mj_name2id(m, kind, n)
        self._site = name(mj.mjtObj.mjOBJ_SITE, "lidar")
        self._qpos = m.jnt_qposadr[name(mj.mjtObj.mjOBJ_JOINT, "burger")]
        # Maze geoms are contiguous, after the floor: a contact touching one is a collision.
        maze_ids = np.flatnonzero(m.geom_group == MAZE_GROUP)
        self._maze_lo, self._maze_hi = int(maze_ids[0]), int(maze_ids[-1])
        assert len(maze_ids) == self._maze_hi - self._maze_lo + 1
        a = np.arange(N_RAYS) * (2 * math.pi / N_RAYS)
        self._rays = np.stack([np.cos(a), np.sin(a), np.zeros(N_RAYS)], axis=1)  # lidar frame
        self._groups = np.zeros(6, np.uint8)
        self._groups[MAZE_GROUP] = 1
        self._geomid = np.zeros(N_RAYS, np.int32)
        self._dist = np.zeros(N_RAYS, np.float64)

    @property
    def angle_increment(self) -> float:
        return 2 * math.pi / N_RAYS

    def place(self, x: float, y: float, yaw: float, settle: int = 10) -> None:
        """Put the robot at rest at (x, y, yaw) on the floor, wheels stopped, and let
        it settle on its contacts for ``settle`` physics steps."""
        mj, d = self._mj, self.data
        mj.mj_resetData(self.model, d)
        quat = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))  # about z: (w, x, y, z)
        d.qpos[self._qpos : self._qpos + 7] = (x, y, 0.0, *quat)
        mj.mj_forward(self.model, d)
        for _ in range(settle):
            mj.mj_step(self.model, d)

    def pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the base footprint (the middle of the wheel axle), as odometry."""
        q = self.data.qpos[self._qpos : self._qpos + 7]
        return float(q[0]), float(q[1]), yaw_from_quaternion(q[4], q[5], q[6], q[3])

    def lidar_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the LiDAR's site."""
        p, mat = self.data.site_xpos[self._site], self.data.site_xmat[self._site]
        return float(p[0]), float(p[1]), math.atan2(mat[3], mat[0])

    def scan(self, rng: np.random.Generator | None = None, noise_std: float = 0.0) -> np.ndarray:
        """f64[360] LaserScan ranges: the distance to the first wall or obstacle along
        each ray, plus N(0, noise_std) noise; +inf past max_range (or no surface), -inf
        below min_range. Ray i at 2 pi i / 360 in the LiDAR's frame."""
        mj, d = self._mj, self.data
        mat = d.site_xmat[self._site].reshape(3, 3)
        vec = (self._rays @ mat.T).reshape(-1)
        pnt = d.site_xpos[self._site].copy()
        mj.mj_multiRay(
            self.model,
            d,
            pnt=pnt,
            vec=vec,
            geomgroup=self._groups,  # the maze only: not the floor, not the robot
            flg_static=1,
            bodyexclude=-1,
            geomid=self._geomid,
            dist=self._dist,
            normal=None,
            nray=N_RAYS,
            cutoff=2 * self.max_range,
        )
        r = self._dist.copy()
        hit = r >= 0
        if noise_std > 0 and rng is not None:
            r = r + noise_std * rng.standard_normal(N_RAYS)
        r = np.where(hit & (r <= self.max_range), r, np.inf)
        return np.where(r < self.min_range, -np.inf, r)

    def touching(self) -> bool:
        """True if a robot geom touches a wall or obstacle now."""
        n = self.data.ncon
        if n == 0:
            return False
        g = self.data.contact.geom[:n]
        return bool(np.any((g >= self._maze_lo) & (g <= self._maze_hi)))

    def command(self, v: float, omega: float) -> tuple[float, float]:
        """Set the wheel servos for a command (v m/s, omega rad/s), through the firmware's
        clipping with ``wheel_limit``; returns the (v, omega) they are set to."""
        if self.wheel_limit:
            v, omega = (float(x) for x in firmware_limit(np.float64(v), np.float64(omega)))
        self.data.ctrl[:] = wheel_speeds(v, omega)
        return v, omega

    def step(self) -> bool:
        """One physics step; True when a robot geom then touches a wall or obstacle."""
        self._mj.mj_step(self.model, self.data)
        return self.touching()

    def drive(self, v: float, omega: float, duration: float) -> bool:
        """Command (v, omega) for ``duration`` seconds of physics; True (and stop at once)
        when the robot touches a wall or obstacle."""
        self.command(v, omega)
        for _ in range(round(duration / self.model.opt.timestep)):
            if self.step():
                return True
        return False


# ----------------------------------------------------------------------------
# The test: jaxnav's episode protocol, goals and reward, in NumPy
# ----------------------------------------------------------------------------


class Task(NamedTuple):
    """The run's test constants (its env preset and settings), as NumPy numbers."""

    omegas: np.ndarray  # f64[A]
    R_plus: float
    R_minus: float
    reward_span: float
    reward_distance_exp: bool
    goal_radius: float
    max_steps: int
    goal_min_separation: float
    goal_candidates: int
    goal_sampler: str  # "free" or "robotis"
    min_range: float
    max_range: float
    # env.reward: dense (the paper's heading shaping, :func:`reward`), sparse or
    # progress (:func:`progress_reward`, with the settings below)
    reward_kind: str = "dense"
    progress_scale: float = 10.0
    step_penalty: float = 0.0
    proximity_penalty: float = 0.0
    proximity_distance: float = 0.3
    change_penalty: float = 0.0
    robot_radius: float = 0.13


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def reward(
    task: Task,
    omega: float,
    heading: float,
    distance: float,
    goal_distance0: float,
    reached: bool,
    collided: bool,
) -> float:
    """jaxnav's reward (:func:`jaxnav.world.reward.reward_fn`) of one step, in NumPy: R- on a
    collision, R+ on the goal, else 5 psi(heading - phi) D, phi the direction the step's
    commanded yaw rate ``omega`` turns towards (``task.omegas[action]`` for a discrete
    action, as jaxnav's; a continuous policy's command scored on the same scale)."""
    if collided:
        return task.R_minus
    if reached:
        return task.R_plus
    phi = omega / np.max(np.abs(task.omegas)) * task.reward_span
    psi = 1.0 - (2.0 / math.pi) * abs(_wrap(heading - phi))
    D = 2.0 ** (distance / max(goal_distance0, 1e-6)) if task.reward_distance_exp else distance
    return float(5.0 * psi * D)


def progress_reward(
    task: Task,
    before: float,
    after: float,
    clearance: float,
    change: float,
    reached: bool,
    collided: bool,
) -> float:
    """jaxnav's progress reward (:func:`jaxnav.world.reward.progress_reward`) of one step,
    in NumPy: R- on a collision, R+ on the goal, else ``progress_scale`` times the metres
    the step came closer (``before`` - ``after``), minus the step penalty, the proximity
    penalty where the step's ``clearance`` (least distance of the robot's centre to a
    surface) is within ``proximity_distance`` of the robot's radius, and the change
    penalty times ``change`` (|dv| / 0.22 + |d omega| / 2.84)."""
    if collided:
        return task.R_minus
    if reached:
        return task.R_plus
    near = min(max(1.0 - (clearance - task.robot_radius) / task.proximity_distance, 0.0), 1.0)
    return float(
        task.progress_scale * (before - after)
        - task.step_penalty
        - task.proximity_penalty * near
        - task.change_penalty * change
    )


def clearance_of(surfaces, a: np.ndarray, b: np.ndarray, samples: int = 9) -> float:
    """The least distance from the robot centre's step, the chord from ``a`` to ``b``
    sampled at ``samples`` points (jaxnav measures its exact arc), to ``surfaces``
    (walls f[S, 4], cylinders f[C, 3]); inf with none."""
    if surfaces is None:
        return math.inf
    walls, circles = surfaces
    p = a[None, :] + np.linspace(0.0, 1.0, samples)[:, None] * (b - a)[None, :]
    best = math.inf
    if len(walls):
        best = float(np.min(point_segment_distance(p, walls)))
    if len(circles):
        dc = np.hypot(p[:, None, 0] - circles[None, :, 0], p[:, None, 1] - circles[None, :, 1])
        best = min(best, float(np.min(dc - circles[None, :, 2])))
    return best


class Goals(NamedTuple):
    """A maze's goal set as :meth:`jaxnav.env.NavEnv.draw_goal` draws from it."""

    points: np.ndarray  # f64[G, 2] the admissible points
    robotis: bool  # ROBOTIS' rule: far enough along x or y, fixed first goal
    separation: float  # m
    first: np.ndarray | None  # f64[2] the first goal (ROBOTIS), or None: drawn
    candidates: int


def draw_goal(rng: np.random.Generator, away_from: np.ndarray, goals: Goals) -> np.ndarray:
    """f64[2]: the first of ``candidates`` uniform draws from the goal set far enough from
    ``away_from`` (the last goal), else the first draw."""
    c = goals.points[rng.integers(0, len(goals.points), goals.candidates)]
    delta = np.abs(c - np.asarray(away_from, np.float64))
    if goals.robotis:
        far = (delta[:, 0] >= goals.separation) | (delta[:, 1] >= goals.separation)
    else:
        far = np.hypot(delta[:, 0], delta[:, 1]) >= goals.separation
    return c[int(np.argmax(far))]


class Episodes(NamedTuple):
    """Per-episode test results, f[E] each."""

    ret: np.ndarray
    goals: np.ndarray
    collided: np.ndarray
    length: np.ndarray


def play(
    policy: Policy,
    robot: Burger,
    start: Sequence[float],
    goals: Goals,
    task: Task,
    n_episodes: int,
    rng: np.random.Generator,
    noise_std: float = LIDAR_NOISE_STD,
    surfaces: tuple[np.ndarray, np.ndarray] | None = None,
) -> Episodes:
    """``n_episodes`` consecutive greedy test episodes of one policy (jaxnav's protocol).

    Each step: scan and pose -> the policy's observation -> its greedy action -> the
    command for dt of physics -> reward. A goal reached draws a new one (the episode
    goes on); a collision or ``max_steps`` steps end the episode, and the robot
    restarts at ``start`` (x, y, yaw) with its goal kept. The reward is the run's
    (``task.reward_kind``); the progress reward's proximity term measures the step
    against ``surfaces`` (the maze's walls f[S, 4] and cylinders f[C, 3]; None: none).
    """
    start = tuple(float(v) for v in start)
    goal = goals.first if goals.first is not None else draw_goal(rng, start[:2], goals)
    out = []
    while len(out) < n_episodes:
        robot.place(*start)
        policy.rest()  # at rest: the normalised observation's last command is (0, 0)
        d0 = math.hypot(goal[0] - start[0], goal[1] - start[1])
        ret, reached_goals, t, collided = 0.0, 0, 0, False
        last = (0.0, 0.0)  # the command before the first step: at rest
        while not collided and t < task.max_steps:
            pose = robot.pose()
            scan = robot.scan(rng, noise_std)
            obs = policy.observe(scan, 0.0, robot.angle_increment, pose, goal)
            linear, angular = policy.take(policy.act(obs))
            collided = robot.drive(linear, angular, policy.dt)
            before = math.hypot(goal[0] - pose[0], goal[1] - pose[1])
            was, pose = np.asarray(pose[:2], np.float64), robot.pose()
            heading, distance = goal_heading_distance(pose, goal)
            reached = distance < task.goal_radius and not collided
            if task.reward_kind == "progress":
                clear = clearance_of(surfaces, was, np.asarray(pose[:2], np.float64))
                change = abs(linear - last[0]) / BURGER_MAX_V + abs(angular - last[1]) / (
                    BURGER_MAX_OMEGA
                )
                ret += progress_reward(task, before, distance, clear, change, reached, collided)
            elif task.reward_kind == "sparse":
                ret += task.R_minus if collided else task.R_plus if reached else 0.0
            else:
                ret += reward(task, angular, heading, distance, d0, reached, collided)
            last = (float(linear), float(angular))
            t += 1
            if reached:
                goal = draw_goal(rng, goal, goals)
                d0 = math.hypot(goal[0] - pose[0], goal[1] - pose[1])
                reached_goals += 1
        out.append((ret, reached_goals, collided, t))
    ret, n_goals, coll, length = (np.asarray(c) for c in zip(*out))
    return Episodes(ret.astype(np.float64), n_goals, coll.astype(bool), length)


def sim_rng(seed: int, maze: str) -> np.random.Generator:
    """The goals' and noise's generator of one (seed, maze), shared by the strategies."""
    return np.random.default_rng([seed, SIM_SALT, zlib.crc32(maze.encode())])
