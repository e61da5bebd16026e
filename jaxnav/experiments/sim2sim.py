"""``python -m jaxnav.sim2sim RUN_DIR [--mazes M ...] [--episodes N] [--seeds K ...] [--out FILE]``

Sim-to-sim transfer: every trained policy of a run, exported as for the robot
(:func:`jaxnav.robot.export.export_policy`, run greedily by the NumPy
:class:`jaxnav.robot.deploy.Policy`, no fine-tuning), drives a TurtleBot3 burger in MuJoCo
physics through the paper's test, beside jaxnav's own result for the same policies.

What is simulated:

* Robot: ROBOTIS' burger (turtlebot3_description): wheel radius 0.033 m, wheel
  separation 0.160 m, 1.0 kg (chassis 0.826, LiDAR 0.114, wheels 0.0285 each,
  caster 0.005), the chassis collision box 0.140 x 0.140 x 0.143 m centred 0.032 m
  behind the wheel axle, the LDS-01 on top 0.032 m behind the axle, a frictionless
  ball caster. Each wheel is a velocity servo (MuJoCo ``velocity`` actuator) with
  the XL430-W250's 1.4 N m stall torque as its limit and rubber tyres (friction 0.8)
  on the floor: a command (v, omega) sets the wheel speeds (v -/+ omega L / 2) / r
  (left/right) and the robot moves through contact physics, never by setting its
  pose.
* Maze: extruded from jaxnav's own geometry (:mod:`jaxnav.world.maps`): every wall segment
  (outline and polygon edges) a thin box whose face lies on the segment, every
  cylinder a cylinder; 0.5 m high.
* LiDAR: 360 rays at 1 degree, counter-clockwise from ahead, cast by
  ``mj_multiRay`` from the LiDAR's site in its own frame (it tilts with the robot);
  Gaussian range noise (sigma 0.01 m by default, as Gazebo's LDS-01 model); a ray
  with no surface within 3.5 m reads +inf, one closer than 0.12 m -inf (REP 117),
  and the policy's own adapter turns the scan into its observation.
* Collision: any MuJoCo contact between a robot geom and a wall or obstacle (checked
  every physics step) ends the episode with R-; the robot restarts at the maze's
  start pose and keeps its goal, as in jaxnav.

The episode protocol is jaxnav's (:mod:`jaxnav.experiments.rollout`): control every dt = 0.2 s
(physics at 200 Hz), a goal within 0.2 m pays R+ and a new goal is drawn from the
maze's goal set as :meth:`jaxnav.env.NavEnv.draw_goal` draws it, 500 steps truncate
an episode, N consecutive episodes per policy and maze, the reward of the run's
preset (:func:`reward`, jaxnav's reward in NumPy). Goals and noise come from a
NumPy generator seeded by (seed, maze), shared by both strategies of a seed.

jaxnav's own result is the greedy rows of ``RUN_DIR/eval/results.csv`` when they
cover the same mazes, strategies and seeds, else a fresh greedy test
(:mod:`jaxnav.experiments.evaluation`'s loading,
:func:`jaxnav.experiments.rollout.run_tests`). Writes::

    FILE (default RUN_DIR/sim2sim/sim2sim.csv)   simulator, strategy, seed, maze,
        episodes, return, goals, collision_rate, length: per-seed means
    FILE with .md   the gap: return, goals per episode and collision rate per
        strategy over all seeds and mazes, jaxnav beside MuJoCo, with 95% bootstrap
        intervals over seeds (:mod:`jaxnav.report.stats`), then per maze

MuJoCo is imported only here (optional extra ``sim``): without it, every other
module of jaxnav works and this command says how to install it.
"""

from __future__ import annotations

import csv
import io
import math
import sys
import time
import zlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from jaxnav.core import cli, rundir
from jaxnav.core.config import Config, load_config
from jaxnav.core.errors import JaxnavError
from jaxnav.env import from_config
from jaxnav.experiments.evaluation import diverged_runs, load_run
from jaxnav.experiments.rollout import padded_mazes, run_tests
from jaxnav.report import stats
from jaxnav.report.results import (
    RESULT_COLUMNS,
    STRATEGY_NAMES,
    episode_rows,
    ordered_unique,
    read_results,
)
from jaxnav.robot.deploy import Policy, goal_heading_distance, yaw_from_quaternion
from jaxnav.robot.export import export_policy
from jaxnav.world.maps import ROBOTIS_FIRST_GOAL, ROBOTIS_GOAL_SEPARATION, Maze, make_maze

