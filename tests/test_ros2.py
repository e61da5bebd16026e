"""The ROS 2 policy node: its checks without ROS, and closed-loop through DDS.

examples/ros2_policy_node.py runs as it would on a robot: its own process, under the
ROS 2 environment's python (rclpy and NumPy, no JAX, no jaxnav: deploy.py found by
path), loading a freshly trained and exported policy. A simulated TurtleBot3
(tests/_ros2_sim.py: jaxnav's own LiDAR, motion and collision check behind /scan,
/odom and /cmd_vel, at 5 Hz) sends it goals on /goal_pose. Two such loops run side
by side, each on a DDS domain of its own, on loopback only:

* "stamped": /cmd_vel as TwistStamped, the node's default with ROS_DISTRO unset and
  rclpy >= 7 (Jazzy and later); the full mission: two goals, stale odometry, NaN
  scans, scans from a shorter-range LiDAR, a goal in frame "map", an odometry jump;
* "twist": ROS_DISTRO=humble, so the node publishes Twist; one goal.

A third loop, "mujoco", runs the same node against the MuJoCo burger of
jaxnav/robot/mujoco_ros2.py, its own process under the ROS 2 environment's python (no
JAX), in real time (wheel physics, contacts, a ray-cast LiDAR, odometry from the
wheels and the IMU; TwistStamped): two goals in square4, no contact, each stop near
the goal by the true pose too.

All end with SIGINT while the robot drives: the last command must be a stop and the
node must exit with status 0. The policy is the first of a few trained seeds that
reaches the goals when the adapter is called directly in the same simulated maze, as
in tests/test_ros1.py (for the MuJoCo loop: in the MuJoCo burger, stepped offline).

The ROS 2 environment is ``.venv-ros2/bin/python`` (scripts/ros2_env.sh --install-only
makes it: PyPI's ros-rclpy wheels) or ``JAXNAV_ROS2_PYTHON``, e.g. a system python3
with a ROS 2 distribution sourced; the closed loop also needs it to be this Python's
version, since the simulated robot loads JAX and rclpy together; the MuJoCo loop
needs MuJoCo there too. Where they are missing the ROS 2 tests skip and say so. The
node's checks also run here without ROS, and its callbacks are called directly under
rclpy (message types, one log line per bad scan or error, never an exception out of a
callback).
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import random
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _ros_sim import (
    GOAL_RADIUS,
    NOISE_STD,
    offline_mission,
    offline_mujoco_mission,
    run_side_by_side,
)
from test_ros1 import ClosedLoop as Ros1ClosedLoop

from jaxnav.robot import deploy

ROOT = Path(__file__).resolve().parent.parent
NODE = ROOT / "examples" / "ros2_policy_node.py"
SIM = ROOT / "tests" / "_ros2_sim.py"
DEFAULT_ROS2_PYTHON = ROOT / ".venv-ros2" / "bin" / "python"
INSTALL_HINT = "scripts/ros2_env.sh --install-only makes it"

# square4 is 3.7 m across, centred on the start pose (0, 0) facing +x.
ROUTE = [(1.2, 0.0), (0.0, 1.2), (-1.2, 0.0)]
# loop -> (goals, last goal, extra sim arguments, extra node environment)
LOOPS = {
    "stamped": (ROUTE[:2], ROUTE[2], ["--cmd-type", "stamped", "--full"], {}),
    "twist": (ROUTE[:1], ROUTE[1], ["--cmd-type", "twist"], {"ROS_DISTRO": "humble"}),
    "mujoco": (ROUTE[:2], ROUTE[2], ["--cmd-type", "stamped", "--robot", "mujoco"], {}),
    # a continuous policy (SAC): the node publishes its (v, omega) commands as they come
    "continuous": (ROUTE[:2], ROUTE[2], ["--cmd-type", "stamped"], {}),
}
TRUE_GOAL_SLACK = 0.1  # m: a stop within the goal radius by odometry, by the true pose
TRAIN_SEEDS = 3
TRAIN = [f"seeds={TRAIN_SEEDS}", "strategies=[ebe]", "episodes=40"]
# SAC with continuous commands in the same room (square4, the LiDAR's noise as above)
TRAIN_CONTINUOUS = [
    "preset=modern",
    "env.maze=square4",
    "env.lidar_noise_std=0.01",
    "agent=sac",
    "strategies=[policy]",
    "env.actions=continuous",
    "env.step_penalty=0.02",
    f"seeds={TRAIN_SEEDS}",
    "episodes=null",
    "total_steps=24576",
    "run.chunk_steps=24576",
]
DEADLINE_S = 150.0  # the loops together; they take about 40 s


def _load_node():
    spec = importlib.util.spec_from_file_location("ros2_policy_node", NODE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


node = _load_node()  # rclpy is imported only when the node runs


# ----------------------------------------------------------------------------
# The node's checks, without ROS
# ----------------------------------------------------------------------------


def _policy(n_beams: int = 24, min_range: float = 0.12, max_range: float = 3.5):
    rng = np.random.default_rng(0)
    size = n_beams + 2
    meta = {
        "n_beams": n_beams,
        "obstacle_obs": False,
        "min_range": min_range,
        "max_range": max_range,
        "omegas": [-1.5, -0.75, 0.0, 0.75, 1.5],
        "linear_velocity": 0.15,
    }
    layers = [(rng.normal(size=(size, 8)), np.zeros(8)), (rng.normal(size=(8, 5)), np.zeros(5))]
    return deploy.Policy(layers, meta)


INC = 2 * math.pi / 360
LDS01 = dict(angle_min=0.0, angle_max=359 * INC, angle_increment=INC, range_min=0.12, range_max=3.5)


def _problem(ranges=None, policy=None, **scan):
    fields = dict(LDS01, **scan)
    ranges = np.full(360, 1.0) if ranges is None else ranges
    return node.scan_problem(policy or _policy(), ranges, **fields)


@pytest.mark.parametrize(
    "distro, version, stamped",
    [
        ("humble", "3.3.16", False),
        ("humble", None, False),
        ("jazzy", "3.3.16", True),  # ROS_DISTRO wins over the version
        ("kilted", None, True),
        ("rolling", None, True),
        (None, "3.3.16", False),  # Humble's rclpy
        (None, "4.1.5", False),  # Iron's
        (None, "7.1.5", True),  # Jazzy's
        (None, "9.1.2", True),  # Kilted's (PyPI's ros-rclpy wheels)
        (None, None, True),
        ("", "3.3.16", False),
    ],
)
def test_cmd_vel_type_follows_the_distribution(distro, version, stamped):
    got, why = node.default_stamped(distro, version)
    assert got is stamped and why


def test_an_lds01_scan_matches_the_policy_and_single_invalid_readings_are_its_business():
    assert _problem() is None
    ranges = np.full(360, 1.0)
    ranges[[0, 15, 30]] = [np.nan, np.inf, 0.0]  # no return, as scan.clean_ranges reads it
    assert _problem(ranges) is None
    # Gazebo's 360 samples from 0 to 2 pi inclusive, and the LDS-01 driver's angle_max 2 pi.
    assert _problem(angle_max=2 * math.pi, angle_increment=2 * math.pi / 359) is None
    assert _problem(angle_max=2 * math.pi) is None
    assert _problem(range_max=8.0, range_min=0.16) is None  # the LDS-02: longer range


@pytest.mark.parametrize(
    "ranges, scan, words",
    [
        (
            np.full(12, 1.0),
            dict(angle_max=11 * math.pi / 6, angle_increment=math.pi / 6),
            "12 rays",
        ),
        (np.full(360, 1.0), dict(angle_max=179 * INC), "describe 180"),
        (np.full(360, 1.0), dict(range_max=2.0), "range_max 2"),
        (np.full(360, 1.0), dict(range_min=0.3), "range_min 0.3"),
        (np.full(180, 1.0), dict(angle_min=-math.pi / 2, angle_max=math.pi / 2), "360-degree"),
        (np.full(360, 1.0), dict(angle_increment=math.inf), "not finite"),
        (np.full(360, 1.0), dict(range_max=math.nan), "not finite"),
    ],
)
def test_a_scan_the_policy_does_not_match_is_named_in_one_line(ranges, scan, words):
    why = _problem(ranges, **scan)
    assert why is not None and words in why and "\n" not in why


def test_a_mostly_nan_scan_is_refused():
    assert "NaN at 24 of the policy's 24 beams" in _problem(np.full(360, np.nan))
    ranges = np.full(360, 1.0)
    ranges[np.arange(0, 360, 15)[:13]] = np.nan  # 13 of the 24 beams the policy reads
    assert "NaN at 13" in _problem(ranges)
    ranges[0] = 1.0
    assert _problem(ranges) is None  # 12 of 24: half, still read as no return


def test_odometry_jumps_are_measured():
    assert node.odom_jump((0.0, 0.0, 0.0), (0.3, 0.4, 1.0)) == pytest.approx(0.5)
    assert node.odom_jump((0.0, 0.0, 0.0), (math.nan, 0.0, 0.0)) == math.inf


# ----------------------------------------------------------------------------
# ROS 2: the environment, the policy, the processes
# ----------------------------------------------------------------------------


def _ros2_python() -> Path:
    return Path(os.environ.get("JAXNAV_ROS2_PYTHON") or DEFAULT_ROS2_PYTHON)


PROBE = """
import json, sys
import numpy, rclpy, sensor_msgs.msg, nav_msgs.msg, geometry_msgs.msg
from importlib import metadata
paths = [p for p in sys.path if "site-packages" in p or "dist-packages" in p]
from importlib.util import find_spec
mj = find_spec("mujoco") and __import__("mujoco").__version__
print(json.dumps({"paths": paths, "version": list(sys.version_info[:2]),
                  "rclpy": metadata.version("rclpy"), "prefix": sys.prefix, "mujoco": mj}))
