"""The host loop around the compiled trainer: chunks, progress, logs, checkpoints.

All seeds of all strategies run as one vmapped program (the trainer of the config's
``agent``, :mod:`jaxnav.core.agents`: :func:`jaxnav.dqn.make_trainer` or
:func:`jaxnav.pqn.make_trainer`), ``run.chunk_steps`` environment steps per call. After
each chunk the host appends the new episodes to ``metrics.csv`` and ``explore.csv``
(and ``run.eval_every``'s evaluations to ``eval.csv``, :mod:`jaxnav.run.greedy`) and
writes a checkpoint that records the training state and how long the logs were, so a
run killed at any moment (even by SIGKILL) resumes from its last chunk (:func:`resume`)
and ends with exactly the metrics and parameters of an uninterrupted run. The files and their
checks are :mod:`jaxnav.core.rundir`'s.

A finished run removes its checkpoints (unless asked to keep them): nothing reads
them once ``params.npz`` and ``summary.json`` are written. Ctrl-C
(:mod:`jaxnav.core.startup`) never cuts a write of the logs, a checkpoint or the
final files in two; it leaves the run resumable from its last checkpoint, or, before
the first one, removes what the command made (:func:`interrupted_text` says which).
"""

from __future__ import annotations

import functools
import json
import os
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
import numpy as np

from jaxnav.agent import replay
from jaxnav.agent.sharding import RunSharding, is_writer
from jaxnav.agent.trainer import Trainer, run_inputs, run_limits, still_training
from jaxnav.core import agents, rundir, startup, sweep
from jaxnav.core.config import Config
from jaxnav.core.errors import RunError
from jaxnav.core.startup import process_age
from jaxnav.report.navigation import last_episodes, training_outcomes
from jaxnav.run import tblog
from jaxnav.run.checkpoint import (
    ROW_SEGMENT,
    checkpoint_arrays,
    chunk_slots,
    params_arrays,
    rows_at,
    start_params,
    state_from_checkpoint,
    warm_started,
    without_rows,
)
from jaxnav.run.greedy import GreedyEval
from jaxnav.run.logs import (
    EXPLORE_BLOCK,
    NONE_PENDING,
    Pending,
    explore_rows,
    pending_arrays,
    restored_pending,
    ring_at,
)

# A swept run's logs have one more column per swept key, named by it, after "strategy"
# (jaxnav.core.sweep.with_swept).
METRIC_COLUMNS = ("strategy", "seed", "episode", "return", "length", "goals", "collided", "explore")
# With an attempt limit (env.attempt_limit), how each episode's goal attempts ended
# (jaxnav.report.navigation); without one they follow from goals, collided and length.
ATTEMPT_COLUMNS = ("successes", "collisions", "timeouts", "cut")
EXPLORE_COLUMNS = ("strategy", "seed", "step", "explore")

PROGRESS_EPISODES = 20  # episodes per seed in the progress bar's mean return

# ----------------------------------------------------------------------------
# The run
# ----------------------------------------------------------------------------