# ROBOTIS' TurtleBot3 burger (turtlebot3_description, in the base_footprint frame:
# x ahead, z up, origin on the floor below the middle of the wheel axle).
WHEEL_RADIUS = 0.033  # m
WHEEL_SEPARATION = 0.160  # m, between the wheels' mid-planes
WHEEL_WIDTH = 0.018  # m
WHEEL_MASS = 0.0285  # kg, each
CHASSIS_MASS = 0.826  # kg
CHASSIS_SIZE = (0.140, 0.140, 0.143)  # m, the collision box
CHASSIS_POS = (-0.032, 0.0, 0.080)  # m, its centre
LIDAR_MASS = 0.114  # kg
LIDAR_POS = (-0.032, 0.0, 0.182)  # m, where the LDS-01 measures from
LIDAR_BODY = (0.055, 0.0315, (-0.017, 0.0, 0.1755))  # collision cylinder: radius, length, centre
CASTER_MASS = 0.005  # kg
CASTER_POS = (-0.081, 0.0, 0.006)  # m; a ball of radius CASTER_POS[2] on the floor
# The wheel servos (Dynamixel XL430-W250) and the tyres.
WHEEL_TORQUE = 1.4  # N m, stall torque at 11.1 V: the servo's force limit
SERVO_GAIN = 0.5  # N m per rad/s of speed error (a proportional velocity servo)
# The geared motor's rotor inertia seen at the wheel through the 258.5:1 gearbox (an
# estimate of its order); it also keeps the stiff servo stable at the 5 ms physics step.
WHEEL_ARMATURE = 3e-3  # kg m^2
TYRE_FRICTION = 0.8  # rubber on a hard floor (sliding; torsional and rolling small)

# The LDS-01 and the simulation.
N_RAYS = 360  # rays at 2 pi / 360, counter-clockwise from straight ahead
LIDAR_NOISE_STD = 0.01  # m, Gazebo's LDS-01 model
TIMESTEP = 0.005  # s, physics (200 Hz): 40 steps per 0.2 s control period
WALL_THICKNESS = 0.05  # m
WALL_HEIGHT = 0.5  # m
SIM_SALT = 0x5125  # mixed into each (seed, maze) generator

# Contact bits: the floor touches the wheels and the caster; walls and obstacles
# touch every robot geom; nothing else touches. Geom groups pick what the LiDAR sees.
_FLOOR_BIT, _MAZE_BIT = 1, 2
_MAZE_GROUP = 1

SIMULATORS = ("jaxnav", "mujoco")
SUMMARY_COLUMNS = (
    "simulator",
    "strategy",
    "seed",
    "maze",
    "episodes",
    "return",
    "goals",
    "collision_rate",
    "length",
)
REALISM_COLUMNS = ("option", *SUMMARY_COLUMNS)  # several runs' sim2sim CSVs in one


def _mujoco():
    """The mujoco module, or a one-line JaxnavError saying how to install it."""
    try:
        import mujoco
    except ImportError:
        raise JaxnavError(
            "MuJoCo is not installed: pip install mujoco (or jaxnav's 'sim' extra)"
        ) from None
    return mujoco


# ----------------------------------------------------------------------------
# The world in MJCF: the maze extruded from jaxnav's geometry, and the burger
# ----------------------------------------------------------------------------


def wheel_speeds(v: float, omega: float) -> tuple[float, float]:
    """(left, right) wheel angular velocities in rad/s of a command (v m/s, omega rad/s)."""
    half = omega * WHEEL_SEPARATION / 2
    return (v - half) / WHEEL_RADIUS, (v + half) / WHEEL_RADIUS


