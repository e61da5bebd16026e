"""A run cut after its first chunk, as a kill just after a checkpoint leaves it: its
directory and config written, one chunk trained, the checkpoint saved as the host loop
saves it. Shared by the tests that resume such a run and compare it with one that was
never cut."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxnav.core import rundir
from jaxnav.core.config import Config, dump_config
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
