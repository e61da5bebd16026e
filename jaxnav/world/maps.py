"""Maze geometry: wall segments and circular obstacles, as padded float32 arrays.

A maze is geometry, not a grid. Walls are line segments ``(x1, y1, x2, y2)`` (the
inner outline of the arena plus the edges of polygonal obstacles) and round
obstacles are circles ``(cx, cy, r)``. Both are stored in fixed-shape arrays with
a validity mask, so mazes of different sizes can be padded to a common shape,
stacked, and vmapped over together (:func:`stack_mazes`).

The goal sampler needs free space with a clearance margin; rather than test random
points inside jit, each maze carries a precomputed set of admissible goal points
on a regular grid (ROBOTIS drew goals from a 0.1 m grid too). Drawing a goal is
then a uniform index into that set, which is jit-able and always lands in free
space.

Built-in mazes (sizes from the spec; square4 is TurtleBot3 stage 1):

========================  =====================================================
``square2``               free square 1.85 m wide, centred at the origin
``square4``               free square 3.7 m wide (x, y in [-1.85, 1.85])
``square8``               free square 7.4 m wide
``triangle``              equilateral triangle of the same area as square4
                          (side 5.623 m), centroid at the origin, apex up (+y)
``pentagon``              regular pentagon of the same area as square4
                          (circumradius 2.122 m), centred at the origin, vertex up
``square4_obstacles``     square4 plus 4 cylinders r = 0.15 m at (+-0.6, +-0.6)
                          (TurtleBot3 stage 2)
``pentagon_obstacles``    pentagon plus 5 cylinders r = 0.15 m on a circle of
                          radius 0.85 m, one on each vertex direction, placed as
                          stage 2 places its four (same radius, same distance
                          from the start at the centre)
========================  =====================================================

All start at (0, 0) facing +x (yaw 0), as TurtleBot3 does.

A user's own maze comes from a YAML file::

    name: corridor              # optional
    outline: [[-2, -1], [2, -1], [2, 1], [-2, 1], [-2, -1]]   # closed: last == first
    obstacles:                  # optional
      - circle: [0.5, 0.0, 0.2]
      - polygon: [[-1, -0.3], [-0.6, -0.3], [-0.6, 0.3], [-1, 0.3], [-1, -0.3]]
    start: [0.0, 0.5, 0.0]      # optional x, y, yaw; default the outline centroid, yaw 0
    walls: [[0.0, -1.0, 0.0, 0.2]]   # optional free wall segments x1, y1, x2, y2, inside
    goal: [1.5, 0.0]            # optional: the first goal of every reset (else drawn)
    shortest_path_m: 3.1        # optional, informational: start to goal, m

``walls`` are segments that bound no area, as a grid maze's walls (``jaxnav mazes``
writes drawn mazes in this format, the outline as the boundary's own segments, so
loading one gives back its walls, obstacles, start and goal exactly).

Loading validates it and rejects a bad file with a one-line :class:`MazeError`.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from typing import Any

import chex
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxnav.core import worlds
from jaxnav.core.errors import MazeError
from jaxnav.core.shipped import shipped_path
from jaxnav.core.values import yaml_mark
from jaxnav.world.builtins import BUILTIN_MAZES, builtin, square
from jaxnav.world.motion import Motion, pad_motion, parked
from jaxnav.world.occupancy import Occupancy, grid_circles, grid_walls, stack_grids
from jaxnav.world.polygons import (
    centroid,
    clearance,
    points_in_polygon,
    polygon_segments,
    segments_intersect,
    self_intersecting,
    signed_area,
)
from jaxnav.world.stages import STAGES, stage

# Geometry constants shared with the environment (robot and goal sampler).
ROBOT_RADIUS = 0.13  # m, ROBOTIS collision threshold
GOAL_CLEARANCE = 0.35  # m, free margin around every goal (robot radius + 0.22)
GOAL_START_CLEARANCE = 0.4  # m, goals are not drawn this close to the start pose
GOAL_GRID = 0.1  # m, resolution of the admissible goal grid (ROBOTIS used 0.1 m)
MAX_GOAL_POINTS = 4096  # the grid is coarsened past this many points
MIN_GOAL_POINTS = 8  # "room left for goals"
MAX_COORDINATE = 1000.0  # m: a maze file reaching beyond 1 km is refused
BURGER_RADIUS = 0.105  # m, the burger's footprint (contact with the LiDAR collision rule)

# ROBOTIS' goal sampler (turtlebot3_machine_learning, respawnGoal.py), in the frame of
# its 3.7 m arena (square4): a 0.1 m grid on [-1.2, 1.2]^2 without the points in a
# 0.4 m box (per axis, boundary included up to Python's float rounding) around the
# origin and around (+-0.6, +-0.6), in stage 1 too. A new goal must be at least 1 m
# from the last along x or y; the first goal is (0.6, 0). Other mazes get this grid
# scaled by their size over 3.7 m.
ROBOTIS_ARENA = 3.7
ROBOTIS_BOX_CENTRES = ((0.6, 0.6), (0.6, -0.6), (-0.6, 0.6), (-0.6, -0.6), (0.0, 0.0))
ROBOTIS_FIRST_GOAL = (0.6, 0.0)
ROBOTIS_GOAL_SEPARATION = 1.0  # m, along x or along y


def robotis_goal_grid() -> np.ndarray:
    """ROBOTIS' goal points f64[256, 2] (of the 625 grid points), compared as its Python does."""
    pts = []
    for i in range(-12, 13):
        for j in range(-12, 13):
            x, y = i / 10.0, j / 10.0
            if not any(abs(x - cx) <= 0.4 and abs(y - cy) <= 0.4 for cx, cy in ROBOTIS_BOX_CENTRES):
                pts.append((x, y))
    return np.asarray(pts)


