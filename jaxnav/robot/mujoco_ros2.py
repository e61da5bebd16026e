"""The MuJoCo TurtleBot3 burger as a ROS 2 robot in real time: /scan, /odom, /cmd_vel.

``python -m jaxnav.robot.mujoco_ros2 --ros-args -p maze:=policy.npz`` runs the burger
of :mod:`jaxnav.robot.mujoco_model` (wheel servos, tyre contacts, ray-cast LiDAR:
:class:`jaxnav.robot.mujoco_rollout.Burger`) with physics advanced in step with the
wall clock, and speaks to ROS 2 as a TurtleBot3 does, so that a policy node (the same
one that would drive the real robot, examples/ros2_policy_node.py) drives it through
DDS:

  /scan          sensor_msgs/LaserScan, sensor-data QoS (best effort, keep last 5), as
                 the LDS-01 driver: 360 rays 1 degree apart counter-clockwise from
                 ahead (angle_min 0, angle_max 359 degrees), range_min 0.12, range_max
                 3.5, no return (or nearer than range_min) reads 0.0; frame base_scan,
                 cast from the LiDAR 3.2 cm behind the axle with Gaussian noise
                 (``lidar_noise``, 0.01 m); every ``1 / scan_rate`` s of simulated time
  /odom          nav_msgs/Odometry (reliable, depth 10), frame odom, child
                 base_footprint: as turtlebot3_node's (turtlebot3_node/src/odometry.cpp),
                 the distance from the wheels' turns (their joint angles) and, with
                 ``use_imu`` (true, as in turtlebot3_bringup's param/burger.yaml), the
                 heading from the IMU (here the body's true yaw: an IMU without drift)
                 or else from the wheels too; it drifts when a tyre slips. The odom
                 frame is the maze's (odometry starts at the maze's start pose); every
                 ``1 / odom_rate`` s
  /ground_truth  nav_msgs/Odometry, frame world: the true pose, with every /odom
  /cmd_vel       geometry_msgs/Twist or TwistStamped (parameter
                 ``enable_stamped_cmd_vel``, default as turtlebot3_node's and the
                 policy node's: Twist on Humble and older, TwistStamped on Jazzy and
                 later; :func:`jaxnav.robot.controller.default_stamped`): linear.x and
                 angular.z become the wheel servos' speeds, through the firmware's
                 clipping with ``wheel_limit`` (:mod:`jaxnav.world.kinematics`). As the
                 OpenCR firmware does, the wheels stop when no command has come for
                 ``cmd_timeout`` s (0.5).

Parameters: maze (a file with arrays maze/walls, maze/obstacles and maze/start: any
policy file from ``jaxnav export`` holds its training maze; this module imports no
JAX, so it cannot build a maze itself), wheel_limit (false), enable_stamped_cmd_vel,
lidar_noise (0.01), seed (0: the noise's), scan_rate (5.0), odom_rate (20.0),
use_imu (true), cmd_timeout (0.5), report (a JSON file written on exit: contacts, poses, how far
physics fell behind; empty: none).

A contact between the burger and a wall or obstacle is logged (one line when it
begins) and counted; physics goes on (the robot pushes against the wall). A command
that is not finite stops the wheels, with one log line until a good one comes. A maze
file or parameter that cannot be used ends the node with one line and status 2;
SIGINT or SIGTERM ends it with status 0. Needs rclpy, NumPy and MuJoCo
(scripts/ros2_env.sh makes such an environment); imports no JAX.

:class:`RealTimeBurger` is the robot without any middleware (physics to a given time,
wheel odometry, the watchdog, contacts, the scan); :class:`BurgerNode` is its ROS 2
side.
"""

from __future__ import annotations

import json
import math
import os
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jaxnav.core.errors import JaxnavError
from jaxnav.robot.controller import default_stamped, rclpy_version
from jaxnav.robot.mujoco_model import WHEEL_RADIUS, WHEEL_SEPARATION, mujoco_module
from jaxnav.robot.mujoco_rollout import LIDAR_NOISE_STD, N_RAYS, Burger

RANGE_MIN, RANGE_MAX = 0.12, 3.5  # m, the LDS-01's
MAX_CATCH_UP_S = 0.5  # physics further behind the clock than this gives up the gap
CHUNK_S = 0.01  # physics runs in chunks this long between callbacks (a command's latency)
CONTACT_GAP_S = 0.5  # a touch this long after the last one is a new contact


@dataclass
class MazeFile:
    """A maze's geometry read from a file (:class:`jaxnav.robot.mujoco_model.MazeGeometry`)."""

    walls_: np.ndarray  # f64[S, 4]
    obstacles_: np.ndarray  # f64[C, 3]
    start: np.ndarray  # f64[3] (x, y, yaw)

    def walls(self) -> np.ndarray:
        return self.walls_

    def obstacles(self) -> np.ndarray:
        return self.obstacles_


