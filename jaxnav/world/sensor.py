"""What the robot senses: the LDS-01 LiDAR and the ROBOTIS observation.

The LiDAR's beams are evenly spread over 360 degrees, counter-clockwise from
straight ahead; each reads the exact distance to the first surface
(:mod:`jaxnav.world.geometry`), clipped to [min_range, max_range]. The imperfections of
a real robot are small pure functions of their own key: Gaussian range noise,
beam dropout (a lost return reads max_range) and odometry noise on the pose the
goal is seen from. :func:`observation` assembles the ROBOTIS state from them.

Keys: one observation key ``key`` per observation; range noise draws from it,
dropout from ``fold_in(key, 1)``, odometry from ``split(fold_in(key, 2))``. An
option that is off draws nothing, so it leaves every other draw unchanged.
"""

from __future__ import annotations

import math

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.core.settings import BURGER_MAX_OMEGA, BURGER_MAX_V
from jaxnav.world.geometry import norm2, ray_distances_dir, wrap_angle
from jaxnav.world.maps import Maze
from jaxnav.world.occupancy import grid_ranges


def beam_step(n_beams: int, inclusive: bool = False, fov: float = 360.0) -> float:
    """Angle between beams: 2 pi / n, or 2 pi / (n - 1) when n samples span [0, 2 pi]
    inclusive (Gazebo's layout: the first and last beams both look ahead); with a field
    of view ``fov`` below 360 degrees, fov / (n - 1): edge to edge."""
    if fov < 360.0:
        return math.radians(fov) / (n_beams - 1)
    return 2 * math.pi / (n_beams - 1 if inclusive and n_beams > 1 else n_beams)


def _first_beam(fov: float) -> float:
    """The first beam's angle from ahead: 0, or the right edge of a narrower scan."""
    return -math.radians(fov) / 2 if fov < 360.0 else 0.0


def beam_angles(n_beams: int, inclusive: bool = False, fov: float = 360.0) -> jax.Array:
    """Beam k points at yaw + k * beam_step (counter-clockwise from ahead; from the right
    edge where the field of view ``fov`` is below 360 degrees): f32[n_beams]."""
    if fov < 360.0:
        a = _first_beam(fov) + np.arange(n_beams) * beam_step(n_beams, inclusive, fov)
        return jnp.asarray(a, jnp.float32)
    return jnp.arange(n_beams, dtype=jnp.float32) * beam_step(n_beams, inclusive)


def beam_directions(
    n_beams: int, yaw: chex.Array, inclusive: bool = False, fov: float = 360.0
) -> chex.Array:
    """Unit vectors f32[n_beams, 2] of the beams at heading ``yaw``.

    The beams' own angles are constants; turning them by ``yaw`` is a rotation, so a
    scan costs one sine and one cosine instead of one per beam.
    """
    a = _first_beam(fov) + np.arange(n_beams) * beam_step(n_beams, inclusive, fov)
    ca, sa = np.cos(a).astype(np.float32), np.sin(a).astype(np.float32)
    cy, sy = jnp.cos(yaw), jnp.sin(yaw)
    return jnp.stack([cy * ca - sy * sa, sy * ca + cy * sa], axis=-1)


def beam_ranges(
    maze: Maze,
    pos: chex.Array,
    yaw: chex.Array,
    n_beams: int,
    inclusive: bool = False,
    fov: float = 360.0,
) -> chex.Array:
    """True, unclipped beam ranges f32[n_beams] from pose (pos f32[2], yaw f32[]) (and
    a maze's occupancy grid walked, :func:`jaxnav.world.occupancy.grid_ranges`)."""
    dirs = beam_directions(n_beams, yaw, inclusive, fov)
    ranges = ray_distances_dir(maze, pos, dirs)
    if maze.grid is not None:
        ranges = jnp.minimum(ranges, grid_ranges(maze.grid, pos, dirs))
    return ranges


