"""The host loop cuts its chunks by time and checkpoints by time, and neither changes a
number: where the chunks end (the host's pace) changes no row of metrics.csv,
explore.csv or eval.csv and no parameter; a checkpoint comes every
``run.checkpoint_s`` of training whatever the budget, and leaves out the ring of
finished episodes, which the host has already copied into metrics.csv."""

from __future__ import annotations

import csv
import itertools

import numpy as np
import pytest

from jaxnav.core import rundir
from jaxnav.core.config import load_config
from jaxnav.run.launch import train_new
from jaxnav.run.training import Run

DQN = [
    "seeds=2",
    "episodes=null",
    "total_steps=1000",
    "env.max_steps=60",
    "run.chunk_steps=400",
    "dqn.batch_size=16",
    "run.eval_every=300",
    "run.eval_episodes=2",
]
PQN = [
    "agent=pqn",
    "seeds=2",
    "episodes=null",
    "total_steps=3200",
    "env.max_steps=50",
    "pqn.num_envs=4",
    "pqn.rollout=8",
    "pqn.minibatches=2",
    "run.chunk_steps=1600",
    "dqn.optimizer=radam",
    "dqn.lr=0.001",
    "run.eval_every=500",
    "run.eval_episodes=2",
]


def _rows(path):
    with open(path) as f:
        return [{k: v for k, v in r.items() if k != "wall_s"} for r in csv.DictReader(f)]


def _files(out):
    with np.load(out / rundir.PARAMS) as d:
        params = {k: d[k] for k in d.files}
    logs = {name: (out / name).read_bytes() for name in (rundir.METRICS, rundir.EXPLORE)}
    return params, logs, _rows(out / rundir.EVAL)


def _train(monkeypatch, out, items, sizes=None):
    """A run whose chunks the host cuts at its longest (``sizes`` None) or, cycling
    through ``sizes``, at that many of the trainer's steps each."""
    if sizes is None:
        items = [*items, "run.chunk_s=0"]
    else:
        cycle = itertools.cycle(sizes)

        def timed_steps(self, step):
            length = self.trainer.chunk_length
            to_end = (step // length + 1) * length - step
            return min(to_end, next(cycle) * self.grain)

        monkeypatch.setattr(Run, "timed_steps", timed_steps)
    train_new(load_config(None, items), out, quiet=True)
    monkeypatch.undo()
    return _files(out)


@pytest.mark.slow  # 16 s on 2 cores
@pytest.mark.parametrize(
    "items, sizes",
    [(DQN, (1, 37, 250, 3, 99)), (PQN, (1, 5, 2, 13))],
    ids=["dqn", "pqn"],
)
def test_where_the_chunks_end_changes_no_log_row_and_no_parameter(
    items, sizes, tmp_path, monkeypatch
):
    long_params, long_logs, long_evals = _train(monkeypatch, tmp_path / "long", items)
    params, logs, evals = _train(monkeypatch, tmp_path / "cut", items, sizes)
    assert logs == long_logs  # byte for byte: the rows grouped by run, blocks whole
    assert evals == long_evals  # evaluated at the same steps, the same results
    assert params.keys() == long_params.keys()
    assert all(np.array_equal(params[k], long_params[k]) for k in params)
    assert len(evals) > 2 * 2  # more than the final evaluation of each run


@pytest.mark.slow  # 6 s on 2 cores
def test_checkpoints_come_every_checkpoint_s_and_at_the_end(tmp_path, monkeypatch):
    items = [*DQN, "run.eval_every=0"]
    monkeypatch.setattr(Run, "timed_steps", lambda self, step: 100)  # chunks of 100 steps
    counts = {}
    for every in (0.0, 1e9):
        out = tmp_path / f"every{every:g}"
        cfg = load_config(None, [*items, f"run.checkpoint_s={every}"])
        run = Run(cfg, out, quiet=True, keep_checkpoints=True)
        rundir.create(out)
        run.finish(run.train(run.fresh_state()))
        counts[every] = len(list((out / "checkpoints").glob("rows-*.npz")))
    # 1,000 steps in chunks of 100: a checkpoint after each, or only the last one
    assert counts == {0.0: 10, 1e9: 1}


@pytest.mark.slow  # 7 s on 2 cores
def test_a_checkpoint_leaves_out_the_ring_of_finished_episodes(tmp_path):
    cfg = load_config("drive_square4", ["seeds=2", "total_steps=1024", "run.checkpoint_s=0"])
    out = tmp_path / "run"
    run = Run(cfg, out, quiet=True, keep_checkpoints=True)
    rundir.create(out)
    run.finish(run.train(run.fresh_state()))
    with np.load(out / rundir.CHECKPOINT) as d:
        names = d.files
        size = sum(d[k].nbytes for k in names)
    assert not [n for n in names if n.startswith("state.metrics.ep_")]
    assert any(n.startswith("state.metrics.cur_") for n in names)  # the episodes under way
    ring = run.trainer.metric_slots * cfg.n_runs * 4  # one field of the ring, 4 bytes a slot
    assert size < ring


def test_explore_rows_are_the_same_wherever_a_window_is_cut():
    """explore.csv's blocks of one run, from one chunk of 700 steps and from the same
    steps cut into chunks of random sizes: the same rows (a block a chunk ends inside
    carried to the next one), blocks counted from each 350-step window's start."""
    from jaxnav.run.logs import NONE_PENDING, explore_rows

    rng = np.random.default_rng(0)
    values = rng.random(700).astype(np.float32)
    whole, left = explore_rows(values, 0, 350, NONE_PENDING, True, ("ebe", 0))
    assert left == NONE_PENDING
    assert [r[2] for r in whole] == [0, 100, 200, 300, 350, 450, 550, 650]
    assert whole[3][3] == f"{float(values[300:350].mean()):.6g}"  # a window's short block
    for _ in range(5):
        cuts = np.sort(rng.choice(np.arange(1, 700), size=6, replace=False))
        rows, pending, start = [], NONE_PENDING, 0
        for end in [*cuts, 700]:
            col = np.full(700, np.nan, np.float32)  # a chunk's log, NaN past its steps
            col[: end - start] = values[start:end]
            got, pending = explore_rows(col, start, 350, pending, end == 700, ("ebe", 0))
            rows += got
            start = end
        assert rows == whole, cuts
