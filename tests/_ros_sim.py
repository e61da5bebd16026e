"""A simulated TurtleBot3 on ROS 1: jaxnav's maze behind /scan, /odom and /cmd_vel.

``python tests/_ros_sim.py --goals "1,0.5;0,-1" --result out.json`` (a ROS master
running, ROS_MASTER_URI set) publishes what the LDS-01 and the odometry of a robot
in the maze would, at 1 / dt = 5 Hz, and integrates each Twist received on cmd_vel
as the exact unicycle over one control period, with jaxnav's collision check along
the path. It sends the goals one after another on the goal topic, each once the
robot has stopped within the goal radius of the last, and writes what happened to
the result file. The scans follow the LDS-01 driver (360 rays, 1 degree apart,
counter-clockwise from ahead; range_min 0.12, range_max 3.5; no return is 0.0) or,
with ``--no-return inf``, Gazebo's model (no return is inf). They are exact unless
``--noise 0.01`` adds the range noise of Gazebo's model, as in training: exact, a run
repeats :func:`offline_mission` step for step as long as no command comes late.

The mission, in order: wait for the node's first command (a stop: it has no goal
yet); drive to each goal; during the second goal, withhold odometry for a while and
then send scans that cover only the front half (the node must stop for both); then
send one more goal, and once the robot drives, create ``<result>.driving`` and go on
until interrupted (SIGINT), so the caller can check that the node stops the robot
when it is shut down.

rospy is pure Python: where the ROS packages are Debian's (python3-rospy), it is
imported from /usr/lib/python3/dist-packages, appended to this interpreter's path.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.world import sensor
from jaxnav.world.geometry import displacement, path_clearance, wrap_angle
from jaxnav.world.maps import ROBOT_RADIUS, make_maze

DEBIAN_PYTHON = "/usr/lib/python3/dist-packages"
N_RAYS = 360  # the LDS-01: ray i at i degrees, counter-clockwise from ahead
RANGE_MIN, RANGE_MAX = 0.12, 3.5
NOISE_STD = 0.01  # Gazebo's LDS-01 model, as in training
DT = 0.2  # s, one control period (the scan rate)
GOAL_RADIUS = 0.2  # m
ODOM_GAP_S = 1.6  # odometry withheld this long during the second goal
BAD_SCANS = 5  # then this many scans of the front half only


class World:
    """One robot in a maze, moved and sensed by jaxnav's exact geometry."""

    def __init__(
        self, maze: str = "square4", no_return: float = 0.0, noise: float = 0.0, seed: int = 0
    ):
        self.maze = make_maze(maze)
        start = np.asarray(self.maze.start, np.float32)
        self.pos, self.yaw = jnp.asarray(start[:2]), jnp.asarray(start[2])
        self.no_return, self.noise = float(no_return), float(noise)
        self.rng = np.random.default_rng(seed)
        m = self.maze
        self._ranges = jax.jit(lambda pos, yaw: sensor.beam_ranges(m, pos, yaw, N_RAYS))

        def step(pos, yaw, v, w):
            clearance = path_clearance(m, pos, yaw, w, v, DT)
            return clearance, pos + displacement(yaw, w, v, DT), wrap_angle(yaw + w * DT)

        self._step = jax.jit(step)

    @property
    def pose(self) -> tuple[float, float, float]:
        return float(self.pos[0]), float(self.pos[1]), float(self.yaw)

    def scan(self) -> np.ndarray:
        """f32[360] ranges as the sensor reports them: noisy, no return outside its limits."""
        r = np.asarray(self._ranges(self.pos, self.yaw), np.float64)
        if self.noise:
            r = r + self.rng.normal(0.0, self.noise, r.shape)
        return np.where((r < RANGE_MIN) | (r > RANGE_MAX), self.no_return, r).astype(np.float32)

    def move(self, v: float, w: float) -> bool:
        """Drive (v m/s, w rad/s) for one period; True (and no motion) if that collides."""
        clearance, pos, yaw = self._step(self.pos, self.yaw, jnp.float32(v), jnp.float32(w))
        if float(clearance) < ROBOT_RADIUS:
            return True
        self.pos, self.yaw = pos, yaw
        return False

    def distance(self, goal) -> float:
        return math.hypot(goal[0] - float(self.pos[0]), goal[1] - float(self.pos[1]))