"""


def _robot_env(env: dict) -> dict:
    """A process environment as on a robot: without this checkout on PYTHONPATH (so the
    node finds deploy.py by path) nor jaxnav's virtual environment; the rest (a sourced
    ROS 2's PYTHONPATH) kept."""
    env = {k: v for k, v in env.items() if k != "VIRTUAL_ENV"}
    keep = [p for p in env.pop("PYTHONPATH", "").split(os.pathsep) if p]
    keep = [p for p in keep if Path(p).resolve() != ROOT]
    return dict(env, PYTHONPATH=os.pathsep.join(keep)) if keep else env


@pytest.fixture(scope="module")
def ros2() -> dict:
    return probe_ros2()


def probe_ros2() -> dict:
    """What the ROS 2 environment is (its package paths, Python, rclpy and MuJoCo
    versions); skip if there is none."""
    py = _ros2_python()
    if not py.exists():
        pytest.skip(f"no ROS 2 environment at {py} (JAXNAV_ROS2_PYTHON): {INSTALL_HINT}")
    r = subprocess.run(
        [str(py), "-c", PROBE],
        capture_output=True,
        text=True,
        timeout=120,
        env=_robot_env(os.environ),
    )
    if r.returncode:
        last = (r.stderr.strip().splitlines() or ["?"])[-1]
        pytest.skip(f"{py} cannot import rclpy and the messages ({last}): {INSTALL_HINT}")
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def ros2_sim(ros2) -> dict:
    """The ROS 2 environment, where the simulated robot can load its rclpy."""
    if tuple(ros2["version"]) != sys.version_info[:2]:
        pytest.skip(
            f"{_ros2_python()} is Python {'.'.join(map(str, ros2['version']))}, this is "
            f"{sys.version_info.major}.{sys.version_info.minor}: the simulated robot needs JAX "
            f"and rclpy in one interpreter ({INSTALL_HINT} with this Python)"
        )
    return ros2