def load_maze_file(path: str) -> MazeFile:
    """The maze of a .npz holding maze/walls, maze/obstacles and maze/start (an exported
    policy file does); a one-line JaxnavError if it cannot be used."""
    keys = ("maze/walls", "maze/obstacles", "maze/start")
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in keys if k not in z.files]
            if missing:
                raise JaxnavError(
                    f"parameter maze: {path} has no array {missing[0]} (a maze file holds "
                    f"{', '.join(keys)}: export a policy)"
                )
            walls = np.asarray(z["maze/walls"], np.float64).reshape(-1, 4)
            obstacles = np.asarray(z["maze/obstacles"], np.float64).reshape(-1, 3)
            start = np.asarray(z["maze/start"], np.float64).reshape(3)
    except FileNotFoundError:
        raise JaxnavError(f"parameter maze: no file {path}") from None
    except (OSError, ValueError) as e:
        raise JaxnavError(f"parameter maze: {path} cannot be read ({e})") from None
    if len(walls) < 3 or not all(np.isfinite(a).all() for a in (walls, obstacles, start)):
        raise JaxnavError(f"parameter maze: {path} has no closed outline or non-finite values")
    return MazeFile(walls, obstacles, start)


@dataclass
class Odometry:
    """Odometry as turtlebot3_node's: the distance from the wheels' turns, the heading's
    change from the wheels too or from the IMU, integrated at the mid heading."""

    x: float
    y: float
    yaw: float
    v: float = 0.0
    omega: float = 0.0

    def update(self, d_left: float, d_right: float, dt: float, dyaw: float | None = None):
        """Advance by the wheels' turns (rad) over dt seconds; ``dyaw``: the heading's
        change from the IMU (rad), or None: from the wheels."""
        ds = WHEEL_RADIUS * (d_left + d_right) / 2
        if dyaw is None:
            dyaw = WHEEL_RADIUS * (d_right - d_left) / WHEEL_SEPARATION
        self.x += ds * math.cos(self.yaw + dyaw / 2)
        self.y += ds * math.sin(self.yaw + dyaw / 2)
        self.yaw = math.remainder(self.yaw + dyaw, 2 * math.pi)
        self.v, self.omega = ds / dt, dyaw / dt


@dataclass
class RealTimeBurger:
    """The MuJoCo burger advanced to given times, without any middleware.

    ``advance(t)`` runs physics up to simulated time ``t`` (s since start), keeping the
    wheel odometry and counting contacts; ``command`` sets the wheels (the
    firmware's clipping with ``wheel_limit``); the wheels stop ``cmd_timeout`` s
    after the last command.
    """

    maze: MazeFile
    wheel_limit: bool = False
    noise_std: float = LIDAR_NOISE_STD
    seed: int = 0
    cmd_timeout: float = 0.5
    use_imu: bool = True  # odometry's heading from the IMU (the true yaw), not the wheels
    t: float = 0.0  # simulated time, s
    contacts: int = 0  # contacts begun (touches less than CONTACT_GAP_S apart are one)
    contact_log: list = field(default_factory=list)  # (t, x, y) of each

    def __post_init__(self):
        self.robot = Burger(self.maze, wheel_limit=self.wheel_limit)
        self.robot.place(*(float(v) for v in self.maze.start))
        mj, m = mujoco_module(), self.robot.model
        self._wheels = [
            m.jnt_qposadr[mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, f"wheel_{side}")]
            for side in ("left", "right")
        ]
        self.odom = Odometry(*(float(v) for v in self.maze.start))
        self._angles = self._wheel_angles()
        self._yaw = self.robot.pose()[2]  # the IMU's last heading
        self._touched = -math.inf  # simulated time of the last touch
        self._last_cmd = -math.inf  # simulated time of the last command
        self.driving = (0.0, 0.0)  # (v, omega) the wheels are set to
        self.rng = np.random.default_rng(self.seed)
        self.dt = float(m.opt.timestep)

    def _wheel_angles(self) -> np.ndarray:
        return np.asarray([self.robot.data.qpos[a] for a in self._wheels], np.float64)

    def command(self, v: float, omega: float) -> None:
        """A velocity command, now."""
        self.driving = self.robot.command(v, omega)
        self._last_cmd = self.t

    def stop(self) -> None:
        self.driving = self.robot.command(0.0, 0.0)

    def advance(self, t: float) -> list[tuple[float, float, float]]:
        """Physics up to simulated time ``t``; returns (t, x, y) of each contact begun."""
        begun = []
        while self.t + self.dt <= t + 1e-9:
            if self.t - self._last_cmd > self.cmd_timeout and self.driving != (0.0, 0.0):
                self.stop()  # the firmware's watchdog: no command, no motion
            touching = self.robot.step()
            self.t += self.dt
            angles = self._wheel_angles()
            d_left, d_right = angles - self._angles
            self._angles = angles
            dyaw = None
            if self.use_imu:
                yaw = self.robot.pose()[2]
                dyaw, self._yaw = math.remainder(yaw - self._yaw, 2 * math.pi), yaw
            self.odom.update(d_left, d_right, self.dt, dyaw)
            if touching:
                if self.t - self._touched > CONTACT_GAP_S:
                    x, y, _ = self.robot.pose()
                    self.contacts += 1
                    begun.append((round(self.t, 3), round(x, 3), round(y, 3)))
                self._touched = self.t
        self.contact_log += begun
        return begun

    def scan(self) -> np.ndarray:
        """f32[360] ranges as the LDS-01 driver reports them: no return reads 0.0."""
        r = self.robot.scan(self.rng, self.noise_std)
        return np.where(np.isfinite(r), r, 0.0).astype(np.float32)

    def summary(self) -> dict:
        o, p = self.odom, self.robot.pose()
        return {
            "sim_time": round(self.t, 3),
            "contacts": self.contacts,
            "contact_log": self.contact_log,
            "true_pose": [round(v, 4) for v in p],
            "odom_pose": [round(o.x, 4), round(o.y, 4), round(o.yaw, 4)],
            "wheel_limit": self.wheel_limit,
        }


