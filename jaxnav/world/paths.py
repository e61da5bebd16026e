"""Shortest paths of the robot's disc through a maze's static geometry, on the host
(NumPy and SciPy, no JAX): the ``l`` of SPL.

The robot is a disc of radius r (0.13 m), so it moves in the plane less every wall
and circle inflated by r. A path is a polyline whose every segment keeps the disc
clear of every surface (:func:`clear_segments`, exact). A start that sees its goal
this way is the straight line. Otherwise a raster of square cells (0.05 m) marks
the cells whose centre is at least r from every surface; Dijkstra over their
8-connected graph (``scipy.sparse.csgraph``) from the goal's cell gives every cell
the next cell towards the goal; the start's chain of cells is then pulled taut,
from each point straight to the farthest point of the chain in clear sight, and
its bends are moved off the raster (each split in two and moved by a compass
search while every leg stays clear). The result is a real path, so its length
bounds the geodesic from above, and it follows the arc around a corner within
millimetres (tests/test_paths.py: 5 mm around a wall's end, against the arc
computed by hand).

A start that cannot reach its goal in the raster (a gap narrower than a cell) has
an infinite length.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

ROBOT_RADIUS = 0.13  # m, the disc (jaxnav.world.maps.ROBOT_RADIUS; no JAX here)
CELL = 0.05  # m, the raster's cells
MAX_CELLS = 1_000_000  # a larger maze gets coarser cells
_TOLERANCE = 1e-9  # m: a segment exactly r from a surface is clear
_NEAR = 3  # cells: how far around a point its raster cell is looked for
_REFINE_ROUNDS = 400  # the most rounds of the compass search that refines a path


# ----------------------------------------------------------------------------
# Exact clearance of straight moves
# ----------------------------------------------------------------------------


def _point_segment(px, py, ax, ay, bx, by) -> np.ndarray:
    """Distances from points (px, py) to segments (ax, ay)-(bx, by), broadcast."""
    dx, dy = bx - ax, by - ay
    t = ((px - ax) * dx + (py - ay) * dy) / np.maximum(dx * dx + dy * dy, 1e-300)
    t = np.clip(t, 0.0, 1.0)
    return np.hypot(px - ax - t * dx, py - ay - t * dy)


def _cross(ox, oy, ax, ay, bx, by) -> np.ndarray:
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


def segment_distances(p: np.ndarray, q: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """f64[K, W]: distance between each segment p_k q_k (p, q: (K, 2)) and each wall
    (W, 4); 0 where they cross."""
    p, q = np.asarray(p, np.float64), np.asarray(q, np.float64)
    w = np.asarray(walls, np.float64)
    px, py, qx, qy = p[:, 0, None], p[:, 1, None], q[:, 0, None], q[:, 1, None]
    ax, ay, bx, by = w[None, :, 0], w[None, :, 1], w[None, :, 2], w[None, :, 3]
    d = np.minimum(
        np.minimum(_point_segment(px, py, ax, ay, bx, by), _point_segment(qx, qy, ax, ay, bx, by)),
        np.minimum(_point_segment(ax, ay, px, py, qx, qy), _point_segment(bx, by, px, py, qx, qy)),
    )
    d1, d2 = _cross(px, py, qx, qy, ax, ay), _cross(px, py, qx, qy, bx, by)
    d3, d4 = _cross(ax, ay, bx, by, px, py), _cross(ax, ay, bx, by, qx, qy)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    return np.where(crossing, 0.0, d)


def clear_segments(
    p: np.ndarray,
    q: np.ndarray,
    walls: np.ndarray,
    circles: np.ndarray,
    radius: float = ROBOT_RADIUS,
) -> np.ndarray:
    """bool[K]: whether the disc of ``radius`` moves straight from p_k to q_k (each
    (K, 2)) without coming closer than ``radius`` to a wall (W, 4) or a circle
    (C, 3: x, y, r)."""
    p, q = np.atleast_2d(np.asarray(p, np.float64)), np.atleast_2d(np.asarray(q, np.float64))
    p, q = np.broadcast_arrays(p, q)
    ok = np.ones(len(p), bool)
    walls, circles = np.asarray(walls).reshape(-1, 4), np.asarray(circles).reshape(-1, 3)
    if len(walls):
        ok &= (segment_distances(p, q, walls) >= radius - _TOLERANCE).all(axis=1)
    if len(circles):
        c = np.asarray(circles, np.float64)
        dc = _point_segment(c[None, :, 0], c[None, :, 1], *(v[:, None] for v in (*p.T, *q.T)))
        ok &= (dc >= c[None, :, 2] + radius - _TOLERANCE).all(axis=1)
    return ok


def clearance(points: np.ndarray, walls: np.ndarray, circles: np.ndarray) -> np.ndarray:
    """f64[N]: distance from each point (N, 2) to the nearest wall or circle surface."""
    pts = np.asarray(points, np.float64)
    d = np.full(len(pts), np.inf)
    walls, circles = np.asarray(walls).reshape(-1, 4), np.asarray(circles).reshape(-1, 3)
    for lo in range(0, len(pts), 65536):  # bounded memory on large rasters
        chunk = pts[lo : lo + 65536, None, :]
        if len(walls):
            w = walls.astype(np.float64)
            x, y = chunk[..., 0], chunk[..., 1]
            dw = _point_segment(x, y, *(w[None, :, k] for k in range(4))).min(axis=1)
            d[lo : lo + 65536] = np.minimum(d[lo : lo + 65536], dw)
        if len(circles):
            c = circles.astype(np.float64)
            dc = (np.linalg.norm(chunk - c[None, :, :2], axis=-1) - c[None, :, 2]).min(axis=1)
            d[lo : lo + 65536] = np.minimum(d[lo : lo + 65536], dc)
    return d


# ----------------------------------------------------------------------------
# The raster and the paths
# ----------------------------------------------------------------------------


class PathFinder:
    """Shortest paths of a disc in one maze: ``walls`` f[W, 4] and ``circles`` f[C, 3]
    (the real rows only). The raster is built on first use and the Dijkstra tree of
    each goal cell is kept, so many starts and goals in one maze are cheap."""

    def __init__(
        self,
        walls: np.ndarray,
        circles: np.ndarray,
        radius: float = ROBOT_RADIUS,
        cell: float = CELL,
    ):
        self.walls = np.asarray(walls, np.float64).reshape(-1, 4)
        self.circles = np.asarray(circles, np.float64).reshape(-1, 3)
        self.radius, self.cell = float(radius), float(cell)
        self._raster: _Raster | None = None
        self._trees: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._lengths: dict[bytes, float] = {}

    # -- queries ---------------------------------------------------------------

    def length(self, start, goal) -> float:
        """The length (m) of the shortest path from ``start`` to ``goal`` (x, y)."""
        key = np.concatenate([np.asarray(start, np.float64)[:2], np.asarray(goal)[:2]]).tobytes()
        if key not in self._lengths:  # a restart's attempt repeats an earlier one
            self._lengths[key] = _polyline_length(self.path(start, goal))
        return self._lengths[key]

    def lengths(self, starts: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """f64[K]: :meth:`length` of each start (K, 2) to its goal (K, 2); the pairs in
        clear sight of each other are tested at once."""
        s = np.asarray(starts, np.float64).reshape(-1, 2)
        g = np.asarray(goals, np.float64).reshape(-1, 2)
        out = np.linalg.norm(g - s, axis=1)
        if len(s) == 0:
            return out
        blocked = ~clear_segments(s, g, self.walls, self.circles, self.radius)
        for k in np.flatnonzero(blocked):
            out[k] = self.length(s[k], g[k])
        return out

    def path(self, start, goal) -> np.ndarray:
        """f64[n, 2]: the shortest path's points from ``start`` to ``goal`` (both
        included); the two points alone when they see each other, NaN rows (length
        inf) when the raster does not connect them."""
        s, g = np.asarray(start, np.float64)[:2], np.asarray(goal, np.float64)[:2]
        if clear_segments(s, g, self.walls, self.circles, self.radius)[0]:
            return np.stack([s, g])
        r = self._raster_of()
        goal_near = self._nearest_visible(g, r)
        if not len(goal_near):
            return _unreachable(s, g)
        goal_cell = int(goal_near[0])  # the path's last cell: the goal's nearest in sight
        dist, pred = self._tree(goal_cell)
        near = self._nearest_visible(s, r)
        if not len(near):
            return _unreachable(s, g)
        cost = np.linalg.norm(r.centres[near] - s, axis=1) + dist[near]
        first = int(near[np.argmin(cost)])
        if not np.isfinite(dist[first]):
            return _unreachable(s, g)
        chain = [first]
        while chain[-1] != goal_cell:
            chain.append(int(pred[chain[-1]]))
        points = np.concatenate([s[None], r.centres[chain], g[None]])
        return self._taut(self._refine(self._taut(points)))

    # -- the pieces --------------------------------------------------------------

    def _taut(self, points: np.ndarray) -> np.ndarray:
        """The polyline pulled taut: from each kept point straight to the farthest
        later point in clear sight (the next one if none is)."""
        kept, i, last = [0], 0, len(points) - 1
        while i < last:
            later = points[i + 1 :]
            clear = clear_segments(points[i], later, self.walls, self.circles, self.radius)
            seen = np.flatnonzero(clear)
            i = i + 1 + (int(seen[-1]) if len(seen) else 0)
            kept.append(i)
        return points[kept]

    def _refine(self, points: np.ndarray) -> np.ndarray:
        """The taut polyline's bends moved off the raster: each bend moved to the
        shortest clear place near it, then split in two along its legs (as far apart
        as the corner lets them see each other: an arc is better followed by two
        points than by one), and the points moved again, until no move shortens the
        path by more than a micrometre."""
        if len(points) < 3:
            return points
        pts = points.copy()
        split = [pts[:1]]
        for i in range(1, len(pts) - 1):
            split.append(self._split(pts[i - 1], pts[i], pts[i + 1]))
        split.append(pts[-1:])
        return self._descend(np.concatenate(split))

    def _split(self, a: np.ndarray, v: np.ndarray, b: np.ndarray) -> np.ndarray:
        """f[2, 2]: the bend v of a-v-b as two points on its legs, the farthest apart
        of a few that still see each other (v twice if none do)."""
        ua = (a - v) / max(np.linalg.norm(a - v), 1e-12)
        ub = (b - v) / max(np.linalg.norm(b - v), 1e-12)
        reach = min(np.linalg.norm(a - v), np.linalg.norm(b - v), 4 * self.cell)
        d = reach * np.linspace(1.0, 0.0, 17)[:-1, None]
        p, q = v + d * ua, v + d * ub
        ok = np.flatnonzero(clear_segments(p, q, self.walls, self.circles, self.radius))
        if not len(ok):
            return np.stack([v, v])
        return np.stack([p[ok[0]], q[ok[0]]])

    def _descend(self, pts: np.ndarray) -> np.ndarray:
        """Compass search on the inner points: every other point at once tries a
        step in 8 directions and takes the one that shortens its two legs most
        while both stay clear; the step halves when none does, from a quarter of a
        cell down to a 32nd."""
        if len(pts) < 3:
            return pts
        lo, hi = pts.min(axis=0) - self.cell, pts.max(axis=0) + self.cell
        walls, circles = self._within(lo, hi)
        ang = np.arange(8) * (np.pi / 4)
        dirs = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        step, inner = self.cell / 4, np.arange(1, len(pts) - 1)
        for _ in range(_REFINE_ROUNDS):
            moved = False
            for idx in (inner[::2], inner[1::2]):  # neighbours fixed while one moves
                if not len(idx):
                    continue
                a, b = np.repeat(pts[idx - 1], 8, axis=0), np.repeat(pts[idx + 1], 8, axis=0)
                cand = (pts[idx][:, None, :] + step * dirs[None]).reshape(-1, 2)
                froms, tos = np.concatenate([a, cand]), np.concatenate([cand, b])
                legs = clear_segments(froms, tos, walls, circles, self.radius)
                ok = legs[: len(cand)] & legs[len(cand) :]
                cost = np.linalg.norm(cand - a, axis=1) + np.linalg.norm(b - cand, axis=1)
                cost = np.where(ok, cost, np.inf).reshape(-1, 8)
                p, pa, pb = pts[idx], pts[idx - 1], pts[idx + 1]
                now = np.linalg.norm(p - pa, axis=1) + np.linalg.norm(pb - p, axis=1)
                k = np.argmin(cost, axis=1)
                better = cost[np.arange(len(idx)), k] < now - 1e-7
                pts[idx[better]] = cand.reshape(-1, 8, 2)[np.flatnonzero(better), k[better]]
                moved |= bool(better.any())
            if not moved:
                step /= 2
                if step < self.cell / 32:
                    break
        return pts

    def _within(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The walls and circles that come within the disc's reach of the box
        [lo, hi] (no others can block a move inside it)."""
        lo, hi = lo - self.radius, hi + self.radius
        w, c = self.walls, self.circles
        near = (np.minimum(w[:, 0], w[:, 2]) <= hi[0]) & (np.maximum(w[:, 0], w[:, 2]) >= lo[0])
        near &= (np.minimum(w[:, 1], w[:, 3]) <= hi[1]) & (np.maximum(w[:, 1], w[:, 3]) >= lo[1])
        close = ((c[:, :2] + c[:, 2:] >= lo) & (c[:, :2] - c[:, 2:] <= hi)).all(axis=1)
        return w[near], c[close]

    def _raster_of(self) -> _Raster:
        if self._raster is None:
            self._raster = _Raster(self.walls, self.circles, self.radius, self.cell)
        return self._raster

    def _tree(self, goal_cell: int) -> tuple[np.ndarray, np.ndarray]:
        """(raster distance, predecessor) towards ``goal_cell`` of every free cell:
        its Dijkstra tree."""
        if goal_cell not in self._trees:
            self._trees[goal_cell] = dijkstra(
                self._raster_of().graph,
                directed=False,
                indices=goal_cell,
                return_predecessors=True,
            )
        return self._trees[goal_cell]

    def _nearest_visible(self, p: np.ndarray, r: _Raster) -> np.ndarray:
        """Free cells within a few cells of ``p`` that it sees (the nearest free ones
        if it sees none), nearest first."""
        near = r.near(p)
        if not len(near):
            return near
        seen = clear_segments(p, r.centres[near], self.walls, self.circles, self.radius)
        return near[seen] if seen.any() else near


