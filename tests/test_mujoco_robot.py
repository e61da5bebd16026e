"""The MuJoCo robot behind the ROS 2 topics (jaxnav/robot/mujoco_ros2.py), without ROS:
its maze file, wheel odometry, command watchdog, LDS-01 scan and wheel limit; and, under
the ROS 2 environment where there is one, its refusal of a bad maze or parameter.
tests/test_ros2.py runs it as a ROS 2 node, closed-loop with the policy node."""

from __future__ import annotations

import json
import math
import random
import subprocess

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="MuJoCo is not installed (pip install mujoco)")

import test_ros2 as r2  # noqa: E402 - the ROS 2 environment, for the node's process

from jaxnav.core.errors import JaxnavError  # noqa: E402
from jaxnav.robot.mujoco_ros2 import (  # noqa: E402
    MazeFile,
    Odometry,
    RealTimeBurger,
    load_maze_file,
)
from jaxnav.world.maps import make_maze  # noqa: E402


def _maze(name: str) -> MazeFile:
    m = make_maze(name)
    return MazeFile(m.walls().astype(np.float64), m.obstacles().astype(np.float64), np.zeros(3))


@pytest.fixture(scope="module")
def square4_file(tmp_path_factory):
    m = make_maze("square4")
    path = tmp_path_factory.mktemp("maze") / "maze.npz"
    np.savez(
        path,
        **{"maze/walls": m.walls(), "maze/obstacles": m.obstacles(), "maze/start": m.start},
    )
    return path


def test_a_maze_file_is_read_as_the_maze(square4_file):
    maze = load_maze_file(str(square4_file))
    np.testing.assert_allclose(maze.walls(), make_maze("square4").walls())
    assert maze.obstacles().shape == (0, 3) and tuple(maze.start) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize(
    "content, words",
    [(None, "no file"), ({"maze/walls": np.zeros((4, 4))}, "has no array maze/obstacles")],
)
def test_a_maze_file_that_cannot_be_used_is_one_line_naming_the_parameter(tmp_path, content, words):
    path = tmp_path / "maze.npz"
    if content is not None:
        np.savez(path, **content)
    with pytest.raises(JaxnavError) as e:
        load_maze_file(str(path))
    assert str(e.value).startswith("parameter maze: ") and words in str(e.value)
    assert "\n" not in str(e.value)


def test_wheel_odometry_integrates_the_wheels_turns():
    """By hand: both wheels turning 1 rad roll r = 0.033 m ahead; opposite turns of 1 rad
    rotate by 2 r / L = 0.4125 rad in place; a quarter turn then goes sideways."""
    o = Odometry(0.0, 0.0, 0.0)
    o.update(1.0, 1.0, 0.1)
    assert (o.x, o.y, o.yaw) == pytest.approx((0.033, 0.0, 0.0))
    assert o.v == pytest.approx(0.33)
    o.update(-1.0, 1.0, 0.1)
    assert (o.x, o.y, o.yaw) == pytest.approx((0.033, 0.0, 0.4125))
    o = Odometry(0.0, 0.0, math.pi / 2)
    o.update(2.0, 2.0, 0.1)
    assert (o.x, o.y) == pytest.approx((0.0, 0.066), abs=1e-12)


def test_driven_straight_the_odometry_follows_the_true_pose():
    robot = RealTimeBurger(_maze("square8"), noise_std=0.0)
    t = 0.0
    for _ in range(10):  # a command every period, as a node sends them
        robot.command(0.15, 0.0)
        t += 0.2
        robot.advance(t)
    x, y, yaw = robot.robot.pose()
    assert 0.25 < x < 0.3 and abs(y) < 1e-3  # 2 s at 0.15 m/s, less the spin-up
    assert (robot.odom.x, robot.odom.y, robot.odom.yaw) == pytest.approx((x, y, yaw), abs=5e-3)
    assert robot.odom.v == pytest.approx(0.15, rel=0.02)