# Padding for unused slots: far away and degenerate, and masked out anyway.
_FAR = 1.0e4


@struct.dataclass
class Maze:
    """Padded maze geometry (a pytree; stack several with :func:`stack_mazes`).

    Attributes:
      segments: f32[S, 4] wall segments (x1, y1, x2, y2); padded rows are far away.
      segment_mask: bool[S] which rows of ``segments`` are real.
      circles: f32[C, 3] circular obstacles (cx, cy, r); padded rows have r = 0.
      circle_mask: bool[C] which rows of ``circles`` are real.
      start: f32[3] start pose (x, y, yaw).
      goal_points: f32[G, 2] admissible goal positions; padded rows repeat real ones.
      n_goal_points: i32[] number of real rows in ``goal_points``.
      bounds: f32[4] bounding box of the outline (xmin, ymin, xmax, ymax).
      n_obstacles: i32[] number of obstacles (circles and polygons) in the outline.
      robotis_goals: f32[256, 2] ROBOTIS' goal points scaled to this maze
        (:func:`robotis_goal_grid`, times :attr:`robotis_scale`); the first
        ``n_robotis_goals`` rows are the points reachable in this maze (free and at
        least the robot radius from every surface), the rest repeat them.
      n_robotis_goals: i32[] number of real rows in ``robotis_goals``.
      robotis_scale: f32[] the maze's size over ROBOTIS' 3.7 m arena (1 for square4).
      motion: the moving cylinders (:class:`jaxnav.world.motion.Motion`), or None (no
        leaves) for a maze that stands still; ``circles`` holds the static ones only.
      goal: f32[2] the first goal of every reset, from a maze file's ``goal``; None
        (no leaf) for the mazes whose goals are drawn, as every built-in's.
      grid: an occupancy grid (:class:`jaxnav.world.occupancy.Occupancy`: a ROS map,
        BARN's cylinders) whose occupied cells are surfaces too; None (no leaves) for
        every maze of walls and cylinders alone.
    """

    segments: chex.Array
    segment_mask: chex.Array
    circles: chex.Array
    circle_mask: chex.Array
    start: chex.Array
    goal_points: chex.Array
    n_goal_points: chex.Array
    bounds: chex.Array
    n_obstacles: chex.Array
    robotis_goals: chex.Array
    n_robotis_goals: chex.Array
    robotis_scale: chex.Array
    motion: Motion | Any = None
    goal: chex.Array | None = None
    grid: Occupancy | None = None

    # Host-side accessors (not for use under jit).
    def walls(self) -> np.ndarray:
        """NumPy (S, 4) array of the real wall segments only (and an occupancy grid's
        outline, :func:`jaxnav.world.occupancy.grid_walls`)."""
        seg = np.asarray(self.segments)
        seg = seg[np.asarray(self.segment_mask)]
        if self.grid is not None:
            seg = np.concatenate([seg, grid_walls(self.grid).astype(seg.dtype)])
        return seg

    def obstacles(self) -> np.ndarray:
        """NumPy (C, 3) array of the real circular obstacles only (and a disc grid's
        occupied cells, :func:`jaxnav.world.occupancy.grid_circles`)."""
        c = np.asarray(self.circles)
        c = c[np.asarray(self.circle_mask)]
        if self.grid is not None:
            c = np.concatenate([c, grid_circles(self.grid).astype(c.dtype)])
        return c

    @property
    def has_obstacles(self) -> bool:
        """True if the maze has anything inside its outline (ROBOTIS stage 2 layout)."""
        return bool(np.asarray(self.n_obstacles).max() > 0)