def free_side_normals(walls: np.ndarray) -> np.ndarray:
    """f64[S, 2] unit normal of each wall segment f[S, 4] pointing into free space.

    A point just off a segment's middle is in free space when a ray from it crosses
    the maze's segments an odd number of times (inside the outline, outside every
    obstacle polygon): the even-odd rule over all segments at once.
    """
    walls = np.asarray(walls, np.float64)
    a, b = walls[:, :2], walls[:, 2:]
    d = b - a
    left = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d, axis=1, keepdims=True)
    probe = (a + b) / 2 + 1e-4 * left  # f[S, 2]
    x, y = probe[:, :1], probe[:, 1:]
    x1, y1, x2, y2 = (walls[None, :, i] for i in range(4))
    crosses = (y1 > y) != (y2 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_at = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
    inside = (crosses & (x < x_at)).sum(axis=1) % 2 == 1
    return np.where(inside[:, None], left, -left)


def _f(*xs: float) -> str:
    return " ".join(f"{x:.6g}" for x in xs)


def maze_mjcf(maze: Maze) -> str:
    """MJCF geoms of a maze: a thin box behind every wall segment (its face on the
    segment, the box on the side away from free space) and a cylinder per obstacle."""
    walls, circles = maze.walls().astype(np.float64), maze.obstacles().astype(np.float64)
    inward = free_side_normals(walls) if len(walls) else np.zeros((0, 2))
    common = f'group="{_MAZE_GROUP}" contype="{_MAZE_BIT}" conaffinity="0" rgba=".7 .7 .7 1"'
    h = WALL_HEIGHT / 2
    lines = []
    for i, (seg, n) in enumerate(zip(walls, inward)):
        a, b = seg[:2], seg[2:]
        centre = (a + b) / 2 - n * WALL_THICKNESS / 2
        length = float(np.linalg.norm(b - a))
        yaw = math.atan2(b[1] - a[1], b[0] - a[0])
        lines.append(
            f'<geom name="wall{i}" type="box" pos="{_f(*centre, h)}" '
            f'size="{_f(length / 2, WALL_THICKNESS / 2, h)}" euler="0 0 {yaw:.9g}" {common}/>'
        )
    for i, (cx, cy, r) in enumerate(circles):
        lines.append(
            f'<geom name="obstacle{i}" type="cylinder" pos="{_f(cx, cy, h)}" '
            f'size="{_f(r, h)}" {common}/>'
        )
    return "\n    ".join(lines)


def burger_mjcf(x: float = 0.0, y: float = 0.0, yaw: float = 0.0) -> str:
    """MJCF body of the burger at pose (x, y, yaw), on a free joint."""
    sx, sy, sz = (s / 2 for s in CHASSIS_SIZE)
    lr, ll, lpos = LIDAR_BODY
    floor_and_maze = _FLOOR_BIT | _MAZE_BIT
    body = f'group="2" contype="0" conaffinity="{_MAZE_BIT}"'
    wheel = (
        f'type="cylinder" size="{_f(WHEEL_RADIUS, WHEEL_WIDTH / 2)}" zaxis="0 1 0" '
        f'mass="{WHEEL_MASS}" friction="{TYRE_FRICTION} 0.005 0.0001" group="2" '
        f'contype="0" conaffinity="{floor_and_maze}"'
    )
    wheels = "".join(
        f"""
      <body name="wheel_{side}" pos="0 {sign * WHEEL_SEPARATION / 2:.6g} {WHEEL_RADIUS}">
        <joint name="wheel_{side}" type="hinge" axis="0 1 0" armature="{WHEEL_ARMATURE}"/>
        <geom name="wheel_{side}" {wheel}/>
      </body>"""
        for side, sign in (("left", 1), ("right", -1))
    )
    return f"""<body name="burger" pos="{_f(x, y, 0.0)}" euler="0 0 {yaw:.9g}">
      <freejoint name="burger"/>
      <geom name="chassis" type="box" pos="{_f(*CHASSIS_POS)}" size="{_f(sx, sy, sz)}"
            mass="{CHASSIS_MASS}" {body}/>
      <geom name="lidar" type="cylinder" pos="{_f(*lpos)}" size="{_f(lr, ll / 2)}"
            mass="{LIDAR_MASS}" {body}/>
      <geom name="caster" type="sphere" pos="{_f(*CASTER_POS)}" size="{CASTER_POS[2]}"
            mass="{CASTER_MASS}" condim="1" priority="1" group="2" contype="0"
            conaffinity="{floor_and_maze}"/>
      <site name="lidar" pos="{_f(*LIDAR_POS)}"/>{wheels}
    </body>"""


def world_mjcf(maze: Maze, timestep: float = TIMESTEP) -> str:
    """The whole MJCF model: floor, maze, burger at the maze's start, wheel servos."""
    x, y, yaw = (float(v) for v in np.asarray(maze.start))
    servo = f'kv="{SERVO_GAIN}" forcerange="{-WHEEL_TORQUE} {WHEEL_TORQUE}"'
    return f"""<mujoco model="jaxnav_burger">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep}" integrator="implicitfast"/>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.05" friction="{TYRE_FRICTION} 0.005 0.0001"
          group="0" contype="{_FLOOR_BIT}" conaffinity="0"/>
    {maze_mjcf(maze)}
    {burger_mjcf(x, y, yaw)}
  </worldbody>
  <actuator>
    <velocity name="wheel_left" joint="wheel_left" {servo}/>
    <velocity name="wheel_right" joint="wheel_right" {servo}/>
  </actuator>
</mujoco>
"""


# ----------------------------------------------------------------------------
# The simulated robot
# ----------------------------------------------------------------------------


class Burger:
    """A burger in a maze in MuJoCo: place it, scan, drive it, read its pose.

    Attributes:
      model, data: the MuJoCo model and its state.
      min_range, max_range: the LiDAR's range (m).
    """

    def __init__(
        self,
        maze: Maze,
        timestep: float = TIMESTEP,
        min_range: float = 0.12,
        max_range: float = 3.5,
    ):
        mj = _mujoco()
        self._mj = mj
        self.model = mj.MjModel.from_xml_string(world_mjcf(maze, timestep))
        self.data = mj.MjData(self.model)
        self.min_range, self.max_range = float(min_range), float(max_range)
        m = self.model
        name = lambda kind, n: mj.mj_name2id(m, kind, n)
        self._site = name(mj.mjtObj.mjOBJ_SITE, "lidar")
        self._qpos = m.jnt_qposadr[name(mj.mjtObj.mjOBJ_JOINT, "burger")]
        # Maze geoms are contiguous, after the floor: a contact touching one is a collision.
        maze_ids = np.flatnonzero(m.geom_group == _MAZE_GROUP)
        self._maze_lo, self._maze_hi = int(maze_ids[0]), int(maze_ids[-1])
        assert len(maze_ids) == self._maze_hi - self._maze_lo + 1
        a = np.arange(N_RAYS) * (2 * math.pi / N_RAYS)
        self._rays = np.stack([np.cos(a), np.sin(a), np.zeros(N_RAYS)], axis=1)  # lidar frame
        self._groups = np.zeros(6, np.uint8)
        self._groups[_MAZE_GROUP] = 1
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

    def drive(self, v: float, omega: float, duration: float) -> bool:
        """Command (v, omega) for ``duration`` seconds of physics; True (and stop at once)
        when the robot touches a wall or obstacle."""
        mj, d = self._mj, self.data
        d.ctrl[:] = wheel_speeds(v, omega)
        for _ in range(round(duration / self.model.opt.timestep)):
            mj.mj_step(self.model, d)
            if self.touching():
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


def task_of(cfg: Config) -> Task:
    """The test constants of a run's config (its env's params and settings)."""
    env, p = from_config(cfg)
    return Task(
        omegas=np.asarray(p.omegas, np.float64),
        R_plus=float(p.R_plus),
        R_minus=float(p.R_minus),
        reward_span=float(p.reward_span),
        reward_distance_exp=bool(p.reward_distance_exp),
        goal_radius=float(p.goal_radius),
        max_steps=int(p.max_steps),
        goal_min_separation=float(p.goal_min_separation),
        goal_candidates=int(env.goal_candidates),
        goal_sampler=env.goal_sampler,
        min_range=float(p.min_range),
        max_range=float(p.max_range),
    )


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def reward(
    task: Task,
    action: int,
    heading: float,
    distance: float,
    goal_distance0: float,
    reached: bool,
    collided: bool,
) -> float:
    """jaxnav's reward (:func:`jaxnav.world.reward.reward_fn`) of one step, in NumPy: R- on a
    collision, R+ on the goal, else 5 psi(heading - phi_a) D."""
    if collided:
        return task.R_minus
    if reached:
        return task.R_plus
    phi = task.omegas[action] / np.max(np.abs(task.omegas)) * task.reward_span
    psi = 1.0 - (2.0 / math.pi) * abs(_wrap(heading - phi))
    D = 2.0 ** (distance / max(goal_distance0, 1e-6)) if task.reward_distance_exp else distance
    return float(5.0 * psi * D)


class Goals(NamedTuple):
    """A maze's goal set as :meth:`jaxnav.env.NavEnv.draw_goal` draws from it."""

    points: np.ndarray  # f64[G, 2] the admissible points
    robotis: bool  # ROBOTIS' rule: far enough along x or y, fixed first goal
    separation: float  # m
    first: np.ndarray | None  # f64[2] the first goal (ROBOTIS), or None: drawn
    candidates: int


def goals_of(maze: Maze, task: Task) -> Goals:
    """The goal set of a test maze under the run's goal sampler."""
    if task.goal_sampler == "robotis":
        n, s = int(maze.n_robotis_goals), float(maze.robotis_scale)
        points = np.asarray(maze.robotis_goals, np.float64)[:n]
        sep = (ROBOTIS_GOAL_SEPARATION - 0.05) * s  # decides exactly on the 0.1 s grid
        return Goals(points, True, sep, np.asarray(ROBOTIS_FIRST_GOAL) * s, task.goal_candidates)
    points = np.asarray(maze.goal_points, np.float64)[: int(maze.n_goal_points)]
    return Goals(points, False, task.goal_min_separation, None, task.goal_candidates)


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
) -> Episodes:
    """``n_episodes`` consecutive greedy test episodes of one policy (jaxnav's protocol).

    Each step: scan and pose -> the policy's observation -> its greedy action -> the
    command for dt of physics -> reward. A goal reached draws a new one (the episode
    goes on); a collision or ``max_steps`` steps end the episode, and the robot
    restarts at ``start`` (x, y, yaw) with its goal kept.
    """
    start = tuple(float(v) for v in start)
    goal = goals.first if goals.first is not None else draw_goal(rng, start[:2], goals)
    out = []
    while len(out) < n_episodes:
        robot.place(*start)
        d0 = math.hypot(goal[0] - start[0], goal[1] - start[1])
        ret, reached_goals, t, collided = 0.0, 0, 0, False
        while not collided and t < task.max_steps:
            pose = robot.pose()
            scan = robot.scan(rng, noise_std)
            obs = policy.observe(scan, 0.0, robot.angle_increment, pose, goal)
            action = policy.act(obs)
            collided = robot.drive(policy.linear_velocity, float(policy.omegas[action]), policy.dt)
            pose = robot.pose()
            heading, distance = goal_heading_distance(pose, goal)
            reached = distance < task.goal_radius and not collided
            ret += reward(task, action, heading, distance, d0, reached, collided)
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