def pooled_ranges(ranges: chex.Array, n_beams: int) -> chex.Array:
    """f32[n_beams]: the least of each sector of a scan of ``len(ranges)`` = m x
    ``n_beams`` evenly spread beams; sector k holds the m beams around beam k's
    direction (2 pi k / n_beams): offsets -(m // 2) .. m - 1 - m // 2 beams of the fine
    scan, so no obstacle between two observed beams goes unseen (Cimurs et al.'s
    minimum per sector)."""
    m = ranges.shape[0] // n_beams
    shifted = jnp.roll(ranges, m // 2)  # beam k m - m // 2 first in its sector
    return jnp.min(shifted.reshape(n_beams, m), axis=1)


# env.history_changes: a beam's change since an earlier scan, in normalised range, times
# this gain and clipped to [-1, 1]: a cylinder closing at 0.4 m/s moves a beam by about
# 0.02 of the sensor's range per 0.2 s step, 0.2 after the gain.
HISTORY_CHANGE_GAIN = 10.0


def turned_changes(scan: chex.Array, history: chex.Array, turned: chex.Array) -> chex.Array:
    """f32[k, n]: :func:`history_changes` with each earlier scan seen from the heading
    the robot has turned to since it (``turned`` f32[k] rad, counter-clockwise
    positive; n evenly spread beams, beam 0 ahead, counter-clockwise). Beam i points now
    where beam i + turned n / (2 pi) of the earlier scan pointed: between its two beams c
    (the nearer) and d, at a fraction w = 2 min(f, 1 - f) of the way to the midpoint (f:
    the fractional part). What the earlier scan saw there is taken as anything from c to
    c + w (d - c), and the change is how far this beam lies outside that interval (0
    inside): 0 where the earlier direction was a beam's, and edges that a turn carries
    across a beam do not read as motion. Turning in place then changes a beam only
    where the earlier scan's two beams missed what lay between them (a corner), while
    what moves still changes beams."""
    n = history.shape[-1]
    at = jnp.arange(n, dtype=jnp.float32)[None, :] + turned[:, None] * (n / (2 * math.pi))
    below = jnp.floor(at)
    f = at - below
    i0 = below.astype(jnp.int32) % n
    a = jnp.take_along_axis(history, i0, axis=1)
    b = jnp.take_along_axis(history, (i0 + 1) % n, axis=1)
    near, far = jnp.where(f < 0.5, a, b), jnp.where(f < 0.5, b, a)
    reach = near + 2.0 * jnp.minimum(f, 1.0 - f) * (far - near)
    seen = jnp.clip(scan[None, :], jnp.minimum(near, reach), jnp.maximum(near, reach))
    return jnp.clip((scan[None, :] - seen) * HISTORY_CHANGE_GAIN, -1.0, 1.0)


def history_changes(scan: chex.Array, history: chex.Array) -> chex.Array:
    """f32[k, n]: each beam of ``scan`` (normalised ranges f32[n]) less the same beam of
    each earlier scan ``history`` f32[k, n], times :data:`HISTORY_CHANGE_GAIN`, clipped
    to [-1, 1]: negative where something came closer."""
    return jnp.clip((scan[None, :] - history) * HISTORY_CHANGE_GAIN, -1.0, 1.0)


def lidar_scan(
    maze: Maze,
    pos: chex.Array,
    yaw: chex.Array,
    n_beams: int = 24,
    min_range: float = 0.12,
    max_range: float = 3.5,
) -> chex.Array:
    """LiDAR ranges f32[n_beams] from pose (pos, yaw), clipped to [min_range, max_range]."""
    ranges = beam_ranges(maze, pos, yaw, n_beams)
    return jnp.clip(ranges, min_range, max_range)


# ----------------------------------------------------------------------------
# Imperfections of a real robot
# ----------------------------------------------------------------------------


def range_noise(key: chex.PRNGKey, ranges: chex.Array, std) -> chex.Array:
    """Ranges f32[B] plus Gaussian noise of standard deviation ``std`` (m)."""
    return ranges + std * jax.random.normal(key, ranges.shape)


def beam_dropout(key: chex.PRNGKey, ranges: chex.Array, p: float, max_range) -> chex.Array:
    """Each beam of f32[B] lost with probability ``p``: it reads ``max_range``, as a real
    LDS-01 returns nothing from dark or shiny surfaces."""
    lost = jax.random.bernoulli(key, p, ranges.shape)
    return jnp.where(lost, max_range, ranges)


def odometry_noise(
    key: chex.PRNGKey, pos: chex.Array, yaw: chex.Array, std: tuple[float, float]
) -> tuple[chex.Array, chex.Array]:
    """The odometry pose: (pos f32[2], yaw f32[]) plus Gaussian noise of standard
    deviations ``std`` = (position m, yaw rad)."""
    k_pos, k_yaw = jax.random.split(key)
    pos = pos + std[0] * jax.random.normal(k_pos, (2,))
    yaw = yaw + std[1] * jax.random.normal(k_yaw)
    return pos, yaw


# ----------------------------------------------------------------------------
# Observation (ROBOTIS state)
# ----------------------------------------------------------------------------


def goal_heading_distance(
    pos: chex.Array, yaw: chex.Array, goal: chex.Array
) -> tuple[chex.Array, chex.Array]:
    """Heading delta f32[] (goal direction minus yaw, in [-pi, pi)) and distance f32[]
    to the goal."""
    rel = goal - pos
    heading = wrap_angle(jnp.arctan2(rel[1], rel[0]) - yaw)
    return heading, norm2(rel)


def robotis_state(
    ranges: chex.Array, heading: chex.Array, distance: chex.Array, obstacle_obs: bool
) -> chex.Array:
    """[ranges, heading, distance(, min range, argmin beam)]: f32[B + 2 (+ 2)]."""
    parts = [ranges, heading[None], distance[None]]
    if obstacle_obs:
        parts += [jnp.min(ranges)[None], jnp.argmin(ranges).astype(jnp.float32)[None]]
    return jnp.concatenate(parts).astype(jnp.float32)


def observation(
    key: chex.PRNGKey,
    ranges: chex.Array,
    pos: chex.Array,
    yaw: chex.Array,
    goal: chex.Array,
    *,
    noise_std,
    min_range,
    max_range,
    dropout: float = 0.0,
    odom_std: tuple[float, float] = (0.0, 0.0),
    obstacle_obs: bool = False,
) -> chex.Array:
    """The ROBOTIS state seen from true ranges f32[B] at the true pose.

    ``noise_std``, ``min_range`` and ``max_range`` may be data (traced);
    ``dropout``, ``odom_std`` and ``obstacle_obs`` fix the computation.
    """
    ranges, heading, distance = _seen(
        key, ranges, pos, yaw, goal, noise_std, min_range, max_range, dropout, odom_std
    )
    return robotis_state(ranges, heading, distance, obstacle_obs)


def _seen(key, ranges, pos, yaw, goal, noise_std, min_range, max_range, dropout, odom_std):
    """(ranges, heading, distance) as the robot reads them: the range noise, clipping
    and dropout on the scan, the odometry noise on the goal's heading and distance."""
    if not (isinstance(noise_std, (int, float)) and noise_std == 0.0):  # no draw for a constant 0
        ranges = range_noise(key, ranges, noise_std)
    ranges = jnp.clip(ranges, min_range, max_range)
    if dropout > 0.0:
        ranges = beam_dropout(jax.random.fold_in(key, 1), ranges, dropout, max_range)
    if odom_std != (0.0, 0.0):  # the goal is seen from the odometry pose
        pos, yaw = odometry_noise(jax.random.fold_in(key, 2), pos, yaw, odom_std)
    heading, distance = goal_heading_distance(pos, yaw, goal)
    return ranges, heading, distance


def normalised_state(
    ranges: chex.Array,
    heading: chex.Array,
    distance: chex.Array,
    last: chex.Array,
    max_range,
    scale: tuple[float, float] = (BURGER_MAX_V, BURGER_MAX_OMEGA),
) -> chex.Array:
    """[ranges / max range, heading / pi, min(distance, max range) / max range, last v /
    0.22, last omega / 2.84]: f32[B + 4], every entry within [-1, 1] (the robot's limits
    ``scale``, the burger's teleop limits by default, scale the command the robot drove
    last, ``last`` (v, omega))."""
    scale = jnp.asarray(scale, jnp.float32)
    parts = [
        ranges / max_range,
        (heading / jnp.pi)[None],
        (jnp.minimum(distance, max_range) / max_range)[None],
        last / scale,
    ]
    return jnp.concatenate(parts).astype(jnp.float32)


def moving_features(
    pos: chex.Array,
    yaw: chex.Array,
    now: chex.Array,
    soon: chex.Array,
    dt,
    k: int,
    max_range,
) -> chex.Array:
    """f32[4 k]: the k moving cylinders nearest the robot, nearest first, each as its
    centre's offset from the robot in the robot's frame (x ahead, y to the left) over
    the sensor's range and its velocity over the next step in the same frame over the
    burger's top speed, all clipped to [-1, 1]; zeros where the maze has fewer than k.
    ``now``, ``soon``: f32[M, 2] their centres at this step's time and ``dt`` s later."""
    c, s = jnp.cos(yaw), jnp.sin(yaw)

    def robot_frame(d):  # world vectors [M, 2] turned by -yaw
        return jnp.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)

    offset = robot_frame(now - pos[None, :])
    velocity = robot_frame((soon - now) / dt)
    order = jnp.argsort(jnp.sum(offset**2, axis=1))[:k]
    rows = jnp.concatenate([offset[order] / max_range, velocity[order] / BURGER_MAX_V], axis=1)
    rows = jnp.clip(rows, -1.0, 1.0)
    if rows.shape[0] < k:  # a maze with fewer moving cylinders than observed
        rows = jnp.concatenate([rows, jnp.zeros((k - rows.shape[0], 4), rows.dtype)])
    return rows.reshape(-1).astype(jnp.float32)


