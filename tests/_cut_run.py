"""A run cut after its first chunk, as a kill just after a checkpoint leaves it: its
directory and config written, one chunk trained, the checkpoint saved as the host loop
saves it. Shared by the tests that resume such a run and compare it with one that was
never cut (:func:`restores_and_resumes`)."""

from __future__ import annotations

from pathlib import Path

import jax
import numpy as np

from jaxnav.core import rundir
from jaxnav.core.config import Config, dump_config
from jaxnav.run import launch
from jaxnav.run.checkpoint import chunk_slots
from jaxnav.run.training import Run


def cut_after_one_chunk(cfg: Config, out: Path):
    """(the Run, its state after the chunk) of ``cfg`` in the new directory ``out``."""
    run = Run(cfg, out, quiet=True)
    rundir.create(out)
    rundir.atomic_write_text(out / rundir.CONFIG, dump_config(cfg))
    ts = run.fresh_state()
    before = run.shard.get(ts.step).copy()
    ts, log = run.chunk(ts, np.int32(run.steps_needed(ts)))
    log = run.shard.get(log)
    rows = np.zeros(0, int)  # PQN keeps no replay
    if cfg.agent == "dqn":
        rows = chunk_slots(before, run.shard.get(ts.step), cfg.buffer_capacity)
    explore = run.explore_blocks(log.explore, before, ~run.active(ts))
    run.save(ts, run.new_episodes(ts), explore, rows)
    return run, ts


def restores_and_resumes(cfg: Config, out: Path, ts, part: str, reference: Path) -> None:
    """Assert that the run cut in ``out`` (its state ``ts`` after the chunk) restores the
    state's field ``part`` exactly from its checkpoint, and, resumed, ends as the
    uninterrupted run in ``reference``: metrics and parameters byte for byte."""
    again = Run(cfg, out, quiet=True).restored_state()
    pairs = zip(
        jax.tree.leaves(getattr(ts, part)), jax.tree.leaves(getattr(again, part)), strict=True
    )
    for x, y in pairs:
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    launch.resume(out, quiet=True)
    for name in (rundir.METRICS, rundir.PARAMS):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