@pytest.fixture(scope="module")
def trained(ros2_sim, tmp_path_factory) -> Path:
    """A few trained policies, each exported to DIR/policy<seed>.npz."""
    from jaxnav.core.config import load_config
    from jaxnav.robot.export import export_policy, save_policy
    from jaxnav.run.launch import train_new

    root = tmp_path_factory.mktemp("ros2")
    cfg = load_config(str(ROOT / "configs" / "paper_no_obstacles.yaml"), TRAIN)
    train_new(cfg, root / "run", quiet=True)
    for seed in range(TRAIN_SEEDS):
        save_policy(export_policy(root / "run", "ebe", seed), root / f"policy{seed}.npz")
    return root


@pytest.fixture(scope="module")
def trained_continuous(ros2_sim, tmp_path_factory) -> Path:
    """A few trained continuous (SAC) policies, each exported to DIR/policy<seed>.npz."""
    from jaxnav.core.config import load_config
    from jaxnav.robot.export import export_policy, save_policy
    from jaxnav.run.launch import train_new

    root = tmp_path_factory.mktemp("ros2_sac")
    cfg = load_config(None, TRAIN_CONTINUOUS)
    train_new(cfg, root / "run", quiet=True)
    for seed in range(TRAIN_SEEDS):
        save_policy(export_policy(root / "run", "policy", seed), root / f"policy{seed}.npz")
    return root


