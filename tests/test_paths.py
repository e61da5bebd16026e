"""Shortest paths of the robot's disc (the l of SPL) against hand computations, the
grid family's breadth-first cell distances and a brute-force visibility graph."""

from __future__ import annotations

import math

import jax
import numpy as np
import pytest
from scipy.sparse.csgraph import shortest_path

from jaxnav.world import generators
from jaxnav.world.maps import ROBOT_RADIUS, make_maze
from jaxnav.world.paths import CELL, PathFinder, clear_segments, shortest_path_length
from jaxnav.world.polygons import clearance

R = ROBOT_RADIUS
NO_CIRCLES = np.zeros((0, 3))
# A 4 m x 2 m room cut by a wall from the floor up to y = 0.5.
ROOM = [[-2, -1, 2, -1], [2, -1, 2, 1], [2, 1, -2, 1], [-2, 1, -2, -1]]
CORRIDOR = np.array(ROOM + [[0, -1, 0, 0.5]], np.float64)


def around_a_disc(s, g, c, radius) -> float:
    """The shortest path from s to g past a disc of ``radius`` centred at c, by hand:
    the tangent from s, the arc of the disc, the tangent to g (or the straight line
    where it misses the disc)."""
    s, g, c = (np.asarray(v, np.float64) for v in (s, g, c))
    ds, dg = np.linalg.norm(s - c), np.linalg.norm(g - c)
    between = math.acos(np.clip(np.dot(s - c, g - c) / (ds * dg), -1, 1))  # angle s-c-g
    arc = between - math.acos(radius / ds) - math.acos(radius / dg)
    if arc <= 0:
        return float(np.linalg.norm(g - s))
    return math.sqrt(ds**2 - radius**2) + math.sqrt(dg**2 - radius**2) + radius * arc


def test_in_an_open_room_the_path_is_the_straight_line():
    maze = make_maze("square4")
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1.85 + R, 1.85 - R, (200, 2))
    finder = PathFinder(maze.walls(), maze.obstacles())
    got = finder.lengths(pts[:100], pts[100:])
    straight = np.linalg.norm(pts[100:] - pts[:100], axis=1)
    np.testing.assert_allclose(got, straight, rtol=0, atol=1e-12)


def test_a_wall_is_passed_around_its_end_as_computed_by_hand():
    s, g = (-1.0, 0.0), (1.0, 0.0)
    # tangents from s and g to the circle of radius r around the wall's end (0, 0.5),
    # and the arc over it: 2 sqrt(1.25 - r^2) + r (2 pi - 2 atan2(1, 0.5) - 2 acos(r / sqrt 1.25))
    d = math.hypot(1.0, 0.5)
    exact = 2 * math.sqrt(d**2 - R**2) + R * (
        2 * math.pi - 2 * math.atan2(1.0, 0.5) - 2 * math.acos(R / d)
    )
    assert exact == pytest.approx(2.37175, abs=1e-5)
    got = shortest_path_length(CORRIDOR, NO_CIRCLES, s, g)
    assert exact - 1e-9 <= got <= exact + CELL / 2  # a real path: never shorter
    path = PathFinder(CORRIDOR, NO_CIRCLES).path(s, g)
    assert np.all(clear_segments(path[:-1], path[1:], CORRIDOR, NO_CIRCLES))
    np.testing.assert_array_equal(path[[0, -1]], [s, g])


@pytest.mark.parametrize("goal", [(1.2, 1.2), (1.0, 0.9), (0.9, 1.3)])
def test_a_cylinder_is_passed_around_as_computed_by_hand(goal):
    maze = make_maze("square4_obstacles")  # a cylinder r 0.15 at (0.6, 0.6)
    exact = around_a_disc((0.0, 0.0), goal, (0.6, 0.6), 0.15 + R)
    got = shortest_path_length(maze.walls(), maze.obstacles(), (0.0, 0.0), goal)
    assert exact > math.hypot(*goal) + 0.01  # the straight line is blocked
    assert exact - 1e-9 <= got <= exact + CELL / 2


