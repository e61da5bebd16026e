"""ROBOTIS' machine-learning stages 3 and 4, with their moving cylinders.

Every number is from ROBOTIS' sources (turtlebot3_simulations' worlds and models,
turtlebot3_machine_learning's obstacle nodes and plugins; the files and commits are
listed in docs/worlds.md). The built-ins are the ROS 1 worlds the paper's ROBOTIS
code trained on; the ``_humble`` variants are ROS 2 Humble's, whose worlds differ.

* ``stage3``: square4 (3.7 m free) with four cylinders r 0.15 m at (+-0.6, +-0.6)
  on one body that ``moving_obstacle.py`` keeps spinning at 0.5 rad/s about the
  origin (a 12.6 s turn, 0.42 m/s at the cylinders). Start (0, 0).
* ``stage3_humble``: a 4.7 m arena, the cylinders at (+-1, +-1) turning once in
  40 s (``obstacles.cpp``'s yaw keyframes 0, pi, 2 pi at 0, 20, 40 s). Start (0, 0).
* ``stage4``: the 4.7 m plaza with eight inner walls (1 x 0.15 m) and two cylinders
  r 0.12 m on the waypoint loops of ``combination_obstacle_1.py`` and
  ``combination_obstacle_2.py``; each leg is driven at the node's step per 0.1 s
  tick (0.07 to 0.21 m/s). Start (-0.7, 0).
* ``stage4_humble``: the same arena with seven inner walls, the cylinders on the
  keyframes of ``obstacle1.cpp`` (160 s loop) and ``obstacle2.cpp`` (140 s loop).
  Start (0, 0).

Simplifications, each small: a leg of stage 4's nodes is driven straight from
waypoint to waypoint (the node adds a fixed step that may point a little off it);
Gazebo's keyframe splines are taken as straight lines between keyframes; the nodes'
10 Hz is taken as exact, and ground friction, which slows stage 3's body between the
node's velocity resets in Gazebo, is not modelled. The obstacles restart from their
first pose at every episode start, as ROBOTIS' reset of the simulation puts them back.
"""

from __future__ import annotations

import math

import numpy as np

from jaxnav.world.motion import Motion, make_motion

WALL_LENGTH, WALL_THICKNESS = 1.0, 0.15  # m, every inner wall of stage 4
HALF_PLAZA = 2.35  # m, the 4.7 m arena's inner faces


def wall_rectangle(cx: float, cy: float, yaw_deg: float, half_limit: float) -> np.ndarray:
    """A 1 x 0.15 m wall centred at (cx, cy), long side along ``yaw``, cut at the
    arena's inner faces (walls that touch the outer wall stop at its face)."""
    a = math.radians(yaw_deg)
    u = np.array([math.cos(a), math.sin(a)]) * WALL_LENGTH / 2
    n = np.array([-math.sin(a), math.cos(a)]) * WALL_THICKNESS / 2
    c = np.array([cx, cy])
    corners = np.array([c - u - n, c + u - n, c + u + n, c - u + n])
    return np.clip(np.round(corners, 6), -half_limit, half_limit)


# stage 4 (ROS 1), turtlebot3_plaza/model.sdf: (centre x, centre y, yaw degrees)
PLAZA_WALLS = (
    (-1.064, 1.548, 0),
    (-1.502, 0.092, -90),
    (-1.937, -1.467, 0),
    (-0.22, -1.866, -90),
    (1.195, -1.002, 90),
    (1.288, 1.93, -90),
    (1.91128, 0.4632, 0),
    (0.204, 0.215, -90),
)
# stage 4 (ROS 2 Humble), turtlebot3_dqn_world/inner_walls/model.sdf
HUMBLE_INNER_WALLS = (
    (-2.0, -1.5, 0),
    (-0.5, -2.0, -90),
    (1.0, -1.0, 90),
    (1.2, 1.9, -90),
    (1.9, 0.4, 0),
    (-0.5, 1.5, 0),
    (-1.2, 0.092, -90),
)

# combination_obstacle_1.py / _2.py: waypoints, and the (dx, dy) added per 0.1 s tick
# on the leg that leaves each waypoint.
OBSTACLE_1_WAYPOINTS = (
    (2, 2), (1.5, 0.8), (0.5, 1.5), (-0.3, 1.3), (-1, 0.8), (-2, 1.5), (-2.2, 0.8),
    (-1.8, -0.3), (-1.5, -1), (-0.6, -0.3), (0.5, -1.4), (1.1, -2), (2, -1), (1.2, 0),
    (0.5, 0.5), (2.2, 1.3),
)  # fmt: skip
OBSTACLE_1_STEPS = (
    (-.005, -.012), (-.01, .007), (-.008, -.002), (-.007, -.005), (-.01, .007),
    (-.002, -.007), (.004, -.011), (.003, -.007), (.009, .007), (.011, -.011),
    (.006, -.006), (.009, .01), (-.008, .01), (-.007, .005), (.017, .008), (-.002, .007),
)  # fmt: skip
OBSTACLE_2_WAYPOINTS = (
    (-2, -2), (-1.3, -2.1), (-0.4, -1.2), (-1, -0.6), (-0.2, -0.7), (1.1, -2), (2, -1),
    (1.2, 0), (0.5, 2), (-2.1, 1.8), (-0.5, 0.2), (-0.9, -2.1),
)  # fmt: skip
OBSTACLE_2_STEPS = (
    (.007, -.001), (.009, .009), (-.006, .006), (.008, -.001), (.013, -.013), (.009, .01),
    (-.008, .01), (-.007, .02), (-.013, -.001), (.008, -.008), (-.002, -.0115),
    (-.011, .001),
)  # fmt: skip
NODE_TICK = 0.1  # s, the obstacle nodes' loop period