def _reaching(trained: Path) -> Path:
    """A trained policy that reaches ROUTE without ROS, exactly and with noise."""
    tried = {}
    for seed in range(TRAIN_SEEDS):
        policy = deploy.Policy.load(trained / f"policy{seed}.npz")
        tried[seed] = [offline_mission(policy, ROUTE, noise=n, seed=1) for n in (0.0, NOISE_STD)]
        if all(outcome == "ok" for _, outcome in tried[seed]):
            return trained / f"policy{seed}.npz"
    pytest.fail(f"no trained seed of {trained} reaches {ROUTE} even without ROS: {tried}")


@pytest.fixture(scope="module")
def policy_file(trained) -> Path:
    return _reaching(trained)


@pytest.fixture(scope="module")
def continuous_policy_file(trained_continuous) -> Path:
    policy = _reaching(trained_continuous)
    assert deploy.Policy.load(policy).continuous
    return policy


def _mujoco_missing(ros2: dict) -> str | None:
    """Why the MuJoCo loop cannot run here, or None."""
    if importlib.util.find_spec("mujoco") is None:
        return "MuJoCo is not installed here (pip install mujoco)"
    if not ros2.get("mujoco"):
        return f"no MuJoCo in {_ros2_python()}: {INSTALL_HINT}"
    return None


@pytest.fixture(scope="module")
def mujoco_policy_file(ros2_sim, trained) -> Path | None:
    """A trained policy that reaches ROUTE in the MuJoCo burger without ROS; None where
    the MuJoCo loop cannot run."""
    if _mujoco_missing(ros2_sim):
        return None
    tried = {}
    for seed in range(TRAIN_SEEDS):
        tried[seed] = offline_mujoco_mission(trained / f"policy{seed}.npz", ROUTE)
        if tried[seed][1] == "ok":
            return trained / f"policy{seed}.npz"
    pytest.fail(f"no trained seed reaches {ROUTE} in MuJoCo even without ROS: {tried}")