# ----------------------------------------------------------------------------
# A run's policies in MuJoCo and in jaxnav
# ----------------------------------------------------------------------------


def policy_labels(run_dir: Path, cfg: Config, seeds: Sequence[int] | None) -> list[tuple[str, int]]:
    """(strategy, seed) of the run's policies to test: ``seeds`` (default all), without
    those that diverged in training."""
    dropped = diverged_runs(run_dir)
    labels = [label for label in cfg.run_labels() if label not in dropped]
    if seeds:
        have = ordered_unique(s for _, s in labels)
        missing = [s for s in seeds if s not in have]
        if missing:
            raise JaxnavError(
                f"{run_dir} has no policy of seed {missing[0]} (seeds: {', '.join(map(str, have))})"
            )
        labels = [(st, s) for st, s in labels if s in seeds]
    if not labels:
        raise JaxnavError(f"{run_dir}: no policy to test (every run diverged in training)")
    return labels


def mujoco_results(
    run_dir: Path,
    cfg: Config,
    names: Sequence[str],
    labels: Sequence[tuple[str, int]],
    n_episodes: int,
    noise_std: float = LIDAR_NOISE_STD,
    timestep: float = TIMESTEP,
    progress=None,
) -> dict[tuple[str, str, int], Episodes]:
    """{(maze, strategy, seed): Episodes} of every exported policy in MuJoCo."""
    task = task_of(cfg)
    policies = {label: Policy.from_arrays(export_policy(run_dir, *label)) for label in labels}
    out = {}
    for name in names:
        maze = make_maze(name)
        robot = Burger(maze, timestep, task.min_range, task.max_range)
        goals, start = goals_of(maze, task), np.asarray(maze.start, np.float64)
        t0 = time.perf_counter()
        for strategy, seed in labels:
            rng = sim_rng(seed, name)
            res = play(
                policies[(strategy, seed)], robot, start, goals, task, n_episodes, rng, noise_std
            )
            out[(name, strategy, seed)] = res
        if progress:
            progress(
                f"{name}: {len(labels)} policies x {n_episodes} episodes in MuJoCo, "
                f"{time.perf_counter() - t0:.0f} s"
            )
    return out


