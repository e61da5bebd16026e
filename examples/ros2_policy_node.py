#!/usr/bin/env python3
"""ROS 2 node: drive a TurtleBot3 to a goal with a policy trained by jaxnav.

UNTESTED ON A ROBOT. It compiles and uses only the adapter that tests/test_deploy.py
checks against the simulator (jaxnav.deploy.Policy.command), but nobody has run it
on a TurtleBot3 yet. Keep a hand on the stop button.

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
  /cmd_vel   geometry_msgs/Twist     published at 1/dt = 5 Hz (one action per scan,
             as in training): linear.x = 0.15 m/s, angular.z = the greedy action's
             angular velocity. Newer TurtleBot3 stacks that expect TwistStamped need
             the publisher changed.

The node publishes a zero twist (stop) whenever there is no goal, the latest scan
or odometry is older than ``stale_after`` seconds, the goal is within
``goal_tolerance`` (then the goal is cleared: send a new one), the scan cannot be
used (e.g. it does not cover 360 degrees), and on shutdown.

Parameters: policy (path of the exported .npz), goal_topic (/goal_pose), rate_hz
(default 1 / the policy's dt), stale_after (0.5 s), goal_tolerance (default the
policy's goal radius, 0.2 m), invalid_range (value for 0 / nan readings; negative
means the policy's max range, the default; see jaxnav/deploy.py).
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan


def _load_deploy():
    """jaxnav.deploy, or deploy.py by path where jaxnav (or JAX) is not installed."""
    try:
        from jaxnav import deploy

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
            "cannot find jaxnav.deploy: install jaxnav or copy deploy.py next to this file"
        ) from None


deploy = _load_deploy()


class PolicyNode(Node):
    def __init__(self):
        super().__init__("jaxnav_policy")
        path = self.declare_parameter("policy", "policy.npz").value
        self.policy = deploy.Policy.load(path)
        p = self.policy
        goal_topic = self.declare_parameter("goal_topic", "/goal_pose").value
        rate_hz = float(self.declare_parameter("rate_hz", 1.0 / p.dt).value)
        self.stale_after = float(self.declare_parameter("stale_after", 0.5).value)
        self.goal_tolerance = float(self.declare_parameter("goal_tolerance", p.goal_radius).value)
        invalid = float(self.declare_parameter("invalid_range", -1.0).value)
        self.invalid = None if invalid < 0 else invalid

        self.scan = None  # (LaserScan, receive time)
        self.odom = None  # ((x, y, yaw), frame_id, receive time)
        self.goal = None  # ((x, y), frame_id)
        self.cmd_pub = self.create_publisher(Twist, "/cmd_vel", 10)
        self.create_subscription(LaserScan, "/scan", self.on_scan, qos_profile_sensor_data)
        self.create_subscription(Odometry, "/odom", self.on_odom, qos_profile_sensor_data)
        self.create_subscription(PoseStamped, goal_topic, self.on_goal, 10)
        self.create_timer(1.0 / rate_hz, self.tick)
        m = p.meta
        self.get_logger().info(
            f"policy {path}: {m.get('strategy')} seed {m.get('seed')} trained on {m.get('maze')}, "
            f"{p.n_beams} beams{' + obstacle features' if p.obstacle_obs else ''}; "
            f"{rate_hz:.1f} Hz; waiting for a goal on {goal_topic}"
        )

    def now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_scan(self, msg: LaserScan):
        self.scan = (msg, self.now())

    def on_odom(self, msg: Odometry):
        q = msg.pose.pose.orientation
        yaw = deploy.yaw_from_quaternion(q.x, q.y, q.z, q.w)
        pos = msg.pose.pose.position
        self.odom = ((pos.x, pos.y, yaw), msg.header.frame_id, self.now())

    def on_goal(self, msg: PoseStamped):
        self.goal = ((msg.pose.position.x, msg.pose.position.y), msg.header.frame_id)
        self.get_logger().info(f"new goal ({self.goal[0][0]:.2f}, {self.goal[0][1]:.2f})")

    def stop(self):
        self.cmd_pub.publish(Twist())

    def tick(self):
        now, log = self.now(), self.get_logger()
        if self.goal is None:
            return self.stop()
        if self.scan is None or self.odom is None:
            log.warn("no scan or odometry yet: stopped", throttle_duration_sec=2.0)
            return self.stop()
        scan, t_scan = self.scan
        pose, odom_frame, t_odom = self.odom
        if now - t_scan > self.stale_after or now - t_odom > self.stale_after:
            log.warn("scan or odometry is stale: stopped", throttle_duration_sec=2.0)
            return self.stop()
        goal, goal_frame = self.goal
        if goal_frame and odom_frame and goal_frame != odom_frame:
            log.warn(
                f"goal is in frame '{goal_frame}', not the odometry frame '{odom_frame}': stopped",
                throttle_duration_sec=2.0,
            )
            return self.stop()
        if math.hypot(goal[0] - pose[0], goal[1] - pose[1]) < self.goal_tolerance:
            log.info("goal reached: stopped; waiting for a new goal")
            self.goal = None
            return self.stop()
        try:
            linear, angular = self.policy.command(
                scan.ranges, scan.angle_min, scan.angle_increment, pose, goal, self.invalid
            )
        except ValueError as e:  # e.g. a scan that does not cover 360 degrees
            log.error(f"cannot use this scan: {e}", throttle_duration_sec=2.0)
            return self.stop()
        cmd = Twist()
        cmd.linear.x = float(linear)
        cmd.angular.z = float(angular)
        self.cmd_pub.publish(cmd)


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
