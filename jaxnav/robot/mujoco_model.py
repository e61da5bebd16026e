"""The TurtleBot3 burger in a jaxnav maze as a MuJoCo model (MJCF), NumPy only.

* Robot: ROBOTIS' burger (turtlebot3_description): wheel radius 0.033 m, wheel
  separation 0.160 m, 1.0 kg (chassis 0.826, LiDAR 0.114, wheels 0.0285 each,
  caster 0.005), the chassis collision box 0.140 x 0.140 x 0.143 m centred 0.032 m
  behind the wheel axle, the LDS-01 on top 0.032 m behind the axle, a frictionless
  ball caster. Each wheel is a velocity servo (MuJoCo ``velocity`` actuator) with
  the XL430-W250's 1.4 N m stall torque as its limit and rubber tyres (friction 0.8)
  on the floor: a command (v, omega) sets the wheel speeds (v -/+ omega L / 2) / r
  (left/right) (:func:`wheel_speeds`) and the robot moves through contact physics,
  never by setting its pose.
* Maze: extruded from jaxnav's own geometry (:class:`jaxnav.world.maps.Maze`, passed
  in; this module never imports it, nor JAX): every wall segment (outline and
  polygon edges) a thin box whose face lies on the segment, every cylinder a
  cylinder; 0.5 m high.

MuJoCo itself is imported only when a model is loaded (:func:`mujoco_module`), so
that a missing install is one line saying how to get it (optional extra ``sim``).
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np

from jaxnav.core.errors import JaxnavError

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

# The simulation and the maze.
TIMESTEP = 0.005  # s, physics (200 Hz): 40 steps per 0.2 s control period
WALL_THICKNESS = 0.05  # m
WALL_HEIGHT = 0.5  # m

# Contact bits: the floor touches the wheels and the caster; walls and obstacles
# touch every robot geom; nothing else touches. Geom groups pick what the LiDAR sees.
FLOOR_BIT, MAZE_BIT = 1, 2
MAZE_GROUP = 1


class MazeGeometry(Protocol):
    """What the model needs of a maze (:class:`jaxnav.world.maps.Maze` has it)."""

    start: Any  # (x, y, yaw)

    def walls(self) -> np.ndarray: ...  # f[S, 4] real wall segments

    def obstacles(self) -> np.ndarray: ...  # f[C, 3] real cylinders (cx, cy, r)


def mujoco_module():
    """The mujoco module, or a one-line JaxnavError saying how to install it."""
    try:
        import mujoco
    except ImportError:
        raise JaxnavError(
            "MuJoCo is not installed: pip install mujoco (or jaxnav's 'sim' extra)"
        ) from None
    return mujoco


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


def maze_mjcf(maze: MazeGeometry) -> str:
    """MJCF geoms of a maze: a thin box behind every wall segment (its face on the
    segment, the box on the side away from free space) and a cylinder per obstacle."""
    walls, circles = maze.walls().astype(np.float64), maze.obstacles().astype(np.float64)
    inward = free_side_normals(walls) if len(walls) else np.zeros((0, 2))
    common = f'group="{MAZE_GROUP}" contype="{MAZE_BIT}" conaffinity="0" rgba=".7 .7 .7 1"'
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
    floor_and_maze = FLOOR_BIT | MAZE_BIT
    body = f'group="2" contype="0" conaffinity="{MAZE_BIT}"'
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


def world_mjcf(maze: MazeGeometry, timestep: float = TIMESTEP) -> str:
    """The whole MJCF model: floor, maze, burger at the maze's start, wheel servos."""
    x, y, yaw = (float(v) for v in np.asarray(maze.start))
    servo = f'kv="{SERVO_GAIN}" forcerange="{-WHEEL_TORQUE} {WHEEL_TORQUE}"'
    return f"""<mujoco model="jaxnav_burger">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep}" integrator="implicitfast"/>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.05" friction="{TYRE_FRICTION} 0.005 0.0001"
          group="0" contype="{FLOOR_BIT}" conaffinity="0"/>
    {maze_mjcf(maze)}
    {burger_mjcf(x, y, yaw)}
  </worldbody>
  <actuator>
    <velocity name="wheel_left" joint="wheel_left" {servo}/>
    <velocity name="wheel_right" joint="wheel_right" {servo}/>
  </actuator>
</mujoco>
"""


def load_model(maze: MazeGeometry, timestep: float = TIMESTEP):
    """The compiled ``mujoco.MjModel`` of :func:`world_mjcf`."""
    return mujoco_module().MjModel.from_xml_string(world_mjcf(maze, timestep))