# ----------------------------------------------------------------------------
# Construction
# ----------------------------------------------------------------------------


def _goal_grid(
    outline: np.ndarray,
    segments: np.ndarray,
    circles: np.ndarray,
    polygons: Sequence[np.ndarray],
    start: np.ndarray,
) -> np.ndarray:
    """Admissible goal points: free, clear of every surface, away from the start."""
    lo, hi = outline.min(axis=0), outline.max(axis=0)
    res = GOAL_GRID
    while True:
        xs = np.arange(lo[0] + res / 2, hi[0], res)
        ys = np.arange(lo[1] + res / 2, hi[1], res)
        gx, gy = np.meshgrid(xs, ys, indexing="xy")
        pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
        if len(pts) <= 4 * MAX_GOAL_POINTS:
            break
        res *= 1.5
    ok = _admissible(pts, outline, segments, circles, polygons, GOAL_CLEARANCE)
    ok &= np.linalg.norm(pts - start[None, :2], axis=1) >= GOAL_START_CLEARANCE
    pts = pts[ok]
    if len(pts) > MAX_GOAL_POINTS:  # thin evenly, deterministically
        idx = np.linspace(0, len(pts) - 1, MAX_GOAL_POINTS).round().astype(int)
        pts = pts[idx]
    return pts


def _admissible(pts, outline, segments, circles, polygons, margin) -> np.ndarray:
    """bool[N]: inside the outline, outside every obstacle, ``margin`` from every surface."""
    ok = points_in_polygon(pts, outline)
    for poly in polygons:
        ok &= ~points_in_polygon(pts, poly)
    if len(circles):
        dc = np.linalg.norm(pts[:, None] - circles[None, :, :2], axis=-1)
        ok &= (dc > circles[None, :, 2]).all(axis=1)
    return ok & (clearance(pts, segments, circles) >= margin)


def _robotis_goals(outline, segments, circles, polygons) -> tuple[np.ndarray, int, float]:
    """ROBOTIS' points scaled to the maze, the reachable ones first: (f32[256, 2], n, scale)."""
    lo, hi = outline.min(axis=0), outline.max(axis=0)
    scale = float(np.max(hi - lo)) / ROBOTIS_ARENA
    grid = robotis_goal_grid() * scale
    ok = _admissible(grid, outline, segments, circles, polygons, ROBOT_RADIUS)
    pts = grid[ok]
    if len(pts) == 0:  # never drawn (the sampler's default is the maze's own set)
        pts = grid[:1]
    return np.resize(pts, grid.shape), int(ok.sum()), scale


