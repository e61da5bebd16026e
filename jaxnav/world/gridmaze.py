"""A maze made of an occupancy grid (:class:`jaxnav.world.occupancy.Occupancy`): its start
checked, its goals drawn ahead on the host from the free space the robot can reach.

The maze holds no walls or cylinders of its own (one masked row of each, as the arrays
need a row), only the grid (``Maze.grid``). Its admissible goals are points of a raster
over the maze's bounds (at most 0.05 m apart, half a cell on coarse grids) that are at
least :data:`jaxnav.world.maps.GOAL_CLEARANCE` from every occupied cell, at least
:data:`jaxnav.world.maps.GOAL_START_CLEARANCE` from the start and reachable from it:
in the start's connected part of the raster points at least the robot's radius
(:data:`jaxnav.world.maps.ROBOT_RADIUS`) from every occupied cell. Distances to square
cells are taken from the nearest cell centre less half the cell's diagonal, so goals
keep a little more room than they must.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from jaxnav.core.errors import MazeError
from jaxnav.world.maps import (
    _FAR,
    GOAL_CLEARANCE,
    GOAL_START_CLEARANCE,
    MAX_GOAL_POINTS,
    MIN_GOAL_POINTS,
    ROBOT_RADIUS,
    Maze,
)
from jaxnav.world.occupancy import Occupancy, exact_clearance, host_clearance

MAX_RASTER = 4_000_000  # raster points of the goal search at most (it is coarsened past this)


def grid_bounds(grid: Occupancy) -> np.ndarray:
    """f64[4]: the grid's extent (xmin, ymin, xmax, ymax)."""
    h, w = grid.shape
    x0, y0 = (float(v) for v in np.asarray(grid.origin, np.float64))
    return np.array([x0, y0, x0 + w * grid.res, y0 + h * grid.res])


def reachable_raster(grid: Occupancy, bounds: np.ndarray, start: np.ndarray, radius: float):
    """The raster points over ``bounds`` (f64[P, 2]), their clearance (f64[P]) and which
    the robot (a disc of ``radius``) reaches from ``start`` (bool[P]): the 8-connected
    part of the points with clearance at least ``radius`` that holds the start's nearest."""
    from scipy import ndimage

    h = min(grid.res / 2.0, 0.05)
    span = bounds[2:] - bounds[:2]
    while np.prod(np.ceil(span / h) + 1) > MAX_RASTER:
        h *= 1.5
    nx, ny = (int(math.ceil(s / h)) + 1 for s in span)
    xs = bounds[0] + h * np.arange(nx)
    ys = bounds[1] + h * np.arange(ny)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    clear = host_clearance(grid, pts)
    free = (clear >= radius).reshape(ny, nx)
    labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
    i = int(np.clip(round((start[1] - bounds[1]) / h), 0, ny - 1))
    j = int(np.clip(round((start[0] - bounds[0]) / h), 0, nx - 1))
    own = labels[i, j]
    reach = (labels == own).ravel() if own else np.zeros(len(pts), bool)
    return pts, clear, reach


def grid_maze(
    grid: Occupancy,
    start: np.ndarray,
    where: str,
    goal: np.ndarray | None = None,
    bounds: np.ndarray | None = None,
    obstacles: int = 0,
) -> Maze:
    """A maze of ``grid`` with the start pose ``start`` (x, y, yaw) and, if given, the
    first goal of every reset ``goal`` (x, y). ``bounds`` (xmin, ymin, xmax, ymax): the
    region goals are drawn from and the planners' raster covers (default the grid's
    extent); ``obstacles``: the count ``Maze.n_obstacles`` holds. A start within the
    robot's radius of an occupied cell, and a grid with no room for goals reachable from
    the start, are refused (:class:`MazeError` naming ``where``)."""
    start = np.asarray(start, np.float64)
    bounds = grid_bounds(grid) if bounds is None else np.asarray(bounds, np.float64)
    clear0 = exact_clearance(grid, start[None, :2])[0]
    if not clear0 >= ROBOT_RADIUS:
        raise MazeError(
            f"{where}: start ({start[0]:g}, {start[1]:g}) is inside a wall or within the robot "
            f"radius ({ROBOT_RADIUS} m) of one"
        )
    pts, clear, reach = reachable_raster(grid, bounds, start, ROBOT_RADIUS)
    ok = reach & (clear >= GOAL_CLEARANCE)
    ok &= np.linalg.norm(pts - start[None, :2], axis=1) >= GOAL_START_CLEARANCE
    goals = pts[ok]
    if len(goals) < MIN_GOAL_POINTS:
        raise MazeError(
            f"{where}: no free cell reachable from the start has room for goals (points "
            f"{GOAL_CLEARANCE} m clear of every occupied cell and {GOAL_START_CLEARANCE} m "
            "from the start)"
        )
    if len(goals) > MAX_GOAL_POINTS:  # thin evenly, deterministically
        goals = goals[np.linspace(0, len(goals) - 1, MAX_GOAL_POINTS).round().astype(int)]
    if goal is not None:
        g = np.asarray(goal, np.float64)
        if not exact_clearance(grid, g[None])[0] > ROBOT_RADIUS:
            raise MazeError(f"{where}: goal ({g[0]:g}, {g[1]:g}) is not in the free space")
    robotis = np.resize(goals, (256, 2))  # ROBOTIS' goal grid is the 3.7 m arena's
    return Maze(
        segments=jnp.full((1, 4), _FAR, jnp.float32),
        segment_mask=jnp.zeros(1, bool),
        circles=jnp.asarray([[_FAR, _FAR, 0.0]], jnp.float32),
        circle_mask=jnp.zeros(1, bool),
        start=jnp.asarray(start, jnp.float32),
        goal_points=jnp.asarray(goals, jnp.float32),
        n_goal_points=jnp.asarray(len(goals), jnp.int32),
        bounds=jnp.asarray(bounds, jnp.float32),
        n_obstacles=jnp.asarray(obstacles, jnp.int32),
        robotis_goals=jnp.asarray(robotis, jnp.float32),
        n_robotis_goals=jnp.asarray(min(len(goals), 256), jnp.int32),
        robotis_scale=jnp.asarray(1.0, jnp.float32),
        goal=None if goal is None else jnp.asarray(goal, jnp.float32),
        grid=grid,
    )


__all__ = ["MAX_RASTER", "grid_bounds", "grid_maze", "reachable_raster"]