def offline_mission(
    policy,
    goals,
    no_return: float = 0.0,
    noise: float = 0.0,
    seed: int = 0,
    max_steps: int = 200,
    maze: str = "square4",
) -> tuple[list[int], str]:
    """The mission without ROS: the node's Controller called directly, one command per
    scan, each applied for one period. Returns the steps to each goal reached and how it
    ended: "ok", "collision" or "timeout"."""
    from jaxnav.robot.controller import Controller

    world, control = World(maze, no_return, noise, seed), Controller(policy)
    steps: list[int] = []
    t = 0.0
    for goal in goals:
        control.on_goal(goal, "odom")
        for k in range(max_steps):
            t += DT
            control.on_odom(world.pose, "odom", t)
            control.on_scan(world.scan(), 0.0, 2 * math.pi / N_RAYS, t)
            cmd = control.decide(t)
            if cmd.reason == "reached":
                steps.append(k)
                break
            if world.move(cmd.linear, cmd.angular):
                return steps, "collision"
        else:
            return steps, "timeout"
    return steps, "ok"


def offline_mujoco_mission(path, goals, max_steps: int = 200) -> tuple[list[int], str]:
    """The mission without ROS in the MuJoCo robot node's own burger (its default noise
    and seed), stepped period by period: the Controller on each scan and the odometry,
    its command for the next period. Returns the steps to each goal and how it ended:
    "ok", "collision" (a contact) or "timeout"."""
    from jaxnav.robot.controller import Controller
    from jaxnav.robot.deploy import Policy
    from jaxnav.robot.mujoco_ros2 import RealTimeBurger, load_maze_file

    control = Controller(Policy.load(path))
    robot = RealTimeBurger(load_maze_file(str(path)))
    steps: list[int] = []
    t = 0.0
    for goal in goals:
        control.on_goal(goal, "odom")
        for k in range(max_steps):
            t += DT
            robot.advance(t)
            if robot.contacts:
                return steps, "collision"
            control.on_odom((robot.odom.x, robot.odom.y, robot.odom.yaw), "odom", t)
            control.on_scan(robot.scan(), 0.0, 2 * math.pi / N_RAYS, t)
            cmd = control.decide(t)
            if cmd.reason == "reached":
                steps.append(k)
                break
            robot.command(cmd.linear, cmd.angular)
        else:
            return steps, "timeout"
    return steps, "ok"


class Interrupted(Exception):
    pass


class Collision(Exception):
    pass


class Timeout(Exception):
    pass


