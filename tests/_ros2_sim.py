"""A simulated TurtleBot3 on ROS 2: jaxnav's maze behind /scan, /odom and /cmd_vel.

``python tests/_ros2_sim.py --goals "1.2,0" --last-goal "0,1.2" --result out.json``
publishes what the LDS-01 driver and turtlebot3_node would, at 1 / dt = 5 Hz: /scan
with sensor-data QoS (best effort, keep last 5; 360 rays, 1 degree apart, counter-
clockwise from ahead; range_min 0.12, range_max 3.5; no return is 0.0) and /odom
(reliable), and integrates each Twist or TwistStamped (``--cmd-type``) received on
/cmd_vel as the exact unicycle over one control period, with jaxnav's collision check
along the path: tests/_ros_sim.py's World, the ROS 1 test's, so its ``offline_mission``
predicts this run. Goals go out on /goal_pose, each once the robot has stopped within
the goal radius of the last; what happened is written to the result file.

The mission, in order: wait for the node's first command (a stop: it has no goal yet);
drive to each goal; with ``--full``, during the first goal withhold odometry for a
while, then send scans that are all NaN, then scans whose range_max is below the
policy's (the node must stop for each), and after the last goal send one in frame
"map" (refused: the robot must stay), then drive off to the last goal, shift the
odometry by 1 m as a reset would (the node must stop and drop the goal), and send the
last goal again in the shifted frame. Finally, once the robot drives, create
``<result>.driving`` and go on until interrupted (SIGINT), so the caller can check
that the node stops the robot when it is shut down.

With ``--robot mujoco`` the robot is another process, the MuJoCo burger of
jaxnav/robot/mujoco_ros2.py, which publishes /scan and /odom and takes /cmd_vel
itself: this process only sends the goals, listens to /cmd_vel, /odom (whether a
stop is at the goal) and /ground_truth (where the robot really is), and writes the
result; collisions are the robot node's contacts (its log and report).

It needs JAX and rclpy in one interpreter: jaxnav's environment runs it, with the ROS 2
environment's package paths appended to sys.path (``JAXNAV_ROS2_SITE``) and its
libraries on LD_LIBRARY_PATH (tests/test_ros2.py sets both).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np
from _ros_sim import (
    DT,
    GOAL_RADIUS,
    N_RAYS,
    RANGE_MAX,
    RANGE_MIN,
    Collision,
    Interrupted,
    Mission,
    Timeout,
    World,
    points,
)

ODOM_GAP_S = 1.6  # odometry withheld this long during the first goal
BAD_SCANS = 5  # then this many scans of each bad kind
SHORT_RANGE_MAX = 2.0  # m: a LiDAR that sees less far than the policy was trained with
ODOM_SHIFT = (1.0, 0.0)  # m: the odometry "reset" of the full mission
WATCH_S = 1.2  # how long the robot must stay after a refused goal or a jump


class Sim(Mission):
    """The ROS 2 side of a World, and the mission (module docstring)."""

    def __init__(self, args, world: World):
        import rclpy
        from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
        from nav_msgs.msg import Odometry
        from rclpy.qos import QoSProfile, qos_profile_sensor_data
        from sensor_msgs.msg import LaserScan

        super().__init__(args, world, cmd_type=args.cmd_type)
        self.rclpy, self.msgs = rclpy, (LaserScan, Odometry, PoseStamped)
        self.node = rclpy.create_node("jaxnav_sim")
        self.unstamped = 0  # TwistStamped commands without a stamp
        self.shift = (0.0, 0.0)  # added to the published odometry after the "reset"
        self.scan_pub = self.node.create_publisher(LaserScan, "/scan", qos_profile_sensor_data)
        self.odom_pub = self.node.create_publisher(Odometry, "/odom", QoSProfile(depth=10))
        self.goal_pub = self.node.create_publisher(PoseStamped, "/goal_pose", QoSProfile(depth=10))
        cmd_type = TwistStamped if args.cmd_type == "stamped" else Twist
        self.node.create_subscription(cmd_type, "/cmd_vel", self.on_cmd, QoSProfile(depth=10))

    def on_cmd(self, msg):
        if self.args.cmd_type == "stamped":
            if msg.header.stamp.sec == 0 and msg.header.stamp.nanosec == 0:
                self.unstamped += 1
            msg = msg.twist
        self.command(msg.linear.x, msg.angular.z)

    # -- what the robot's drivers publish --------------------------------------

    def publish(self, odom: bool = True, scan: str = "ok"):
        LaserScan, Odometry, _ = self.msgs
        stamp = self.node.get_clock().now().to_msg()
        with self.lock:
            x, y, yaw = self.world.pose
            ranges = self.world.scan()
        if odom:
            o = Odometry()
            o.header.stamp, o.header.frame_id, o.child_frame_id = stamp, "odom", "base_footprint"
            o.pose.pose.position.x = x + self.shift[0]
            o.pose.pose.position.y = y + self.shift[1]
            q = o.pose.pose.orientation
            q.z, q.w = math.sin(yaw / 2), math.cos(yaw / 2)
            self.odom_pub.publish(o)
        s = LaserScan()
        s.header.stamp, s.header.frame_id = stamp, "base_scan"
        inc = 2 * math.pi / N_RAYS
        s.angle_min, s.angle_increment, s.scan_time = 0.0, inc, DT
        s.angle_max = inc * (N_RAYS - 1)
        s.range_min, s.range_max = RANGE_MIN, RANGE_MAX
        if scan == "nan":
            ranges = np.full_like(ranges, np.nan)
        elif scan == "short":  # a shorter-range LiDAR than the policy's
            s.range_max = SHORT_RANGE_MAX
            ranges = np.where(ranges > SHORT_RANGE_MAX, 0.0, ranges).astype(np.float32)
        s.ranges = ranges.tolist()
        self.scan_pub.publish(s)

    def send_goal(self, goal, frame: str = "odom", track: bool = True):
        _, _, PoseStamped = self.msgs
        g = PoseStamped()
        g.header.stamp, g.header.frame_id = self.node.get_clock().now().to_msg(), frame
        g.pose.position.x = goal[0] + self.shift[0]
        g.pose.position.y = goal[1] + self.shift[1]
        g.pose.orientation.w = 1.0
        if track:
            with self.lock:
                self.goal, self.reached = tuple(goal), False
        self.goal_pub.publish(g)
        self.event("goal", goal=list(goal), frame=frame)

    # -- the mission -------------------------------------------------------------

    def tick(self, **publish) -> None:
        """One control period: publish, then sleep to the next; raises on a collision."""
        self.publish(**publish)
        self.next_tick += DT
        time.sleep(max(0.0, self.next_tick - time.monotonic()))
        if self.collided:
            raise Collision

    def disturbs(self, i: int) -> bool:
        return self.args.full and i == 0

    def disturb(self) -> None:
        """Odometry withheld, then scans the node must not act on: count its stops."""
        t = self.now()
        while self.now() - t < ODOM_GAP_S:
            self.tick(odom=False)
        # Commands answering scans sent over stale_after (0.5 s) after the last odometry.
        stops = {"stale_odometry": self.zeros_since(t + 0.9)}
        for kind in ("nan", "short"):
            t = self.now()
            for _ in range(BAD_SCANS):
                self.tick(scan=kind)
            # The first bad scan's answer may follow a drive command still in flight.
            stops[f"{kind}_scan"] = self.zeros_since(t)
            stops[f"{kind}_moving"] = self.moving_since(t + 2 * DT)
        self.result["stops"] = stops
        self.event("disturbed", **stops)

    def watch(self, key: str) -> None:
        """Tick for WATCH_S and record the commands that moved the robot meanwhile."""
        t = self.now()
        while self.now() - t < WATCH_S:
            self.tick()
        # A command answering a scan sent just before may still be on its way.
        self.result[key] = self.moving_since(t + 2 * DT)
        self.event(key, moving=self.result[key])

    def drive_off(self, goal, n: int = 3) -> None:
        self.send_goal(goal)
        t, deadline = self.now(), self.now() + 10.0
        while self.moving_since(t) < n:
            if self.now() > deadline:
                self.event("timeout", goal=list(goal), pose=self.world.pose)
                raise Timeout
            self.tick()

    def run(self) -> None:
        self.next_tick = time.monotonic()
        t = self.now()
        while not self.cmds or self.goal_pub.get_subscription_count() == 0:
            if self.now() - t > self.args.start_timeout:  # the node is up once it answers
                self.event("no node")
                raise Timeout
            self.tick()
        self.result["idle_command"] = list(self.cmds[0][1:])
        self.event("node up")
        for i, goal in enumerate(self.args.goals):
            self.drive_to(i, goal)
        last = self.args.last_goal
        if self.args.full:
            self.send_goal(last, frame="map", track=False)
            self.watch("moving_after_map_goal")
            self.drive_off(last)
            with self.lock:
                self.shift = ODOM_SHIFT
            self.event("odometry shifted", shift=list(ODOM_SHIFT))
            self.watch("moving_after_jump")
        # Drive off once more and wait to be interrupted: the node must stop the robot.
        self.drive_off(last)
        Path(str(self.args.result) + ".driving").touch()
        self.event("driving")
        deadline = self.now() + 30.0
        while self.now() < deadline:
            self.tick()


class Watched:
    """The MuJoCo robot as the mission sees it, from its topics: it moves by itself."""

    def __init__(self):
        self.pose = (math.nan, math.nan, math.nan)  # odometry
        self.true = (math.nan, math.nan, math.nan)  # /ground_truth

    def move(self, v: float, w: float) -> bool:
        return False  # the robot node drives; its contacts are in its own log

    def distance(self, goal) -> float:
        return math.hypot(goal[0] - self.pose[0], goal[1] - self.pose[1])


class WatchedSim(Sim):
    """The mission around a robot that is its own node (``--robot mujoco``)."""

    # The node stops on the scan it saw within 0.2 m by odometry; the robot rolls on
    # for the command's way back (a few mm) before this process compares odometry.
    goal_radius = GOAL_RADIUS + 0.03

    def __init__(self, args, world: Watched):
        import rclpy
        from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
        from nav_msgs.msg import Odometry
        from rclpy.qos import QoSProfile

        Mission.__init__(self, args, world, cmd_type=args.cmd_type, robot="mujoco")
        self.rclpy, self.msgs = rclpy, (None, Odometry, PoseStamped)
        self.node = rclpy.create_node("jaxnav_mission")
        self.unstamped, self.shift = 0, (0.0, 0.0)
        self.goal_pub = self.node.create_publisher(PoseStamped, "/goal_pose", QoSProfile(depth=10))
        cmd_type = TwistStamped if args.cmd_type == "stamped" else Twist
        self.node.create_subscription(cmd_type, "/cmd_vel", self.on_cmd, QoSProfile(depth=10))
        self.node.create_subscription(Odometry, "/odom", self.on_odom, QoSProfile(depth=10))
        self.node.create_subscription(
            Odometry, "/ground_truth", self.on_truth, QoSProfile(depth=10)
        )

    @staticmethod
    def _pose(msg) -> tuple[float, float, float]:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        return p.x, p.y, math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))

    def on_odom(self, msg):
        with self.lock:
            self.world.pose = self._pose(msg)

    def on_truth(self, msg):
        with self.lock:
            self.world.true = self._pose(msg)

    def tick(self, **publish) -> None:
        """One control period; the robot node publishes its own topics."""
        self.next_tick += DT
        time.sleep(max(0.0, self.next_tick - time.monotonic()))

    def drive_to(self, i: int, goal) -> None:
        super().drive_to(i, goal)
        with self.lock:
            self.result["goals"][-1]["true_pose"] = self.world.true


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--goals", type=points, required=True, help='"x,y;x,y;..." in odom frame')
    p.add_argument("--last-goal", type=lambda s: points(s)[0], default=(0.0, 0.0))
    p.add_argument("--result", type=Path, required=True)
    p.add_argument("--maze", default="square4")
    p.add_argument("--cmd-type", choices=["twist", "stamped"], default="stamped")
    p.add_argument("--full", action="store_true", help="the bad-input part of the mission")
    p.add_argument("--goal-timeout", type=float, default=40.0)
    p.add_argument("--start-timeout", type=float, default=30.0)
    p.add_argument("--robot", choices=["kinematic", "mujoco"], default="kinematic")
    args = p.parse_args(argv)
    if args.robot == "mujoco":
        world = Watched()
    else:
        world = World(args.maze, 0.0)
        world.scan(), world.move(0.0, 0.0)  # compile before the clock starts

    for site in os.environ.get("JAXNAV_ROS2_SITE", "").split(os.pathsep):
        if site and site not in sys.path:
            sys.path.append(site)  # after this environment's own packages (NumPy)
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)  # SIGINT: KeyboardInterrupt
    sim = (WatchedSim if args.robot == "mujoco" else Sim)(args, world)
    executor = SingleThreadedExecutor()
    executor.add_node(sim.node)
    done = threading.Event()

    def spin():
        while not done.is_set():
            executor.spin_once(timeout_sec=0.05)

    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    outcome = "interrupted"
    try:
        sim.run()
        outcome = "done"
    except (KeyboardInterrupt, Interrupted):
        outcome = "interrupted"
    except Collision:
        outcome = "collision"
    except Timeout:
        outcome = "timeout"
    finally:
        time.sleep(0.3)  # the node's last command, if any is on its way
        with sim.lock:
            sim.result.update(
                outcome=outcome,
                collided=sim.collided,
                pose=world.pose,
                true_pose=getattr(world, "true", None),
                n_commands=len(sim.cmds),
                unstamped=sim.unstamped,
                last_command=list(sim.cmds[-1][1:]) if sim.cmds else None,
            )
            args.result.write_text(json.dumps(sim.result, indent=1))
        done.set()
        spinner.join(timeout=5.0)
        executor.shutdown(timeout_sec=1.0)
        sim.node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