def _dds_env(ros2: dict, work: Path, domain: int) -> dict:
    """The environment of a loop's processes: its own DDS domain, on loopback only."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "RMW_"))}
    env.update(
        ROS_DOMAIN_ID=str(domain),
        ROS_LOCALHOST_ONLY="1",  # Humble's name for it
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",  # Jazzy's and later
        RMW_IMPLEMENTATION="rmw_fastrtps_cpp",
        ROS_LOG_DIR=str(work / "ros_log"),
        ROS_HOME=str(work),
        PYTHONUNBUFFERED="1",
    )
    env.pop("ROS_DISTRO", None)
    return env


def _ros2_libraries(ros2: dict) -> str:
    """LD_LIBRARY_PATH for rclpy's libraries outside its own interpreter (what the
    wheels' bootstrap does for the ROS 2 environment's python)."""
    dirs = [str(p) for site in ros2["paths"] for p in sorted(Path(site).glob("ros_*.libs"))]
    dirs.append(str(Path(ros2["prefix"]) / "lib"))
    old = os.environ.get("LD_LIBRARY_PATH")
    return os.pathsep.join(dirs + ([old] if old else []))


class ClosedLoop(Ros1ClosedLoop):
    """The simulated robot and the policy node on one DDS domain."""

    TAIL = 40

    def start(self, ros2: dict, policy: Path, domain: int) -> None:
        goals, last, sim_args, node_env = LOOPS[self.name]
        env = _dds_env(ros2, self.work, domain)
        if self.name == "mujoco":  # the robot: ROS 2's python, jaxnav on the path, no JAX
            self.robot_report = self.work / "robot.json"
            argv = [str(_ros2_python()), "-m", "jaxnav.robot.mujoco_ros2", "--ros-args"]
            argv += ["-p", f"maze:={policy}", "-p", f"report:={self.robot_report}"]
            self.robot = self._start("robot", argv, dict(_robot_env(env), PYTHONPATH=str(ROOT)))
        sim_env = dict(
            env,
            JAX_PLATFORMS="cpu",
            JAXNAV_ROS2_SITE=os.pathsep.join(ros2["paths"]),
            LD_LIBRARY_PATH=_ros2_libraries(ros2),
        )
        goals = ";".join(f"{x},{y}" for x, y in goals)
        argv = [sys.executable, str(SIM), f"--goals={goals}", "--last-goal={},{}".format(*last)]
        argv += ["--result", str(self.result_path)]
        self.sim = self._start("sim", argv + sim_args, sim_env)
        # As on a robot: ROS 2's python, without JAX or jaxnav (deploy.py by path).
        argv = [str(_ros2_python()), str(NODE), "--ros-args", "-p", f"policy:={policy}"]
        if self.name == "stamped" and not node.default_stamped(None, ros2["rclpy"])[0]:
            argv += ["-p", "enable_stamped_cmd_vel:=true"]  # an rclpy older than Jazzy's
        self.node = self._start("node", argv, _robot_env(dict(env, **node_env)))


@pytest.fixture(scope="module")
def loops(ros2_sim, policy_file, mujoco_policy_file, continuous_policy_file, tmp_path_factory):
    """The loops, run side by side to their end; every process is gone afterwards."""
    started: dict[str, ClosedLoop] = {}
    domains = random.Random().sample(range(1, 101), len(LOOPS))  # 0..101: Fast DDS's ports
    policies = {name: policy_file for name in LOOPS}
    policies["mujoco"] = mujoco_policy_file
    policies["continuous"] = continuous_policy_file
    try:
        for name, domain in zip(LOOPS, domains):
            if policies[name] is None:
                continue
            started[name] = ClosedLoop(name, tmp_path_factory.mktemp(name))
            started[name].start(ros2_sim, policies[name], domain)
        run_side_by_side(started.values(), DEADLINE_S)
        for loop in started.values():  # any still running at the deadline ends now
            loop.close()
            loop.read_result()
        yield started
    finally:
        for loop in started.values():
            loop.close()


# ----------------------------------------------------------------------------
# Closed-loop checks
# ----------------------------------------------------------------------------


def _loop(loops: dict, name: str, ros2: dict) -> ClosedLoop:
    if name not in loops:
        pytest.skip(f"the {name} loop did not run: {_mujoco_missing(ros2)}")
    return loops[name]


@pytest.mark.slow
@pytest.mark.parametrize("name", list(LOOPS))
def test_the_node_drives_the_robot_to_each_goal_without_collision(loops, name, ros2):
    loop = _loop(loops, name, ros2)
    r = loop.result
    assert r is not None, f"no result\n{loop.report()}"
    assert not r["collided"], loop.report()
    assert [tuple(g["goal"]) for g in r["goals"]] == LOOPS[name][0], loop.report()
    assert any(e["event"] == "driving" for e in r["events"]), loop.report()
    node_log = loop.node.log.read_text()
    assert node_log.count("reached: stopped") == len(LOOPS[name][0]), loop.report()
    assert "Traceback" not in node_log and "callback failed" not in node_log, loop.report()
    sim_log = loop.sim.log.read_text()
    assert "Traceback" not in sim_log and "terminate called" not in sim_log, loop.report()
    want = "Twist " if name == "twist" else "TwistStamped"
    assert f"/cmd_vel as {want}" in node_log, loop.report()
    assert r["unstamped"] == 0, loop.report()  # every TwistStamped carries its time


@pytest.mark.slow  # the closed loop: a ROS graph, a trained policy and MuJoCo in real time
def test_in_mujoco_no_contact_and_each_stop_is_at_the_goal_by_the_true_pose(loops, ros2):
    loop = _loop(loops, "mujoco", ros2)
    r = loop.result
    assert r is not None and r["goals"], f"no result\n{loop.report()}"
    robot_log = loop.robot.log.read_text()
    assert "/cmd_vel as TwistStamped" in robot_log and "MuJoCo 4." in robot_log, loop.report()
    assert "contact:" not in robot_log and "Traceback" not in robot_log, loop.report()
    report = json.loads(loop.robot_report.read_text())  # written when SIGINT ended it
    assert report["contacts"] == 0 and report["sim_time"] > 10, loop.report()
    assert loop.robot.p.returncode == 0, loop.report()
    for g in r["goals"]:  # odometry drifts a little: the true pose is near the goal too
        x, y, _ = g["true_pose"]
        off = math.hypot(x - g["goal"][0], y - g["goal"][1])
        assert off < GOAL_RADIUS + TRUE_GOAL_SLACK, loop.report()


@pytest.mark.slow  # the closed loop: a ROS graph and a trained policy
@pytest.mark.parametrize("name", list(LOOPS))
def test_the_node_stops_without_goal_and_on_sigint(loops, name, ros2):
    loop = _loop(loops, name, ros2)
    r = loop.result
    assert r is not None, f"no result\n{loop.report()}"
    assert r["idle_command"] == [0.0, 0.0], loop.report()  # before the first goal
    # Reaching a goal stops the robot: the sim sent the next goal only after a stop
    # within the goal radius (first test). Interrupting the node stops it too:
    assert r["last_command"] == [0.0, 0.0], loop.report()
    assert loop.node.p.returncode == 0, loop.report()
    assert "interrupted: stopping the robot" in loop.node.log.read_text(), loop.report()


@pytest.mark.slow  # the closed loop: a ROS graph and a trained policy
def test_the_node_stops_on_stale_odometry_and_bad_scans_with_one_line_each(loops):
    loop = loops["stamped"]
    r = loop.result
    assert r is not None and "stops" in r, f"no result\n{loop.report()}"
    s = r["stops"]
    # 1.6 s without odometry, then 5 all-NaN scans, then 5 from a shorter-range LiDAR.
    assert s["stale_odometry"] >= 2, loop.report()
    assert s["nan_scan"] >= 4 and s["nan_moving"] == 0, loop.report()
    assert s["short_scan"] >= 4 and s["short_moving"] == 0, loop.report()
    log = loop.node.log.read_text()
    assert log.count("odometry older than") == 1, loop.report()
    assert log.count("scan reads NaN at 24 of the policy's 24 beams") == 1, loop.report()
    assert log.count("scan range_max 2 m is below the policy's max range") == 1, loop.report()


@pytest.mark.slow  # the closed loop: a ROS graph and a trained policy
def test_the_node_refuses_a_goal_in_another_frame_and_stops_on_an_odometry_jump(loops):
    loop = loops["stamped"]
    r = loop.result
    assert r is not None, f"no result\n{loop.report()}"
    assert r.get("moving_after_map_goal") == 0, loop.report()
    assert r.get("moving_after_jump") == 0, loop.report()
    log = loop.node.log.read_text()
    refused = "goal refused: frame 'map' is not the odometry frame 'odom'"
    assert log.count(refused) == 1, loop.report()
    assert log.count("odometry jumped") == 1, loop.report()  # 1 m, less the robot's motion


def test_a_policy_file_that_cannot_be_read_ends_the_node_with_one_line(ros2, tmp_path):
    bad = tmp_path / "policy.npz"
    bad.write_bytes(b"not a policy")
    env = _dds_env(ros2, tmp_path, random.Random().randrange(1, 101))
    env = _robot_env(env)
    argv = [str(_ros2_python()), str(NODE), "--ros-args", "-p", f"policy:={bad}"]
    r = subprocess.run(argv, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=60)
    out = r.stdout + r.stderr
    assert r.returncode == 1, out
    assert "cannot be read" in out and "Traceback" not in out, out


IN_PROCESS = """
import importlib.util, json, math, sys
spec = importlib.util.spec_from_file_location("ros2_policy_node", sys.argv[1])
mod = importlib.util.module_from_spec(spec)
spec.loader.exec_module(mod)
import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from sensor_msgs.msg import LaserScan