def _build(
    outline: np.ndarray,
    circles: np.ndarray,
    polygons: Sequence[np.ndarray],
    start: np.ndarray,
    where: str,
    motion: Motion | None = None,
    walls: np.ndarray | None = None,
    goal: np.ndarray | None = None,
) -> Maze:
    segments = _segments(outline, polygons, walls)
    goals = _goal_grid(outline, segments, circles, polygons, start)
    if len(goals) < MIN_GOAL_POINTS:
        raise MazeError(
            f"{where}: no room left for goals (need free points {GOAL_CLEARANCE} m "
            f"clear of walls and obstacles and {GOAL_START_CLEARANCE} m from the start)"
        )
    lo, hi = outline.min(axis=0), outline.max(axis=0)
    robotis, n_robotis, robotis_scale = _robotis_goals(outline, segments, circles, polygons)
    n_circles = len(circles)
    circles = circles.reshape(-1, 3)
    if n_circles == 0:  # keep one masked row so reductions over circles are never empty
        circles = np.array([[_FAR, _FAR, 0.0]])
    maze = Maze(
        segments=jnp.asarray(segments, jnp.float32),
        segment_mask=jnp.ones(len(segments), bool),
        circles=jnp.asarray(circles, jnp.float32),
        circle_mask=jnp.arange(len(circles)) < n_circles,
        start=jnp.asarray(start, jnp.float32),
        goal_points=jnp.asarray(goals, jnp.float32),
        n_goal_points=jnp.asarray(len(goals), jnp.int32),
        bounds=jnp.asarray([lo[0], lo[1], hi[0], hi[1]], jnp.float32),
        n_obstacles=jnp.asarray(
            n_circles + len(polygons) + (motion.n if motion is not None else 0), jnp.int32
        ),
        robotis_goals=jnp.asarray(robotis, jnp.float32),
        n_robotis_goals=jnp.asarray(n_robotis, jnp.int32),
        robotis_scale=jnp.asarray(robotis_scale, jnp.float32),
        motion=motion,
        goal=None if goal is None else jnp.asarray(goal, jnp.float32),
    )
    return maze


def _segments(outline, polygons, walls=None) -> np.ndarray:
    """The wall segments: the outline's, the polygons', then the free walls."""
    segs = [polygon_segments(outline)] + [polygon_segments(p) for p in polygons]
    if walls is not None and len(walls):
        segs.append(np.asarray(walls, np.float64).reshape(-1, 4))
    return np.concatenate(segs, axis=0)