# obstacle1.cpp / obstacle2.cpp (ROS 2 Humble): keyframe times (s) and world positions.
HUMBLE_OBSTACLE_1 = (
    (0, 10, 50, 70, 90, 130, 140, 160),
    ((2, 2), (1.5, 1.0), (-1.5, 1.0), (-1.7, -1.0), (-1.5, 1.0), (1.5, 1.0), (2, 2), (2, 2)),
)
HUMBLE_OBSTACLE_2 = (
    (0, 10, 40, 55, 85, 100, 110, 115, 120, 125, 130, 140),
    (
        (-2, -2), (-1.3, -1.8), (0.5, 1.5), (-1.7, 1.5), (1.5, -0.2), (1.5, -2.0),
        (0.0, -1.5), (-0.5, -1.0), (-1.0, -1.5), (-1.5, -1.9), (-2, -2), (-2, -2),
    ),
)  # fmt: skip

STAGE3_SPIN = 0.5  # rad/s, moving_obstacle.py's twist angular.z
HUMBLE_STAGE3_SPIN = 2 * 3.141592 / 40  # obstacles.cpp: yaw 2 PI in 40 s, PI = 3.141592


def _node_loop(waypoints, steps, radius: float) -> dict:
    speeds = [math.hypot(*s) / NODE_TICK for s in steps]
    return {"radius": radius, "points": waypoints, "speeds": speeds}


def _keyframe_loop(keys, radius: float) -> dict:
    times, points = keys
    # the loop closes on its first point at the last time (both files end there)
    return {"radius": radius, "points": points[:-1], "times": times}


def _spinning(points, radius: float, spin: float) -> list[dict]:
    return [{"radius": radius, "points": [p], "spin": spin} for p in points]


def stage(name: str) -> tuple[np.ndarray, list[np.ndarray], np.ndarray, Motion]:
    """(outline side m, inner wall polygons, start pose, motion) of a stage."""
    corners = [(0.6, 0.6), (-0.6, 0.6), (-0.6, -0.6), (0.6, -0.6)]
    if name == "stage3":
        return (
            3.7,
            [],
            np.array([0.0, 0.0, 0.0]),
            make_motion(_spinning(corners, 0.15, STAGE3_SPIN)),
        )
    if name == "stage3_humble":
        far = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
        return (
            4.7,
            [],
            np.array([0.0, 0.0, 0.0]),
            make_motion(_spinning(far, 0.15, HUMBLE_STAGE3_SPIN)),
        )
    if name == "stage4":
        walls = [wall_rectangle(*w, HALF_PLAZA) for w in PLAZA_WALLS]
        motion = make_motion(
            [
                _node_loop(OBSTACLE_1_WAYPOINTS, OBSTACLE_1_STEPS, 0.12),
                _node_loop(OBSTACLE_2_WAYPOINTS, OBSTACLE_2_STEPS, 0.12),
            ]
        )
        return 4.7, walls, np.array([-0.7, 0.0, 0.0]), motion
    if name == "stage4_humble":
        walls = [wall_rectangle(*w, HALF_PLAZA) for w in HUMBLE_INNER_WALLS]
        motion = make_motion(
            [_keyframe_loop(HUMBLE_OBSTACLE_1, 0.12), _keyframe_loop(HUMBLE_OBSTACLE_2, 0.12)]
        )
        return 4.7, walls, np.array([0.0, 0.0, 0.0]), motion
    raise KeyError(name)


STAGES = {
    "stage3": "TurtleBot3 stage 3 (ROS 1): square4, four cylinders spinning about the centre",
    "stage3_humble": "stage 3 as in ROS 2 Humble: 4.7 m arena, cylinders at (+-1, +-1), 40 s turn",
    "stage4": "TurtleBot3 stage 4 (ROS 1): 4.7 m plaza, 8 inner walls, two cylinders on loops",
    "stage4_humble": "stage 4 as in ROS 2 Humble: 7 inner walls, keyframed cylinders",
}

__all__ = ["STAGES", "stage", "wall_rectangle"]
