"""The ROS 1 policy node closed-loop, through a live ROS master.

examples/ros1_policy_node.py runs as it would on a robot: under Debian's python3 with
rospy and NumPy but no JAX, loading a freshly trained and exported policy. A
simulated TurtleBot3 (tests/_ros_sim.py: jaxnav's own LiDAR, motion and collision
check behind /scan, /odom and /cmd_vel, at 5 Hz) sends it goals one after another
on /move_base_simple/goal. Two such loops run side by side, each with a master of
its own: one with the LDS-01's scans (no return is 0.0), one with Gazebo's (inf).

The policy is the first of a few trained seeds that reaches the goals when the
adapter is called directly in the same simulated maze: how well DQN trains is for
other tests; here what is checked is that the node, through real messages and real
timing, drives the robot there as the adapter does, and stops when it must.

Skipped where ROS 1 is not installed: scripts/ros1_closed_loop.sh installs Debian's
packages and runs this file.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import xmlrpc.client
from pathlib import Path

import pytest
from _ros_sim import DEBIAN_PYTHON, NOISE_STD, offline_mission, run_side_by_side

ROOT = Path(__file__).resolve().parent.parent
NODE = ROOT / "examples" / "ros1_policy_node.py"
SIM = ROOT / "tests" / "_ros_sim.py"
ROS_PYTHON = "/usr/bin/python3"  # Debian's, where python3-rospy installs rospy
INSTALL_HINT = "scripts/ros1_closed_loop.sh installs it"

# square4 is 3.7 m across, centred on the start pose (0, 0) facing +x.
GOALS = [(1.2, 0.0), (0.0, 1.2), (-1.2, 0.0)]
LAST_GOAL = (0.0, -1.2)  # driven towards when the node is shut down
# Training: 40 episodes of paper_no_obstacles, several seeds in one vmapped run.
TRAIN_SEEDS = 6
TRAIN = [f"seeds={TRAIN_SEEDS}", "strategies=[ebe]", "episodes=40"]
LOOPS = {"lds01": "0", "gazebo_inf": "inf"}  # loop -> how its scans report no return
DEADLINE_S = 150.0  # the loops together; they take about 40 s


def _ros1_missing() -> str | None:
    """Why ROS 1 cannot run here, or None."""
    if shutil.which("rosmaster") is None:
        return "no rosmaster on PATH"
    if not (Path(ROS_PYTHON).exists() and Path(DEBIAN_PYTHON).is_dir()):
        return f"no {ROS_PYTHON} with {DEBIAN_PYTHON}"
    mods = "numpy, rospy, sensor_msgs.msg, nav_msgs.msg, geometry_msgs.msg"
    r = subprocess.run(
        [ROS_PYTHON, "-c", f"import {mods}"], capture_output=True, text=True, timeout=60
    )
    if r.returncode:
        return f"{ROS_PYTHON} cannot import {mods}: {(r.stderr.strip().splitlines() or ['?'])[-1]}"
    return None


@pytest.fixture(scope="module")
def ros1():
    why = _ros1_missing()
    if why:
        pytest.skip(f"ROS 1 not installed ({why}): {INSTALL_HINT}")


@pytest.fixture(scope="module")
def policy_file(ros1, tmp_path_factory) -> Path:
    """A trained policy that reaches GOALS and LAST_GOAL without ROS, exactly and with noise."""
    from jaxnav.core.config import load_config
    from jaxnav.robot.deploy import Policy
    from jaxnav.robot.export import export_policy, save_policy
    from jaxnav.run.launch import train_new

    root = tmp_path_factory.mktemp("ros1")
    cfg = load_config(str(ROOT / "configs" / "paper_no_obstacles.yaml"), TRAIN)
    train_new(cfg, root / "run", quiet=True)
    tried = {}
    for seed in range(TRAIN_SEEDS):
        arrays = export_policy(root / "run", "ebe", seed)
        policy = Policy.from_arrays(arrays)
        goals = [*GOALS, LAST_GOAL]
        tried[seed] = [offline_mission(policy, goals, noise=n, seed=1) for n in (0.0, NOISE_STD)]
        if all(outcome == "ok" for _, outcome in tried[seed]):
            save_policy(arrays, root / "policy.npz")
            return root / "policy.npz"
    pytest.fail(f"no trained seed reaches {GOALS} even without ROS: {tried}")


# ----------------------------------------------------------------------------
# Processes: a master, the simulated robot and the node per loop
# ----------------------------------------------------------------------------


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Proc:
    """A subprocess in a process group of its own, its output in a file."""

    def __init__(self, argv: list[str], env: dict, log: Path, cwd: Path):
        self.log = log
        if shutil.which("setpriv"):  # SIGTERM when pytest dies, even by SIGKILL (Linux)
            argv = ["setpriv", "--pdeathsig", "TERM", "--", *argv]
        with open(log, "wb") as out:
            self.p = subprocess.Popen(
                argv,
                env=env,
                cwd=cwd,
                stdout=out,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )

    def running(self) -> bool:
        return self.p.poll() is None

    def signal(self, sig: int) -> None:
        if self.running():
            try:
                os.killpg(self.p.pid, sig)
            except ProcessLookupError:
                pass

    def close(self) -> None:
        """Interrupt, then terminate, then kill the whole group."""
        for sig, wait in ((signal.SIGINT, 5), (signal.SIGTERM, 3), (signal.SIGKILL, 3)):
            if not self.running():
                break
            self.signal(sig)
            try:
                self.p.wait(wait)
            except subprocess.TimeoutExpired:
                pass
        try:  # the group's other members, if the leader left any
            os.killpg(self.p.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass

    def tail(self, n: int = 25) -> str:
        lines = self.log.read_text(errors="replace").splitlines()[-n:]
        return f"--- {self.log.name}\n" + "\n".join(lines)


class ClosedLoop:
    """A ROS master on a free loopback port, the simulated robot and the policy node.
    The ROS 2 test's loop is this one started on a DDS domain instead."""

    TAIL = 25  # log lines a failed check shows of each process

    def __init__(self, name: str, work: Path):
        self.name, self.work = name, work
        self.result_path = work / "result.json"
        self.result: dict | None = None
        self.procs: list[Proc] = []

    def start(self, no_return: str, policy: Path) -> None:
        work, port = self.work, _free_port()
        uri = f"http://127.0.0.1:{port}"
        env = {k: v for k, v in os.environ.items() if not k.startswith("ROS")}
        env.update(
            ROS_MASTER_URI=uri, ROS_IP="127.0.0.1", ROS_HOSTNAME="127.0.0.1", ROS_HOME=str(work)
        )
        self.master = self._start("master", ["rosmaster", "--core", "-p", str(port)], env)
        _wait_for_master(uri, self.master)
        sim_env = dict(env, JAX_PLATFORMS="cpu")
        goals = ";".join(f"{x},{y}" for x, y in GOALS)
        self.sim = self._start(
            "sim",
            [sys.executable, str(SIM), "--goals", goals, "--last-goal", "{},{}".format(*LAST_GOAL)]
            + ["--no-return", no_return, "--result", str(self.result_path)],
            sim_env,
        )
        # As on a robot: Debian's python3, outside the virtual environment, without JAX.
        node_env = {k: v for k, v in env.items() if k != "VIRTUAL_ENV"}
        self.node = self._start("node", [ROS_PYTHON, str(NODE), f"_policy:={policy}"], node_env)

    def _start(self, name: str, argv: list[str], env: dict) -> Proc:
        proc = Proc(argv, env, self.work / f"{name}.log", self.work)
        self.procs.append(proc)
        return proc

    def mission(self):
        """Advance on each next(): wait for the robot to drive off after the last goal,
        shut the node down, then the simulated robot, and read its result."""
        driving = Path(str(self.result_path) + ".driving")
        while not driving.exists() and self.sim.running() and self.node.running():
            yield
        if driving.exists():
            self.node.signal(signal.SIGINT)
            t = time.monotonic()
            while self.node.running() and time.monotonic() - t < 10:
                yield
            t = time.monotonic()
            while time.monotonic() - t < 0.5:  # the node's last command reaches the robot
                yield
        self.sim.signal(signal.SIGINT)
        t = time.monotonic()
        while self.sim.running() and time.monotonic() - t < 10:
            yield
        self.read_result()

    def read_result(self) -> None:
        if self.result_path.exists():
            self.result = json.loads(self.result_path.read_text())

    def close(self) -> None:
        for proc in reversed(self.procs):
            proc.close()

    def report(self) -> str:
        """What a failed check shows: the result and the ends of the logs."""
        return "\n".join(
            [f"loop {self.name}: {json.dumps(self.result)}"]
            + [p.tail(self.TAIL) for p in self.procs]
        )


