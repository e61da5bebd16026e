"""Polygon geometry on the host (NumPy): what building and checking a maze needs.

Segments of a polygon, its area and centroid, segment intersection, point-in-polygon
and clearance of points from walls and obstacles. The compiled, per-step geometry
(rays and the swept disc) is :mod:`jaxnav.world.geometry`.
"""

from __future__ import annotations

import numpy as np


def polygon_segments(poly: np.ndarray) -> np.ndarray:
    """Closed polygon vertices (N, 2), without the repeated last point -> (N, 4)."""
    return np.concatenate([poly, np.roll(poly, -1, axis=0)], axis=1)


def signed_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def centroid(poly: np.ndarray) -> np.ndarray:
    x, y = poly[:, 0], poly[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    a = 0.5 * cross.sum()
    cx = ((x + np.roll(x, -1)) * cross).sum() / (6 * a)
    cy = ((y + np.roll(y, -1)) * cross).sum() / (6 * a)
    return np.array([cx, cy])


def segments_intersect(p1, p2, q1, q2, eps: float = 1e-12) -> bool:
    """Closed segments p1p2 and q1q2 share a point."""

    def orient(a, b, c):
        v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return 0 if abs(v) < eps else (1 if v > 0 else -1)

    def on_seg(a, b, c):
        return (
            min(a[0], b[0]) - eps <= c[0] <= max(a[0], b[0]) + eps
            and min(a[1], b[1]) - eps <= c[1] <= max(a[1], b[1]) + eps
        )

    o1, o2 = orient(p1, p2, q1), orient(p1, p2, q2)
    o3, o4 = orient(q1, q2, p1), orient(q1, q2, p2)
    if o1 != o2 and o3 != o4:
        return True
    return (
        (o1 == 0 and on_seg(p1, p2, q1))
        or (o2 == 0 and on_seg(p1, p2, q2))
        or (o3 == 0 and on_seg(q1, q2, p1))
        or (o4 == 0 and on_seg(q1, q2, p2))
    )


def self_intersecting(poly: np.ndarray) -> bool:
    n = len(poly)
    for i in range(n):
        a1, a2 = poly[i], poly[(i + 1) % n]
        for j in range(i + 1, n):
            if j == i or (j + 1) % n == i or (i + 1) % n == j:
                continue  # adjacent edges share a vertex
            if segments_intersect(a1, a2, poly[j], poly[(j + 1) % n]):
                return True
    return False


def point_segment_distance(p: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Distances from points p (N, 2) to segments seg (S, 4) -> (N, S)."""
    p = np.asarray(p, np.float64)[:, None, :]
    a = seg[None, :, :2].astype(np.float64)
    b = seg[None, :, 2:].astype(np.float64)
    ab = b - a
    denom = np.maximum((ab**2).sum(-1), 1e-18)
    t = np.clip(((p - a) * ab).sum(-1) / denom, 0.0, 1.0)
    closest = a + t[..., None] * ab
    return np.linalg.norm(p - closest, axis=-1)


def points_in_polygon(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule: which of the points p (N, 2) lie inside polygon (M, 2)."""
    x, y = p[:, 0:1], p[:, 1:2]
    x1, y1 = poly[None, :, 0], poly[None, :, 1]
    x2, y2 = np.roll(poly[:, 0], -1)[None], np.roll(poly[:, 1], -1)[None]
    crosses = (y1 > y) != (y2 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xint = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
    return (crosses & (x < xint)).sum(axis=1) % 2 == 1


def clearance(
    points: np.ndarray,
    segments: np.ndarray,
    circles: np.ndarray,
) -> np.ndarray:
    """Distance from each point (N, 2) to the nearest wall or obstacle surface."""
    d = np.full(len(points), np.inf)
    if len(segments):
        d = np.minimum(d, point_segment_distance(points, segments).min(axis=1))
    if len(circles):
        dc = np.linalg.norm(points[:, None, :] - circles[None, :, :2], axis=-1)
        d = np.minimum(d, (dc - circles[None, :, 2]).min(axis=1))
    return d