def jaxnav_results(
    run_dir: Path, names: Sequence[str], labels: Sequence[tuple[str, int]]
) -> tuple[dict[tuple[str, str, int], Episodes], str]:
    """({(maze, strategy, seed): Episodes} of jaxnav's greedy test, where they came from):
    RUN_DIR/eval/results.csv if it covers every test, else a fresh greedy test with the
    config's test episodes."""
    path = run_dir / "eval" / "results.csv"
    keys = [(m, s, k) for m in names for s, k in labels]
    res = read_results(path.read_text(), "greedy") if path.is_file() else {}
    source = f"{path} (greedy)"
    if not all(k in res for k in keys):
        run = load_run(run_dir)
        n = run.config.run.test_episodes
        tests = run_tests(run.policies, padded_mazes(names), n, mode="greedy")
        rows = episode_rows(run.policies.labels, names, tests, n, "greedy")
        res = read_results(rundir.csv_text(RESULT_COLUMNS, rows), "greedy")
        source = f"jaxnav.experiments.rollout greedy test, {n} episodes"
    out = {
        k: Episodes(res[k]["return"], res[k]["goals"], res[k]["collided"] > 0, res[k]["length"])
        for k in keys
    }
    return out, source


def summary_rows(simulator: str, results: dict[tuple[str, str, int], Episodes]):
    """Per-seed rows (simulator, strategy, seed, maze, episodes, return, goals,
    collision_rate, length) of per-episode results: means over the episodes."""
    for (maze, strategy, seed), e in results.items():
        yield (
            simulator,
            strategy,
            seed,
            maze,
            len(e.ret),
            f"{float(np.mean(e.ret)):.4f}",
            f"{float(np.mean(e.goals)):.4f}",
            f"{float(np.mean(e.collided)):.4f}",
            f"{float(np.mean(e.length)):.2f}",
        )


