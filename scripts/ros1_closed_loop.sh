#!/usr/bin/env bash
# The ROS 1 policy node, closed-loop through a live ROS master (tests/test_ros1.py):
# installs Debian's ROS 1 packages if they are missing, then runs that test.
#
#   scripts/ros1_closed_loop.sh                 install if needed, run the test
#   scripts/ros1_closed_loop.sh --install-only  install if needed; exit 1 if it cannot
#
# Needs Debian (bookworm packages ros-core and python3-rospy) and root or sudo for
# apt-get; with the packages already installed it needs neither and touches nothing.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(ros-core python3-rospy python3-sensor-msgs python3-nav-msgs
          python3-geometry-msgs python3-numpy python3-yaml)

installed() {
    local p
    for p in "${PACKAGES[@]}"; do
        [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null)" = "install ok installed" ] || return 1
    done
    command -v rosmaster >/dev/null
}

install() {
    if installed; then
        echo "ROS 1 packages already installed"
        return 0
    fi
    if ! command -v apt-get >/dev/null; then
        echo "no apt-get here: cannot install ${PACKAGES[*]}" >&2
        return 1
    fi
    local sudo=()
    if [ "$(id -u)" -ne 0 ]; then
        command -v sudo >/dev/null || { echo "not root and no sudo: cannot apt-get install" >&2; return 1; }
        sudo=(sudo -n)
    fi
    echo "installing ${PACKAGES[*]}"
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q || return 1
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
        "${PACKAGES[@]}" || return 1
    installed
}

if [ "${1:-}" = "--install-only" ]; then
    install
    exit
fi
install || { echo "ROS 1 could not be installed: the closed-loop test would skip" >&2; exit 1; }
if [ -x .venv/bin/python ]; then
    PY=.venv/bin/python
else
    PY=python3
fi
exec "$PY" -m pytest tests/test_ros1.py -rs
