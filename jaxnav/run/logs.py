"""What the host loop makes of a chunk's logs: the rows of explore.csv (the mean
exploration per block of env steps, a block a chunk ended inside carried to the next
chunk) and the new slots of the ring of finished episodes (the rows of metrics.csv).

Pure functions of arrays; :class:`jaxnav.run.training.Run` keeps their state.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

EXPLORE_BLOCK = 100  # env steps averaged per row of explore.csv
# A block of explore.csv a chunk ended inside: (its first env step, its values so far).
Pending = tuple[int, np.ndarray]
NONE_PENDING: Pending = (0, np.zeros(0, np.float32))


def explore_rows(
    col: np.ndarray,
    step_before: int,
    length: int,
    pending: Pending,
    finished: bool,
    fields: tuple,
) -> tuple[list[tuple], Pending]:
    """One run's explore.csv rows from a chunk's log ``col`` (f32[chunk steps], NaN once
    the run has finished) that starts at env step ``step_before``: the mean of each block
    of :data:`EXPLORE_BLOCK` steps, counted from the start of each ``length``-step window
    (the trainer's chunk length; a window's last block as long as what is left of it),
    each row ``(*fields, first step, mean)``. ``pending`` is the block the last chunk
    ended inside; the block this chunk ends inside is returned as the next one, unless
    the run has ``finished``. So the rows are the same wherever the chunks end."""
    real = np.flatnonzero(~np.isnan(col))
    values = col[real]
    steps = step_before + real
    base = steps // length * length
    starts = base + (steps - base) // EXPLORE_BLOCK * EXPLORE_BLOCK
    cut = np.flatnonzero(np.diff(starts)) + 1
    firsts = starts[np.concatenate([[0], cut]).astype(np.int64)] if len(starts) else starts
    blocks = [(int(b), v) for b, v in zip(firsts, np.split(values, cut)) if len(v)]
    start, kept = pending
    if len(kept):
        if blocks and blocks[0][0] == start:
            blocks[0] = (start, np.concatenate([kept, blocks[0][1]]))
        else:
            blocks.insert(0, (start, kept))
    left = NONE_PENDING
    if blocks and not finished:
        b = blocks[-1][0]
        end = min(b + EXPLORE_BLOCK, b // length * length + length)
        if step_before + len(real) < end:  # the block goes on in the next chunk
            left = blocks.pop()
    rows = [(*fields, b, f"{float(np.asarray(v, col.dtype).mean()):.6g}") for b, v in blocks]
    return rows, left


def pending_arrays(pending: list[Pending]) -> dict[str, np.ndarray]:
    """The explore.csv blocks chunks ended inside, as a checkpoint keeps them."""
    values = np.full((len(pending), EXPLORE_BLOCK), np.nan, np.float32)
    for r, (_, v) in enumerate(pending):
        values[r, : len(v)] = v
    return {
        "explore_pending_start": np.asarray([b for b, _ in pending], np.int64),
        "explore_pending_count": np.asarray([len(v) for _, v in pending], np.int64),
        "explore_pending": values,
    }


def restored_pending(host: dict[str, np.ndarray], n_runs: int) -> list[Pending]:
    """:func:`pending_arrays` read back from a checkpoint's host arrays (none pending
    where a checkpoint was written before blocks were carried: every chunk then ended
    on a block's end)."""
    if "explore_pending" not in host:
        return [NONE_PENDING] * n_runs
    starts, counts, values = (host[f"explore_pending{k}"] for k in ("_start", "_count", ""))
    return [
        (int(b), values[r, :n].astype(np.float32)) for r, (b, n) in enumerate(zip(starts, counts))
    ]


def ring_at(metrics: Any, at: jax.Array) -> dict[str, jax.Array]:
    """The ring of finished episodes (the trainer's ``metrics``, every run) at slots
    ``at`` (i32[runs, k]): each ``ep_*`` field f[runs, k]."""
    ring = {
        f.name: getattr(metrics, f.name)
        for f in dataclasses.fields(metrics)
        if f.name.startswith("ep_") and getattr(metrics, f.name) is not None
    }
    return {k: jnp.take_along_axis(v, at, axis=1) for k, v in ring.items()}


__all__ = [
    "EXPLORE_BLOCK",
    "NONE_PENDING",
    "explore_rows",
    "pending_arrays",
    "restored_pending",
    "ring_at",
]
