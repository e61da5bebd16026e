"""Could any robot as fast as the burger get past the ring of a spinning stage? A bound.

ROBOTIS' stage 3 (and stage3_humble) spin four cylinders on one body about the
origin, where the robot starts, inside the ring they sweep. Seen from a frame that
turns with the body, the cylinders stand still and the robot drifts: its velocity
there is ``u - w x p`` for the velocity ``u`` it commands in the world. This script
computes, on a raster of that frame, a set that holds every point a robot could
reach from the start, over any time, moving in any direction at up to ``--speed``
m/s (a disc of the burger's collision radius that can also move sideways, so at
least as capable as the burger with any action set), never touching a cylinder, and
prints the farthest radius of the set beside the ring's outer edge (the cylinders'
orbit plus their radius and the robot's).

The set only over-approximates: each step of ``dt`` grows it by ``speed * dt`` plus
the raster's rounding, rotates it with the frame (cell centres, then that growth),
and removes only cells wholly inside a cylinder's reach (the robot's radius added),
ignoring the walls. So where its farthest radius stays inside the ring, no robot at
that speed gets out and no goal beyond the ring can be reached: the world cannot be
solved, whatever the policy or planner. Where it gets out, the bound rules nothing
out, and what a planner or a policy scores is the measure.

    python scripts/moving_reach.py stage3 stage3_humble
    python scripts/moving_reach.py stage3 --speed 0.1
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
from scipy import ndimage

from jaxnav.core.errors import MazeError
from jaxnav.world.maps import ROBOT_RADIUS, make_maze

BURGER_SPEED = 0.22  # m/s, the burger's largest linear command


def spinning(name: str) -> tuple[np.ndarray, np.ndarray, float, float, np.ndarray]:
    """(cylinder centres at time 0 [K, 2], radii [K], spin rad/s, arena half side, the
    robot's start [2]) of a stage whose cylinders all spin about the origin at one rate."""
    try:
        maze = make_maze(name)
    except MazeError as e:
        raise SystemExit(f"moving_reach: {e}") from None
    m = maze.motion
    if m is None:
        raise SystemExit(f"{name}: no moving obstacles")
    spin = np.asarray(m.spin, np.float64)
    centre = np.asarray(m.centre, np.float64)
    if np.any(spin != spin[0]) or np.any(centre != 0.0) or spin[0] == 0.0:
        raise SystemExit(f"{name}: its cylinders do not all spin about the origin at one rate")
    loops = np.asarray(m.points, np.float64)  # [K, waypoints, 2]
    if np.any(loops != loops[:, :1]):
        raise SystemExit(f"{name}: its cylinders also move along paths")
    half = float(np.max(np.abs(np.asarray(maze.bounds))))
    start = np.asarray(maze.start[:2], np.float64)
    return loops[:, 0], np.asarray(m.radius, np.float64), float(spin[0]), half, start


def farthest_reach(
    name: str, speed: float, cell: float, dt: float, horizon: float
) -> tuple[float, float, float, float]:
    """(farthest radius of the over-approximated reachable set, the ring's inner and
    outer edge for the robot's centre, the time the set stopped growing or the horizon)."""
    centres, radii, spin, half, start = spinning(name)
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("stages", nargs="+", help="stages whose cylinders spin about the origin")
    ap.add_argument("--speed", type=float, default=BURGER_SPEED, help="m/s, in any direction")
    ap.add_argument("--cell", type=float, default=0.005, help="raster cell, m")
    ap.add_argument("--dt", type=float, default=0.2, help="time step, s")
    ap.add_argument("--horizon", type=float, default=120.0, help="s")
    args = ap.parse_args(argv)
    for name in args.stages:
        try:
            far, lo, hi, t = farthest_reach(name, args.speed, args.cell, args.dt, args.horizon)
        except SystemExit as e:  # a stage the bound does not apply to: one line, status 2
            print(e, file=sys.stderr)
            return 2
        verdict = (
            "cannot leave the ring: no goal beyond it is reachable"
            if far < hi
            else "gets past the ring, so the bound rules the world out for no robot this fast"
        )
        print(
            f"{name}: a robot at up to {args.speed} m/s in any direction reaches at most "
            f"{far:.3f} m from the centre (within {t:.0f} s); the cylinders' ring spans "
            f"{lo:.3f}-{hi:.3f} m for the robot's centre: it {verdict}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
