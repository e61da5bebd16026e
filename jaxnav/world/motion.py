"""Moving cylinders: where each is at a time, and how close the robot comes to them
over one step.

A maze with moving obstacles carries a :class:`Motion`: M cylinders, each on a closed
loop of keyframes (piecewise linear in time, repeating every ``period``), the whole
path then turned about ``centre`` at ``spin`` rad/s. That one form holds both of
ROBOTIS' machine-learning stages: stage 3's four cylinders are one keyframe each
(they stand still in the loop) spun about the origin, and stage 4's two cylinders are
waypoint loops with no spin (:mod:`jaxnav.world.stages`).

Time is the episode's: ``t * dt`` after ``t`` steps. An episode's start resets the
obstacles to their keyframe-0 pose, as ROBOTIS' environment resets the Gazebo world
after a collision or a time-out; a goal reached mid-episode does not.

Collision over a step (:func:`moving_clearance`) is tested between the robot's centre
on its exact arc and each cylinder's centre on its own path, through their relative
motion: the step is cut into ``SUBSTEPS`` pieces, both ends of every piece are exact
positions, and within a piece the relative motion is taken as the straight chord
between them, whose distance to the origin is exact. The chord departs from the true
relative path by at most its sagitta, a few micrometres at the robot's and the
cylinders' speeds and turn rates (0.15 m/s on a 0.1 m radius, 0.42 m/s on a 0.85 m
radius: under 5e-6 m at 16 pieces of a 0.2 s step).
"""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from jaxnav.world.geometry import displacement, path_clearance, point_segment_distance

SUBSTEPS = 16  # pieces of a step for the moving-obstacle collision test


@struct.dataclass
class Motion:
    """M moving cylinders on closed keyframe loops (a pytree; all arrays).

    Attributes:
      radius: f32[M] each cylinder's radius, m.
      times: f32[M, K] keyframe times in [0, period], ``times[:, 0] == 0``, non-
        decreasing; a loop of fewer keyframes repeats its last one (back at the
        start point) at ``period``.
      points: f32[M, K, 2] the keyframe positions; ``points[:, K-1]`` equals
        ``points[:, 0]`` (the loop closes).
      period: f32[M] the loop's duration, s.
      centre: f32[M, 2] the point the path turns about.
      spin: f32[M] its turn rate, rad/s (counter-clockwise positive).
    """

    radius: chex.Array
    times: chex.Array
    points: chex.Array
    period: chex.Array
    centre: chex.Array
    spin: chex.Array

    @property
    def n(self) -> int:
        return self.radius.shape[-1]


def make_motion(loops: list[dict]) -> Motion:
    """A :class:`Motion` from host-side loops, each ``{"radius": r, "points": [[x, y],
    ...], "speeds": [...], "spin": w, "centre": [x, y]}``.

    ``points`` are the loop's waypoints in order (not repeating the first); leg i runs
    from point i to point i + 1 (the last back to the first) at ``speeds[i]`` m/s.
    A single point with ``spin`` is a cylinder turning about ``centre``. With
    ``times`` instead of ``speeds`` the keyframe times are given directly (the last
    one the period).
    """
    rows = []
    for loop in loops:
        pts = np.asarray(loop["points"], np.float64).reshape(-1, 2)
        closed = np.concatenate([pts, pts[:1]])
        if "times" in loop:
            times = np.asarray(loop["times"], np.float64)
        elif len(pts) == 1:
            times = np.asarray([0.0, 1.0])
        else:
            legs = np.linalg.norm(np.diff(closed, axis=0), axis=1)
            speeds = np.broadcast_to(np.asarray(loop["speeds"], np.float64), legs.shape)
            times = np.concatenate([[0.0], np.cumsum(legs / speeds)])
        rows.append(
            (loop["radius"], times, closed, loop.get("centre", (0.0, 0.0)), loop.get("spin", 0.0))
        )
    k = max(len(r[1]) for r in rows)

    def pad(a: np.ndarray) -> np.ndarray:  # repeat the last row up to K rows
        return np.concatenate([a, np.repeat(a[-1:], k - len(a), axis=0)])

    f32 = np.float32
    return Motion(
        radius=jnp.asarray([r[0] for r in rows], f32),
        times=jnp.asarray(np.stack([pad(r[1]) for r in rows]), f32),
        points=jnp.asarray(np.stack([pad(r[2]) for r in rows]), f32),
        period=jnp.asarray([r[1][-1] for r in rows], f32),
        centre=jnp.asarray([r[3] for r in rows], f32),
        spin=jnp.asarray([r[4] for r in rows], f32),
    )


