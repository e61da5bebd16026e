"""What a ROS node does with a policy, without ROS: :class:`Controller` holds the
latest scan, odometry and goal and decides each twist (when to drive, when to stop,
when a goal is reached), so the ROS 1 and ROS 2 example nodes share it and it is tested
without ROS; and which message ROS 2's /cmd_vel carries on a distribution
(:func:`default_stamped`). NumPy and the standard library only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

try:  # inside the jaxnav package
    from jaxnav.robot.deploy import Policy
except ImportError:  # beside a robot's node, without jaxnav: deploy.py next to this file
    import importlib.util
    from pathlib import Path

    _spec = importlib.util.spec_from_file_location(
        "jaxnav_deploy", Path(__file__).resolve().with_name("deploy.py")
    )
    _deploy = importlib.util.module_from_spec(_spec)
    _spec.loader.exec_module(_deploy)
    Policy = _deploy.Policy

# Distributions before Jazzy take a plain Twist on /cmd_vel: turtlebot3_bringup loads
# enable_stamped_cmd_vel: false for humble, its one target before Jazzy, and true for
# the rest; foxy, galactic and iron are taken to be like humble.
TWIST_DISTROS = ("foxy", "galactic", "humble", "iron")
STAMPED_RCLPY = 7  # Jazzy's rclpy is 7.x; Humble's 3.x, Iron's 4.x


def default_stamped(distro: str | None, rclpy_version: str | None) -> tuple[bool, str]:
    """(TwistStamped?, why) for /cmd_vel: Twist on Humble and older, stamped after;
    from ROS_DISTRO, or where that is unset from rclpy's version. The ROS 2 policy node
    publishes, and the MuJoCo robot node (jaxnav.robot.mujoco_ros2) takes, this type."""
    if distro:
        stamped = distro.strip().lower() not in TWIST_DISTROS
        return stamped, f"ROS_DISTRO={distro}"
    try:
        major = int(str(rclpy_version).split(".")[0])
    except ValueError:
        return True, "ROS_DISTRO unset and rclpy's version unknown"
    return major >= STAMPED_RCLPY, f"ROS_DISTRO unset, rclpy {rclpy_version}"


def rclpy_version() -> str | None:
    """The installed rclpy's version (a distribution's or PyPI's ros-rclpy), or None."""
    from importlib import metadata

    for name in ("rclpy", "ros-rclpy"):
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return None


# Why a Command drives or stops -> the level a node logs its message at ("": quiet).
REASONS = {
    "drive": "",
    "no goal": "",
    "reached": "info",
    "waiting": "warn",
    "stale": "warn",
    "frame": "warn",
    "bad input": "error",
}


class Command(NamedTuple):
    """A twist for /cmd_vel and why: ``reason`` is "drive" or why the robot stops."""

    linear: float  # m/s
    angular: float  # rad/s, + counter-clockwise
    reason: str  # a key of REASONS
    message: str  # what to log, "" for nothing

    @property
    def level(self) -> str:
        """How loudly a node logs the message: "" (not at all), "info", "warn" or "error"."""
        return REASONS[self.reason]


def _stop(reason: str, message: str = "") -> Command:
    return Command(0.0, 0.0, reason, message)


def _frame(frame_id: str) -> str:
    """A frame id without ROS 1's optional leading slash ("/odom" is "odom")."""
    return str(frame_id or "").lstrip("/")


class Controller:
    """The latest scan, odometry and goal of a policy node, and the twist they give.

    A node hands in each message with its receive time (seconds on the node's clock),
    publishes :meth:`decide` after each scan (one action per scan, as in training)
    and :meth:`watchdog`'s stop, if any, from a timer, since a node that acts only
    on scans would otherwise leave the last command running when the LiDAR goes
    quiet. The robot stops (zero twist) unless there is a goal, a scan and odometry
    each at most ``stale_after`` s old, the goal is in the odometry's frame (no TF
    lookup), and the scan and pose are usable; within ``goal_tolerance`` of the goal
    it stops and clears the goal. Not thread-safe: a node with concurrent callbacks
    holds a lock around every call.
    """

    def __init__(
        self,
        policy: Policy,
        stale_after: float = 0.5,
        goal_tolerance: float | None = None,
        invalid: float | None = None,
    ):
        self.policy = policy
        self.stale_after = float(stale_after)
        tolerance = policy.goal_radius if goal_tolerance is None else goal_tolerance
        self.goal_tolerance = float(tolerance)
        self.invalid = invalid  # value of 0 / nan readings, None: the policy's max range
        self.scan: tuple[np.ndarray, float, float, float] | None = None  # ranges, angles, time
        self.odom: tuple[tuple[float, float, float], str, float] | None = None  # pose, frame, t
        self.goal: tuple[tuple[float, float], str] | None = None  # (x, y), frame

    def on_scan(
        self, ranges: Sequence[float], angle_min: float, angle_increment: float, now: float
    ) -> None:
        self.scan = (np.asarray(ranges, np.float64), angle_min, angle_increment, now)

    def on_odom(self, pose: Sequence[float], frame_id: str, now: float) -> None:
        """Odometry pose (x, y, yaw) in frame ``frame_id``."""
        x, y, yaw = (float(v) for v in pose)
        self.odom = ((x, y, yaw), _frame(frame_id), now)

    def on_goal(self, goal: Sequence[float], frame_id: str) -> None:
        """A new goal (x, y), replacing the current one; ValueError if not finite."""
        x, y = (float(v) for v in goal)
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"goal ({x}, {y}) is not finite")
        self.goal = ((x, y), _frame(frame_id))

    def _age_ok(self, t: float, now: float) -> bool:
        return 0.0 <= now - t <= self.stale_after  # a negative age: the clock jumped back

    def decide(self, now: float) -> Command:
        """The twist for now: the policy's greedy action, or a stop and why."""
        command = self._decide(now)
        if command.reason != "drive":  # stopped: the policy's last command is (0, 0)
            self.policy.rest()
        return command

    def _decide(self, now: float) -> Command:
        if self.goal is None:
            return _stop("no goal")
        if self.scan is None or self.odom is None:
            return _stop("waiting", "no scan or odometry yet: stopped")
        ranges, angle_min, angle_increment, t_scan = self.scan
        pose, odom_frame, t_odom = self.odom
        old = [n for n, t in (("scan", t_scan), ("odometry", t_odom)) if not self._age_ok(t, now)]
        if old:
            return _stop("stale", f"{' and '.join(old)} older than {self.stale_after:g} s: stopped")
        goal, goal_frame = self.goal
        if goal_frame and odom_frame and goal_frame != odom_frame:
            return _stop(
                "frame",
                f"goal is in frame '{goal_frame}', not the odometry frame '{odom_frame}': stopped",
            )
        if math.hypot(goal[0] - pose[0], goal[1] - pose[1]) < self.goal_tolerance:
            self.goal = None
            return _stop(
                "reached", f"goal ({goal[0]:.2f}, {goal[1]:.2f}) reached: stopped; send a new goal"
            )
        try:
            linear, angular = self.policy.command(
                ranges, angle_min, angle_increment, pose, goal, self.invalid
            )
        except ValueError as e:  # a scan that does not cover 360 degrees, a nan pose
            return _stop("bad input", f"cannot act on this scan and pose: {e}; stopped")
        return Command(linear, angular, "drive", "")

    def watchdog(self, now: float) -> Command | None:
        """A stop while no fresh scan arrives (None while scans do: they drive)."""
        if self.scan is not None and self._age_ok(self.scan[3], now):
            return None
        return self.decide(now)