class Mission:
    """What the ROS 1 and ROS 2 simulators share, whatever the middleware: the clock,
    the events, the commands received and what they do to the World, and driving to a
    goal. A subclass publishes the robot's topics (``tick``) and sends goals."""

    goal_radius = GOAL_RADIUS  # a stop this near the goal counts as arriving

    def __init__(self, args, world: World, **result):
        self.args, self.world = args, world
        self.lock = threading.Lock()
        self.t0 = time.monotonic()
        self.result: dict = {**result, "goals": [], "events": []}
        self.cmds: list[tuple[float, float, float]] = []  # (time, v, w) of every command
        self.collided = False
        self.goal: tuple[float, float] | None = None
        self.reached = False  # stopped within the goal radius of self.goal

    def now(self) -> float:
        return time.monotonic() - self.t0

    def event(self, what: str, **info):
        self.result["events"].append({"t": round(self.now(), 2), "event": what, **info})

    def command(self, v: float, w: float) -> None:
        """A velocity command received: the World moves, a collision or arrival is noted."""
        with self.lock:
            self.cmds.append((self.now(), v, w))
            if self.collided:
                return
            if self.world.move(v, w):
                self.collided = True
                self.event("collision", pose=self.world.pose, v=v, w=w)
            elif v == 0.0 and w == 0.0 and self.goal is not None:
                self.reached = self.world.distance(self.goal) < self.goal_radius

    def zeros_since(self, t: float) -> int:
        with self.lock:
            return sum(1 for tc, v, w in self.cmds if tc >= t and v == 0.0 and w == 0.0)

    def moving_since(self, t: float) -> int:
        with self.lock:
            return sum(1 for tc, v, w in self.cmds if tc >= t and (v != 0.0 or w != 0.0))

    def disturbs(self, i: int) -> bool:
        """Whether the way to goal i is disturbed (:meth:`disturb`)."""
        return i == 1

    def drive_to(self, i: int, goal) -> None:
        """Send goal i and simulate until the robot stopped within its radius."""
        self.send_goal(goal)
        t_goal, deadline = self.now(), self.now() + self.args.goal_timeout
        disturb = self.disturbs(i)
        while not self.reached:
            if self.now() > deadline:
                self.event("timeout", goal=list(goal), pose=self.world.pose)
                raise Timeout
            if disturb and self.now() - t_goal > 1.0:
                disturb = False
                self.disturb()
            self.tick()
        self.result["goals"].append(
            {
                "goal": list(goal),
                "seconds": round(self.now() - t_goal, 2),
                "steps": self.moving_since(t_goal),
                "pose": self.world.pose,
            }
        )
        self.event("reached", goal=list(goal))


def run_side_by_side(loops, deadline_s: float) -> None:
    """Step every loop's mission (a generator) in turn until all end or the deadline."""
    pending = [loop.mission() for loop in loops]
    t = time.monotonic()
    while pending and time.monotonic() - t < deadline_s:
        for m in list(pending):
            try:
                next(m)
            except StopIteration:
                pending.remove(m)
        time.sleep(0.05)


class Sim(Mission):
    """The ROS side of a World, and the mission (module docstring)."""

    def __init__(self, args, world: World):
        import rospy
        from geometry_msgs.msg import PoseStamped, Twist
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import LaserScan

        super().__init__(args, world, no_return=args.no_return)
        self.rospy, self.msgs = rospy, (LaserScan, Odometry, PoseStamped)
        self.scan_pub = rospy.Publisher("scan", LaserScan, queue_size=1, tcp_nodelay=True)
        self.odom_pub = rospy.Publisher("odom", Odometry, queue_size=1, tcp_nodelay=True)
        self.goal_pub = rospy.Publisher(args.goal_topic, PoseStamped, queue_size=1, latch=True)
        rospy.Subscriber("cmd_vel", Twist, self.on_cmd, queue_size=10, tcp_nodelay=True)

    def on_cmd(self, msg):
        self.command(msg.linear.x, msg.angular.z)

    # -- what the robot's drivers publish --------------------------------------

    def publish(self, odom: bool = True, bad: bool = False):
        LaserScan, Odometry, _ = self.msgs
        stamp = self.rospy.Time.now()
        with self.lock:
            x, y, yaw = self.world.pose
            ranges = self.world.scan()
        if odom:
            o = Odometry()
            o.header.stamp, o.header.frame_id, o.child_frame_id = stamp, "odom", "base_footprint"
            o.pose.pose.position.x, o.pose.pose.position.y = x, y
            q = o.pose.pose.orientation
            q.z, q.w = math.sin(yaw / 2), math.cos(yaw / 2)
            self.odom_pub.publish(o)
        s = LaserScan()
        s.header.stamp, s.header.frame_id = stamp, "base_scan"
        inc = 2 * math.pi / N_RAYS
        s.angle_min, s.angle_increment, s.scan_time = 0.0, inc, DT
        s.range_min, s.range_max = RANGE_MIN, RANGE_MAX
        s.ranges = ranges.tolist()
        if bad:  # the front half only: from -90 to +90 degrees
            s.angle_min, s.ranges = -math.pi / 2, np.roll(ranges, 90)[:181].tolist()
        s.angle_max = s.angle_min + inc * (len(s.ranges) - 1)
        self.scan_pub.publish(s)

    def send_goal(self, goal):
        _, _, PoseStamped = self.msgs
        g = PoseStamped()
        g.header.stamp, g.header.frame_id = self.rospy.Time.now(), "odom"
        g.pose.position.x, g.pose.position.y, g.pose.orientation.w = goal[0], goal[1], 1.0
        with self.lock:
            self.goal, self.reached = tuple(goal), False
        self.goal_pub.publish(g)
        self.event("goal", goal=list(goal))

    # -- the mission -------------------------------------------------------------

    def tick(self, **publish) -> None:
        """One control period: publish, then sleep to the next; raises on a collision."""
        if self.rospy.is_shutdown():
            raise Interrupted
        self.publish(**publish)
        try:
            self.rate.sleep()
        except self.rospy.ROSInterruptException:
            raise Interrupted from None
        if self.collided:
            raise Collision

    def disturb(self) -> None:
        """Odometry withheld, then scans the policy cannot use: count the node's stops."""
        t = self.now()
        while self.now() - t < ODOM_GAP_S:
            self.tick(odom=False)
        # Commands answering scans sent over stale_after (0.5 s) after the last odometry.
        stale = self.zeros_since(t + 0.9)
        t = self.now()
        for _ in range(BAD_SCANS):
            self.tick(bad=True)
        bad = self.zeros_since(t)
        self.result["stops"] = {"stale_odometry": stale, "bad_scan": bad}
        self.event("disturbed", **self.result["stops"])

    def run(self) -> None:
        self.rate = self.rospy.Rate(1.0 / DT)
        t = self.now()
        while not self.cmds:  # the node is up once it answers a scan
            if self.now() - t > self.args.start_timeout:
                self.event("no node")
                raise Timeout
            self.tick()
        self.result["idle_command"] = list(self.cmds[0][1:])
        self.event("node up")
        for i, goal in enumerate(self.args.goals):
            self.drive_to(i, goal)
        # Drive off once more and wait to be interrupted: the node must stop the robot.
        self.send_goal(self.args.last_goal)
        t = self.now()
        while self.moving_since(t) < 3:
            self.tick()
        Path(str(self.args.result) + ".driving").touch()
        self.event("driving")
        deadline = self.now() + 30.0
        while self.now() < deadline:
            self.tick()


