#!/usr/bin/env python3
"""ROS 2 node: drive a TurtleBot3 to a goal with a policy trained by jaxnav.

UNTESTED ON A ROBOT, and never run under ROS 2: it compiles, and its decisions are
jaxnav.robot.deploy.Controller's, which ros1_policy_node.py shares and tests/test_ros1.py
runs closed-loop through a live ROS 1 master. Keep a hand on the stop button.

    # on the training machine
    python -m jaxnav.export runs/paper_no_obstacles_8 --strategy ebe --seed 0 \
        --out policy.npz
    # on the robot (ROS 2 sourced; needs NumPy, not JAX)
    python3 ros2_policy_node.py --ros-args -p policy:=policy.npz
    # a goal 1 m ahead and 0.5 m to the left of where odometry started
    ros2 topic pub --once /goal_pose geometry_msgs/msg/PoseStamped \
        "{header: {frame_id: odom}, pose: {position: {x: 1.0, y: 0.5}}}"

Topics:
  /scan      sensor_msgs/LaserScan   subscribed (sensor-data QoS); the LDS-01's 360 rays
  /odom      nav_msgs/Odometry       subscribed; x, y and yaw (from the quaternion)
  /goal_pose geometry_msgs/PoseStamped subscribed; only position x, y are used, and they
             must be in the odometry frame (RViz2's "2D Goal Pose" tool publishes
             this topic; set RViz's fixed frame to odom). A goal stamped with another
             frame is refused (no TF lookup here).
  /cmd_vel   geometry_msgs/Twist     published once per scan (5 Hz on a TurtleBot3, one
             action per scan, as in training): linear.x = 0.15 m/s, angular.z = the
             greedy action's angular velocity. Newer TurtleBot3 stacks that expect
             TwistStamped need the publisher changed.

The node publishes a zero twist (stop) whenever there is no goal, the latest scan
or odometry is older than ``stale_after`` seconds (a timer keeps stopping the robot
while no scan arrives), the goal is within ``goal_tolerance`` (then the goal is
cleared: send a new one), the scan or pose cannot be used (e.g. a scan that does not
cover 360 degrees), and on shutdown.

Parameters: policy (path of the exported .npz), goal_topic (/goal_pose), stale_after
(0.5 s), goal_tolerance (default the policy's goal radius, 0.2 m), invalid_range
(value for 0 / nan readings; negative means the policy's max range, the default;
see jaxnav/robot/deploy.py).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan


def _load_deploy():
    """jaxnav.robot.deploy, or deploy.py by path where jaxnav (or JAX) is not installed."""
    try:
        from jaxnav.robot import deploy

        return deploy
    except ImportError:
        here = Path(__file__).resolve().parent
        for path in (here / "deploy.py", here.parent / "jaxnav" / "deploy.py"):
            if path.is_file():
                spec = importlib.util.spec_from_file_location("jaxnav_deploy", path)
                module = importlib.util.module_from_spec(spec)
                spec.loader.exec_module(module)
                return module
        raise ImportError(
            "cannot find jaxnav.robot.deploy: install jaxnav or copy deploy.py next to this file"
        ) from None


deploy = _load_deploy()
THROTTLE_S = 2.0  # at most one repeated warning per this many seconds


class PolicyNode(Node):
    """The ROS 2 side of :class:`deploy.Controller`: messages in, twists out (one
    executor thread, so no lock)."""

    def __init__(self):
        super().__init__("jaxnav_policy")
        path = self.declare_parameter("policy", "policy.npz").value
        policy = deploy.Policy.load(path)
        goal_topic = self.declare_parameter("goal_topic", "/goal_pose").value
        invalid = float(self.declare_parameter("invalid_range", -1.0).value)
        self.control = deploy.Controller(
            policy,
            stale_after=float(self.declare_parameter("stale_after", 0.5).value),
            goal_tolerance=float(
                self.declare_parameter("goal_tolerance", policy.goal_radius).value
            ),
            invalid=None if invalid < 0 else invalid,
        )
        self.cmd_pub = self.create_publisher(Twist, "/cmd_vel", 10)
        self.create_subscription(LaserScan, "/scan", self.on_scan, qos_profile_sensor_data)
        self.create_subscription(Odometry, "/odom", self.on_odom, qos_profile_sensor_data)
        self.create_subscription(PoseStamped, goal_topic, self.on_goal, 10)
        self.create_timer(policy.dt, self.on_timer)
        m = policy.meta
        self.get_logger().info(
            f"policy {path}: {m.get('strategy')} seed {m.get('seed')} trained on {m.get('maze')}, "
            f"{policy.n_beams} beams{' + obstacle features' if policy.obstacle_obs else ''}; "
            f"one command per scan; waiting for a goal on {goal_topic}"
        )

    def now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_scan(self, msg: LaserScan):
        now = self.now()
        self.control.on_scan(msg.ranges, msg.angle_min, msg.angle_increment, now)
        self.publish(self.control.decide(now))

    def on_odom(self, msg: Odometry):
        q, p = msg.pose.pose.orientation, msg.pose.pose.position
        pose = (p.x, p.y, deploy.yaw_from_quaternion(q.x, q.y, q.z, q.w))
        self.control.on_odom(pose, msg.header.frame_id, self.now())

    def on_goal(self, msg: PoseStamped):
        x, y, frame = msg.pose.position.x, msg.pose.position.y, msg.header.frame_id
        try:
            self.control.on_goal((x, y), frame)
        except ValueError as e:
            self.get_logger().error(f"goal refused: {e}")
            return
        self.get_logger().info(f"new goal ({x:.2f}, {y:.2f}) in frame '{frame}'")

    def on_timer(self):
        cmd = self.control.watchdog(self.now())
        if cmd is not None:
            self.publish(cmd)

    def publish(self, cmd):
        """Publish a deploy.Command and log why it stops."""
        twist = Twist()
        twist.linear.x, twist.angular.z = float(cmd.linear), float(cmd.angular)
        self.cmd_pub.publish(twist)
        log = self.get_logger()
        if cmd.level == "info":
            log.info(cmd.message)
        elif cmd.level == "warn":
            log.warn(cmd.message, throttle_duration_sec=THROTTLE_S)
        elif cmd.level == "error":
            log.error(cmd.message, throttle_duration_sec=THROTTLE_S)

    def stop(self):
        self.cmd_pub.publish(Twist())


def main(args=None) -> int:
    rclpy.init(args=args)
    node = PolicyNode()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        try:
            node.stop()  # leave the robot standing
        except Exception:  # the context may already be shut down by Ctrl-C
            pass
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