def parked(k: int = 2) -> Motion:
    """One cylinder of radius 0 parked far away: what a maze that stands still carries
    when stacked beside mazes that move (it is never seen and never touched)."""
    far = 1.0e4
    return make_motion([{"radius": 0.0, "points": [(far, far)], "times": [0.0] + [1.0] * (k - 1)}])


def pad_motion(motion: Motion, n: int, k: int) -> Motion:
    """``motion`` with n cylinders of k keyframes: its loops' last keyframe repeated,
    then parked cylinders (host side; for stacking mazes)."""
    m, k0 = motion.n, motion.times.shape[-1]
    if n < m or k < k0:
        raise ValueError("pad_motion cannot shrink a motion")

    def rows(a, axis_len):  # repeat the last keyframe up to k
        return jnp.concatenate([a, jnp.repeat(a[:, -1:], axis_len, axis=1)], axis=1)

    out = motion.replace(times=rows(motion.times, k - k0), points=rows(motion.points, k - k0))
    if n == m:
        return out
    extra = parked(k)
    return jax.tree.map(lambda a, b: jnp.concatenate([a, jnp.repeat(b, n - m, axis=0)]), out, extra)


def _one_position(times, points, period, centre, spin, time) -> chex.Array:
    """f32[2]: one cylinder's centre at ``time``."""
    tau = jnp.mod(time, period)
    k = times.shape[0]
    i = jnp.clip(jnp.sum(times[1:] <= tau), 0, k - 2)
    t0, t1 = times[i], times[i + 1]
    frac = jnp.clip((tau - t0) / jnp.maximum(t1 - t0, 1e-9), 0.0, 1.0)
    p = points[i] + frac * (points[i + 1] - points[i])
    angle = spin * time
    c, s = jnp.cos(angle), jnp.sin(angle)
    r = p - centre
    return centre + jnp.stack([c * r[0] - s * r[1], s * r[0] + c * r[1]])


def positions(motion: Motion, time: chex.Array) -> chex.Array:
    """f32[M, 2]: every moving cylinder's centre at ``time`` (s)."""
    one = jax.vmap(_one_position, in_axes=(0, 0, 0, 0, 0, None))
    return one(motion.times, motion.points, motion.period, motion.centre, motion.spin, time)


def circles_at(motion: Motion, time: chex.Array) -> chex.Array:
    """f32[M, 3]: the moving cylinders (x, y, r) at ``time``."""
    return jnp.concatenate([positions(motion, time), motion.radius[:, None]], axis=1)


def paced(motion: Motion, pace: chex.Array) -> Motion:
    """``motion`` run ``pace`` times as fast (f32[]; 0 stands still at the first pose):
    the same loops and turns, the cylinder at time t where ``motion`` has it at
    ``pace * t``."""
    rate = jnp.maximum(jnp.asarray(pace, jnp.float32), 1e-6)  # 0: keyframes out of reach
    return motion.replace(
        times=motion.times / rate, period=motion.period / rate, spin=motion.spin * pace
    )


def longest_cycle(motion: Motion) -> float:
    """Host side: the longest cycle of any cylinder (s): its loop's period, or a full
    turn when it spins."""
    spin = np.abs(np.asarray(motion.spin, np.float64))
    turn = np.where(spin > 0, 2 * np.pi / np.maximum(spin, 1e-9), 0.0)
    return float(np.max(np.maximum(np.asarray(motion.period, np.float64), turn)))


