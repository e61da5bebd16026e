"""The built-in mazes' geometry: the paper's rooms (TurtleBot3 stages 1 and 2 and their
variants) and, from :mod:`jaxnav.world.stages`, ROBOTIS' stages 3 and 4. What each is:
:data:`BUILTIN_MAZES`; :func:`jaxnav.world.maps.make_maze` builds them.
"""

from __future__ import annotations

import math

import numpy as np

from jaxnav.world.stages import STAGES


def _regular_polygon(n: int, area: float, angle0: float) -> np.ndarray:
    """Regular n-gon of the given area centred at the origin, first vertex at angle0."""
    circumradius = math.sqrt(2 * area / (n * math.sin(2 * math.pi / n)))
    ang = angle0 + 2 * math.pi * np.arange(n) / n
    return np.stack([circumradius * np.cos(ang), circumradius * np.sin(ang)], axis=1)


def square(side: float) -> np.ndarray:
    h = side / 2
    return np.array([[-h, -h], [h, -h], [h, h], [-h, h]])


SQUARE4_SIDE = 3.7
SQUARE4_AREA = SQUARE4_SIDE**2
_STAGE2_CYLINDERS = np.array(
    [[0.6, 0.6, 0.15], [-0.6, 0.6, 0.15], [-0.6, -0.6, 0.15], [0.6, -0.6, 0.15]]
)


def _pentagon_cylinders() -> np.ndarray:
    # Same radius as stage 2 and the same distance from the start (0.6 * sqrt 2).
    r = 0.6 * math.sqrt(2)
    ang = math.pi / 2 + 2 * math.pi * np.arange(5) / 5
    return np.stack([r * np.cos(ang), r * np.sin(ang), np.full(5, 0.15)], axis=1)


def builtin(name: str):
    """Return (outline, circles, polygons, start) of a built-in maze."""
    start = np.array([0.0, 0.0, 0.0])
    none = np.zeros((0, 3))
    if name == "square2":
        return square(SQUARE4_SIDE / 2), none, [], start
    if name == "square4":
        return square(SQUARE4_SIDE), none, [], start
    if name == "square8":
        return square(SQUARE4_SIDE * 2), none, [], start
    if name == "triangle":
        tri = _regular_polygon(3, SQUARE4_AREA, math.pi / 2)
        return tri, none, [], start
    if name == "pentagon":
        return _regular_polygon(5, SQUARE4_AREA, math.pi / 2), none, [], start
    if name == "square4_obstacles":
        return square(SQUARE4_SIDE), _STAGE2_CYLINDERS.copy(), [], start
    if name == "pentagon_obstacles":
        pent = _regular_polygon(5, SQUARE4_AREA, math.pi / 2)
        return pent, _pentagon_cylinders(), [], start
    raise KeyError(name)


# The built-in mazes, each with what ``jaxnav list`` says of it.
BUILTIN_MAZES = {
    "square2": "square room of half square4's side (1.85 m free)",
    "square4": "TurtleBot3 stage 1: square room, 3.7 m x 3.7 m free (the paper's training maze)",
    "square8": "square room of twice square4's side (7.4 m free)",
    "triangle": "equilateral triangle of square4's area",
    "pentagon": "regular pentagon of square4's area",
    "square4_obstacles": "TurtleBot3 stage 2: square4, four cylinders (r 0.15 m) at (+-0.6, +-0.6)",
    "pentagon_obstacles": "pentagon with five cylinders (r 0.15 m) 0.85 m from the centre",
    **STAGES,
}
