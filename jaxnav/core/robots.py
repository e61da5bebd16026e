"""Robot profiles by name: the robot a config drives (``robot: burger | waffle_pi |
jackal``), the registry every part of jaxnav reads.

A profile holds the makers' numbers (footprint, speed and acceleration limits, the
LiDAR's beams, field of view and range, each with its source in ``sources``) and the
config defaults they give, applied as a preset's are: after the preset's, before the
file's and the command line's, so a user's own value always wins. The burger's defaults
are empty: the paper's numbers are the burger's, and a config that names no robot
drives the burger exactly as before.

Where the environment reads the profile (``NavEnv.robot``): the action sets' commands
(``vw``, ...) are the burger's scaled by this robot's top speed and yaw rate over the
burger's teleop limits; the normalised observation and the change penalty scale the
last command by this robot's limits; continuous commands may reach its limits; the
burger's firmware wheel limit (``env.wheel_limit``) is the burger's alone. The robot
is a disc of ``radius`` (env.robot_radius) for collisions; ``footprint`` says what it
models. No JAX here::

    from jaxnav.core import robots

    robots.register(robots.Robot(name="mybot", ...))
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

# The burger's teleop limits (jaxnav.core.settings.BURGER_MAX_V, BURGER_MAX_OMEGA).
_BURGER_V, _BURGER_OMEGA = 0.22, 2.84


@dataclass(frozen=True)
class Robot:
    """One robot as registered (lengths m, speeds m/s and rad/s, angles degrees)."""

    name: str
    about: str
    footprint: tuple[float, float]  # length x width of the body (a box), m
    radius: float  # the disc jaxnav tests for collision, m
    max_v: float  # top forward speed
    max_omega: float  # top yaw rate
    accel: tuple[float, float] | None  # (linear m/s^2, angular rad/s^2) limits, or None
    lidar: str  # the scanner
    lidar_beams: int  # its samples per scan
    lidar_fov: float  # its field of view, degrees
    lidar_range: tuple[float, float]  # (min, max), m
    sources: tuple[str, ...]  # where each number comes from
    # config defaults (dotted keys) this robot gives, after the preset's
    defaults: dict[str, Any] = field(default_factory=dict)

    @property
    def command_scale(self) -> tuple[float, float]:
        """(v, omega) factors from the burger's action sets to this robot's."""
        return self.max_v / _BURGER_V, self.max_omega / _BURGER_OMEGA


_REGISTRY: dict[str, Robot] = {}


def register(robot: Robot) -> Robot:
    """Register a robot profile (a second registration of a name replaces the first)."""
    _REGISTRY[robot.name] = robot
    return robot


def get(name: str) -> Robot:
    if name not in _REGISTRY:
        raise KeyError(f"unknown robot {name!r} (choose from {', '.join(names())})")
    return _REGISTRY[name]


def names() -> list[str]:
    return list(_REGISTRY)


def config_defaults(values: dict[str, Any]) -> dict[str, Any]:
    """The config defaults of the robot flat config ``values`` name (``env.robot``, or
    its short name ``robot``, which is moved to ``env.robot`` in ``values``)."""
    from jaxnav.core.errors import ConfigError

    if "robot" in values:
        if "env.robot" in values:
            raise ConfigError("config: robot is env.robot's short name: set one of them")
        values["env.robot"] = values.pop("robot")
    name = values.get("env.robot", "burger")
    return defaults(name) if isinstance(name, str) else {}


def defaults(name: str) -> dict[str, Any]:
    """The config defaults of robot ``name`` (none for an unknown name: the config's own
    check names it)."""
    robot = _REGISTRY.get(name)
    return dict(robot.defaults) if robot is not None else {}


register(
    Robot(
        name="burger",
        about="ROBOTIS TurtleBot3 Burger with its LDS-01 LiDAR (the paper's robot)",
        footprint=(0.138, 0.178),
        radius=0.13,
        max_v=_BURGER_V,
        max_omega=_BURGER_OMEGA,
        accel=None,
        lidar="ROBOTIS LDS-01 (HLS-LFCD2)",
        lidar_beams=360,
        lidar_fov=360.0,
        lidar_range=(0.12, 3.5),
        sources=(
            "footprint 138 x 178 mm: ROBOTIS e-Manual, TurtleBot3 specifications",
            "radius 0.13 m: ROBOTIS' collision threshold (turtlebot3_machine_learning, "
            "min_range); the body's own is 0.105 m (OpenCR turtlebot3_burger.h ROBOT_RADIUS)",
            "0.22 m/s, 2.84 rad/s: turtlebot3_teleop BURGER_MAX_LIN_VEL, BURGER_MAX_ANG_VEL",
            "no acceleration limit: the OpenCR firmware sets the wheels' speed at once",
            "LDS-01: 360 samples over 360 degrees, 0.12-3.5 m (turtlebot3_description)",
        ),
    )
)

register(
    Robot(
        name="waffle_pi",
        about="ROBOTIS TurtleBot3 Waffle Pi with its LDS-01 LiDAR",
        footprint=(0.281, 0.306),
        radius=0.22,
        max_v=0.26,
        max_omega=1.82,
        accel=None,
        lidar="ROBOTIS LDS-01 (HLS-LFCD2)",
        lidar_beams=360,
        lidar_fov=360.0,
        lidar_range=(0.12, 3.5),
        sources=(
            "footprint 281 x 306 mm: ROBOTIS e-Manual, TurtleBot3 specifications",
            "radius 0.22 m: OpenCR turtlebot3_waffle.h ROBOT_RADIUS (ROBOTIS-GIT/OpenCR)",
            "0.26 m/s, 1.82 rad/s: turtlebot3_teleop WAFFLE_MAX_LIN_VEL, WAFFLE_MAX_ANG_VEL",
            "no acceleration limit: the OpenCR firmware sets the wheels' speed at once",
            "LDS-01: as the burger's",
        ),
        defaults={"env.robot_radius": 0.22},
    )
)

# The Jackal's disc (env.robot_radius): its body is a 0.508 x 0.430 m box. docs/barn.md
# shows what each disc lets it pass in BARN's worlds, measured with the oracle.
JACKAL_RADIUS = 0.25

register(
    Robot(
        name="jackal",
        about="Clearpath Jackal with a Hokuyo UST-10 LiDAR (the BARN challenge's robot)",
        footprint=(0.508, 0.430),
        radius=JACKAL_RADIUS,
        max_v=2.0,
        max_omega=4.0,
        accel=(20.0, 25.0),
        lidar="Hokuyo UST-10LX",
        lidar_beams=720,
        lidar_fov=270.0,
        lidar_range=(0.1, 10.0),
        sources=(
            "footprint 508 x 430 mm: Clearpath Robotics, Jackal specifications",
            "2.0 m/s, 4.0 rad/s, accelerations 20 m/s^2 and 25 rad/s^2: jackal/jackal "
            "jackal_control/config/control.yaml (commit eb028c91)",
            "UST-10: 720 samples over -2.35619..2.35619 rad (270 degrees), noise std 0.001 m: "
            "jackal/jackal jackal_description/urdf/accessories/hokuyo_ust10.urdf.xacro "
            "(commit 02d83ff6), which the BARN challenge's run.py selects "
            "(JACKAL_LASER_MODEL=ust10)",
            "range 0.1 m (the Gazebo model's minimum) to 10 m (Hokuyo's rated range for the "
            "UST-10LX; the Gazebo model reads to 30 m)",
        ),
        defaults={
            "env.robot_radius": JACKAL_RADIUS,
            "env.n_beams": 720,
            "env.lidar_fov": 270.0,
            "env.min_range": 0.1,
            "env.max_range": 10.0,
            "env.speed_range": (0.0, 2.0),
            "env.max_yaw_rate": 4.0,
        },
    )
)


__all__ = ["JACKAL_RADIUS", "Robot", "config_defaults", "defaults", "get", "names", "register"]