def loop_paths(motion: Motion, n: int = 400) -> np.ndarray:
    """f64[M, n, 2] host side: each cylinder's centre over its longest cycle (for
    drawing): the loop's period, or a full turn when it spins."""
    times = jnp.linspace(0.0, longest_cycle(motion), n)
    return np.asarray(jax.vmap(lambda t: positions(motion, t))(times), np.float64).transpose(
        1, 0, 2
    )


def top_speed(motion: Motion, n: int = 2000) -> float:
    """Host side: the fastest any cylinder moves (m/s), from the chords between ``n``
    points of its longest cycle (:func:`loop_paths`)."""
    paths = loop_paths(motion, n)
    step = longest_cycle(motion) / (n - 1)
    return float(np.max(np.linalg.norm(np.diff(paths, axis=1), axis=-1))) / step


def frozen_at(maze, time):
    """``maze`` (a :class:`jaxnav.world.maps.Maze` with a motion) with its moving
    cylinders joined to the static ones where they are at ``time`` (s), and no motion:
    what the LiDAR sees at that time. A maze without a motion is returned as it is."""
    if maze.motion is None:
        return maze
    moving = circles_at(maze.motion, time)
    return maze.replace(
        circles=jnp.concatenate([maze.circles, moving]),
        circle_mask=jnp.concatenate([maze.circle_mask, jnp.ones(len(moving), bool)]),
        motion=None,
    )


def moving_clearance(
    motion: Motion, pos: chex.Array, yaw: chex.Array, omega, v, dt, time0: chex.Array
) -> chex.Array:
    """f32[]: the smallest distance between the robot's centre and any moving
    cylinder's surface over the step that starts at ``time0`` from pose (pos, yaw)
    (the robot collides iff this is below its radius)."""
    s = jnp.linspace(0.0, 1.0, SUBSTEPS + 1) * dt
    robot = pos[None, :] + jax.vmap(lambda si: displacement(yaw, omega, v, si))(s)  # [N+1, 2]
    discs = jax.vmap(lambda si: positions(motion, time0 + si))(s)  # [N+1, M, 2]
    rel = robot[:, None, :] - discs  # the robot seen from each cylinder
    a, b = rel[:-1], rel[1:]
    d = point_segment_distance(0.0, 0.0, a[..., 0], a[..., 1], b[..., 0], b[..., 1])
    return jnp.min(d - motion.radius[None, :])


def step_clearance(maze, pos: chex.Array, yaw: chex.Array, omega, v, dt, time0) -> chex.Array:
    """f32[]: the smallest distance between the robot's centre and any surface over the
    step that starts at ``time0`` from pose (pos, yaw): the walls and standing cylinders
    along its exact arc (:func:`jaxnav.world.geometry.path_clearance`) and, in a maze
    whose ``motion`` is not None, the moving cylinders over the step's time
    (:func:`moving_clearance`). The robot collides iff this is below its radius; the
    environment's step, the oracle and ``jaxnav probe search`` all test with it."""
    return step_clearances(maze, pos, yaw, omega, v, dt, time0)[0]


def step_clearances(maze, pos: chex.Array, yaw: chex.Array, omega, v, dt, time0):
    """(:func:`step_clearance`, the moving cylinders' part of it): the second is
    :func:`moving_clearance` over the step, or None in a maze whose ``motion`` is None."""
    clearance = path_clearance(maze, pos, yaw, omega, v, dt)
    moving = None
    if maze.motion is not None:
        moving = moving_clearance(maze.motion, pos, yaw, omega, v, dt, time0)
        clearance = jnp.minimum(clearance, moving)
    return clearance, moving


__all__ = [
    "SUBSTEPS",
    "Motion",
    "circles_at",
    "frozen_at",
    "loop_paths",
    "make_motion",
    "moving_clearance",
    "pad_motion",
    "parked",
    "positions",
    "paced",
    "step_clearance",
    "step_clearances",
]