def _wait_for_master(uri: str, master: Proc, timeout: float = 30.0) -> None:
    t = time.monotonic()
    while time.monotonic() - t < timeout and master.running():
        try:
            if xmlrpc.client.ServerProxy(uri).getPid("/test")[0] == 1:
                return
        except OSError:
            pass
        time.sleep(0.1)
    raise RuntimeError(f"the ROS master at {uri} did not start\n{master.tail()}")


@pytest.fixture(scope="module")
def loops(policy_file, tmp_path_factory):
    """Both loops, run side by side to their end; every process is gone afterwards."""
    started: dict[str, ClosedLoop] = {}
    try:
        for name, no_return in LOOPS.items():
            started[name] = ClosedLoop(name, tmp_path_factory.mktemp(name))
            started[name].start(no_return, policy_file)
        run_side_by_side(started.values(), DEADLINE_S)
        for loop in started.values():  # any still running at the deadline ends now
            loop.close()
            loop.read_result()
        yield started
    finally:
        for loop in started.values():
            loop.close()


# ----------------------------------------------------------------------------
# Checks
# ----------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("name", list(LOOPS))
def test_the_node_drives_the_robot_to_each_goal_without_collision(loops, name):
    loop = loops[name]
    r = loop.result
    assert r is not None, f"no result\n{loop.report()}"
    assert not r["collided"], loop.report()
    assert [tuple(g["goal"]) for g in r["goals"]] == GOALS, loop.report()
    assert any(e["event"] == "driving" for e in r["events"]), loop.report()
    node_log = loop.node.log.read_text()
    assert node_log.count("reached: stopped") == len(GOALS), loop.report()
    assert "Traceback" not in node_log, loop.report()


@pytest.mark.slow  # the closed loop: a ROS graph and a trained policy
@pytest.mark.parametrize("name", list(LOOPS))
def test_the_node_stops_without_goal_on_stale_odometry_bad_scans_and_shutdown(loops, name):
    loop = loops[name]
    r = loop.result
    assert r is not None, f"no result\n{loop.report()}"
    assert r["idle_command"] == [0.0, 0.0], loop.report()  # before the first goal
    # 1.6 s without odometry, then 5 scans that do not cover 360 degrees.
    assert r["stops"]["stale_odometry"] >= 2 and r["stops"]["bad_scan"] >= 3, loop.report()
    # Reaching a goal stops the robot: the sim sent the next goal only after a stop
    # within the goal radius (first test). Interrupting the node stops it too:
    assert r["last_command"] == [0.0, 0.0], loop.report()
    assert loop.node.p.returncode == 0, loop.report()