class _Raster:
    """Free cells (centre at least ``radius`` from every surface) of a grid over the
    maze and their 8-connected graph, edges weighted by the centres' distance."""

    def __init__(self, walls, circles, radius: float, cell: float):
        pts = np.concatenate([walls[:, :2], walls[:, 2:], circles[:, :2]]).reshape(-1, 2)
        pad = circles[:, 2].max(initial=0.0) + 2 * cell
        lo = pts.min(axis=0) - pad if len(pts) else np.zeros(2) - pad
        hi = pts.max(axis=0) + pad if len(pts) else np.zeros(2) + pad
        while math.prod(np.ceil((hi - lo) / cell).astype(int)) > MAX_CELLS:
            cell *= 1.5
        nx, ny = (int(n) for n in np.ceil((hi - lo) / cell))
        self.lo, self.cell, self.shape = lo, cell, (ny, nx)
        xs, ys = lo[0] + cell * (np.arange(nx) + 0.5), lo[1] + cell * (np.arange(ny) + 0.5)
        gx, gy = np.meshgrid(xs, ys, indexing="xy")
        centres = np.stack([gx.ravel(), gy.ravel()], axis=1)
        free = clearance(centres, walls, circles) >= radius
        self.index = np.full(ny * nx, -1)  # raster cell -> free cell number
        self.index[free] = np.arange(free.sum())
        self.centres = centres[free]
        grid = self.index.reshape(ny, nx)
        padded = np.pad(grid, 1, constant_values=-1)
        rows, cols, weights = [], [], []
        for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):  # each edge once
            a, b = grid, padded[1 + dy : 1 + dy + ny, 1 + dx : 1 + dx + nx]
            both = (a >= 0) & (b >= 0)
            rows.append(a[both])
            cols.append(b[both])
            weights.append(np.full(both.sum(), cell * math.hypot(dx, dy)))
        n = len(self.centres)
        self.graph = coo_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
        ).tocsr()

    def near(self, p: np.ndarray) -> np.ndarray:
        """Free cells within ``_NEAR`` cells of ``p``, nearest first."""
        ny, nx = self.shape
        cx, cy = (int(v) for v in np.floor((p - self.lo) / self.cell))
        xs = np.arange(max(cx - _NEAR, 0), min(cx + _NEAR + 1, nx))
        ys = np.arange(max(cy - _NEAR, 0), min(cy + _NEAR + 1, ny))
        if not len(xs) or not len(ys):
            return np.zeros(0, int)
        ids = self.index[(ys[:, None] * nx + xs[None, :]).ravel()]
        ids = ids[ids >= 0]
        return ids[np.argsort(np.linalg.norm(self.centres[ids] - p, axis=1), kind="stable")]


def _polyline_length(points: np.ndarray) -> float:
    """The polyline's length; inf for an unconnected path (NaN points)."""
    if np.isnan(points).any():
        return math.inf
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def _unreachable(s: np.ndarray, g: np.ndarray) -> np.ndarray:
    return np.stack([s, np.full(2, np.nan), g])


def shortest_path_length(walls, circles, start, goal, radius: float = ROBOT_RADIUS) -> float:
    """The shortest path's length (m) of a disc of ``radius`` from ``start`` to
    ``goal`` among ``walls`` (W, 4) and ``circles`` (C, 3)."""
    return PathFinder(walls, circles, radius).length(start, goal)