def _as_points(value, what: str, where: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise MazeError(f"{where}: {what} must be a list of [x, y] points") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or not np.isfinite(arr).all():
        raise MazeError(f"{where}: {what} must be a list of finite [x, y] points")
    if np.abs(arr).max(initial=0.0) > MAX_COORDINATE:
        raise MazeError(
            f"{where}: {what} reaches beyond 1 km ({np.abs(arr).max():.3g} m); "
            "maze coordinates are metres"
        )
    return arr


def _closed_polygon(value, what: str, where: str) -> np.ndarray:
    pts = _as_points(value, what, where)
    if len(pts) < 4 or not np.allclose(pts[0], pts[-1]):
        raise MazeError(
            f"{where}: {what} is not closed (give at least 3 vertices and repeat the "
            "first vertex at the end)"
        )
    poly = pts[:-1]
    if np.any(np.linalg.norm(np.diff(np.vstack([poly, poly[:1]]), axis=0), axis=1) < 1e-9):
        raise MazeError(f"{where}: {what} has a repeated vertex")
    flat = np.linalg.matrix_rank(poly - poly.mean(axis=0), tol=1e-9) < 2
    if flat:  # every vertex on one line
        raise MazeError(f"{where}: {what} encloses no area (its vertices lie on one line)")
    if self_intersecting(poly):  # a bow tie's signed area can be 0 too: say what it is
        raise MazeError(f"{where}: {what} crosses itself (two of its edges intersect)")
    if abs(signed_area(poly)) < 1e-9:
        raise MazeError(f"{where}: {what} encloses no area")
    return poly


def load_maze_file(path: str) -> Maze:
    """Load and validate a maze YAML file (format in the module docstring)."""
    where = f"maze file {path}"
    doc = _read_maze_yaml(path, where)
    outline = _closed_polygon(doc["outline"], "outline", where)
    circles, polygons = _obstacles(doc.get("obstacles") or [], outline, where)
    circles_arr = np.asarray(circles).reshape(-1, 3)
    walls = _free_walls(doc.get("walls"), outline, where)
    segments = _segments(outline, polygons, walls)
    start = _start_pose(doc, outline, polygons, segments, circles_arr, where)
    goal = _goal(doc, outline, polygons, segments, circles_arr, where)
    if doc.get("shortest_path_m") is not None:
        length = doc["shortest_path_m"]
        if isinstance(length, bool) or not isinstance(length, (int, float)) or not length >= 0:
            raise MazeError(f"{where}: shortest_path_m must be a number of metres, 0 or more")
    return _build(outline, circles_arr, polygons, start, where, walls=walls, goal=goal)


def _free_walls(value, outline: np.ndarray, where: str) -> np.ndarray:
    """The file's free walls f64[W, 4], each of some length and inside the outline
    (its ends inside or on it)."""
    if value is None:
        return np.zeros((0, 4))
    try:
        walls = (
            np.asarray(value, np.float64).reshape(-1, 4)
            if value == []
            else np.asarray(value, np.float64)
        )
    except (TypeError, ValueError):
        walls = np.zeros((0, 3))
    if walls.ndim != 2 or walls.shape[1] != 4 or not np.isfinite(walls).all():
        raise MazeError(f"{where}: walls must be a list of [x1, y1, x2, y2] segments")
    if np.abs(walls).max(initial=0.0) > MAX_COORDINATE:
        raise MazeError(f"{where}: walls reach beyond 1 km; maze coordinates are metres")
    if np.any(np.hypot(walls[:, 2] - walls[:, 0], walls[:, 3] - walls[:, 1]) < 1e-9):
        raise MazeError(f"{where}: a wall has no length (its two ends are the same point)")
    ends = walls.reshape(-1, 2)
    on = clearance(ends, polygon_segments(outline), np.zeros((0, 3))) <= 1e-9
    inside = points_in_polygon(ends, outline) | on
    if not inside.all():
        raise MazeError(f"{where}: wall {int(np.argmin(inside)) // 2} is not inside the outline")
    return walls


def _goal(doc, outline, polygons, segments, circles, where: str) -> np.ndarray | None:
    """The file's goal (x, y), in the free space clear of the robot radius, or None."""
    if doc.get("goal") is None:
        return None
    try:
        goal = np.asarray(doc["goal"], np.float64)
    except (TypeError, ValueError):
        goal = np.zeros(0)
    if goal.shape != (2,) or not np.isfinite(goal).all():
        raise MazeError(f"{where}: goal must be [x, y]")
    inside = points_in_polygon(goal[None], outline)[0] and not any(
        points_in_polygon(goal[None], p)[0] for p in polygons
    )
    if not inside or clearance(goal[None], segments, circles)[0] <= ROBOT_RADIUS:
        raise MazeError(
            f"{where}: goal is not in the free space (inside, and more than the robot "
            f"radius {ROBOT_RADIUS} m from every wall and obstacle)"
        )
    return goal


def _read_maze_yaml(path: str, where: str) -> dict:
    """The file's mapping, with only known keys and an outline."""
    import yaml

    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except FileNotFoundError:
        raise MazeError(f"{where}: no such file") from None
    except yaml.YAMLError as e:
        line = getattr(yaml_mark(e), "line", None)
        at = f" at line {line + 1}" if line is not None else ""
        raise MazeError(f"{where}: not valid YAML{at}") from None
    except OSError as e:
        raise MazeError(f"{where}: cannot read ({e.strerror})") from None
    except UnicodeDecodeError:
        raise MazeError(f"{where}: not a text file (not UTF-8)") from None
    if not isinstance(doc, dict):
        raise MazeError(f"{where}: expected a mapping with an 'outline' key")
    unknown = set(doc) - {
        "name",
        "outline",
        "obstacles",
        "start",
        "walls",
        "goal",
        "shortest_path_m",
    }
    if unknown:
        raise MazeError(f"{where}: unknown key {sorted(map(str, unknown))[0]!r}")
    if "outline" not in doc:
        raise MazeError(f"{where}: missing 'outline'")
    return doc


def _obstacles(obstacles, outline: np.ndarray, where: str):
    """(circles [x, y, r], polygons (N, 2)) of the file's obstacle list, each inside the
    outline."""
    circles, polygons = [], []
    if not isinstance(obstacles, list):
        raise MazeError(f"{where}: 'obstacles' must be a list")
    for i, ob in enumerate(obstacles):
        what = f"obstacle {i}"
        if (
            not isinstance(ob, dict)
            or len(ob) != 1
            or next(iter(ob))
            not in (
                "circle",
                "polygon",
            )
        ):
            raise MazeError(f"{where}: {what} must be {{circle: [x, y, r]}} or {{polygon: [...]}}")
        kind, val = next(iter(ob.items()))
        if kind == "circle":
            try:
                c = np.asarray(val, np.float64)
            except (TypeError, ValueError):
                c = np.zeros(0)
            if c.shape != (3,) or not np.isfinite(c).all() or c[2] <= 0:
                raise MazeError(f"{where}: {what} circle must be [x, y, r] with r > 0")
            if (
                not points_in_polygon(c[None, :2], outline)[0]
                or clearance(c[None, :2], polygon_segments(outline), np.zeros((0, 3)))[0] < c[2]
            ):
                raise MazeError(f"{where}: {what} is not inside the outline")
            circles.append(c)
        else:
            poly = _closed_polygon(val, what, where)
            if not points_in_polygon(poly, outline).all() or any(
                segments_intersect(a[:2], a[2:], b[:2], b[2:])
                for a in polygon_segments(poly)
                for b in polygon_segments(outline)
            ):
                raise MazeError(f"{where}: {what} is not inside the outline")
            polygons.append(poly)
    return circles, polygons


def _start_pose(doc, outline, polygons, segments, circles, where: str) -> np.ndarray:
    """The file's start pose (x, y, yaw), default the outline's centroid facing +x; in
    free space and clear of the robot radius."""
    if "start" in doc and doc["start"] is not None:
        try:
            start = np.asarray(doc["start"], np.float64)
        except (TypeError, ValueError):
            start = np.zeros(0)
        if start.shape != (3,) or not np.isfinite(start).all():
            raise MazeError(f"{where}: start must be [x, y, yaw]")
    else:
        c = centroid(outline)
        start = np.array([c[0], c[1], 0.0])
    inside = points_in_polygon(start[None, :2], outline)[0] and not any(
        points_in_polygon(start[None, :2], p)[0] for p in polygons
    )
    if not inside:
        raise MazeError(f"{where}: start pose is not inside the free space")
    if clearance(start[None, :2], segments, circles)[0] <= ROBOT_RADIUS:
        raise MazeError(
            f"{where}: start pose is within the robot radius ({ROBOT_RADIUS} m) "
            "of a wall or obstacle"
        )
    return start


def make_maze(name_or_path: str) -> Maze:
    """A built-in maze by name, a maze YAML file by path, or a maze of a registered
    source of worlds (:mod:`jaxnav.core.worlds`: a ROS map, a BARN world)."""
    source = worlds.source_of(name_or_path)
    if source is not None:
        return source.loader()(name_or_path)
    if name_or_path in STAGES:
        side, walls, start, motion = stage(name_or_path)
        where = f"maze {name_or_path}"
        return _build(square(side), np.zeros((0, 3)), walls, start, where, motion)
    if name_or_path in BUILTIN_MAZES:
        outline, circles, polys, start = builtin(name_or_path)
        return _build(outline, circles, polys, start, f"maze {name_or_path}")
    if os.path.splitext(name_or_path)[1] in (".yaml", ".yml") or os.path.exists(name_or_path):
        return load_maze_file(shipped_path(name_or_path))
    raise MazeError(
        f"unknown maze '{name_or_path}': a built-in name ({', '.join(BUILTIN_MAZES)}), "
        f"barn:N (0-{worlds.BARN_WORLDS - 1}), or a path to a maze file or a ROS map's .yaml"
    )


def pad_maze(maze: Maze, n_segments: int, n_circles: int, n_goal_points: int) -> Maze:
    """Pad a single maze's arrays to the given sizes (masked, harmless rows)."""
    s, c, g = maze.segments.shape[0], maze.circles.shape[0], maze.goal_points.shape[0]
    if n_segments < s or n_circles < c or n_goal_points < g:
        raise ValueError("pad_maze cannot shrink a maze")
    seg_pad = jnp.full((n_segments - s, 4), _FAR, jnp.float32)
    circ_pad = jnp.concatenate(
        [jnp.full((n_circles - c, 2), _FAR, jnp.float32), jnp.zeros((n_circles - c, 1))],
        axis=1,
    ).astype(jnp.float32)
    # Goal padding repeats real points; n_goal_points keeps the draw uniform anyway.
    reps = jnp.resize(maze.goal_points, (n_goal_points - g, 2))
    return Maze(
        segments=jnp.concatenate([maze.segments, seg_pad]),
        segment_mask=jnp.concatenate([maze.segment_mask, jnp.zeros(n_segments - s, bool)]),
        circles=jnp.concatenate([maze.circles, circ_pad]),
        circle_mask=jnp.concatenate([maze.circle_mask, jnp.zeros(n_circles - c, bool)]),
        start=maze.start,
        goal_points=jnp.concatenate([maze.goal_points, reps]),
        n_goal_points=maze.n_goal_points,
        bounds=maze.bounds,
        n_obstacles=maze.n_obstacles,
        robotis_goals=maze.robotis_goals,
        n_robotis_goals=maze.n_robotis_goals,
        robotis_scale=maze.robotis_scale,
        motion=maze.motion,
        goal=maze.goal,
        grid=maze.grid,
    )


def stack_mazes(mazes: Sequence[Maze]) -> Maze:
    """Pad mazes to a common shape and stack them on a new leading axis (for vmap)."""
    s = max(m.segments.shape[0] for m in mazes)
    c = max(max(m.circles.shape[0] for m in mazes), 1)
    g = max(m.goal_points.shape[0] for m in mazes)
    padded = [pad_maze(m, s, c, g) for m in mazes]
    motion = None
    if any(m.motion is not None for m in mazes):  # still mazes carry a parked cylinder
        motions = [parked() if m.motion is None else m.motion for m in mazes]
        n = max(x.n for x in motions)
        k = max(x.times.shape[-1] for x in motions)
        motions = [pad_motion(x, n, k) for x in motions]
        motion = jax.tree.map(lambda *a: jnp.stack(a), *motions)
    stacked = Maze(*(jnp.stack(leaves) for leaves in zip(*(_fields(m) for m in padded))))
    stacked = stacked.replace(motion=motion, grid=stack_grids([m.grid for m in padded]))
    goals = [m.goal for m in padded]
    if all(x is not None for x in goals):
        return stacked.replace(goal=jnp.stack(goals))
    if any(x is not None for x in goals):
        raise ValueError("stack_mazes: either every maze has a goal of its own or none has")
    return stacked


def _fields(m: Maze) -> list:
    """The maze's arrays in field order, without its optional goal, motion and grid."""
    optional = ("goal", "motion", "grid")
    return [getattr(m, f.name) for f in dataclasses.fields(m) if f.name not in optional]
