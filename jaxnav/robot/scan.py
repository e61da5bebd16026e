"""What a robot's raw scan and pose become before a policy reads them, in NumPy alone:
the trained beams' nearest rays of a LaserScan, its readings cleaned and clipped as the
simulator's, pooled sectors, the history's changes, the scan convolutions, the goal's
heading and distance, and odometry's yaw. Each is the NumPy twin of the simulator's
(named in its docstring); :class:`jaxnav.robot.deploy.Policy` builds its observation
with them. NumPy and the standard library only, so the robot side runs without JAX
(a contract in pyproject.toml checks it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def _wrap(a):
    """Wrap angles to [-pi, pi), as jaxnav.world.geometry.wrap_angle."""
    return (np.asarray(a, np.float64) + math.pi) % (2 * math.pi) - math.pi


def beam_angles(n_beams: int, layout: str = "even") -> np.ndarray:
    """f64[n_beams]: trained beam k looks at 2 pi k / n_beams in the robot frame, or at
    2 pi k / (n_beams - 1) for a policy trained with Gazebo's inclusive layout."""
    span = n_beams - 1 if layout == "gazebo" and n_beams > 1 else n_beams
    return np.arange(n_beams, dtype=np.float64) * (2 * math.pi / span)


def nearest_rays(
    n_rays: int, angle_min: float, angle_increment: float, n_beams: int, layout: str = "even"
) -> np.ndarray:
    """i64[n_beams]: index of the scan ray nearest each trained beam direction.

    Ray i of the scan points at ``angle_min + i * angle_increment`` (robot frame,
    counter-clockwise). Distances between angles are circular; ties go to the lower
    index. Raises ValueError if a beam has no ray within one increment (the scan
    does not cover that direction).
    """
    angle_min, inc = float(angle_min), float(angle_increment)
    if n_rays < 1:
        raise ValueError("the scan has no rays")
    if not (math.isfinite(angle_min) and math.isfinite(inc)) or (n_rays > 1 and inc == 0.0):
        raise ValueError(f"bad scan angles (angle_min {angle_min}, angle_increment {inc})")
    rays = angle_min + inc * np.arange(n_rays, dtype=np.float64)
    angles = beam_angles(n_beams, layout)
    gap = np.abs(_wrap(rays[None, :] - angles[:, None]))  # [n_beams, n_rays]
    idx = np.argmin(gap, axis=1)
    worst = gap[np.arange(n_beams), idx]
    tol = abs(inc) * (1 + 1e-6) if n_rays > 1 else 1e-6
    bad = np.flatnonzero(worst > tol)
    if bad.size:
        k = int(bad[0])
        beam_deg, off_deg = math.degrees(angles[k]), math.degrees(worst[k])
        raise ValueError(
            f"the scan does not cover trained beam {k} at {beam_deg:.1f} deg (nearest ray "
            f"{off_deg:.1f} deg away); the policy needs a 360-degree scan"
        )
    return idx


def clean_ranges(
    ranges: np.ndarray, min_range: float, max_range: float, invalid: float | None = None
) -> np.ndarray:
    """f64 ranges as the trained LiDAR gives them: no-return and invalid readings
    replaced, then clipped to [min_range, max_range].

    +inf -> max_range; -inf -> min_range; 0, nan, negative -> ``invalid``
    (default max_range, see the module docstring).
    """
    r = np.asarray(ranges, np.float64)
    invalid = max_range if invalid is None else float(invalid)
    out = np.where(np.isposinf(r), max_range, r)
    out = np.where(np.isneginf(r), min_range, out)
    out = np.where(np.isnan(r) | (np.isfinite(r) & (r <= 0.0)), invalid, out)
    return np.clip(out, min_range, max_range)


