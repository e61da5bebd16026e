"""Independent float64 NumPy geometry for the tests (no jaxnav internals).

Formulas here are deliberately different from the ones in ``jaxnav.world.geometry`` (line
equations instead of cross-product Cramer solves, perpendicular-foot circle
intersection, dense sampling of the arc instead of closed-form arc distances, the
integral of the velocity instead of the chord formula), so an agreement means
something. Each primitive of ``jaxnav.world.geometry`` has its counterpart here
(``ray_wall``, ``ray_cylinder``, ``point_wall``, ``displacement``, ``arc_wall_distance``,
``arc_cylinder_distance``, ``wrap``).
"""

from __future__ import annotations

import numpy as np

V = 0.15  # m/s, spec: constant forward speed
DT = 0.2  # s, spec: control period
ROBOT_R = 0.13  # m, spec: collision radius
OMEGAS = np.array([-1.5, -0.75, 0.0, 0.75, 1.5])  # spec: paper Table 1
MIN_RANGE, MAX_RANGE = 0.12, 3.5  # m, spec: LDS-01


def maze_geometry(maze) -> tuple[np.ndarray, np.ndarray]:
    """(walls (S, 4), circles (C, 3)) as float64, real rows only."""
    return maze.walls().astype(np.float64), maze.obstacles().astype(np.float64)


# ----------------------------------------------------------------------------
# Rays
# ----------------------------------------------------------------------------


def ray_distances(
    pos: np.ndarray, angles: np.ndarray, walls: np.ndarray, circles: np.ndarray
) -> np.ndarray:
    """Distance along each ray to the first surface (inf when nothing is hit).

    pos: (P, 2); angles: (P, B) world-frame directions -> (P, B).
    """
    pos = np.asarray(pos, np.float64)
    angles = np.asarray(angles, np.float64)
    d = np.stack([np.cos(angles), np.sin(angles)], axis=-1)  # (P, B, 2)
    p = pos[:, None, None, :]  # (P, 1, 1, 2)
    dd = d[:, :, None, :]  # (P, B, 1, 2)
    best = np.full(angles.shape, np.inf)

    if len(walls):
        a = walls[None, None, :, :2]
        b = walls[None, None, :, 2:]
        ab = b - a
        # The wall's line is {x : n . x = n . a} with n normal to the wall.
        n = np.stack([-ab[..., 1], ab[..., 0]], axis=-1)
        nd = np.sum(n * dd, axis=-1)  # (P, B, S)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.sum(n * (a - p), axis=-1) / nd
            q = p + t[..., None] * dd
            u = np.sum((q - a) * ab, axis=-1) / np.sum(ab * ab, axis=-1)
        ok = (nd != 0) & (t >= 0) & (u >= -1e-12) & (u <= 1 + 1e-12)
        best = np.minimum(best, np.where(ok, t, np.inf).min(axis=-1))

    if len(circles):
        c = circles[None, None, :, :2]
        r = circles[None, None, :, 2]
        pc = c - p  # (P, 1, C, 2)
        s = np.sum(pc * dd, axis=-1)  # foot of the centre along the ray
        h2 = np.sum(pc * pc, axis=-1) - s**2  # squared miss distance
        half = np.sqrt(np.maximum(r**2 - h2, 0.0))
        outside = np.sum(pc * pc, axis=-1) > r**2
        t = np.where(outside, s - half, s + half)
        ok = (h2 <= r**2) & (t >= 0)
        best = np.minimum(best, np.where(ok, t, np.inf).min(axis=-1))
    return best


def ray_wall(origin, angles, wall) -> np.ndarray:
    """Distance along rays from ``origin`` (2,) at ``angles`` (B,) to one wall (4,) -> (B,)."""
    origin, angles = np.asarray(origin, np.float64), np.asarray(angles, np.float64)
    walls = np.asarray(wall, np.float64)[None]
    return ray_distances(origin[None], angles[None], walls, np.zeros((0, 3)))[0]


def ray_cylinder(origin, angles, circle) -> np.ndarray:
    """Distance along rays from ``origin`` (2,) at ``angles`` (B,) to one circle (3,) -> (B,)."""
    origin, angles = np.asarray(origin, np.float64), np.asarray(angles, np.float64)
    circles = np.asarray(circle, np.float64)[None]
    return ray_distances(origin[None], angles[None], np.zeros((0, 4)), circles)[0]


