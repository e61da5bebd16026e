#!/usr/bin/env python3
"""ROS 2 node: drive a TurtleBot3 to goals with a policy trained by jaxnav.

Not yet run on a robot. tests/test_ros2.py runs it closed-loop, as its own process
through real DDS messages (rclpy 9.1.2 from PyPI's ros-rclpy wheels, i.e. ROS 2
Kilted; RMW rmw_fastrtps_cpp 9.3.3, Fast DDS 3.2.3; Python 3.11.7 on Debian 12 x86_64;
loopback only), against two simulated TurtleBot3s:

  * jaxnav's own LiDAR and exact motion behind /scan, /odom and /cmd_vel, at 5 Hz
    (tests/_ros2_sim.py): to goals in the square4 maze with both Twist and
    TwistStamped on /cmd_vel, and its stops on stale odometry, NaN scans, a scan the
    policy does not match, a goal in another frame, an odometry jump and SIGINT;
  * the MuJoCo burger in real time as its own ROS 2 node (jaxnav/robot/mujoco_ros2.py,
    MuJoCo 4.0.0: wheel servos, tyre contacts, a ray-cast LiDAR 3.2 cm behind the
    axle, odometry from the wheels; TwistStamped): to two goals in square4 without a
    contact, each stop within the goal radius by odometry and within 0.3 m by the
    true pose, and the stop on SIGINT.

A real robot's latency, sensor and drift, turtlebot3_node itself, Humble's or
Jazzy's own rclpy and another RMW are not tested. Keep a hand on the stop button. To
run that test:

    scripts/ros2_env.sh --install-only      # the ROS 2 venv .venv-ros2 (PyPI wheels)
    python -m pytest tests/test_ros2.py     # from jaxnav's own environment

On a robot:

    # on the training machine
    jaxnav export runs/paper_no_obstacles --strategy ebe --seed 0 --out policy.npz
    # on the robot (ROS 2 sourced; needs NumPy, not JAX: jaxnav/robot's deploy.py, scan.py,
    # controller.py and shipped.py next to this file, or jaxnav importable)
    python3 ros2_policy_node.py --ros-args -p policy:=policy.npz
    python3 ros2_policy_node.py --policy drive_anywhere    # a policy that ships with jaxnav
    # a goal 1 m ahead and 0.5 m to the left of where odometry started
    ros2 topic pub --once /goal_pose geometry_msgs/msg/PoseStamped \\
        "{header: {frame_id: odom}, pose: {position: {x: 1.0, y: 0.5}}}"

Topics:
  /scan      sensor_msgs/LaserScan   subscribed with sensor-data QoS (best effort, as the
             LDS-01/02/03 drivers publish it); 360-degree scans (0 = no return)
  /odom      nav_msgs/Odometry       subscribed (best effort: matches a reliable
             publisher too); x, y and yaw (from the quaternion)
  /goal_pose geometry_msgs/PoseStamped subscribed; only position x, y are used, and they
             must be in the odometry frame (RViz2's "2D Goal Pose" tool publishes this
             topic in RViz's fixed frame: set that to odom). A goal stamped with another
             frame is refused (no TF lookup here).
  /cmd_vel   geometry_msgs/Twist or TwistStamped, published once per scan (one action
             per scan, as in training): linear.x = the policy's speed (0.15 m/s),
             angular.z = the greedy action's angular velocity. Which type is parameter
             enable_stamped_cmd_vel, named and meant as turtlebot3_node's: its default
             is what the running distribution's TurtleBot3 stack expects, i.e. Twist on
             Humble and older, TwistStamped on Jazzy and later; taken from ROS_DISTRO,
             or, where that is unset, from rclpy's version (7.x is Jazzy's).

The node publishes a zero twist (stop) whenever there is no goal, the latest scan or
odometry is older than ``stale_after`` seconds (a timer keeps stopping the robot while
no scan arrives), the goal is within ``goal_tolerance`` (then the goal is cleared:
send a new one), and on SIGINT or SIGTERM (then it exits with status 0). Bad input
also stops it, with one log line per reason until the robot drives again or gets a
new goal (not one per message):

  * a scan the policy does not match: fewer rays than the policy's beams, a ray count
    that disagrees with the scan's own angles, a scan not covering 360 degrees, a
    range_max below the policy's max range or a range_min more than 5 cm above its
    min range, or non-finite angles or limits;
  * a scan with NaN at more than half of the rays the policy reads: a blind sensor (a
    few NaN, 0 or +inf readings are read as no return, as jaxnav/robot/deploy.py
    says, since drivers differ in how they mark a ray without a return);
  * odometry whose pose is not finite (until a finite one comes), or that jumps more
    than ``odom_jump`` metres between two messages (a reset, a relocalisation): then
    the goal is cleared, send a new one;
  * a goal in another frame than the odometry's: refused, and the current goal with it.

An exception in a callback is logged once and stops the robot; it never loops.

Parameters: policy (path of the exported .npz, or the name of a policy that ships with
jaxnav: ``--policy NAME`` before ``--ros-args`` sets it too), goal_topic (/goal_pose), stale_after
(0.5 s), goal_tolerance (default the policy's goal radius, 0.2 m), invalid_range
(value for 0 / nan readings; negative means the policy's max range, the default),
enable_stamped_cmd_vel (see /cmd_vel), odom_jump (0.5 m).
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import os
import signal
import sys
from pathlib import Path

import numpy as np


def _load(name: str):
    """jaxnav.robot.NAME (deploy, controller), or NAME.py by path where jaxnav (or JAX)
    is not installed: the robot side's files (deploy.py, scan.py, controller.py and
    shipped.py) copied next to this node, or a checkout's."""
    try:
        return importlib.import_module(f"jaxnav.robot.{name}")
    except ImportError:
        here = Path(__file__).resolve().parent
        for path in (here / f"{name}.py", here.parent / "jaxnav" / "robot" / f"{name}.py"):
            if path.is_file():
                spec = importlib.util.spec_from_file_location(f"jaxnav_{name}", path)
                module = importlib.util.module_from_spec(spec)
                spec.loader.exec_module(module)
                return module
        raise ImportError(
            f"cannot find jaxnav.robot.{name}: install jaxnav or copy the robot side's files "
            "(jaxnav/robot/deploy.py, scan.py, controller.py, shipped.py) next to this file"
        ) from None


