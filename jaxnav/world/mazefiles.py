"""A maze written as a maze file, the YAML format :mod:`jaxnav.world.maps` reads.

A drawn maze is wall segments, not polygons: its outline is the bounding box of its
walls, written through every end of the segments that lie on the box's sides (so
loading it gives back those very segments), and every other segment is a free wall.
Numbers are written at Python's ``repr`` precision, so each float32 coordinate is
read back exactly.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def number(x: float) -> str:
    """A float as YAML reads back exactly (``repr``, with a dot before any exponent:
    PyYAML reads ``1e-05`` as a string)."""
    text = repr(float(x))
    if "e" in text and "." not in text:
        text = text.replace("e", ".0e")
    return text


def _flow(values: Sequence[float]) -> str:
    return "[" + ", ".join(number(v) for v in values) + "]"


def canonical_segments(segments: np.ndarray) -> np.ndarray:
    """The segments f[N, 4] as a set: each from its smaller end, rows sorted (to
    compare two mazes' walls whatever their order and direction)."""
    seg = np.asarray(segments, np.float64).reshape(-1, 4)
    a, b = seg[:, :2], seg[:, 2:]
    swap = (a[:, 0] > b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] > b[:, 1]))
    seg = np.where(swap[:, None], np.concatenate([b, a], 1), seg)
    return seg[np.lexsort(seg.T[::-1])]


def outline_and_walls(segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(outline f[V, 2] counter-clockwise, not closed; free walls f[W, 4]) of a maze
    enclosed by its bounding box. ValueError if the segments on the box's sides do
    not tile its whole boundary, end to end."""
    seg = np.asarray(segments, np.float64).reshape(-1, 4)
    (x0, y0), (x1, y1) = seg.reshape(-1, 2).min(0), seg.reshape(-1, 2).max(0)
    xs, ys = seg[:, [0, 2]], seg[:, [1, 3]]
    on_side = ((ys == y0).all(1) | (ys == y1).all(1) | (xs == x0).all(1) | (xs == x1).all(1)) & (
        (xs[:, 0] != xs[:, 1]) | (ys[:, 0] != ys[:, 1])
    )
    ends = np.concatenate([seg[on_side, :2], seg[on_side, 2:], [[x0, y0], [x1, y0]]])
    ends = np.concatenate([ends, [[x1, y1], [x0, y1]]])
    ends = np.unique(ends, axis=0)
    # Counter-clockwise from (x0, y0): the bottom side, the right, the top, the left.
    sides = [
        (ends[:, 1] == y0) & (ends[:, 0] < x1),
        (ends[:, 0] == x1) & (ends[:, 1] < y1),
        (ends[:, 1] == y1) & (ends[:, 0] > x0),
        (ends[:, 0] == x0) & (ends[:, 1] > y0),
    ]
    keys = [ends[:, 0], ends[:, 1], -ends[:, 0], -ends[:, 1]]
    outline = np.concatenate([ends[s][np.argsort(k[s])] for s, k in zip(sides, keys)])
    ring = np.concatenate([outline, np.roll(outline, -1, axis=0)], axis=1)
    if not np.array_equal(canonical_segments(ring), canonical_segments(seg[on_side])):
        raise ValueError("its walls do not close its bounding box end to end")
    return outline, seg[~on_side]


def maze_text(
    segments: np.ndarray,
    circles: np.ndarray,
    start: Sequence[float],
    goal: Sequence[float] | None = None,
    shortest_path_m: float | None = None,
    name: str | None = None,
) -> str:
    """A maze file's text: the real wall segments f[S, 4] (closing their bounding
    box), circles f[C, 3], the start pose (x, y, yaw), a goal and its path's length."""
    outline, walls = outline_and_walls(segments)
    lines = [f"name: {name}"] if name else []
    lines.append("outline:")
    lines += [f"  - {_flow(p)}" for p in (*outline, outline[0])]
    if len(walls):
        lines.append("walls:")
        lines += [f"  - {_flow(w)}" for w in walls]
    circles = np.asarray(circles, np.float64).reshape(-1, 3)
    if len(circles):
        lines.append("obstacles:")
        lines += [f"  - circle: {_flow(c)}" for c in circles]
    lines.append(f"start: {_flow(start)}")
    if goal is not None:
        lines.append(f"goal: {_flow(goal)}")
    if shortest_path_m is not None:
        lines.append(f"shortest_path_m: {number(shortest_path_m)}")
    return "\n".join(lines) + "\n"