# ----------------------------------------------------------------------------
# The table: a pure function of the CSV
# ----------------------------------------------------------------------------

# (CSV column, name in the table, decimals)
METRICS = (
    ("return", "return", 1),
    ("goals", "goals per episode", 2),
    ("collision_rate", "collision rate", 2),
)


def _summary_entries(text: str):
    """(row, (simulator, maze, strategy, seed), {metric: value}) of each CSV row."""
    for row in csv.DictReader(io.StringIO(text)):
        key = (row["simulator"], row["maze"], row["strategy"], int(row["seed"]))
        yield row, key, {c: float(row[c]) for c in SUMMARY_COLUMNS[4:]}


def read_summary(text: str) -> dict[tuple[str, str, str, int], dict[str, float]]:
    """sim2sim CSV text -> {(simulator, maze, strategy, seed): {metric: value}}."""
    return {key: values for _, key, values in _summary_entries(text)}


def _ci(iv: stats.Interval, digits: int, sign: str = "") -> str:
    v = f"{iv.value:{sign}.{digits}f}"
    if math.isnan(iv.low):
        return f"{v} [n/a]"
    return f"{v} [{iv.low:{sign}.{digits}f}, {iv.high:{sign}.{digits}f}]"


def gap_markdown(text: str, title: str = "Sim-to-sim gap") -> str:
    """Markdown of a sim2sim CSV: per strategy over all seeds and mazes, each metric in
    jaxnav and in MuJoCo with 95% bootstrap intervals over seeds, and their difference
    (a seed's own MuJoCo minus jaxnav, seeds resampled jointly over the mazes); then
    per maze."""
    res = read_summary(text)
    keys = [k for k in res if k[0] == "mujoco"]
    mazes = ordered_unique(k[1] for k in keys)
    strategies = ordered_unique(k[2] for k in keys)
    seeds = sorted({k[3] for k in keys})
    n_eps = {
        sim: ordered_unique(int(v["episodes"]) for k, v in res.items() if k[0] == sim)
        for sim in SIMULATORS
    }

    def scores(sim, strategy, metric, maze_list):  # f[seeds, mazes]
        return np.asarray([[res[(sim, m, strategy, s)][metric] for m in maze_list] for s in seeds])

    lines = [f"# {title}", ""]
    lines.append(
        f"Every policy greedy (argmax Q), {len(seeds)} seeds per strategy, test mazes "
        f"{', '.join(mazes)}; episodes per policy and maze: jaxnav "
        f"{'/'.join(map(str, n_eps['jaxnav']))}, MuJoCo {'/'.join(map(str, n_eps['mujoco']))}. "
        "Mean over seeds and mazes of each seed's mean over its episodes, with a 95% "
        "percentile bootstrap interval over seeds (a drawn seed keeps all its mazes); "
        "the gap is MuJoCo minus jaxnav for the same network."
    )
    lines += ["", "## Over all test mazes", ""]
    header = ["strategy", "metric", "jaxnav", "MuJoCo", "MuJoCo - jaxnav"]
    rows = []
    for strategy in strategies:
        for metric, label, digits in METRICS:
            jx = scores("jaxnav", strategy, metric, mazes)
            mj = scores("mujoco", strategy, metric, mazes)
            rows.append(
                [
                    STRATEGY_NAMES.get(strategy, strategy),
                    label,
                    _ci(stats.mean_ci(jx), digits),
                    _ci(stats.mean_ci(mj), digits),
                    _ci(stats.mean_ci(mj - jx), digits, "+"),
                ]
            )
    lines += _table(header, rows)
    lines += ["", "## Per maze", ""]
    header = ["maze", "strategy", "return jaxnav", "return MuJoCo", "return gap"]
    header += ["goals/ep jaxnav", "goals/ep MuJoCo", "collisions jaxnav", "collisions MuJoCo"]
    rows = []
    for maze in mazes:
        for strategy in strategies:
            jx = {m: scores("jaxnav", strategy, m, [maze])[:, 0] for m, _, _ in METRICS}
            mj = {m: scores("mujoco", strategy, m, [maze])[:, 0] for m, _, _ in METRICS}
            rows.append(
                [
                    maze,
                    STRATEGY_NAMES.get(strategy, strategy),
                    _ci(stats.mean_ci(jx["return"]), 1),
                    _ci(stats.mean_ci(mj["return"]), 1),
                    _ci(stats.mean_ci(mj["return"] - jx["return"]), 1, "+"),
                    f"{jx['goals'].mean():.2f}",
                    f"{mj['goals'].mean():.2f}",
                    f"{jx['collision_rate'].mean():.2f}",
                    f"{mj['collision_rate'].mean():.2f}",
                ]
            )
    lines += _table(header, rows)
    return "\n".join(lines) + "\n"