def pool_sectors(ranges: np.ndarray, n_beams: int) -> np.ndarray:
    """The least range of each of ``n_beams`` sectors of an evenly spread scan of m x
    ``n_beams`` ranges, sector k centred on beam k (offsets -(m // 2) .. m - 1 - m // 2),
    as :func:`jaxnav.world.sensor.pooled_ranges`."""
    r = np.asarray(ranges, np.float64)
    m = r.shape[-1] // n_beams
    return np.roll(r, m // 2, axis=-1).reshape(*r.shape[:-1], n_beams, m).min(axis=-1)


def turned_changes(
    scan: np.ndarray, history: np.ndarray, turned: np.ndarray, gain: float
) -> np.ndarray:
    """f32[k, n]: each beam's change since each earlier scan of ``history`` f32[k, n],
    that scan seen from the heading the robot has turned to since it (``turned`` f[k]
    rad, counter-clockwise). The NumPy twin of
    :func:`jaxnav.world.sensor.turned_changes` (this file imports nothing of jaxnav):
    beam i now points where beam i + turned n / (2 pi) pointed; between the earlier
    scan's two beams there, c (the nearer) and d, it saw anything from c to
    c + 2 min(f, 1 - f) (d - c); the change is how far beam i lies outside that, times
    ``gain``, clipped to [-1, 1]."""
    n = history.shape[-1]
    at = np.arange(n, dtype=np.float32)[None, :] + np.asarray(turned, np.float32)[:, None] * (
        np.float32(n / (2 * math.pi))
    )
    below = np.floor(at)
    f = at - below
    i0 = below.astype(np.int64) % n
    a = np.take_along_axis(history, i0, axis=1)
    b = np.take_along_axis(history, (i0 + 1) % n, axis=1)
    near, far = np.where(f < 0.5, a, b), np.where(f < 0.5, b, a)
    reach = near + 2.0 * np.minimum(f, 1.0 - f) * (far - near)
    seen = np.clip(scan[None, :], np.minimum(near, reach), np.maximum(near, reach))
    return np.clip((scan[None, :] - seen) * gain, -1.0, 1.0).astype(np.float32)


def circular_conv(x: np.ndarray, kernel: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """f64[..., ceil(w / 2), F]: one circular convolution over the beams of x f[..., w, C]
    with ``kernel`` f[5, C, F] and ``bias`` f[F], ReLU after it: output o sums tap t's
    kernel times beam (2 o + t - 2) mod w. The NumPy twin of
    :class:`jaxnav.agent.networks.CircularConv`."""
    x = np.asarray(x, np.float64)
    width, taps = x.shape[-2], kernel.shape[0]
    out = -(-width // 2)
    idx = (2 * np.arange(out)[:, None] + np.arange(taps)[None, :] - taps // 2) % width
    patches = x[..., idx, :].reshape(x.shape[:-2] + (out, -1))  # [..., out, taps * C]
    k = np.asarray(kernel, np.float64).reshape(-1, kernel.shape[-1])
    return np.maximum(patches @ k + np.asarray(bias, np.float64), 0.0)


def scan_torso(obs: np.ndarray, convs, layout: Sequence[int]) -> np.ndarray:
    """f64[..., m]: normalised observations f[..., obs_size] through the scan
    convolutions ``convs`` ((kernel, bias) each): the scan and each of ``layout``'s
    (beams, gap, history) history blocks as channels, convolved, flattened, then the
    observation's other values in their order (as :class:`jaxnav.agent.networks.ScanTorso`)."""
    beams, gap, history = (int(v) for v in layout)
    x = np.asarray(obs, np.float64)
    start, end = beams + gap, beams + gap + history * beams
    blocks = [x[..., :beams]]
    blocks += [x[..., start + k * beams : start + (k + 1) * beams] for k in range(history)]
    y = np.stack(blocks, axis=-1)
    for kernel, bias in convs:
        y = circular_conv(y, kernel, bias)
    y = y.reshape(y.shape[:-2] + (-1,))
    return np.concatenate([y, x[..., beams:start], x[..., end:]], axis=-1)


def goal_heading_distance(pose: Sequence[float], goal: Sequence[float]) -> tuple[float, float]:
    """Heading to the goal relative to yaw, in [-pi, pi), and distance to it."""
    x, y, yaw = (float(v) for v in pose)
    gx, gy = (float(v) for v in goal)
    if not all(math.isfinite(v) for v in (x, y, yaw, gx, gy)):
        raise ValueError(f"pose {tuple(pose)} and goal {tuple(goal)} must be finite")
    heading = float(_wrap(math.atan2(gy - y, gx - x) - yaw))
    return heading, math.hypot(gx - x, gy - y)


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Yaw (rotation about z, counter-clockwise) of a unit quaternion, as odometry sends it."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