def normalised_observation(
    key: chex.PRNGKey,
    ranges: chex.Array,
    pos: chex.Array,
    yaw: chex.Array,
    goal: chex.Array,
    last: chex.Array,
    *,
    noise_std,
    min_range,
    max_range,
    dropout: float = 0.0,
    odom_std: tuple[float, float] = (0.0, 0.0),
    waypoint: chex.Array | None = None,
    scale: tuple[float, float] = (BURGER_MAX_V, BURGER_MAX_OMEGA),
) -> chex.Array:
    """The normalised state (:func:`normalised_state`) seen from true ranges at the true
    pose, with the same noise as :func:`observation`'s; ``last``: the command driven
    last (v, omega). ``waypoint`` (f32[2]): its heading over pi and its distance over
    the sensor's range (capped at 1), seen from the same odometry pose, follow."""
    ranges, heading, distance = _seen(
        key, ranges, pos, yaw, goal, noise_std, min_range, max_range, dropout, odom_std
    )
    state = normalised_state(ranges, heading, distance, last, max_range, scale)
    if waypoint is None:
        return state
    if odom_std != (0.0, 0.0):  # the odometry pose of _seen (the same key)
        pos, yaw = odometry_noise(jax.random.fold_in(key, 2), pos, yaw, odom_std)
    w_heading, w_distance = goal_heading_distance(pos, yaw, waypoint)
    extra = jnp.stack([w_heading / jnp.pi, jnp.minimum(w_distance, max_range) / max_range])
    return jnp.concatenate([state, extra.astype(jnp.float32)])
