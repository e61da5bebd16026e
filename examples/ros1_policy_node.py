#!/usr/bin/env python3
"""ROS 1 node: drive a TurtleBot3 to goals with a policy trained by jaxnav.

Not yet run on a robot. tests/test_ros1.py runs it closed-loop through a live ROS
master against a simulated TurtleBot3 (jaxnav's own LiDAR and motion behind /scan,
/odom and /cmd_vel), so the messages, the timing and the stops are tested; a real
robot's dynamics, latency and odometry drift are not. Keep a hand on the stop button.

    # on the training machine
    jaxnav export runs/paper_no_obstacles --strategy ebe --seed 0 --out policy.npz
    # on the robot (ROS 1 sourced, e.g. after roslaunch turtlebot3_bringup
    # turtlebot3_robot.launch; needs NumPy, not JAX)
    python3 ros1_policy_node.py _policy:=policy.npz
    python3 ros1_policy_node.py --policy drive_anywhere    # a policy that ships with jaxnav
    # a goal 1 m ahead and 0.5 m to the left of where odometry started
    rostopic pub -1 /move_base_simple/goal geometry_msgs/PoseStamped \\
        "{header: {frame_id: odom}, pose: {position: {x: 1.0, y: 0.5}, orientation: {w: 1.0}}}"

Topics (scan, odom and cmd_vel are relative names: ROS_NAMESPACE or remapping moves them):
  scan       sensor_msgs/LaserScan   subscribed; the LDS-01's 360 rays (0 = no return)
  odom       nav_msgs/Odometry       subscribed; x, y and yaw (from the quaternion)
  ~goal_topic geometry_msgs/PoseStamped subscribed; only position x, y are used, and
             they must be in the odometry frame: RViz's "2D Nav Goal" publishes
             /move_base_simple/goal in RViz's fixed frame, so set that to odom. A goal
             stamped with another frame is refused (no TF lookup here).
  cmd_vel    geometry_msgs/Twist     published once per scan (5 Hz on a TurtleBot3, one
             action per scan as in training): linear.x = 0.15 m/s, angular.z = the
             greedy action's angular velocity.

The node publishes a zero twist (stop) when there is no goal, the scan or odometry
is older than ~stale_after seconds (a timer keeps stopping the robot while no scan
arrives), the goal is within ~goal_tolerance (then the goal is cleared: send a new
one), the scan or pose cannot be used (e.g. a scan that does not cover 360 degrees),
and on shutdown. The decisions are jaxnav.robot.controller.Controller's, shared with
ros2_policy_node.py.

Private parameters: ~policy (path of the exported .npz, or the name of a policy that
ships with jaxnav; ``--policy NAME`` sets it too), ~goal_topic
(/move_base_simple/goal), ~stale_after (0.5 s), ~goal_tolerance (default the
policy's goal radius, 0.2 m), ~invalid_range (value for 0 / nan readings; negative
means the policy's max range, the default; see jaxnav/robot/deploy.py).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import threading
import time
from pathlib import Path

import rospy
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan


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
THROTTLE_S = 2.0  # at most one repeated warning per this many seconds


class PolicyNode:
    """The ROS 1 side of :class:`controller.Controller`: messages in, twists out.

    rospy runs each subscription and the timer in a thread of its own, so every call
    into the controller holds ``lock``.
    """

    def __init__(self):
        path = policy_file(rospy.get_param("~policy", POLICY[0]))
        policy = deploy.Policy.load(path)
        goal_topic = rospy.get_param("~goal_topic", "/move_base_simple/goal")
        invalid = float(rospy.get_param("~invalid_range", -1.0))
        self.control = controller.Controller(
            policy,
            stale_after=float(rospy.get_param("~stale_after", 0.5)),
            goal_tolerance=float(rospy.get_param("~goal_tolerance", policy.goal_radius)),
            invalid=None if invalid < 0 else invalid,
        )
        self.lock = threading.Lock()
        self.shutting_down = False  # after the final stop nothing else is published
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=1, tcp_nodelay=True)
        rospy.Subscriber("odom", Odometry, self.on_odom, queue_size=1, tcp_nodelay=True)
        rospy.Subscriber(goal_topic, PoseStamped, self.on_goal, queue_size=1)
        rospy.Timer(rospy.Duration(policy.dt), self.on_timer)
        rospy.on_shutdown(self.on_shutdown)
        m = policy.meta
        rospy.loginfo(
            f"policy {path}: {m.get('strategy')} seed {m.get('seed')} trained on {m.get('maze')}, "
            f"{policy.n_beams} beams{' + obstacle features' if policy.obstacle_obs else ''}; "
            f"one command per scan; waiting for a goal on {rospy.resolve_name(goal_topic)}"
        )

    def on_scan(self, msg: LaserScan):
        with self.lock:
            now = rospy.get_time()
            self.control.on_scan(msg.ranges, msg.angle_min, msg.angle_increment, now)
            self.publish(self.control.decide(now))

    def on_odom(self, msg: Odometry):
        q, p = msg.pose.pose.orientation, msg.pose.pose.position
        pose = (p.x, p.y, scan.yaw_from_quaternion(q.x, q.y, q.z, q.w))
        with self.lock:
            self.control.on_odom(pose, msg.header.frame_id, rospy.get_time())

    def on_goal(self, msg: PoseStamped):
        x, y, frame = msg.pose.position.x, msg.pose.position.y, msg.header.frame_id
        with self.lock:
            try:
                self.control.on_goal((x, y), frame)
            except ValueError as e:
                rospy.logerr(f"goal refused: {e}")
                return
        rospy.loginfo(f"new goal ({x:.2f}, {y:.2f}) in frame '{frame}'")

    def on_timer(self, _event):
        with self.lock:
            cmd = self.control.watchdog(rospy.get_time())
            if cmd is not None:
                self.publish(cmd)

    def publish(self, cmd):
        """Publish a controller.Command and log why it stops (caller holds the lock)."""
        if self.shutting_down:
            return
        twist = Twist()
        twist.linear.x, twist.angular.z = float(cmd.linear), float(cmd.angular)
        self.cmd_pub.publish(twist)
        if cmd.level == "info":
            rospy.loginfo(cmd.message)
        elif cmd.level == "warn":
            rospy.logwarn_throttle(THROTTLE_S, cmd.message)
        elif cmd.level == "error":
            rospy.logerr_throttle(THROTTLE_S, cmd.message)

    def on_shutdown(self):
        """Leave the robot standing: one last zero twist, and nothing after it."""
        with self.lock:
            self.shutting_down = True
            self.cmd_pub.publish(Twist())
        time.sleep(0.1)  # the publisher sends from its own thread: let it


def main() -> int:
    POLICY[0] = policy_arg(sys.argv) or POLICY[0]  # --policy NAME|FILE
    rospy.init_node("jaxnav_policy")
    try:
        PolicyNode()
    except deploy.PolicyError as e:
        rospy.logfatal(str(e))
        return 1
    rospy.spin()
    return 0


if __name__ == "__main__":
    sys.exit(main())
