"""Could any robot as fast as the burger get past the ring of a spinning stage? A bound
(NumPy and SciPy, no JAX).

ROBOTIS' stage 3 (and stage3_humble) spin four cylinders on one body about the
origin, where the robot starts, inside the ring they sweep. Seen from a frame that
turns with the body, the cylinders stand still and the robot drifts: its velocity
there is ``u - w x p`` for the velocity ``u`` it commands in the world.
:func:`farthest_reach` computes, on a raster of that frame, a set that holds every
point a robot could reach from the start, over any time, moving in any direction at up
to ``speed`` m/s (a disc of the burger's collision radius that can also move sideways,
so at least as capable as the burger with any action set), never touching a cylinder,
and gives the farthest radius of the set beside the ring's outer edge (the cylinders'
orbit plus their radius and the robot's).

The set only over-approximates: each step of ``dt`` grows it by ``speed * dt`` plus
the raster's rounding, rotates it with the frame (cell centres, then that growth),
and removes only cells wholly inside a cylinder's reach (the robot's radius added),
ignoring the walls. So where its farthest radius stays inside the ring, no robot at
that speed gets out and no goal beyond the ring can be reached: the world cannot be
solved, whatever the policy or planner. Where it gets out, the bound rules nothing
out, and what a planner or a policy scores is the measure.

``jaxnav probe reach STAGE ... [--speed S]`` prints the bound for each stage.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage

from jaxnav.core.errors import MazeError
from jaxnav.world.paths import ROBOT_RADIUS

BURGER_SPEED = 0.22  # m/s, the burger's largest linear command


class Spinning(NamedTuple):
    """A stage whose cylinders all spin about the origin at one rate."""

    centres: np.ndarray  # f64[K, 2] the cylinders' centres at time 0
    radii: np.ndarray  # f64[K]
    spin: float  # rad/s
    half: float  # m, the arena's half side
    start: np.ndarray  # f64[2] the robot's start


def spinning(maze, name: str) -> Spinning:
    """The :class:`Spinning` stage of ``maze`` (a :class:`jaxnav.world.maps.Maze`, named
    ``name`` in errors); :class:`MazeError` where its cylinders do not all spin about
    the origin at one rate."""
    m = maze.motion
    if m is None:
        raise MazeError(f"{name}: no moving obstacles")
    spin = np.asarray(m.spin, np.float64)
    centre = np.asarray(m.centre, np.float64)
    if np.any(spin != spin[0]) or np.any(centre != 0.0) or spin[0] == 0.0:
        raise MazeError(f"{name}: its cylinders do not all spin about the origin at one rate")
    loops = np.asarray(m.points, np.float64)  # [K, waypoints, 2]
    if np.any(loops != loops[:, :1]):
        raise MazeError(f"{name}: its cylinders also move along paths")
    half = float(np.max(np.abs(np.asarray(maze.bounds))))
    start = np.asarray(maze.start[:2], np.float64)
    return Spinning(loops[:, 0], np.asarray(m.radius, np.float64), float(spin[0]), half, start)


def farthest_reach(
    stage: Spinning, speed: float, cell: float, dt: float, horizon: float
) -> tuple[float, float, float, float]:
    """(farthest radius of the over-approximated reachable set, the ring's inner and
    outer edge for the robot's centre, the time the set stopped growing or the horizon)."""
    centres, radii, spin, half, start = stage
    n = int(math.ceil(2 * half / cell))
    xs = (np.arange(n) + 0.5) * cell - half
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    blocked = np.zeros((n, n), bool)  # cells wholly within a cylinder's reach
    inner = cell / math.sqrt(2.0)
    for (cx, cy), r in zip(centres, radii):
        blocked |= np.hypot(X - cx, Y - cy) < r + ROBOT_RADIUS - inner
    orbit = np.hypot(centres[:, 0], centres[:, 1])
    ring = (
        float(np.min(orbit - radii - ROBOT_RADIUS)),
        float(np.max(orbit + radii + ROBOT_RADIUS)),
    )
    grow = speed * dt + 2 * inner  # the step's motion and two roundings to the raster
    k = int(math.ceil(grow / cell))
    g = np.arange(-k, k + 1) * cell
    disc = np.hypot(*np.meshgrid(g, g, indexing="ij")) <= grow
    reach = np.zeros((n, n), bool)
    reach[tuple(np.clip(((start + half) / cell).astype(int), 0, n - 1))] = True
    c, s = math.cos(-spin * dt), math.sin(-spin * dt)  # the frame turns with the body
    t = 0.0
    while t < horizon:
        i, j = np.nonzero(reach)
        x, y = xs[i], xs[j]
        xr, yr = c * x - s * y, s * x + c * y
        ii = np.clip(np.floor((xr + half) / cell).astype(int), 0, n - 1)
        jj = np.clip(np.floor((yr + half) / cell).astype(int), 0, n - 1)
        moved = np.zeros_like(reach)
        moved[ii, jj] = True
        nxt = (ndimage.binary_dilation(moved, structure=disc) | reach) & ~blocked
        t += dt
        if np.array_equal(nxt, reach):
            break
        reach = nxt
    r = np.hypot(X, Y)[reach]
    return float(r.max()), ring[0], ring[1], t


def verdict_line(name: str, speed: float, bound: tuple[float, float, float, float]) -> str:
    """The bound of stage ``name`` (:func:`farthest_reach`'s result) as one line."""
    far, lo, hi, t = bound
    verdict = (
        "cannot leave the ring: no goal beyond it is reachable"
        if far < hi
        else "gets past the ring, so the bound rules the world out for no robot this fast"
    )
    return (
        f"{name}: a robot at up to {speed} m/s in any direction reaches at most "
        f"{far:.3f} m from the centre (within {t:.0f} s); the cylinders' ring spans "
        f"{lo:.3f}-{hi:.3f} m for the robot's centre: it {verdict}"
    )