def realism_markdown(text: str, baseline: str = "plain") -> str:
    """Markdown table of which training options help in MuJoCo. ``text`` is the sim2sim
    CSVs of several runs of one config, each trained with one option, in one CSV
    with an ``option`` column first (:data:`REALISM_COLUMNS`; the same mazes,
    strategies and seeds for every option); ``baseline`` names the run trained
    without any.

    Per option and strategy, over all test mazes: MuJoCo's return, and the chance
    that a seed trained with the option scores more in MuJoCo than a seed trained
    without (rliable's probability of improvement, mazes as tasks, with its
    bootstrap interval, seeds of the two runs resampled independently); then the
    gap, MuJoCo minus jaxnav, signed and as the mean size of a seed's per-maze gap,
    with the chance that the option's gaps are smaller than the baseline's."""
    res: dict[str, dict] = {}
    for row, key, values in _summary_entries(text):
        res.setdefault(row["option"], {})[key] = values
    if baseline not in res:
        raise ValueError(f"no run named {baseline!r} to compare with")
    keys = [k for k in res[baseline] if k[0] == "mujoco"]
    mazes = ordered_unique(k[1] for k in keys)
    strategies = ordered_unique(k[2] for k in keys)
    seeds = sorted({k[3] for k in keys})
    for name, r in res.items():
        have = {k for k in r if k[0] == "mujoco"}
        if have != set(keys):
            raise ValueError(f"{name}'s mazes, strategies or seeds differ from {baseline}'s")

    def scores(name, sim, strategy):  # f[seeds, mazes]
        r = res[name]
        return np.asarray([[r[(sim, m, strategy, s)]["return"] for m in mazes] for s in seeds])

    def verdict(p: stats.Interval, better: str, worse: str) -> str:
        return {1: better, -1: worse, 0: "no difference"}[stats.side(p)]

    header = ["option", "strategy", "MuJoCo return", f"P(MuJoCo return > {baseline}'s)"]
    header += ["gap", "size of gap", f"P(gap smaller than {baseline}'s)", "narrows the gap?"]
    rows = []
    for name in [baseline, *(n for n in res if n != baseline)]:
        for strategy in strategies:
            mj, jx = scores(name, "mujoco", strategy), scores(name, "jaxnav", strategy)
            size = np.abs(mj - jx)
            row = [name, STRATEGY_NAMES.get(strategy, strategy), _ci(stats.mean_ci(mj), 1)]
            if name == baseline:
                row += ["", _ci(stats.mean_ci(mj - jx), 1, "+"), _ci(stats.mean_ci(size), 1)]
                row += ["", ""]
            else:
                base_mj = scores(baseline, "mujoco", strategy)
                base_size = np.abs(base_mj - scores(baseline, "jaxnav", strategy))
                p_return = stats.probability_of_improvement_ci(mj, base_mj)
                p_gap = stats.probability_of_improvement_ci(-size, -base_size)
                row += [
                    f"{_ci(p_return, 2)} {verdict(p_return, 'higher', 'lower')}",
                    _ci(stats.mean_ci(mj - jx), 1, "+"),
                    _ci(stats.mean_ci(size), 1),
                    _ci(p_gap, 2),
                    verdict(p_gap, "yes", "widens it"),
                ]
            rows.append(row)
    n_eps = ordered_unique(
        int(v["episodes"]) for r in res.values() for k, v in r.items() if k[0] == "mujoco"
    )
    lines = [
        f"Every policy greedy, {len(seeds)} seeds per strategy and option, test mazes "
        f"{', '.join(mazes)}, {'/'.join(map(str, n_eps))} MuJoCo episodes per policy and "
        "maze. Return: mean over seeds and mazes with a 95% bootstrap interval over "
        f"seeds. P(MuJoCo return > {baseline}'s): the chance that a seed trained with the "
        f"option scores more in MuJoCo than a seed trained without (rliable's probability "
        "of improvement over the mazes; 95% interval, the two runs' seeds resampled "
        "independently). Gap: a seed's MuJoCo return minus its jaxnav return on the same "
        "maze, averaged (signed) and as its size (mean absolute gap per seed and maze); "
        "jaxnav's column is tested in the run's own training settings. A verdict needs "
        "its interval to exclude 0.5.",
        "",
    ]
    return "\n".join(lines + _table(header, rows)) + "\n"


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return lines + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]