def points(text: str) -> list[tuple[float, float]]:
    return [tuple(float(v) for v in p.split(",")) for p in text.split(";") if p.strip()]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--goals", type=points, required=True, help='"x,y;x,y;..." in odom frame')
    p.add_argument("--last-goal", type=lambda s: points(s)[0], default=(0.0, 0.0))
    p.add_argument("--result", type=Path, required=True)
    p.add_argument("--maze", default="square4")
    p.add_argument("--no-return", choices=["0", "inf"], default="0")
    p.add_argument(
        "--noise", type=float, default=0.0, help=f"range noise std (m), e.g. {NOISE_STD}"
    )
    p.add_argument("--goal-topic", default="/move_base_simple/goal")
    p.add_argument("--goal-timeout", type=float, default=40.0)
    p.add_argument("--start-timeout", type=float, default=30.0)
    args = p.parse_args(argv)
    world = World(args.maze, float(args.no_return), args.noise)
    world.scan(), world.move(0.0, 0.0)  # compile before the clock starts

    if DEBIAN_PYTHON not in sys.path:
        sys.path.append(DEBIAN_PYTHON)
    import rospy

    rospy.init_node("jaxnav_sim")
    sim = Sim(args, world)
    outcome = "interrupted"
    try:
        sim.run()
        outcome = "done"
    except (Interrupted, Collision, Timeout) as e:
        outcome = {Interrupted: "interrupted", Collision: "collision", Timeout: "timeout"}[type(e)]
    finally:
        with sim.lock:
            sim.result.update(
                outcome=outcome,
                collided=sim.collided,
                pose=world.pose,
                n_commands=len(sim.cmds),
                last_command=list(sim.cmds[-1][1:]) if sim.cmds else None,
            )
            args.result.write_text(json.dumps(sim.result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
