"""The burger's wheel limits: a velocity command as the OpenCR firmware executes it.

The TurtleBot3 burger's firmware does not drive every command it receives. ROBOTIS'
OpenCR firmware for ROS 1 (ROBOTIS-GIT/OpenCR master 68ec75d8,
``arduino/opencr_arduino/opencr/libraries/turtlebot3/``; the same logic on
noetic-devel and develop) does two things:

1. ``examples/turtlebot3_burger/turtlebot3_core/turtlebot3_core.ino``,
   ``commandVelocityCallback``: linear.x and angular.z are each clipped to
   +-MAX_LINEAR_VELOCITY and +-MAX_ANGULAR_VELOCITY (``turtlebot3_burger.h``:
   0.033 * 2 pi * 61 / 60 = 0.2108 m/s and that over the 0.080 m turning radius,
   2.635 rad/s);
2. ``src/turtlebot3/turtlebot3_motor_driver.cpp``, ``controlMotor``: the wheels' speeds
   v -/+ omega L / 2 (L = 0.160 m) are converted to Dynamixel units
   (VELOCITY_CONSTANT_VALUE / r = 41.69988758 / 0.033 per m/s) and each is clipped on
   its own to BURGER_DXL_LIMIT_MAX_VELOCITY = 265 units, 0.2097 m/s at the wheel.

So the ratio of v to omega is not kept when a wheel saturates: the paper's turn
(0.15 m/s, 1.5 rad/s) asks 0.27 m/s of the outer wheel and the robot drives
(0.1199 m/s, 1.123 rad/s). :func:`firmware_limit` returns the (v, omega) the robot
drives: both steps, then the wheels back to (v, omega). The firmware's truncation of
each wheel to a whole unit (1 / 1263.6 m/s) is left out.

The ROS 2 firmware (``libraries/turtlebot3_ros2/``) has the same command clip but a
per-wheel limit of 337 units (0.267 m/s, set for the waffle's XM430); the burger's
XL430 saturates near 61 rpm (0.21 m/s) whichever firmware runs, so the ROS 1 limit is
the one modelled.

No JAX and no NumPy here: the function is plain arithmetic and ``.clip``, so it runs on
JAX arrays inside the compiled step (``jaxnav.env``) and on NumPy numbers in the MuJoCo
robot (``jaxnav.robot.mujoco_rollout``) alike.
"""

from __future__ import annotations

import math
from typing import Any

WHEEL_RADIUS = 0.033  # m, turtlebot3_burger.h
WHEEL_SEPARATION = 0.160  # m
MAX_LINEAR_VELOCITY = WHEEL_RADIUS * 2 * math.pi * 61 / 60  # 0.21080 m/s
MAX_ANGULAR_VELOCITY = MAX_LINEAR_VELOCITY / (WHEEL_SEPARATION / 2)  # 2.6350 rad/s
# Dynamixel goal-velocity units per m/s of wheel speed: VELOCITY_CONSTANT_VALUE / r.
DXL_UNITS_PER_MPS = 41.69988758 / WHEEL_RADIUS
MAX_WHEEL_SPEED = 265 / DXL_UNITS_PER_MPS  # 0.20971 m/s: BURGER_DXL_LIMIT_MAX_VELOCITY


def firmware_limit(v: Any, omega: Any) -> tuple[Any, Any]:
    """(v m/s, omega rad/s) the burger drives for a command (v, omega).

    ``v`` and ``omega``: arrays of one shape (JAX or NumPy, scalars included; anything
    with arithmetic and ``.clip``). The command is clipped to the firmware's
    +-0.2108 m/s and +-2.635 rad/s, each wheel's speed to +-0.2097 m/s, and the two
    wheel speeds are turned back into (v, omega).
    """
    v = v.clip(-MAX_LINEAR_VELOCITY, MAX_LINEAR_VELOCITY)
    omega = omega.clip(-MAX_ANGULAR_VELOCITY, MAX_ANGULAR_VELOCITY)
    half = omega * (WHEEL_SEPARATION / 2)
    left = (v - half).clip(-MAX_WHEEL_SPEED, MAX_WHEEL_SPEED)
    right = (v + half).clip(-MAX_WHEEL_SPEED, MAX_WHEEL_SPEED)
    return (left + right) / 2, (right - left) / WHEEL_SEPARATION
