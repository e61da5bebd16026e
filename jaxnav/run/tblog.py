"""Training curves for TensorBoard while a run trains (``run.tensorboard: true``).

Two TensorBoard runs in ``RUN_DIR/tensorboard/``:

* ``episodes``: per strategy, the mean over seeds of each episode's return, goals,
  length, collision (the share of seeds whose episode ended in one) and mean
  exploration, at step = episode index, written once every seed has finished that
  episode (from the same rows as metrics.csv);
* ``steps``: per strategy, the mean over seeds and 100 env steps of the TD loss and
  of max_a Q(s, a) at the acting state, at step = env step (runs step in lockstep);
* ``eval``, with ``run.eval_every``: per strategy, the mean over seeds of each greedy
  evaluation's return, goals and success rate per goal attempt (the rows of
  eval.csv), at step = env step.

Written by tensorboardX (a small writer without TensorFlow; optional extra
``tensorboard``). A resumed run purges what was written after its checkpoint, so
the curves match the files. No JAX here.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from jaxnav.core.errors import ConfigError
from jaxnav.core.sweep import row_arm

DIR = "tensorboard"
BLOCK = 100  # env steps per point of the step curves
EPISODE_CURVES = ("return", "length", "goals", "collided", "explore")  # metrics.csv columns
EVAL_CURVES = ("return", "goals", "success")  # eval.csv columns


def check_available() -> None:
    """ConfigError unless tensorboardX can be imported (before a run directory is made)."""
    if importlib.util.find_spec("tensorboardX") is None:
        raise ConfigError(
            "config: run.tensorboard needs tensorboardX (pip install -e '.[tensorboard]')"
        )


def _writer(path: Path, purge_step: int | None):
    from tensorboardX import SummaryWriter

    return SummaryWriter(str(path), purge_step=purge_step, flush_secs=10)


def tag(arm: str) -> str:
    """An arm's name in TensorBoard's tag alphabet: ``ebe`` or, at a sweep point,
    ``ebe/ebe_temperature_0.1`` (a group per strategy)."""
    return arm.replace(" ", "/").replace("=", "_")


class TensorBoardLog:
    """Per-strategy curves, aggregated over seeds, into ``run_dir/tensorboard``.

    Args:
      labels: (arm, seed) of each run, the run axis's order; an arm is a strategy, or
        a strategy at a sweep point (curves are tagged and averaged per arm).
      columns: the names of a metrics row's fields (metrics.csv's header).
      resumed: training goes on from a checkpoint at env step ``first_step``: what was
        written before is purged, the episode curves from episode 0 (the caller adds
        metrics.csv's rows again), the step curves from ``first_step``, the evaluations
        after it (the checkpoint's chunk wrote the one at ``first_step``).
      eval_columns: eval.csv's header, when the run evaluates its policies (None: not).
    """

    def __init__(
        self,
        run_dir: Path,
        labels: Sequence[tuple[str, int]],
        columns: Sequence[str],
        resumed: bool = False,
        first_step: int = 0,
        eval_columns: Sequence[str] | None = None,
    ):
        self.labels = list(labels)
        self.columns = list(columns)
        self.column = {name: list(columns).index(name) for name in ("strategy", "episode")}
        self.column.update({name: list(columns).index(name) for name in EPISODE_CURVES})
        self.seeds: dict[str, int] = {}
        for strategy, _ in self.labels:
            self.seeds[strategy] = self.seeds.get(strategy, 0) + 1
        self.pending: dict[tuple[str, int], list[tuple]] = {}
        self.episodes = _writer(run_dir / DIR / "episodes", 0 if resumed else None)
        self.steps = _writer(run_dir / DIR / "steps", first_step if resumed else None)
        self.eval_columns = None if eval_columns is None else list(eval_columns)
        self.evals = None
        if eval_columns is not None:
            self.evals = _writer(run_dir / DIR / "eval", first_step + 1 if resumed else None)

    def add_episodes(self, rows: Sequence[tuple]) -> None:
        """metrics.csv rows of a chunk (fields in ``columns`` order); an episode's means
        are written once every seed has it."""
        c = self.column
        for row in rows:
            key = (row_arm(dict(zip(self.columns, row))), int(row[c["episode"]]))
            got = self.pending.setdefault(key, [])
            got.append(row)
            if len(got) == self.seeds[key[0]]:
                for name in EPISODE_CURVES:
                    mean = float(np.mean([float(r[c[name]]) for r in got]))
                    self.episodes.add_scalar(f"{tag(key[0])}/{name}", mean, key[1])
                del self.pending[key]

    def add_steps(self, loss: np.ndarray, max_q: np.ndarray, first_step: int) -> None:
        """A chunk's f32[runs, chunk_steps] TD losses and max Q-values (NaN where none),
        its first column at env step ``first_step``: means over seeds and blocks."""
        for strategy in self.seeds:
            rows = [r for r, (s, _) in enumerate(self.labels) if s == strategy]
            for name, values in (("loss", loss), ("max_q", max_q)):
                for b in range(0, values.shape[1], BLOCK):
                    block = values[rows, b : b + BLOCK]
                    if np.isfinite(block).any():
                        mean = float(np.nanmean(block))
                        self.steps.add_scalar(f"{tag(strategy)}/{name}", mean, first_step + b)

    def add_evals(self, rows: Sequence[tuple]) -> None:
        """One evaluation's eval.csv rows (fields in ``eval_columns`` order): per arm, the
        means over seeds at the env step of its runs still training (the largest)."""
        by_arm: dict[str, list[dict]] = {}
        for row in rows:
            named = dict(zip(self.eval_columns, row))
            by_arm.setdefault(row_arm(named), []).append(named)
        for arm, got in by_arm.items():
            step = max(int(r["env_step"]) for r in got)
            for name in EVAL_CURVES:
                mean = float(np.mean([float(r[name]) for r in got]))
                self.evals.add_scalar(f"{tag(arm)}/{name}", mean, step)

    def _writers(self) -> list:
        return [w for w in (self.episodes, self.steps, self.evals) if w is not None]

    def flush(self) -> None:
        for w in self._writers():
            w.flush()

    def close(self) -> None:
        for w in self._writers():
            w.close()