deploy, controller = _load("deploy"), _load("controller")
scan = _load("scan")
shipped = _load("shipped")  # --policy NAME|FILE: a file, one beside this node, or a shipped one
policy_arg = shipped.policy_arg


def policy_file(name_or_file: str) -> str:
    """The policy file to drive with (jaxnav.robot.shipped.node_policy_file)."""
    return shipped.node_policy_file(name_or_file, Path(__file__).resolve().parent)


POLICY = ["policy.npz"]  # the policy parameter's default: --policy NAME|FILE sets it

# ----------------------------------------------------------------------------
# What the node decides without ROS (tests/test_ros2.py calls these directly)
# ----------------------------------------------------------------------------

# Twist on Humble and older, TwistStamped after (controller.py says why).
default_stamped = controller.default_stamped
RANGE_MIN_SLACK = 0.05  # m: a LiDAR blind this much nearer than training is a mismatch
MAX_NAN_FRACTION = 0.5  # of the policy's beams: more NaN than this and the scan is unusable


def scan_problem(
    policy,
    ranges,
    angle_min: float,
    angle_max: float,
    angle_increment: float,
    range_min: float,
    range_max: float,
) -> str | None:
    """Why the policy cannot act on this scan (one line), or None.

    Checks what a scan must share with the policy: enough rays over 360 degrees,
    consistent angles, range limits that cover the trained ones, and mostly non-NaN
    readings at the trained beams. Single invalid readings are the policy's business
    (scan.clean_ranges).
    """
    n = len(ranges)
    fields = (angle_min, angle_max, angle_increment, range_min, range_max)
    if not all(math.isfinite(v) for v in fields):
        return (
            "scan angles or range limits are not finite (angle_min, angle_max, "
            f"angle_increment, range_min, range_max = {', '.join(f'{v:g}' for v in fields)})"
        )
    if n < policy.n_beams:
        return f"scan has {n} rays, fewer than the policy's {policy.n_beams} beams"
    if n > 1 and angle_increment != 0.0:
        described = round((angle_max - angle_min) / angle_increment) + 1
        if abs(described - n) > 1:
            return (
                f"scan has {n} rays but its angles describe {described} "
                f"({angle_min:g} to {angle_max:g} rad by {angle_increment:g})"
            )
    if range_max < policy.max_range - 1e-3:
        return (
            f"scan range_max {range_max:g} m is below the policy's max range "
            f"{policy.max_range:g} m: it was trained on a longer-range LiDAR"
        )
    if range_min > policy.min_range + RANGE_MIN_SLACK:
        return (
            f"scan range_min {range_min:g} m is above the policy's min range "
            f"{policy.min_range:g} m: near walls would read as no return"
        )
    try:
        idx = scan.nearest_rays(n, angle_min, angle_increment, policy.n_beams, policy.beam_layout)
    except ValueError as e:
        return f"scan does not match the policy: {e}"
    nan = int(np.isnan(np.asarray(ranges, np.float64)[idx]).sum())
    if nan > MAX_NAN_FRACTION * policy.n_beams:
        return f"scan reads NaN at {nan} of the policy's {policy.n_beams} beams"
    return None