out = {}


class Recorder:
    def __init__(self):
        self.msgs = []

    def publish(self, msg):
        self.msgs.append(msg)


def make(stamped):
    params = [Parameter("policy", value=sys.argv[2]),
              Parameter("enable_stamped_cmd_vel", value=stamped)]
    context = rclpy.Context()  # one each: Fast DDS takes one type per topic and participant
    rclpy.init(context=context)
    name = f"jaxnav_policy_{int(stamped)}"
    node = rclpy.create_node(name, parameter_overrides=params, context=context)
    pn = mod.PolicyNode(node)
    pn.cmd_pub = Recorder()
    odom = Odometry()
    odom.header.frame_id, odom.pose.pose.orientation.w = "odom", 1.0
    pn.on_odom(odom)
    goal = PoseStamped()
    goal.header.frame_id, goal.pose.position.x = "odom", 1.2
    pn.on_goal(goal)
    return pn


def scan(n=360, value=1.0):
    s = LaserScan()
    inc = 2 * math.pi / n
    s.angle_min, s.angle_max, s.angle_increment = 0.0, inc * (n - 1), inc
    s.range_min, s.range_max, s.ranges = 0.12, 3.5, [value] * n
    return s


def twists(pn):
    return [[m.twist.linear.x, m.twist.angular.z, m.header.stamp.sec + m.header.stamp.nanosec]
            if pn.stamped else [m.linear.x, m.angular.z, None] for m in pn.cmd_pub.msgs]


