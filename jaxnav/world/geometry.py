"""Exact 2D geometry of rays and swept discs, branchless, in JAX.

Two questions about a maze of wall segments and cylinders are answered exactly:
how far a ray travels before it hits something (the LiDAR), and how close the
robot's centre comes to any surface while it drives along one step's arc (the
collision test). As in MuJoCo MJX's ``_src/ray.py``, each answer is one
module-level primitive per kind of surface, all with the same signature style,
vmapped over the maze's walls or cylinders and reduced with ``min``; a miss is
``inf`` rather than a branch (``lax.cond`` under vmap runs both branches anyway),
and divisions are made safe instead of guarded.

Primitives (each tested alone against a float64 NumPy reference):

* :func:`ray_segment`, :func:`ray_circle`: distance along a ray to one wall or one
  cylinder.
* :func:`point_segment_distance`: distance from a point to a wall.
* :func:`arc` builds an :class:`Arc`, one step's path of the robot centre;
  :func:`arc_segment_clearance` and :func:`arc_circle_clearance` give its distance
  to one wall or one cylinder surface.
* :func:`displacement`: where one step of the unicycle takes the robot.

Maze-level functions: :func:`ray_distances`, :func:`ray_distances_dir` and
:func:`path_clearance`, built from them with :func:`min_over`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import NamedTuple, Protocol

import chex
import jax
import jax.numpy as jnp


class Surfaces(Protocol):
    """What the maze-level functions read of a maze (``jaxnav.world.maps.Maze`` has it):
    its wall segments f32[S, 4] and cylinders f32[C, 3] (x, y, r), each with a mask of
    the real rows (bool[S], bool[C]); padding rows are ignored."""

    segments: chex.Array
    segment_mask: chex.Array
    circles: chex.Array
    circle_mask: chex.Array


_EPS = 1e-9


def wrap_angle(a: chex.Array) -> chex.Array:
    """Wrap angles to [-pi, pi)."""
    return (a + jnp.pi) % (2 * jnp.pi) - jnp.pi


def _cross(ax, ay, bx, by):
    """z of the 2D cross product (ax, ay) x (bx, by)."""
    return ax * by - ay * bx


def _safe(x: chex.Array) -> chex.Array:
    """x with values too close to 0 replaced by 1 (for division)."""
    return jnp.where(jnp.abs(x) < _EPS, 1.0, x)


def hypot(x: chex.Array, y: chex.Array) -> chex.Array:
    """Length of the vector (x, y)."""
    return jnp.sqrt(x * x + y * y)


def norm2(v: chex.Array) -> chex.Array:
    """Length of a 2-vector f32[2]."""
    return hypot(v[0], v[1])


# Geometry is written on x and y components of one wall or cylinder at a time, and
# vmapped over the walls: under the caller's vmap every quantity is then a flat
# [batch, walls] or [batch, walls, beams] array. (Arrays with a trailing axis of 2
# per point leave XLA's CPU loops two lanes wide.) The minimum over the walls is a
# reduction, whose result XLA computes once: a chain of element-wise minimums would
# be recomputed inside every consumer, such as each element of an observation.


def min_over(fn: Callable[..., chex.Array], table: chex.Array, mask: chex.Array) -> chex.Array:
    """min over the rows i of ``table`` with ``mask[i]`` of ``fn(*table[i])``, inf if none.

    Args:
      fn: a primitive taking one row's columns (``ax, ay, bx, by`` or ``cx, cy, r``).
      table: f32[N, K] walls f32[N, 4] or cylinders f32[N, 3].
      mask: bool[N] which rows are real.
    Returns:
      the minimum over the real rows, the shape of one ``fn`` result.
    """
    vals = jax.vmap(fn)(*(table[:, j] for j in range(table.shape[1])))
    mask = mask.reshape(mask.shape + (1,) * (vals.ndim - 1))
    return jnp.min(jnp.where(mask, vals, jnp.inf), axis=0)


# ----------------------------------------------------------------------------
# Rays
# ----------------------------------------------------------------------------


def ray_segment(ox, oy, dx, dy, ax, ay, bx, by) -> chex.Array:
    """Distance t >= 0 along the ray o + t d to the wall from a to b (inf on a miss).

    Args:
      ox, oy: f32[] ray origin.
      dx, dy: f32[B] unit ray directions.
      ax, ay, bx, by: f32[] the wall's end points.
    Returns:
      f32[B] distances.
    """
    # origin + t d = a + u e, solved with 2D cross products.
    ex, ey = bx - ax, by - ay
    wx, wy = ax - ox, ay - oy
    denom = _cross(dx, dy, ex, ey)
    sd = _safe(denom)
    t = _cross(wx, wy, ex, ey) / sd
    u = _cross(wx, wy, dx, dy) / sd
    hit = (jnp.abs(denom) >= _EPS) & (t >= 0.0) & (u >= -1e-6) & (u <= 1.0 + 1e-6)
    return jnp.where(hit, t, jnp.inf)


def ray_circle(ox, oy, dx, dy, cx, cy, r) -> chex.Array:
    """Distance t >= 0 along the ray o + t d to the circle's edge (inf on a miss).

    From inside the circle the ray hits its edge on the way out.

    Args:
      ox, oy: f32[] ray origin.
      dx, dy: f32[B] unit ray directions.
      cx, cy, r: f32[] the circle's centre and radius.
    Returns:
      f32[B] distances.
    """
    # |f + t d|^2 = r^2 with f = origin - c.
    fx, fy = ox - cx, oy - cy
    b = fx * dx + fy * dy
    c = fx * fx + fy * fy - r**2
    # disc = b^2 - c = r^2 - h^2 with h the centre's offset from the ray's line.
    # Computed as (r - h)(r + h): b^2 - c cancels in float32 near a tangent.
    h = jnp.abs(_cross(dx, dy, fx, fy))
    disc = (r - h) * (r + h)
    sq = jnp.sqrt(jnp.maximum(disc, 0.0))
    tc = jnp.where(c > 0.0, -b - sq, -b + sq)  # first root outside, second inside
    return jnp.where((disc >= 0.0) & (tc >= 0.0), tc, jnp.inf)


def ray_distances(maze: Surfaces, origin: chex.Array, angles: chex.Array) -> chex.Array:
    """Exact distance along each ray to the first wall or obstacle (inf if none).

    Args:
      maze: the maze (single, unbatched).
      origin: f32[2] ray origin.
      angles: f32[B] world-frame ray directions.
    Returns:
      f32[B] distances.
    """
    return ray_distances_dir(maze, origin, jnp.stack([jnp.cos(angles), jnp.sin(angles)], axis=-1))


def ray_distances_dir(maze: Surfaces, origin: chex.Array, dirs: chex.Array) -> chex.Array:
    """:func:`ray_distances` with the rays given as unit vectors f32[B, 2]."""
    ox, oy = origin[0], origin[1]
    dx, dy = dirs[:, 0], dirs[:, 1]  # [B]
    t_seg = min_over(
        functools.partial(ray_segment, ox, oy, dx, dy), maze.segments, maze.segment_mask
    )
    t_circ = min_over(functools.partial(ray_circle, ox, oy, dx, dy), maze.circles, maze.circle_mask)
    return jnp.minimum(t_seg, t_circ)


# ----------------------------------------------------------------------------
# One step's path of the robot centre
# ----------------------------------------------------------------------------


def displacement(yaw, omega, v, dt) -> chex.Array:
    """Exact unicycle displacement f32[2]: chord of length v dt sinc(omega dt / 2), mid heading."""
    half = 0.5 * omega * dt
    chord = v * dt * jnp.sinc(half / jnp.pi)  # jnp.sinc(x) = sin(pi x) / (pi x)
    mid = yaw + half
    return chord * jnp.stack([jnp.cos(mid), jnp.sin(mid)])


def point_segment_distance(px, py, ax, ay, bx, by) -> chex.Array:
    """Distance f32[] from the point p to the segment from a to b (all f32[])."""
    abx, aby = bx - ax, by - ay
    den = jnp.maximum(abx * abx + aby * aby, _EPS)
    t = jnp.clip(((px - ax) * abx + (py - ay) * aby) / den, 0.0, 1.0)
    return hypot(px - (ax + t * abx), py - (ay + t * aby))


class Arc(NamedTuple):
    """The path of the robot centre over one step (all f32[] or bool[]).

    A straight segment from p0 to p1 when ``straight``, otherwise an arc of the
    circle with centre C and radius ``rad`` swept from p0 to p1 turning by ``sgn``.
    """

    x0: chex.Array  # start point p0
    y0: chex.Array
    x1: chex.Array  # end point p1
    y1: chex.Array
    straight: chex.Array  # omega = 0: the path is the segment p0 p1
    cx: chex.Array  # centre C of the turning circle
    cy: chex.Array
    rad: chex.Array  # its radius v / |omega|
    u0x: chex.Array  # p0 - C
    u0y: chex.Array
    u1x: chex.Array  # p1 - C
    u1y: chex.Array
    sgn: chex.Array  # +1 counter-clockwise, -1 clockwise
    half_turn: chex.Array  # the sweep |omega dt| is at most pi


def arc(pos: chex.Array, yaw: chex.Array, omega: chex.Array, v, dt) -> Arc:
    """The exact unicycle path of one step from pose (pos f32[2], yaw f32[]).

    A straight segment when omega = 0, otherwise an arc of radius v / |omega|
    swept by omega * dt.
    """
    x0, y0 = pos[0], pos[1]
    disp = displacement(yaw, omega, v, dt)
    x1, y1 = x0 + disp[0], y0 + disp[1]
    straight = jnp.abs(omega) < 1e-6

    # Arc path: centre C, signed radius R, from p0 to p1, sweep omega dt.
    w = jnp.where(straight, 1.0, omega)
    R = v / w
    cx, cy = x0 - R * jnp.sin(yaw), y0 + R * jnp.cos(yaw)
    rad = jnp.abs(R)
    u0x, u0y, u1x, u1y = x0 - cx, y0 - cy, x1 - cx, y1 - cy
    sgn = jnp.sign(w)
    half_turn = jnp.abs(w * dt) <= jnp.pi
    return Arc(x0, y0, x1, y1, straight, cx, cy, rad, u0x, u0y, u1x, u1y, sgn, half_turn)


def in_arc(arc: Arc, px, py) -> chex.Array:
    """bool[]: is the direction of the point p (f32[] each) from C within the swept arc?"""
    # Turning by sgn from u0: after u0 (angle in [0, pi]) and before u1 (the
    # remaining angle in [0, pi]); both for sweeps up to pi, either beyond.
    rx, ry = px - arc.cx, py - arc.cy
    after = arc.sgn * _cross(arc.u0x, arc.u0y, rx, ry) >= 0.0
    before = arc.sgn * _cross(rx, ry, arc.u1x, arc.u1y) >= 0.0
    return jnp.where(arc.half_turn, after & before, after | before)


def point_arc_distance(arc: Arc, px, py) -> chex.Array:
    """Distance f32[] from the point p (f32[] each) to the curved path (not the straight
    one)."""
    rho = hypot(px - arc.cx, py - arc.cy)
    ends = jnp.minimum(hypot(px - arc.x0, py - arc.y0), hypot(px - arc.x1, py - arc.y1))
    return jnp.where(in_arc(arc, px, py), jnp.abs(rho - arc.rad), ends)


def arc_segment_clearance(arc: Arc, ax, ay, bx, by) -> chex.Array:
    """Smallest distance f32[] between the path and the wall from a to b (f32[] each), 0
    if they cross."""
    x0, y0, x1, y1 = arc.x0, arc.y0, arc.x1, arc.y1
    d_ends = jnp.minimum(
        point_segment_distance(x0, y0, ax, ay, bx, by),
        point_segment_distance(x1, y1, ax, ay, bx, by),
    )
    # Straight path: segment-segment distance, 0 if they cross.
    d = jnp.minimum(
        d_ends,
        jnp.minimum(
            point_segment_distance(ax, ay, x0, y0, x1, y1),
            point_segment_distance(bx, by, x0, y0, x1, y1),
        ),
    )
    ex, ey = x1 - x0, y1 - y0
    abx, aby = bx - ax, by - ay
    o1 = _cross(ex, ey, ax - x0, ay - y0)
    o2 = _cross(ex, ey, bx - x0, by - y0)
    o3 = _cross(abx, aby, x0 - ax, y0 - ay)
    o4 = _cross(abx, aby, x1 - ax, y1 - ay)
    d_line = jnp.where((o1 * o2 < 0) & (o3 * o4 < 0), 0.0, d)

    # Arc: the wall's end points, the foot F of C on the wall's line, and the
    # crossings of the wall's line with the circle.
    cx, cy, rad = arc.cx, arc.cy, arc.rad
    d_segpts = jnp.minimum(point_arc_distance(arc, ax, ay), point_arc_distance(arc, bx, by))
    ab2 = jnp.maximum(abx * abx + aby * aby, _EPS)
    tau = ((cx - ax) * abx + (cy - ay) * aby) / ab2
    fx, fy = ax + tau * abx, ay + tau * aby
    h = hypot(fx - cx, fy - cy)
    d_foot = jnp.where(
        (h >= rad) & (tau >= 0.0) & (tau <= 1.0) & in_arc(arc, fx, fy), h - rad, jnp.inf
    )
    half = jnp.sqrt(jnp.maximum(rad**2 - h**2, 0.0)) / jnp.sqrt(ab2)
    hits = False
    for sgn_q in (-1.0, 1.0):
        tq = tau + sgn_q * half
        qx, qy = ax + tq * abx, ay + tq * aby
        hits |= (h < rad) & (tq >= 0.0) & (tq <= 1.0) & in_arc(arc, qx, qy)
    d_arc = jnp.where(hits, 0.0, jnp.minimum(jnp.minimum(d_ends, d_segpts), d_foot))
    return jnp.where(arc.straight, d_line, d_arc)


def arc_circle_clearance(arc: Arc, qx, qy, r) -> chex.Array:
    """Smallest distance f32[] between the path and the edge of the circle (centre q,
    radius r, f32[] each), negative when the path enters it."""
    d_line = point_segment_distance(qx, qy, arc.x0, arc.y0, arc.x1, arc.y1)
    return jnp.where(arc.straight, d_line, point_arc_distance(arc, qx, qy)) - r


def path_clearance(
    maze: Surfaces, pos: chex.Array, yaw: chex.Array, omega: chex.Array, v: float, dt: float
) -> chex.Array:
    """Smallest distance f32[] from the robot centre's path over one step to any surface.

    The centre moves on the exact unicycle path (:func:`arc`). The robot collides
    during the step iff this is below its radius.
    """
    path = arc(pos, yaw, omega, v, dt)
    return jnp.minimum(
        min_over(functools.partial(arc_segment_clearance, path), maze.segments, maze.segment_mask),
        min_over(functools.partial(arc_circle_clearance, path), maze.circles, maze.circle_mask),
    )