def odom_jump(previous, pose) -> float:
    """How far (m) odometry moved between two poses (x, y, yaw); inf if not finite."""
    d = math.hypot(pose[0] - previous[0], pose[1] - previous[1])
    return d if math.isfinite(d) else math.inf


# ----------------------------------------------------------------------------
# The ROS 2 node
# ----------------------------------------------------------------------------


class PolicyNode:
    """The ROS 2 side of :class:`controller.Controller`: messages in, twists out (one
    executor thread, so no lock)."""

    def __init__(self, node):
        from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
        from nav_msgs.msg import Odometry
        from rclpy.qos import qos_profile_sensor_data
        from sensor_msgs.msg import LaserScan

        self.node = node
        path = policy_file(node.declare_parameter("policy", POLICY[0]).value)
        policy = self.policy = deploy.Policy.load(path)
        goal_topic = node.declare_parameter("goal_topic", "/goal_pose").value
        invalid = float(node.declare_parameter("invalid_range", -1.0).value)
        self.control = controller.Controller(
            policy,
            stale_after=float(node.declare_parameter("stale_after", 0.5).value),
            goal_tolerance=float(
                node.declare_parameter("goal_tolerance", policy.goal_radius).value
            ),
            invalid=None if invalid < 0 else invalid,
        )
        self.jump_limit = float(node.declare_parameter("odom_jump", 0.5).value)
        stamped, why = default_stamped(os.environ.get("ROS_DISTRO"), controller.rclpy_version())
        self.stamped = bool(node.declare_parameter("enable_stamped_cmd_vel", stamped).value)
        self.twist_type = TwistStamped if self.stamped else Twist
        self.last_pose = None  # the previous odometry pose, for the jump check
        self.bad_scan_at = -math.inf  # when the latest unusable scan came
        # (reason, message) logged since the robot last drove or got a goal: each
        # reason to stop is logged once, however often it recurs or alternates
        self.logged: set[tuple[str, str]] = set()
        self.odom_bad: str | None = None  # why the latest odometry is unusable
        self.shutting_down = False
        self.failed = None  # the last unexpected error logged
        self.cmd_pub = node.create_publisher(self.twist_type, "/cmd_vel", 10)
        node.create_subscription(LaserScan, "/scan", self.on_scan, qos_profile_sensor_data)
        node.create_subscription(Odometry, "/odom", self.on_odom, qos_profile_sensor_data)
        node.create_subscription(PoseStamped, goal_topic, self.on_goal, 10)
        node.create_timer(policy.dt, self.on_timer)
        m = policy.meta
        self.log().info(
            f"policy {path}: {m.get('strategy')} seed {m.get('seed')} trained on {m.get('maze')}, "
            f"{policy.n_beams} beams{' + obstacle features' if policy.obstacle_obs else ''}; "
            f"/cmd_vel as {self.twist_type.__name__} (default {'stamped' if stamped else 'Twist'}"
            f" from {why}); one command per scan; waiting for a goal on {goal_topic}"
        )

    def log(self):
        return self.node.get_logger()

    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    # -- callbacks: none of them raises ---------------------------------------

    def on_scan(self, msg) -> None:
        try:
            now = self.now()
            why = scan_problem(
                self.policy,
                msg.ranges,
                msg.angle_min,
                msg.angle_max,
                msg.angle_increment,
                msg.range_min,
                msg.range_max,
            )
            if why is not None:  # the previous scan is not acted on either: no decide()
                self.bad_scan_at = now
                self.publish(controller.Command(0.0, 0.0, "bad input", f"{why}: stopped"))
                return
            if self.odom_bad is not None:  # nor is the last good pose
                self.publish(controller.Command(0.0, 0.0, "bad input", self.odom_bad))
                return
            self.control.on_scan(msg.ranges, msg.angle_min, msg.angle_increment, now)
            self.publish(self.control.decide(now))
        except Exception as e:  # noqa: BLE001 - one log line and a stop, never a loop
            self.fail("scan", e)

    def on_odom(self, msg) -> None:
        try:
            q, p = msg.pose.pose.orientation, msg.pose.pose.position
            pose = (p.x, p.y, scan.yaw_from_quaternion(q.x, q.y, q.z, q.w))
            if not all(math.isfinite(v) for v in pose):
                self.odom_bad = "odometry pose is not finite: stopped"
                self.publish(controller.Command(0.0, 0.0, "bad input", self.odom_bad))
                return
            self.odom_bad = None
            previous, self.last_pose = self.last_pose, pose
            if previous is not None:
                jump = odom_jump(previous, pose)
                if jump > self.jump_limit and self.control.goal is not None:
                    self.control.goal = None
                    self.publish(
                        controller.Command(
                            0.0,
                            0.0,
                            "bad input",
                            f"odometry jumped {jump:.2f} m between two messages (a reset?): "
                            "goal cleared, stopped; send a new goal",
                        )
                    )
            self.control.on_odom(pose, msg.header.frame_id, self.now())
        except Exception as e:  # noqa: BLE001
            self.fail("odometry", e)

    def on_goal(self, msg) -> None:
        try:
            x, y, frame = msg.pose.position.x, msg.pose.position.y, msg.header.frame_id
            odom_frame = self.control.odom[1] if self.control.odom else ""
            goal_frame = str(frame or "").lstrip("/")
            if odom_frame and goal_frame and goal_frame != odom_frame:
                self.control.goal = None
                self.publish(
                    controller.Command(
                        0.0,
                        0.0,
                        "frame",
                        f"goal refused: frame '{goal_frame}' is not the odometry frame "
                        f"'{odom_frame}' (no TF lookup here); current goal cleared, stopped",
                    ),
                    force_log=True,
                )
                return
            try:
                self.control.on_goal((x, y), frame)
            except ValueError as e:
                self.control.goal = None
                self.publish(controller.Command(0.0, 0.0, "bad input", f"goal refused: {e}"), True)
                return
            self.logged.clear()
            self.log().info(f"new goal ({x:.2f}, {y:.2f}) in frame '{frame}'")
        except Exception as e:  # noqa: BLE001
            self.fail("goal", e)

    def on_timer(self) -> None:
        try:
            now = self.now()
            cmd = self.control.watchdog(now)
            if cmd is not None:
                # While scans come but are unusable, on_scan stops the robot and has
                # logged why: stop quietly, so the log keeps that one line.
                quiet = 0.0 <= now - self.bad_scan_at <= self.control.stale_after
                self.publish(cmd._replace(message="") if quiet else cmd)
        except Exception as e:  # noqa: BLE001
            self.fail("timer", e)

    # -- output ------------------------------------------------------------------

    def fail(self, where: str, e: Exception) -> None:
        """An unexpected error: stop, and log it once (not once per message)."""
        msg = f"{where} callback failed ({type(e).__name__}: {e}): stopped"
        try:
            if not self.shutting_down:
                self.cmd_pub.publish(self.twist(0.0, 0.0))
        except Exception as e2:  # noqa: BLE001 - nothing more can be done from here
            msg += f"; the stop could not be sent ({type(e2).__name__}: {e2})"
        if msg != self.failed:
            self.failed = msg
            self.log().error(msg)

    def twist(self, linear: float, angular: float):
        msg = self.twist_type()
        t = msg.twist if self.stamped else msg
        t.linear.x, t.angular.z = float(linear), float(angular)
        if self.stamped:
            msg.header.stamp = self.node.get_clock().now().to_msg()
        return msg

    def publish(self, cmd, force_log: bool = False) -> None:
        """Publish a controller.Command; log why it stops, once per stop (see ``logged``)."""
        if self.shutting_down:
            return
        self.cmd_pub.publish(self.twist(cmd.linear, cmd.angular))
        key = (cmd.reason, cmd.message)
        if cmd.reason == "drive":
            self.logged.clear()
        elif cmd.level and cmd.message and (force_log or key not in self.logged):
            self.logged.add(key)
            # One call per severity: rclpy refuses two severities from one call site.
            if cmd.level == "info":
                self.log().info(cmd.message)
            elif cmd.level == "warn":
                self.log().warning(cmd.message)
            else:
                self.log().error(cmd.message)

    def stop(self) -> None:
        """Leave the robot standing: one last zero twist, delivered, and nothing after it."""
        from rclpy.duration import Duration

        self.cmd_pub.publish(self.twist(0.0, 0.0))
        self.shutting_down = True
        self.cmd_pub.wait_for_all_acked(Duration(seconds=1.0))


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def main(args=None) -> int:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    # Python's own SIGINT handling (KeyboardInterrupt), not rclpy's: rclpy's would shut
    # the context down first, and the final stop could no longer be published.
    argv = list(sys.argv if args is None else args)
    POLICY[0] = policy_arg(argv) or POLICY[0]  # --policy NAME|FILE, before --ros-args
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    signal.signal(signal.SIGTERM, _interrupt)
    node = rclpy.create_node("jaxnav_policy")
    try:
        policy_node = PolicyNode(node)
    except deploy.PolicyError as e:
        node.get_logger().fatal(str(e))
        node.destroy_node()
        rclpy.shutdown()
        return 1
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except KeyboardInterrupt:
        node.get_logger().info("interrupted: stopping the robot")
    finally:
        try:
            policy_node.stop()
        except Exception as e:  # noqa: BLE001 - the context may be gone already
            print(f"jaxnav_policy: final stop not sent ({type(e).__name__}: {e})", file=sys.stderr)
        executor.shutdown()
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