def test_with_the_imu_the_odometry_heading_is_the_true_one_in_turns():
    """turtlebot3_node takes the heading from the IMU (use_imu, burger.yaml): in a
    sequence of turns, the heading is the body's, and the position errs less than with
    the heading from the wheels, which the tyres' scrub in turns throws off."""
    errors = {}
    for imu in (True, False):
        robot = RealTimeBurger(_maze("square8"), noise_std=0.0, use_imu=imu)
        t = 0.0
        for k in range(40):
            robot.command(0.15, (1.5, -0.75, 0.0, 0.75)[(k // 3) % 4])
            t += 0.2
            robot.advance(t)
        x, y, yaw = robot.robot.pose()
        o = robot.odom
        errors[imu] = (math.hypot(o.x - x, o.y - y), abs(math.remainder(o.yaw - yaw, 2 * math.pi)))
    assert errors[True][1] < 1e-9 and errors[False][1] > 1e-3
    assert errors[True][0] < errors[False][0]


def test_the_wheels_stop_when_commands_stop():
    """The firmware's watchdog: one command, then none for 2 s: the robot drives for
    cmd_timeout (0.5 s) only."""
    robot = RealTimeBurger(_maze("square8"), noise_std=0.0, cmd_timeout=0.5)
    robot.command(0.15, 0.0)
    robot.advance(2.0)
    assert robot.driving == (0.0, 0.0) and robot.t == pytest.approx(2.0)
    x = robot.robot.pose()[0]
    assert 0.05 < x < 0.5 * 0.15 + 0.01
    robot.advance(3.0)
    assert robot.robot.pose()[0] == pytest.approx(x, abs=1e-3)


def test_the_scan_follows_the_lds01_no_return_is_zero():
    far = RealTimeBurger(_maze("square8"), noise_std=0.0)  # walls 3.7 m away
    assert far.scan().dtype == np.float32 and (far.scan() == 0.0).all()
    near = RealTimeBurger(_maze("square2"), noise_std=0.0)  # walls 0.925 m away
    r = near.scan()
    assert r.shape == (360,) and ((r > 0.12) & (r < 1.4)).all()
    # Ray 0 looks ahead from the LiDAR 0.032 m behind the axle, ray 90 to the left.
    assert r[0] == pytest.approx(0.925 + 0.032, abs=1e-3)
    assert r[90] == pytest.approx(0.925, abs=1e-3)


def test_contacts_are_counted_once_each():
    robot = RealTimeBurger(_maze("square2"), noise_std=0.0)
    t = 0.0
    while t < 10.0 and not robot.contacts:
        robot.command(0.15, 0.0)
        t += 0.2
        robot.advance(t)
    assert robot.contacts == 1 and robot.contact_log[0][1] > 0.7
    for _ in range(5):  # pushing on (the contact flickers): the same contact
        robot.command(0.15, 0.0)
        t += 0.2
        robot.advance(t)
    assert robot.contacts == 1
    for v in [-0.15] * 5 + [0.15] * 10:  # back off 1 s, and drive on again: a second one
        robot.command(v, 0.0)
        t += 0.2
        robot.advance(t)
    assert robot.contacts == 2


def test_with_the_wheel_limit_a_command_is_driven_as_the_firmware_clips_it():
    robot = RealTimeBurger(_maze("square8"), wheel_limit=True)
    robot.command(0.15, 1.5)
    assert robot.driving == pytest.approx((0.1198564, 1.1232050), abs=1e-6)
    free = RealTimeBurger(_maze("square8"))
    free.command(0.15, 1.5)
    assert free.driving == (0.15, 1.5)


def test_the_same_seed_gives_the_same_run():
    runs = []
    for _ in range(2):
        robot = RealTimeBurger(_maze("square4"), seed=3)
        robot.command(0.15, 0.75)
        robot.advance(0.4)
        runs.append((robot.scan().tobytes(), robot.robot.pose(), robot.odom.x))
    assert runs[0] == runs[1]


@pytest.mark.parametrize(
    "params, words",
    [
        (["maze:={tmp}/none.npz"], "parameter maze: no file"),
        (["maze:={tmp}/maze.npz", "lidar_noise:=-1.0"], "parameter lidar_noise must be"),
        (["maze:={tmp}/maze.npz", "scan_rate:=0.0"], "parameter scan_rate must be"),
    ],
)
def test_the_mujoco_robot_refuses_a_bad_maze_or_parameter_with_one_line(tmp_path, params, words):
    ros2 = r2.probe_ros2()
    if r2._mujoco_missing(ros2):
        pytest.skip(r2._mujoco_missing(ros2))
    np.savez(tmp_path / "maze.npz", **{"maze/walls": np.zeros((4, 4))})
    env = r2._dds_env(ros2, tmp_path, random.Random().randrange(1, 101))
    env = dict(r2._robot_env(env), PYTHONPATH=str(r2.ROOT))
    argv = [str(r2._ros2_python()), "-m", "jaxnav.robot.mujoco_ros2", "--ros-args"]
    for param in params:
        argv += ["-p", param.format(tmp=tmp_path)]
    r = subprocess.run(argv, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=60)
    out = r.stdout + r.stderr
    assert r.returncode == 2, out
    assert out.count(words) == 1 and "Traceback" not in out, out


IN_PROCESS = """
import json, math, sys
import numpy as np
import rclpy
from geometry_msgs.msg import TwistStamped
from rclpy.parameter import Parameter
from jaxnav.robot.mujoco_ros2 import BurgerNode

rclpy.init()
params = [Parameter("maze", value=sys.argv[1]), Parameter("enable_stamped_cmd_vel", value=True),
          Parameter("wheel_limit", value=True)]
burger = BurgerNode(rclpy.create_node("burger", parameter_overrides=params))
out = {}


def cmd(v, w):
    m = TwistStamped()
    m.twist.linear.x, m.twist.angular.z = v, w
    burger.on_cmd(m)
    return list(burger.robot.driving)


out["drive"] = cmd(0.15, 1.5)
out["nan"] = [cmd(math.nan, 0.5) for _ in range(3)] + [cmd(0.1, math.inf)]
out["again"] = cmd(0.15, 0.0)
out["nan_again"] = cmd(math.nan, 0.0)
print(json.dumps(out))
"""


def test_the_node_stops_the_wheels_on_a_command_that_is_not_finite(square4_file, tmp_path):
    """BurgerNode's /cmd_vel callback called directly under rclpy: the firmware's
    clipping, and a stop with one log line per run of non-finite commands."""
    ros2 = r2.probe_ros2()
    if r2._mujoco_missing(ros2):
        pytest.skip(r2._mujoco_missing(ros2))
    env = r2._dds_env(ros2, tmp_path, random.Random().randrange(1, 101))
    env = dict(r2._robot_env(env), PYTHONPATH=str(r2.ROOT))
    argv = [str(r2._ros2_python()), "-c", IN_PROCESS, str(square4_file)]
    r = subprocess.run(argv, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr
    out, log = json.loads(r.stdout.strip().splitlines()[-1]), r.stderr
    assert out["drive"] == pytest.approx([0.1198564, 1.1232050], abs=1e-6)
    assert out["nan"] == [[0.0, 0.0]] * 4 and out["nan_again"] == [0.0, 0.0]
    assert out["again"] == pytest.approx([0.15, 0.0])
    assert log.count("is not finite: wheels stopped") == 2, log  # one per run of them
    assert "Traceback" not in log