def grid_mazes(rows, cols, n):
    grid = generators.Grid(rows, cols)
    for seed in range(n):
        d = generators.draw(jax.random.PRNGKey(seed), grid, "test")
        maze = generators.layout_maze(d.open, grid, d.start_cell, 0.0)
        walls = np.asarray(maze.segments)[np.asarray(maze.segment_mask)].astype(np.float64)
        cells = np.asarray(generators.cell_distances(d.open, grid))
        yield walls, np.asarray(maze.goal_points, np.float64), cells


@pytest.mark.slow  # 3 s on 2 cores
def test_grid_paths_lie_between_the_straight_line_and_the_cell_path():
    """From cell centre to cell centre the path through the centres of the cells on
    the way (breadth-first, one cell a step) is a real path: the shortest is no
    longer, and no shorter than the straight line."""
    for walls, centres, cells in grid_mazes(4, 4, 1):
        finder = PathFinder(walls, NO_CIRCLES)
        n = len(centres)
        got = finder.lengths(np.repeat(centres, n, 0), np.tile(centres, (n, 1))).reshape(n, n)
        straight = np.linalg.norm(centres[:, None] - centres[None], axis=-1)
        assert np.all(got >= straight - 1e-9)
        assert np.all(got <= cells * 1.0 + 1e-9)
        assert np.any(got < cells - 0.2)  # turns cut their corners


def visibility_graph_length(walls, s, g, n_ring=16) -> float:
    """Brute force: Dijkstra over start, goal and points circling every wall end just
    outside the disc's reach, joined where points sampled every 1 cm along the move
    keep the disc clear (jaxnav.world.polygons.clearance)."""
    ends = np.unique(np.concatenate([walls[:, :2], walls[:, 2:]]), axis=0)
    ang = 2 * math.pi * np.arange(n_ring) / n_ring
    ring = R * (1 + 1e-6) / math.cos(math.pi / n_ring)  # the polygon stays outside
    pts = (ends[:, None, :] + ring * np.stack([np.cos(ang), np.sin(ang)], -1)).reshape(-1, 2)
    pts = pts[clearance(pts, walls, NO_CIRCLES) >= R]
    nodes = np.concatenate([[s, g], pts])
    n = len(nodes)
    weight = np.zeros((n, n))
    span = np.linalg.norm(nodes.max(0) - nodes.min(0))
    t = np.linspace(0, 1, int(span / 0.01) + 2)[None, :, None]  # 1 cm apart at most
    for i in range(n - 1):
        ends = nodes[i + 1 :]
        lines = nodes[i] + t * (ends - nodes[i])[:, None, :]
        free = clearance(lines.reshape(-1, 2), walls, NO_CIRCLES).reshape(len(ends), -1)
        ok = free.min(axis=1) >= R - 0.005  # a move dips at most 5 mm between samples
        weight[i, i + 1 :] = np.where(ok, np.linalg.norm(ends - nodes[i], axis=1), 0)
    return float(shortest_path(weight, directed=False, indices=0)[1])


@pytest.mark.slow
def test_paths_match_a_brute_force_visibility_graph():
    walls, centres, cells = next(grid_mazes(3, 3, 1))
    finder = PathFinder(walls, NO_CIRCLES)
    pairs = [(a, b) for a in range(9) for b in range(a + 1, 9) if cells[a, b] >= 2][:4]
    for a, b in pairs:
        ref = visibility_graph_length(walls, centres[a], centres[b])
        assert finder.length(centres[a], centres[b]) == pytest.approx(ref, abs=CELL / 2)
    ref = visibility_graph_length(CORRIDOR, (-1.0, 0.0), (1.0, 0.0))
    assert shortest_path_length(CORRIDOR, NO_CIRCLES, (-1.0, 0.0), (1.0, 0.0)) == pytest.approx(
        ref, abs=CELL / 2
    )


def test_a_goal_behind_a_closed_wall_is_unreachable():
    box = np.array(ROOM + [[0, -1, 0, 1]], np.float64)  # the wall closes the room in two
    assert shortest_path_length(box, NO_CIRCLES, (-1.0, 0.0), (1.0, 0.0)) == math.inf