def lidar(pos, yaw, walls, circles, n_beams) -> np.ndarray:
    """Clipped scan (P, n_beams); beam k at yaw + 2 pi k / n (counter-clockwise)."""
    yaw = np.asarray(yaw, np.float64)
    angles = yaw[:, None] + 2 * np.pi * np.arange(n_beams)[None, :] / n_beams
    return np.clip(ray_distances(pos, angles, walls, circles), MIN_RANGE, MAX_RANGE)


# ----------------------------------------------------------------------------
# Points
# ----------------------------------------------------------------------------


def point_wall_distance(pts: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """(N, 2) points, (S, 4) walls -> (N,) distance to the nearest wall."""
    if not len(walls):
        return np.full(len(pts), np.inf)
    p = pts[:, None, :]
    a, b = walls[None, :, :2], walls[None, :, 2:]
    ab = b - a
    u = np.clip(np.sum((p - a) * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    return np.linalg.norm(p - (a + u[..., None] * ab), axis=-1).min(axis=1)


def point_wall(p, wall) -> float:
    """Distance from the point p (2,) to one wall (4,)."""
    pts = np.asarray(p, np.float64)[None]
    return float(point_wall_distance(pts, np.asarray(wall, np.float64)[None])[0])


def clearance(pts: np.ndarray, walls: np.ndarray, circles: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest wall or circle surface (N,)."""
    pts = np.asarray(pts, np.float64)
    d = point_wall_distance(pts, walls)
    if len(circles):
        dc = np.linalg.norm(pts[:, None, :] - circles[None, :, :2], axis=-1) - circles[None, :, 2]
        d = np.minimum(d, dc.min(axis=1))
    return d


def inside_walls(pts: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Crossing parity of a +x ray against every wall: inside the outline and outside
    every polygon obstacle (obstacle edges are walls too)."""
    x, y = pts[:, 0:1], pts[:, 1:2]
    x1, y1, x2, y2 = (walls[None, :, i] for i in range(4))
    straddles = (y1 > y) != (y2 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
    return (straddles & (xc > x)).sum(axis=1) % 2 == 1


def in_free_space(pts, walls, circles, margin: float = 0.0) -> np.ndarray:
    pts = np.asarray(pts, np.float64)
    ok = inside_walls(pts, walls) & (clearance(pts, walls, circles) > margin)
    if len(circles):
        dc = np.linalg.norm(pts[:, None, :] - circles[None, :, :2], axis=-1)
        ok &= (dc > circles[None, :, 2]).all(axis=1)
    return ok


def sample_free(rng: np.random.Generator, maze, n: int, margin: float) -> np.ndarray:
    """n uniform points in free space at least ``margin`` from every surface."""
    walls, circles = maze_geometry(maze)
    lo, hi = walls[:, :2].min(axis=0), walls[:, :2].max(axis=0)
    out = []
    while sum(len(o) for o in out) < n:
        pts = rng.uniform(lo, hi, size=(4 * n, 2))
        out.append(pts[in_free_space(pts, walls, circles, margin)])
    return np.concatenate(out)[:n]


# ----------------------------------------------------------------------------
# Motion
# ----------------------------------------------------------------------------


def unicycle(pos, yaw, omega, s, v=V):
    """Closed-form unicycle pose after time s at speed v (arrays broadcast)."""
    pos = np.asarray(pos, np.float64)
    yaw = np.asarray(yaw, np.float64)
    omega = np.asarray(omega, np.float64)
    s = np.asarray(s, np.float64)
    straight = np.abs(omega) < 1e-12
    w = np.where(straight, 1.0, omega)
    x_arc = pos[..., 0] + v / w * (np.sin(yaw + w * s) - np.sin(yaw))
    y_arc = pos[..., 1] - v / w * (np.cos(yaw + w * s) - np.cos(yaw))
    x_lin = pos[..., 0] + v * s * np.cos(yaw)
    y_lin = pos[..., 1] + v * s * np.sin(yaw)
    x = np.where(straight, x_lin, x_arc)
    y = np.where(straight, y_lin, y_arc)
    return np.stack([x, y], axis=-1), yaw + omega * s


def displacement(yaw, omega, v, dt, n: int = 64) -> np.ndarray:
    """Unicycle displacement (2,) over time dt: the integral of the velocity
    v (cos, sin)(yaw + omega s) for s in [0, dt], by n-point Gauss-Legendre quadrature
    (exact to float64 rounding for the smooth integrand of a turn below 2 pi)."""
    nodes, weights = np.polynomial.legendre.leggauss(n)
    s = 0.5 * dt * (nodes + 1.0)
    heading = float(yaw) + float(omega) * s
    w = 0.5 * dt * weights * float(v)
    return np.array([np.sum(w * np.cos(heading)), np.sum(w * np.sin(heading))])


def path_min_clearance(pos, yaw, omega, walls, circles, n: int = 400) -> float:
    """Min clearance of the robot centre over ``n`` points of one step's true arc."""
    s = np.linspace(0.0, DT, n)
    pts, _ = unicycle(np.broadcast_to(pos, (n, 2)), np.full(n, yaw), np.full(n, omega), s)
    inside = inside_walls(pts, walls)
    c = clearance(pts, walls, circles)
    # A point outside the outline (or inside a polygon) has crossed a wall.
    return float(np.where(inside, c, -c).min())


def wrap(x):
    return (np.asarray(x, np.float64) + np.pi) % (2 * np.pi) - np.pi


def psi(x):
    """Spec: psi(x) = 1 - (2/pi) |wrap(x)|."""
    return 1.0 - 2.0 / np.pi * np.abs(wrap(x))


def path_min_clearance_batch(pos, yaw, omega, walls, circles, n: int = 400) -> np.ndarray:
    """Vectorised :func:`path_min_clearance` for poses (N, 2), (N,), (N,) -> (N,)."""
    pos = np.asarray(pos, np.float64)
    N = len(pos)
    s = np.linspace(0.0, DT, n)[None, :]
    pts, _ = unicycle(pos[:, None, :], np.asarray(yaw)[:, None], np.asarray(omega)[:, None], s)
    flat = pts.reshape(-1, 2)
    c = clearance(flat, walls, circles)
    c = np.where(inside_walls(flat, walls), c, -c)
    return c.reshape(N, n).min(axis=1)


def swept_distance_batch(pos, yaw, omega, v, dt, walls, circles, n: int = 4000) -> np.ndarray:
    """Smallest distance from n samples of each arc to any wall (unsigned) or cylinder
    surface (negative inside), for arcs (N, 2), (N,), (N,), (N,), (N,) -> (N,)."""
    pos = np.asarray(pos, np.float64)
    u = np.linspace(0.0, 1.0, n)[None, :]
    s = np.asarray(dt)[:, None] * u
    pts, _ = unicycle(
        pos[:, None, :],
        np.asarray(yaw)[:, None],
        np.asarray(omega)[:, None],
        s,
        np.asarray(v)[:, None],
    )
    return clearance(pts.reshape(-1, 2), walls, circles).reshape(len(pos), n).min(axis=1)


def arc_wall_distance(pos, yaw, omega, v, dt, wall, n: int = 4000) -> float:
    """Smallest distance from n samples of one step's path to one wall (4,)."""
    walls = np.asarray(wall, np.float64)[None]
    return float(_swept_one(pos, yaw, omega, v, dt, walls, np.zeros((0, 3)), n))


def arc_cylinder_distance(pos, yaw, omega, v, dt, circle, n: int = 4000) -> float:
    """Smallest distance from n samples of one step's path to one circle's edge (3,),
    negative inside it."""
    circles = np.asarray(circle, np.float64)[None]
    return float(_swept_one(pos, yaw, omega, v, dt, np.zeros((0, 4)), circles, n))


def _swept_one(pos, yaw, omega, v, dt, walls, circles, n):
    args = (np.asarray(x, np.float64)[None] for x in (pos, yaw, omega, v, dt))
    return swept_distance_batch(*args, walls, circles, n=n)[0]


def turned_changes_by_hand(now, old, turned):
    """The rule of env.history_turned, beam by beam: beam i now points where beam
    i + turned n / (2 pi) of an earlier scan pointed; between that scan's beams c (the
    nearer) and d there, it saw anything from c to c + w (d - c), w = 2 min(f, 1 - f);
    the change is how far beam i lies outside that, x 10, clipped to [-1, 1]."""
    n = len(now)
    out = np.zeros((len(old), n))
    for j, (scan, turn) in enumerate(zip(old, turned)):
        for i in range(n):
            at = i + turn * n / (2 * np.pi)
            lo = int(np.floor(at))
            f = at - lo
            a, b = scan[lo % n], scan[(lo + 1) % n]
            c, d = (a, b) if f < 0.5 else (b, a)
            e = c + 2 * min(f, 1 - f) * (d - c)
            inside = min(max(now[i], min(c, e)), max(c, e))
            out[j, i] = min(max((now[i] - inside) * 10.0, -1.0), 1.0)
    return out