for stamped in (True, False):
    pn = make(stamped)
    pn.on_scan(scan())
    out[f"drive_{stamped}"] = [type(pn.cmd_pub.msgs[-1]).__name__, twists(pn)]
pn.cmd_pub.msgs.clear()
for bad in (scan(value=math.nan),) * 5 + (scan(n=12),) * 5:
    pn.on_scan(bad)
out["bad"] = twists(pn)
pn.cmd_pub.msgs.clear()


def broken(now):
    raise RuntimeError("broken")


nan_odom = Odometry()
nan_odom.header.frame_id, nan_odom.pose.pose.position.x = "odom", math.nan
for _ in range(5):
    pn.on_odom(nan_odom)
    pn.on_scan(scan())
out["nan_odom"] = twists(pn)
nan_odom.pose.pose.position.x = 0.0  # finite again
pn.on_odom(nan_odom)
pn.cmd_pub.msgs.clear()
pn.control.decide = broken
for _ in range(5):
    pn.on_scan(scan())
out["broken"] = twists(pn)
print(json.dumps(out))
"""


def test_in_process_the_node_publishes_either_type_and_stops_on_bad_scans(ros2, tmp_path):
    """The node's callbacks called directly under rclpy: the message types, and one log
    line (not one per message) for NaN scans, a 12-ray scan, NaN odometry and an error
    in a callback."""
    policy, p = tmp_path / "policy.npz", _policy()
    meta = dict(p.meta, format=deploy.FORMAT, version=deploy.FORMAT_VERSION)
    meta["layers"] = [f"Dense_{i}" for i in range(len(p.layers))]
    arrays = {"meta": np.asarray(json.dumps(meta))}
    for name, (k, b) in zip(meta["layers"], p.layers):
        arrays[f"{name}/kernel"], arrays[f"{name}/bias"] = k, b
    np.savez(policy, **arrays)
    env = _dds_env(ros2, tmp_path, random.Random().randrange(1, 101))
    env = _robot_env(env)
    argv = [str(_ros2_python()), "-c", IN_PROCESS, str(NODE), str(policy)]
    r = subprocess.run(argv, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr
    out, log = json.loads(r.stdout.strip().splitlines()[-1]), r.stderr
    kind, (cmd,) = out["drive_True"]
    assert kind == "TwistStamped" and cmd[0] == 0.15 and cmd[2] > 0, out  # stamped: a time
    kind, (cmd,) = out["drive_False"]
    assert kind == "Twist" and cmd[0] == 0.15, out
    assert [c[:2] for c in out["bad"]] == [[0.0, 0.0]] * 10, out
    assert log.count("scan reads NaN") == 1 and log.count("scan has 12 rays") == 1, log
    assert [c[:2] for c in out["nan_odom"]] == [[0.0, 0.0]] * 10, out
    assert log.count("odometry pose is not finite") == 1, log
    assert [c[:2] for c in out["broken"]] == [[0.0, 0.0]] * 5, out
    assert log.count("scan callback failed (RuntimeError: broken): stopped") == 1, log
    assert "Traceback" not in log, log