# ----------------------------------------------------------------------------
# The command
# ----------------------------------------------------------------------------


def sim2sim(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    seeds: Sequence[int] | None = None,
    out: str | Path | None = None,
    noise_std: float = LIDAR_NOISE_STD,
    progress=None,
) -> tuple[Path, Path]:
    """Test a run's policies in MuJoCo and in jaxnav; write the CSV and its table.

    Returns the paths of the CSV and of the markdown table.
    """
    mujoco = _mujoco()  # before any work: say at once if MuJoCo is missing
    run_dir = rundir.existing(run_dir, finished=True)
    cfg = load_config(str(run_dir / rundir.CONFIG))
    if n_episodes is not None and n_episodes < 1:
        raise JaxnavError("--episodes must be at least 1")
    if not (math.isfinite(noise_std) and noise_std >= 0):
        raise JaxnavError(f"--lidar-noise must be a finite number >= 0, not {noise_std}")
    names = list(maze_names) if maze_names else list(cfg.run.test_mazes)
    if len(set(names)) != len(names):
        raise JaxnavError("a maze is listed twice")
    for name in names:
        make_maze(name)  # a bad maze fails before any simulation
    n_episodes = cfg.run.test_episodes if n_episodes is None else n_episodes
    labels = policy_labels(run_dir, cfg, seeds)
    out = Path(out) if out is not None else run_dir / "sim2sim" / "sim2sim.csv"
    if out.parent == run_dir / "sim2sim":
        out.parent.mkdir(exist_ok=True)
    if not out.parent.is_dir():
        raise JaxnavError(f"cannot write {out}: directory {out.parent} does not exist")
    jx, source = jaxnav_results(run_dir, names, labels)
    mj = mujoco_results(run_dir, cfg, names, labels, n_episodes, noise_std, progress=progress)
    text = rundir.csv_text(
        SUMMARY_COLUMNS, [*summary_rows("jaxnav", jx), *summary_rows("mujoco", mj)]
    )
    table = gap_markdown(text, f"Sim-to-sim gap of {run_dir.name}: jaxnav and MuJoCo")
    table += (
        f"\njaxnav: {source}. MuJoCo {mujoco.__version__}: physics step {TIMESTEP} s, "
        f"LiDAR noise sigma {noise_std} m, {N_RAYS} rays.\n"
    )
    md = out.with_suffix(".md")
    rundir.atomic_write_text(out, text)
    rundir.atomic_write_text(md, table)
    return out, md


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="python -m jaxnav.sim2sim",
        description="Test every trained policy of a run, exported as for the robot, on a "
        "TurtleBot3 burger in MuJoCo physics (wheel servos, contacts, ray-cast LiDAR), "
        "beside jaxnav's own test of the same policies; write a per-seed CSV and a "
        "markdown table of the gap.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a finished training run (with params.npz)")
    p.add_argument(
        "--mazes",
        nargs="+",
        metavar="M",
        help="test mazes (default the config's run.test_mazes): built-in names or maze YAML paths",
    )
    p.add_argument(
        "--episodes",
        type=int,
        metavar="N",
        help="consecutive MuJoCo test episodes per policy and maze (default run.test_episodes)",
    )
    p.add_argument(
        "--seeds", type=int, nargs="+", metavar="K", help="test only these seeds (default all)"
    )
    p.add_argument(
        "--out",
        metavar="FILE",
        help="the CSV (default RUN_DIR/sim2sim/sim2sim.csv); the table goes beside it as .md",
    )
    p.add_argument(
        "--lidar-noise",
        type=float,
        default=LIDAR_NOISE_STD,
        metavar="SIGMA",
        help=f"Gaussian range noise of the MuJoCo LiDAR in m (default {LIDAR_NOISE_STD})",
    )
    args = p.parse_args(argv)

    def work() -> None:
        say = lambda line: print(line, file=sys.stderr, flush=True)
        csv_path, md = sim2sim(
            args.run_dir, args.mazes, args.episodes, args.seeds, args.out, args.lidar_noise, say
        )
        print(f"wrote {csv_path} and {md}")

    return cli.run(p.prog, work)