class Run:
    """Host loop around the compiled chunk: progress, metrics, checkpoints."""

    def __init__(
        self, cfg: Config, out: Path | None, quiet: bool = False, keep_checkpoints: bool = False
    ):
        """``out`` None: a run that only computes (tests, benchmarks), no files.
        ``keep_checkpoints``: a finished run keeps its checkpoints (they go otherwise)."""
        self.cfg, self.out, self.quiet = cfg, out, quiet
        self.keep_checkpoints = keep_checkpoints
        if cfg.run.tensorboard:
            tblog.check_available()
        self.trainer = trainer_of(cfg)
        self.labels = cfg.run_labels()  # (arm name, seed)
        self.fields = cfg.run_fields()  # the logs' leading fields of each run
        # The run axis of every array is laid over all devices.
        self.shard = RunSharding(cfg.n_runs)
        sharding = self.shard.sharding
        self.init = jax.jit(jax.vmap(self.trainer.init), out_shardings=sharding)
        self.counts_attempts = bool(cfg.env.attempt_limit)
        columns = METRIC_COLUMNS + (ATTEMPT_COLUMNS if self.counts_attempts else ())
        self.metric_columns = sweep.with_swept(columns, cfg.sweep)
        self.chunk = jax.jit(
            self.shard.per_device(jax.vmap(self.trainer.chunk, in_axes=(0, None)), 2),
            donate_argnums=0,
            out_shardings=sharding,
        )
        self.rows_at = jax.jit(rows_at)
        self.segments = 0  # row segments the last checkpoint covers
        out = Path(".") if out is None else out
        self.metrics = rundir.CsvLog(out / rundir.METRICS, self.metric_columns)
        self.explore = rundir.CsvLog(
            out / rundir.EXPLORE, sweep.with_swept(EXPLORE_COLUMNS, cfg.sweep)
        )
        self.checkpoint = out / rundir.CHECKPOINT
        on = cfg.run.eval_every > 0  # the greedy evaluations while training (eval.csv)
        self.greedy = GreedyEval(cfg, self.trainer, self.shard, out, EXPLORE_BLOCK) if on else None
        self.logged = np.zeros(cfg.n_runs, np.int64)  # episodes written per run
        # per run, its episodes' (return, successful attempts, decided attempts)
        self.recent: dict[tuple[str, int], list[tuple[float, int, int]]] = {
            label: [] for label in self.labels
        }
        self.max_steps = cfg.env.max_steps
        self.wall = 0.0  # training seconds over all sessions of this run
        # run-steps the compiled chunks computed over all sessions: every run of the
        # batch takes each chunk's steps, finished runs as no-ops (lockstep)
        self.computed = 0
        self.compile_s = self.startup_s = None  # this session's, see compile_chunk
        self.diverged: dict[int, int] = {}  # run index -> env step it diverged at
        # called once the final files are written, inside the block a Ctrl-C waits for
        # (jaxnav.run.launch says so in the interrupted line)
        self.on_finished: Callable[[], None] = lambda: None
        # Chunks are cut by time (run.chunk_s), after whole steps of the trainer, at least
        # a block of the logs' each (a one-step chunk would cost more than it trains);
        # the logs and evaluations are those of any other cut (explore_blocks, GreedyEval).
        size = self.trainer.step_size
        self.grain = -(-EXPLORE_BLOCK // size) * size
        self.rate: float | None = None  # lockstep env steps per second, last chunk
        # per run, the explore.csv block a chunk ended inside (jaxnav.run.logs.Pending)
        self.pending: list[Pending] = [NONE_PENDING] * cfg.n_runs
        self.ring_at = jax.jit(ring_at)

    # -- state ---------------------------------------------------------------

    def state_shapes(self) -> Any:
        """The shapes and dtypes of the trainer state of every run (nothing computed)."""
        return jax.eval_shape(jax.vmap(self.trainer.init), *run_inputs(self.cfg))

    @functools.cached_property
    def start_params(self) -> Any:
        """run.init_from's params of every run (None without it), read once: a new run
        reads it before it writes anything, a resumed one only if it starts over."""
        if not self.cfg.run.init_from:
            return None
        return start_params(self.cfg, self.state_shapes().params)

    def fresh_state(self) -> Any:
        ts = self.init(*self.shard.put(tuple(run_inputs(self.cfg))))
        if self.start_params is not None:
            ts = warm_started(ts, self.shard.put(self.start_params))
        return ts

    def drawn_bank(self) -> Any:
        """Every run's bank of layouts as its start draws it (host copies): what a
        checkpoint that left the bank out restores (jaxnav.run.checkpoint)."""
        bank = jax.jit(jax.vmap(lambda *a: self.trainer.init(*a).bank))
        return self.shard.get(bank(*self.shard.put(tuple(run_inputs(self.cfg)))))

    def restored_state(self) -> Any:
        """The last checkpoint's state, the logs cut back to what it covers."""
        cfg = self.cfg
        template = self.state_shapes()
        template = jax.tree.map(lambda s: np.zeros((cfg.n_runs, *s.shape[1:]), s.dtype), template)
        arrays = rundir.read_npz(self.checkpoint, f"checkpoint {self.checkpoint}")
        host = {k[5:]: v for k, v in arrays.items() if k.startswith("host.")}
        if not {"logged", "wall", "csv_sizes", "segments"} <= set(host):
            raise RunError(f"checkpoint {self.checkpoint} was written by another jaxnav version")
        self.segments = int(host["segments"])
        segments = [
            rundir.read_npz(self.out / ROW_SEGMENT.format(k), f"checkpoint segment {k}")
            for k in range(self.segments)
        ]
        ts, host = state_from_checkpoint(
            arrays, segments, template, self.checkpoint, bank=self.drawn_bank
        )
        diverged_at = np.asarray(ts.diverged_at)
        self.diverged = {int(r): int(diverged_at[r]) for r in np.flatnonzero(diverged_at >= 0)}
        self.logged = host["logged"].astype(np.int64)
        self.wall = float(host["wall"])
        self.pending = restored_pending(host, cfg.n_runs)
        # -1: unknown (a checkpoint of an earlier version did not count)
        self.computed = int(host.get("computed", -1))
        metrics_size, explore_size = (int(x) for x in host["csv_sizes"])
        if is_writer():
            self.metrics.truncate(metrics_size)
            self.explore.truncate(explore_size)
        if self.greedy is not None:
            eval_size = int(host.get("eval_size", 0)) if is_writer() else None
            self.greedy.restore(int(np.asarray(ts.step).max()), eval_size)
            if self.greedy.best is not None:
                self.greedy.best.restore(host, ts.params)
        for row in self.metrics.read():
            self._remember((sweep.row_arm(row), int(row["seed"])), row)
        return self.shard.put(ts)

    def active(self, ts: Any) -> np.ndarray:
        """Which real runs still train (host side, the trainer's own rule)."""
        episode, step, diverged_at = self.shard.get((ts.episode, ts.step, ts.diverged_at))
        running = still_training(episode, step, *run_limits(self.cfg))
        return np.asarray(running & (diverged_at < 0))

    def steps_needed(self, ts: Any) -> int:
        """The most env steps any active run can still take, at most a chunk: a run
        stops within its step limit and within max_steps per episode left; whole
        steps of the trainer (PQN: whole updates)."""
        cfg, trainer = self.cfg, self.trainer
        episode, step = (np.asarray(a, np.int64) for a in self.shard.get((ts.episode, ts.step)))
        episodes, steps = run_limits(cfg)
        left = np.minimum(steps - step, (episodes - episode) * cfg.env.max_steps)
        active = self.active(ts)
        if not active.any():
            return 0
        size = trainer.step_size
        n = int(min(trainer.chunk_length, -(-left[active].max() // size) * size))
        now = int(step.max())
        n = n if self.greedy is None else self.greedy.chunk_end(now, n)
        return min(n, self.timed_steps(now))

    def timed_steps(self, step: int) -> int:
        """The env steps a chunk from lockstep ``step`` takes to last about ``run.chunk_s``
        at the last chunk's pace (one trainer step for the first): whole steps of the
        trainer, never past the end of the ``chunk_length`` window the chunk lies in."""
        length, aim = self.trainer.chunk_length, self.cfg.run.chunk_s
        to_end = (step // length + 1) * length - step
        if not aim:  # every chunk as long as compiled
            return to_end
        if self.rate is None:
            return min(to_end, self.grain)
        grains = max(1, int(self.rate * aim) // self.grain)
        return min(to_end, grains * self.grain)

    def check_divergence(self, ts: Any) -> list[str]:
        """Runs that diverged in the last chunk, each described in words."""
        diverged_at = self.shard.get(ts.diverged_at)
        new = []
        for r in np.flatnonzero(diverged_at >= 0):
            if int(r) not in self.diverged:
                self.diverged[int(r)] = int(diverged_at[r])
                strategy, seed = self.labels[r]
                new.append(f"{strategy} seed {seed} diverged at step {int(diverged_at[r])}")
        return new

    def diverged_runs(self) -> list[dict[str, Any]]:
        return [
            {"strategy": self.labels[r][0], "seed": self.labels[r][1], "step": step}
            for r, step in sorted(self.diverged.items())
        ]

    # -- per chunk -----------------------------------------------------------

    def new_episodes(self, ts: Any) -> list[tuple]:
        """metrics.csv rows of the episodes finished in the last chunk (only their
        slots of the ring are copied to the host)."""
        episodes = self.shard.get(ts.episode)
        slots = self.trainer.metric_slots
        new = int((episodes - self.logged).max(initial=0))
        if new == 0:
            return []
        width = 1 << (new - 1).bit_length()  # few program shapes: powers of two
        at = (self.logged[:, None] + np.arange(width)[None, :]) % slots
        m = self.shard.get(self.ring_at(ts.metrics, self.shard.put(at.astype(np.int32))))
        rows = []
        for r, label in enumerate(self.labels):
            for e in range(self.logged[r], episodes[r]):
                i = e - self.logged[r]
                ret = float(m["ep_return"][r, i])
                row = (
                    *self.fields[r],
                    e,
                    f"{ret:.6g}",
                    int(m["ep_length"][r, i]),
                    int(m["ep_goals"][r, i]),
                    int(m["ep_collided"][r, i]),
                    f"{float(m['ep_explore'][r, i]):.6g}",
                )
                if self.counts_attempts:
                    row += tuple(int(m[f"ep_{c}"][r, i]) for c in ATTEMPT_COLUMNS)
                rows.append(row)
                self._remember(label, dict(zip(self.metric_columns, map(str, row))))
            self.logged[r] = episodes[r]
        return rows

    def explore_blocks(
        self, explore: np.ndarray, step_before: np.ndarray, finished: np.ndarray
    ) -> list[tuple]:
        """explore.csv rows of the last chunk, run by run (:func:`jaxnav.run.logs.explore_rows`);
        ``explore`` is [n_runs, chunk steps]. The blocks a chunk ended inside wait in
        :attr:`pending` for the next chunk."""
        rows = []
        for r, fields in enumerate(self.fields):
            mine, self.pending[r] = explore_rows(
                explore[r],
                int(step_before[r]),
                self.trainer.chunk_length,
                self.pending[r],
                bool(finished[r]),
                fields,
            )
            rows += mine
        return rows

    def save(
        self,
        ts: Any,
        metric_rows: list,
        explore_rows: list,
        slots: np.ndarray,
        checkpoint: bool = True,
        eval_rows: list = (),
    ) -> None:
        """Append the chunk's rows, then checkpoint (with the logs' new lengths): the
        replay slots the chunk wrote (``slots``) to a new segment, then the rest.

        All or nothing: if a write fails (a full disk), both logs are cut back to their
        lengths before this chunk, so they still match the previous checkpoint, which
        stays as it was (a segment it does not count is never read); the error goes on
        to the command's one-line report."""
        # every process: a gather across hosts is collective
        keep_bank = bool(self.cfg.env.maze_bank_refresh)  # else drawn again on resume
        state = self.shard.get(without_rows(ts, keep_bank)) if checkpoint else None
        rows = self.shard.get(self.rows_at(ts, slots)) if checkpoint else None
        if not is_writer():
            return
        with startup.no_interrupt():  # Ctrl-C: after the checkpoint, never between
            self._write(metric_rows, explore_rows, eval_rows, slots, rows, state, checkpoint)

    def _write(self, metric_rows, explore_rows, eval_rows, slots, rows, state, checkpoint) -> None:
        """:meth:`save`'s writes, on the host copies it gathered."""
        evals = () if self.greedy is None else (self.greedy.log,)
        logs = (self.metrics, self.explore, *evals)
        before = [log.size() for log in logs]
        try:
            sizes = np.asarray(
                [self.metrics.append(metric_rows), self.explore.append(explore_rows)], np.int64
            )
            host = {"eval_size": np.int64(evals[0].append(eval_rows))} if evals else {}
            if not checkpoint:
                return
            segments = self.segments
            if len(slots):  # a trainer without replay (PQN) writes no row segments
                segment = {"slots": slots, **{f"rows.buffer.{r}": a for r, a in rows.items()}}
                rundir.atomic_write_npz(self.out / ROW_SEGMENT.format(segments), segment)
                segments += 1
            host |= {
                "logged": self.logged,
                "wall": np.float64(self.wall),
                "csv_sizes": sizes,
                "segments": np.int64(segments),
                "computed": np.int64(self.computed),
                **pending_arrays(self.pending),
            }
            if self.greedy is not None and self.greedy.best is not None:
                host |= self.greedy.best.arrays()
            rundir.atomic_write_npz(self.checkpoint, checkpoint_arrays(state, host))
            self.segments = segments
        except OSError:
            for log, size in zip(logs, before):
                log.restore(size)
            raise

    def _remember(self, label: tuple[str, int], row: dict[str, str]) -> None:
        """Keep an episode's return and attempts (its metrics.csv row) for the progress."""
        successes, collisions, timeouts, _ = training_outcomes(row, self.max_steps)
        decided = successes + collisions + timeouts
        self.recent[label].append((float(row["return"]), successes, decided))

    def progress_text(self, steps_per_s: float) -> str:
        """Each arm's mean return over its seeds' last episodes and the success of their
        decided goal attempts (jaxnav.report.navigation); with more than four arms, the
        lowest and the highest return."""
        means, success = {}, {}
        for s in self.cfg.arm_names():
            recent = [
                x
                for (arm, _), episodes in self.recent.items()
                if arm == s
                for x in episodes[-PROGRESS_EPISODES:]
            ]
            if recent:
                ret, succ, decided = (np.sum(c) for c in zip(*recent))
                means[s] = ret / len(recent)
                success[s] = f" success={succ / decided:.2f}" if decided else ""
        if len(means) > 4:
            lo, hi = min(means, key=means.get), max(means, key=means.get)
            success = {f"{len(means)} arms, lowest {lo}": success[lo], f"highest {hi}": success[hi]}
            means = {f"{len(means)} arms, lowest {lo}": means[lo], f"highest {hi}": means[hi]}
        parts = [f"{s} R={m:.0f}{success[s]}" for s, m in means.items()]
        parts.append(f"{steps_per_s / 1000:.1f}k steps/s")
        return " ".join(parts)

    # -- loop ----------------------------------------------------------------

    def _progress_bar(self, ts: Any):
        from tqdm import tqdm

        cfg = self.cfg
        if cfg.episodes is not None:
            total, unit = cfg.n_runs * cfg.episodes, "ep"
        else:
            total, unit = cfg.n_runs * cfg.total_steps, "step"
        bar = tqdm(
            total=total,
            initial=self._done(ts),
            unit=unit,
            disable=self.quiet or not is_writer(),
            dynamic_ncols=True,
            file=sys.stderr,
        )
        return bar

    def _done(self, ts: Any) -> int:
        """Progress: episodes (or steps) finished over all runs."""
        if self.cfg.episodes is not None:
            return int(np.minimum(self.shard.get(ts.episode), self.cfg.episodes).sum())
        return int(self.shard.get(ts.step).sum())

    def _tensorboard(self, ts: Any) -> tblog.TensorBoardLog | None:
        """The TensorBoard log when asked for; a resumed run's episode curves are
        rewritten from metrics.csv and its step curves purged past the checkpoint."""
        if not (self.cfg.run.tensorboard and self.out is not None and is_writer()):
            return None
        step = int(self.shard.get(ts.step).max())
        resumed = step > 0
        columns = self.metric_columns
        evals = None if self.greedy is None else self.greedy.log.header
        tb = tblog.TensorBoardLog(self.out, self.labels, columns, resumed, step, evals)
        if not self.quiet:
            where = self.out / "tensorboard"
            print(f"TensorBoard: tensorboard --logdir {where} shows the curves", file=sys.stderr)
        if resumed and self.metrics.size():
            tb.add_episodes([tuple(r[c] for c in columns) for r in self.metrics.read()])
        return tb

    def compile_chunk(self, ts: Any):
        """The chunk program, compiled before its first call (loaded from JAX's
        persistent cache when it is there), timed: ``compile_s``, and ``startup_s``,
        the process's age when training can begin (imports, set-up and compilation)."""
        t0 = time.perf_counter()
        compiled = self.chunk.lower(ts, np.int32(0)).compile()
        self.compile_s = time.perf_counter() - t0
        self.startup_s = process_age()
        return compiled

    def train(self, ts: Any) -> Any:
        bar = self._progress_bar(ts)
        tb = self._tensorboard(ts)
        chunk = self.compile_chunk(ts) if self.active(ts).any() else None
        saved_step = self.shard.get(ts.step).copy()  # at the last checkpoint
        saved_at = time.perf_counter()
        try:
            while self.active(ts).any():
                before = self._done(ts)
                step_before = self.shard.get(ts.step).copy()
                n = self.steps_needed(ts)
                t0 = time.perf_counter()
                ts, log = chunk(ts, np.int32(n))
                log = self.shard.get(log)  # waits for the chunk
                dt = time.perf_counter() - t0
                self.rate = n / max(dt, 1e-9)
                self.wall += dt
                if self.computed >= 0:
                    self.computed += n * self.cfg.n_runs
                steps = int((self.shard.get(ts.step) - step_before).sum())
                diverged = self.check_divergence(ts)
                stop = bool(diverged) and self.cfg.run.on_divergence == "stop"
                # On a stop the finished episodes are kept and the last checkpoint
                # (before the divergence) stays: a resume replays this chunk.
                still = self.active(ts)
                rows = self.new_episodes(ts), self.explore_blocks(log.explore, step_before, ~still)
                done = not still.any()
                evals = [] if self.greedy is None else self.greedy.evaluate(ts, done)
                if tb is not None:  # before the checkpoint: a resume purges it, never misses it
                    tb.add_episodes(rows[0])
                    tb.add_steps(log.loss, log.max_q, int(step_before.max()))
                    tb.add_evals(evals)
                    tb.flush()
                # A checkpoint every run.checkpoint_s of training, and at the end; it
                # holds the replay slots written since the last one.
                due = time.perf_counter() - saved_at >= self.cfg.run.checkpoint_s
                checkpoint = not stop and (due or done)
                step_now = self.shard.get(ts.step)
                slots = chunk_slots(saved_step, step_now, self.cfg.buffer_capacity)
                if not has_replay(self.cfg):
                    slots = slots[:0]
                self.save(ts, *rows, slots, checkpoint=checkpoint, eval_rows=evals)
                if checkpoint:
                    saved_step, saved_at = step_now.copy(), time.perf_counter()
                if stop:
                    raise RunError(
                        f"training diverged: {diverged[0]}"
                        + (f" (and {len(diverged) - 1} more runs)" if len(diverged) > 1 else "")
                        + " (non-finite loss, Q-values or "
                        "parameters); finished episodes are in metrics.csv and the last good "
                        "checkpoint is kept (lower dqn.lr, or set run.on_divergence=drop)"
                    )
                for line in diverged:
                    print(f"warning: {line}; the run is dropped", file=sys.stderr, flush=True)
                bar.set_postfix_str(self.progress_text(steps / max(dt, 1e-9)), refresh=False)
                bar.update(self._done(ts) - before)
        finally:
            bar.close()
            if tb is not None:
                tb.close()
        return ts

    def finish(self, ts: Any) -> dict[str, Any]:
        """Write params.npz and summary.json; return the summary."""
        steps = int(self.shard.get(ts.step).sum())
        summary: dict[str, Any] = {
            "wall_clock_s": round(self.wall, 2),
            "env_steps": steps,
            "steps_per_s": round(steps / max(self.wall, 1e-9), 1),
            # the share of the run-steps computed in lockstep that were real steps
            "lockstep_useful": round(steps / self.computed, 4) if self.computed > 0 else None,
            "compile_s": None if self.compile_s is None else round(self.compile_s, 2),
            "startup_s": None if self.startup_s is None else round(self.startup_s, 2),
            "buffer_capacity": self.cfg.buffer_capacity if has_replay(self.cfg) else None,
            "buffer_bytes_per_seed": replay.nbytes(
                self.cfg.buffer_capacity,
                self.trainer.env.obs_size,
                self.trainer.env_params.max_steps,
                self.cfg.dqn.prioritised,
            )
            if has_replay(self.cfg)
            else None,
            "machine": f"{platform.machine()} {os.cpu_count()} cores, jax {jax.__version__} "
            f"on {jax.default_backend()}",
            "devices": self.shard.n_devices,
            "processes": jax.process_count(),
            "last50": last_episodes(self.metrics.read(), self.cfg.arm_names())
            if is_writer()
            else {},
            "diverged": self.diverged_runs(),
        }
        params = self.shard.get(ts.params)  # every process: collective across hosts
        best = None if self.greedy is None else self.greedy.best
        if best is not None and best.params is not None:  # run.keep_best
            params = best.params
            summary["best"] = best.summary(self.labels)
        if is_writer():
            params = params_arrays(self.cfg, params)
            text = json.dumps(summary, indent=2) + "\n"
            with startup.no_interrupt():  # Ctrl-C: a finished run, or one to resume
                for log in (self.metrics, self.explore):  # the same whatever the chunks
                    log.group_by_run(self.fields)
                rundir.atomic_write_npz(self.out / rundir.PARAMS, params)
                rundir.atomic_write_text(self.out / rundir.SUMMARY, text)
                if not self.keep_checkpoints:  # only after both: until then, resume needs them
                    rundir.remove_checkpoints(self.out)
                self.on_finished()  # before the block ends: a Ctrl-C acts then
        if len(self.diverged) == self.cfg.n_runs:
            raise RunError("training diverged: every run (summary.json lists them; lower dqn.lr)")
        return summary


def trainer_of(cfg: Config) -> Trainer:
    """The trainer of a config's agent (``agent``, :mod:`jaxnav.core.agents`)."""
    return agents.get(cfg.agent).make_trainer(cfg)


def has_replay(cfg: Config) -> bool:
    """Whether a config's agent keeps a replay memory (DQN does, PQN does not)."""
    return agents.get(cfg.agent).replay
