#!/usr/bin/env bash
# The ROS 2 policy node, closed-loop through DDS (tests/test_ros2.py): makes the ROS 2
# environment .venv-ros2 if it is missing, then runs that test.
#
#   scripts/ros2_env.sh                 make it if needed, run the test
#   scripts/ros2_env.sh --install-only  make it if needed; exit 1 if it cannot
#
# ROS 2's Python client from PyPI's wheels (rclpy 9.1.2, ROS 2 Kilted; Fast DDS), in a
# virtual environment of its own: no apt, no root, no sourcing of /opt/ros. MuJoCo too,
# pinned to the version jaxnav's .venv gets from the 'sim' extra (pyproject.toml), for
# the MuJoCo TurtleBot3 behind the same topics (jaxnav/robot/mujoco_ros2.py). It is made
# with the same Python as jaxnav's .venv where there is one, because the test's
# simulated robot loads JAX from .venv and rclpy from .venv-ros2 in one interpreter.
set -euo pipefail
cd "$(dirname "$0")/.."

VENV=.venv-ros2
PACKAGES=(ros-rclpy==9.1.2 ros-sensor-msgs==5.5.1 ros-geometry-msgs==5.5.1
          ros-nav-msgs==5.5.1 ros-rmw-fastrtps-cpp==9.3.3 mujoco==4.0.0 numpy pyyaml)
CHECK="import numpy, rclpy, sensor_msgs.msg, nav_msgs.msg, geometry_msgs.msg, rmw_fastrtps_cpp"
CHECK="$CHECK, mujoco"

ready() {
    [ -x "$VENV/bin/python" ] && env -u PYTHONPATH "$VENV/bin/python" -c "$CHECK" 2>/dev/null
}

install() {
    if ready; then
        echo "ROS 2 environment $VENV already made"
        return 0
    fi
    local base=python3
    if [ -x .venv/bin/python ]; then  # the interpreter behind jaxnav's own environment
        base=$(.venv/bin/python -c 'import sys; print(sys._base_executable)')
    fi
    echo "making $VENV with $base: ${PACKAGES[*]}"
    rm -rf "$VENV"
    "$base" -m venv "$VENV" || return 1
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "${PACKAGES[@]}" \
        || return 1
    ready || { echo "$VENV cannot import rclpy and the messages after the install" >&2; return 1; }
}

if [ "${1:-}" = "--install-only" ]; then
    install
    exit
fi
install || { echo "the ROS 2 environment could not be made: the closed-loop test would skip" >&2; exit 1; }
if [ -x .venv/bin/python ]; then
    PY=.venv/bin/python
else
    PY=python3
fi
exec "$PY" -m pytest tests/test_ros2.py -rs