class BurgerNode:
    """The ROS 2 side of a :class:`RealTimeBurger` (one thread: physics, publishing and
    callbacks take turns in :meth:`spin`)."""

    def __init__(self, node):
        from geometry_msgs.msg import Twist, TwistStamped
        from nav_msgs.msg import Odometry as OdometryMsg
        from rclpy.qos import QoSProfile, qos_profile_sensor_data
        from sensor_msgs.msg import LaserScan

        self.node, self.msgs = node, (LaserScan, OdometryMsg)

        def p(name: str, default):
            return node.declare_parameter(name, default).value

        maze_path = str(p("maze", ""))
        if not maze_path:
            raise JaxnavError("parameter maze: give a maze file (-p maze:=policy.npz)")
        wheel_limit = bool(p("wheel_limit", False))
        noise = float(p("lidar_noise", LIDAR_NOISE_STD))
        seed = int(p("seed", 0))
        self.scan_period = _period("scan_rate", float(p("scan_rate", 5.0)))
        self.odom_period = _period("odom_rate", float(p("odom_rate", 20.0)))
        cmd_timeout = float(p("cmd_timeout", 0.5))
        use_imu = bool(p("use_imu", True))
        self.report = str(p("report", ""))
        stamped, why = default_stamped(os.environ.get("ROS_DISTRO"), rclpy_version())
        self.stamped = bool(p("enable_stamped_cmd_vel", stamped))
        if not (math.isfinite(noise) and noise >= 0):
            raise JaxnavError(f"parameter lidar_noise must be a finite number >= 0, not {noise}")
        if not cmd_timeout > 0:
            raise JaxnavError(f"parameter cmd_timeout must be positive, not {cmd_timeout}")
        maze = load_maze_file(maze_path)
        self.robot = RealTimeBurger(maze, wheel_limit, noise, seed, cmd_timeout, use_imu)
        self.scan_pub = node.create_publisher(LaserScan, "/scan", qos_profile_sensor_data)
        self.odom_pub = node.create_publisher(OdometryMsg, "/odom", QoSProfile(depth=10))
        self.truth_pub = node.create_publisher(OdometryMsg, "/ground_truth", QoSProfile(depth=10))
        twist = TwistStamped if self.stamped else Twist
        node.create_subscription(twist, "/cmd_vel", self.on_cmd, QoSProfile(depth=10))
        self.bad_cmd = False  # a non-finite command was logged and not yet followed by a good one
        self.lag_max = 0.0  # s, how far physics fell behind the clock at most
        self.gaps = 0  # times it gave a gap up
        x, y, yaw = (float(v) for v in maze.start)
        self.log().info(
            f"MuJoCo {mujoco_module().__version__} burger in {maze_path} ({len(maze.walls())} "
            f"walls, {len(maze.obstacles())} obstacles) at ({x:g}, {y:g}, {yaw:g}); /scan "
            f"{N_RAYS} rays at {1 / self.scan_period:g} Hz, /odom from the wheels"
            f"{' and the IMU' if use_imu else ''} at {1 / self.odom_period:g} Hz, /cmd_vel as "
            f"{twist.__name__} (default "
            f"{'stamped' if stamped else 'Twist'} from {why}), wheel limit "
            f"{'on' if wheel_limit else 'off'}; real time"
        )

    def log(self):
        return self.node.get_logger()

    def on_cmd(self, msg) -> None:
        t = msg.twist if self.stamped else msg
        v, w = t.linear.x, t.angular.z
        if not (math.isfinite(v) and math.isfinite(w)):
            self.robot.stop()
            if not self.bad_cmd:
                self.log().warning(f"cmd_vel ({v}, {w}) is not finite: wheels stopped")
            self.bad_cmd = True
            return
        self.bad_cmd = False
        self.robot.command(v, w)

    def publish_scan(self) -> None:
        LaserScan, _ = self.msgs
        s = LaserScan()
        s.header.stamp, s.header.frame_id = self.node.get_clock().now().to_msg(), "base_scan"
        inc = 2 * math.pi / N_RAYS
        s.angle_min, s.angle_max, s.angle_increment = 0.0, inc * (N_RAYS - 1), inc
        s.scan_time, s.range_min, s.range_max = self.scan_period, RANGE_MIN, RANGE_MAX
        s.ranges = self.robot.scan().tolist()
        self.scan_pub.publish(s)

    def publish_odom(self) -> None:
        _, OdometryMsg = self.msgs
        stamp = self.node.get_clock().now().to_msg()
        o = self.robot.odom
        true = self.robot.robot.pose()
        for pub, frame, (x, y, yaw) in (
            (self.odom_pub, "odom", (o.x, o.y, o.yaw)),
            (self.truth_pub, "world", true),
        ):
            m = OdometryMsg()
            m.header.stamp, m.header.frame_id, m.child_frame_id = stamp, frame, "base_footprint"
            m.pose.pose.position.x, m.pose.pose.position.y = x, y
            m.pose.pose.orientation.z, m.pose.pose.orientation.w = (
                math.sin(yaw / 2),
                math.cos(yaw / 2),
            )
            m.twist.twist.linear.x, m.twist.twist.angular.z = o.v, o.omega
            pub.publish(m)

    def spin(self, executor, running) -> None:
        """Physics in step with the clock; scans and odometry when due; callbacks between."""
        t0 = time.monotonic()
        next_scan = next_odom = 0.0
        while running():
            now = time.monotonic() - t0
            behind = now - self.robot.t
            self.lag_max = max(self.lag_max, behind)
            if behind > MAX_CATCH_UP_S:  # a stalled machine: slow down, do not race
                t0 += behind - self.robot.dt
                now = time.monotonic() - t0
                self.gaps += 1
                if self.gaps == 1:
                    self.log().warning(
                        f"physics fell {behind:.2f} s behind the clock: the simulation slows "
                        "down instead of catching up (reported once)"
                    )
            for t, x, y in self.robot.advance(min(now, next_scan, next_odom)):
                self.log().warning(
                    f"contact: the burger touches a wall or obstacle at ({x:.2f}, {y:.2f}), "
                    f"t = {t:.1f} s (contact {self.robot.contacts})"
                )
            if self.robot.t + 1e-9 >= next_odom:
                self.publish_odom()
                next_odom += self.odom_period
            if self.robot.t + 1e-9 >= next_scan:
                self.publish_scan()
                next_scan += self.scan_period
            due = min(next_scan, next_odom, self.robot.t + CHUNK_S)
            executor.spin_once(timeout_sec=max(0.0, due - (time.monotonic() - t0)))

    def write_report(self) -> None:
        if self.report:
            info = dict(self.robot.summary(), lag_max=round(self.lag_max, 3), gaps=self.gaps)
            Path(self.report).write_text(json.dumps(info, indent=1))


def _period(name: str, rate: float) -> float:
    if not (math.isfinite(rate) and rate > 0):
        raise JaxnavError(f"parameter {name} must be a positive number of Hz, not {rate}")
    return 1.0 / rate


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def main(args=None) -> int:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    signal.signal(signal.SIGTERM, _interrupt)
    node = rclpy.create_node("jaxnav_mujoco_burger")
    try:
        burger = BurgerNode(node)
    except Exception as e:  # noqa: BLE001 - a parameter or file it cannot use: one line
        why = str(e) if isinstance(e, JaxnavError) else f"{type(e).__name__}: {e}"
        node.get_logger().fatal(why)
        node.destroy_node()
        rclpy.try_shutdown()
        return 2
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        burger.spin(executor, rclpy.ok)
    except KeyboardInterrupt:
        pass
    finally:
        s = burger.robot.summary()
        node.get_logger().info(
            f"stopped after {s['sim_time']:.1f} s: {s['contacts']} contacts, physics at most "
            f"{burger.lag_max:.2f} s behind the clock"
        )
        burger.write_report()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
