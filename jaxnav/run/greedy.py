"""The greedy evaluation of every run while it trains (``run.eval_every``).

At every multiple of ``run.eval_every`` env steps (the first point past it where the
logs' blocks are whole, :meth:`GreedyEval.due_at`; and once when training ends), each
run's current policy plays ``run.eval_episodes`` consecutive episodes greedily (argmax
Q, dropout off, no exploration) in the training environment (with drawn mazes, layouts
of the training split, a new one every episode, whatever ``env.new_maze_every``): the
test rollout of finished runs, :func:`jaxnav.agent.rollout.make_rollout`, with the same
key as ``jaxnav evaluate`` (:func:`jaxnav.agent.rollout.eval_keys`) at every
evaluation. The evaluation only
reads the training state, so training's numbers are those of a run without it.

One row per run and evaluation goes to ``eval.csv`` (:data:`EVAL_COLUMNS`), appended
with the chunk's logs before its checkpoint, so a resumed run cuts it back as it
does metrics.csv. An evaluation comes at a step fixed by the config
(:meth:`GreedyEval.due_at`), wherever the host loop ends its chunks: a chunk is cut there.

With ``run.keep_best`` each evaluation also plays ``run.eval_episodes`` held-out
episodes (keys with VALID_SALT, neither the test's nor training's), and each run keeps
the policy that did best there (:class:`BestPolicy`): params.npz gets it instead of
the last one, so a seed that falls apart late in training is tested as it was at
its best, and the choice never sees the test's episodes.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import jax
import numpy as np

from jaxnav.agent.explored import BLOCK, coverage
from jaxnav.agent.rollout import VALID_SALT, eval_keys, make_rollout
from jaxnav.agent.sharding import RunSharding
from jaxnav.agent.trainer import Trainer
from jaxnav.core import agents, rundir, sweep
from jaxnav.core.config import Config
from jaxnav.core.settings import training_only_on
from jaxnav.core.startup import process_age
from jaxnav.env import NavEnv
from jaxnav.planners.raster import ORACLE_CELL, free_blocks, raster_for
from jaxnav.report.navigation import COLLISION, CUT, SUCCESS, TIMEOUT, run_attempts
from jaxnav.run.checkpoint import leaf_names
from jaxnav.world.maps import ROBOT_RADIUS

# A swept run's eval.csv has one more column per swept key after "strategy", as
# metrics.csv. return, goals and collided are means over the evaluation's episodes;
# attempts, successes, collisions, timeouts and cut count its goal attempts
# (jaxnav.report.navigation: cut attempts are neither success nor failure), success is
# the successes' share of the decided attempts (attempts - cut).
EVAL_COLUMNS = (
    "strategy",
    "seed",
    "env_step",
    "wall_s",
    "return",
    "goals",
    "collided",
    "attempts",
    "successes",
    "success",
    "collisions",
    "timeouts",
    "cut",
)
# With run.coverage, two more: the env steps by the run's first goal in training (empty
# before one) and the share of the world's free cells its robot has visited
# (jaxnav.agent.explored).
COVERAGE_COLUMNS = ("first_goal", "coverage")


def free_cells(maze) -> np.ndarray:
    """bool[ny, nx]: run.coverage's free cells of a fixed maze (the oracle's raster
    pooled as the trainer pools it, :func:`jaxnav.pqn.coverage_grid`)."""
    raster = raster_for([maze], ORACLE_CELL)
    return np.asarray(free_blocks(maze, raster, BLOCK, ROBOT_RADIUS))


class BestPolicy:
    """Each run's best policy so far on the held-out episodes (``run.keep_best``).

    A run's score is the success of its decided goal attempts there (0 with none
    decided), then the fewer collisions per attempt; of equal scores the later
    policy wins, as the more trained one. A run that diverged keeps what it had."""

    def __init__(self, n_runs: int) -> None:
        self.score = np.full((n_runs, 2), -np.inf)  # (success, -collision share)
        self.step = np.full(n_runs, -1, np.int64)  # the env step of the kept policy
        self.params = None  # host copies, a leading run axis; None before the first

    def offer(self, params, score: np.ndarray, steps: np.ndarray, ok: np.ndarray) -> None:
        """Keep ``params`` (host copies) for the runs where ``score`` is at least as
        good as the kept one's and ``ok`` (not diverged)."""
        s, b = score, self.score
        better = ok & ((s[:, 0] > b[:, 0]) | ((s[:, 0] == b[:, 0]) & (s[:, 1] >= b[:, 1])))
        if self.params is None:
            self.params = jax.tree.map(np.array, params)
        self.params = jax.tree.map(
            lambda kept, new: np.where(better.reshape((-1,) + (1,) * (new.ndim - 1)), new, kept),
            self.params,
            params,
        )
        self.score = np.where(better[:, None], s, b)
        self.step = np.where(better, steps, self.step)

    def summary(self, labels) -> list[dict]:
        """summary.json's ``best``: per run (``labels``: its arm and seed) the env step
        of the kept policy and its held-out success, None for a run that diverged
        before its first evaluation."""
        return [
            {
                "strategy": arm,
                "seed": seed,
                "env_step": int(self.step[r]) if self.step[r] >= 0 else None,
                "held_out_success": round(float(self.score[r, 0]), 4)
                if self.step[r] >= 0
                else None,
            }
            for r, (arm, seed) in enumerate(labels)
        ]

    def arrays(self) -> dict[str, np.ndarray]:
        """The checkpoint's host entries (none before the first evaluation)."""
        if self.params is None:
            return {}
        leaves = jax.tree.leaves(self.params)
        named = {f"best.params{n}": a for n, a in zip(leaf_names(self.params), leaves)}
        return {"best.score": self.score, "best.step": self.step, **named}

    def restore(self, host: dict[str, np.ndarray], template) -> None:
        """Back from a checkpoint's host entries (:meth:`arrays`); ``template``: the
        run's params, for their structure."""
        if "best.score" not in host:
            return
        leaves = [host[f"best.params{n}"] for n in leaf_names(template)]
        self.params = jax.tree.unflatten(jax.tree.structure(template), leaves)
        self.score = np.asarray(host["best.score"], np.float64)
        self.step = np.asarray(host["best.step"], np.int64)


def evaluation_env(env: NavEnv) -> NavEnv:
    """The environment the periodic evaluation plays: the training one, with drawn
    mazes a new layout every episode, as jaxnav evaluate tests, whatever
    env.new_maze_every training keeps one for (a greedy policy replays its failure in a
    kept layout, so N episodes would be N / new_maze_every layouts), and every
    training-only setting off (the moving cylinders at their own pace, real
    collisions: :data:`jaxnav.core.settings.TRAINING_ONLY`), as the test has them."""
    if env.generates:
        env = dataclasses.replace(env, new_maze_every=1)
    return dataclasses.replace(env, **training_only_on(env))


class GreedyEval:
    """The evaluations of a run's policies while it trains, and their log.

    ``block``: the env steps the host loop averages per row of its step logs
    (explore.csv, TensorBoard); a chunk is cut only a whole number of blocks (and of
    the trainer's steps) after where it would start without evaluation."""

    def __init__(
        self, cfg: Config, trainer: Trainer, shard: RunSharding, out: Path, block: int
    ) -> None:
        self.every = cfg.run.eval_every
        self.n_episodes = cfg.run.eval_episodes
        self.fields = cfg.run_fields()
        self.chunk_length = trainer.chunk_length
        self.grain = math.lcm(trainer.step_size, block)
        columns = EVAL_COLUMNS + (COVERAGE_COLUMNS if cfg.run.coverage else ())
        self.log = rundir.CsvLog(out / rundir.EVAL, sweep.with_swept(columns, cfg.sweep))
        self.free = free_cells(trainer.env_params.maze) if cfg.run.coverage else None
        self.shard = shard
        rollout = make_rollout(
            evaluation_env(trainer.env),
            agents.get(cfg.agent).network_of(cfg, trainer.env),
            self.n_episodes,
            int(trainer.env_params.max_steps),
            navigation=True,
        )
        self.rollout = jax.jit(
            jax.vmap(rollout, in_axes=(0, 0, 0, 0, None)), out_shardings=shard.sharding
        )
        self.keys = shard.put(np.asarray(eval_keys(cfg.run_labels())))
        self.best = BestPolicy(cfg.n_runs) if cfg.run.keep_best else None
        if self.best is not None:
            self.valid_keys = shard.put(np.asarray(eval_keys(cfg.run_labels(), VALID_SALT)))
        self.env_params = trainer.env_params
        self.limit = trainer.env.attempt_steps(trainer.env_params)
        self.done = 0  # multiples of ``every`` evaluated so far

    def restore(self, step: int, log_size: int | None) -> None:
        """Training goes on from env step ``step`` (0, or a checkpoint's): the
        multiples up to it were evaluated (a chunk end at or past each one did).
        ``log_size``: eval.csv's length at the checkpoint (None: leave it), the rows
        after it cut off."""
        self.done = step // self.every
        if log_size is None:
            return
        if log_size:
            self.log.truncate(log_size)
        else:
            self.log.path.unlink(missing_ok=True)

    def due_at(self, k: int) -> int:
        """The lockstep env step of the ``k``-th evaluation: the first point at or past
        ``k * run.eval_every`` that is a whole number of ``grain`` steps after the start
        of its ``chunk_length`` window, or that window's end. It depends on the config
        alone, not on where the host loop ends its chunks (it cuts one there)."""
        due = k * self.every
        base = (due - 1) // self.chunk_length * self.chunk_length
        cut = base + -(-(due - base) // self.grain) * self.grain
        return min(cut, base + self.chunk_length)

    def chunk_end(self, step: int, n: int) -> int:
        """The env steps of the next chunk from ``step`` (the runs' lockstep count): at
        most ``n``, and ending at the next evaluation (:meth:`due_at`) if it comes first."""
        return min(n, self.due_at(self.done + 1) - step)

    def _offer(self, ts, steps: np.ndarray) -> None:
        """Play the held-out episodes and offer the policies to :attr:`best`."""
        res = self.rollout(ts.params, self.valid_keys, ts.strategy, ts.hyper, self.env_params)
        res, params, diverged_at = self.shard.get((res, ts.params, ts.diverged_at))
        score = np.zeros((len(self.fields), 2))
        for r in range(len(self.fields)):
            att = run_attempts(res.steps, r, self.n_episodes, self.limit)
            decided = int(np.sum(att.outcome != CUT))
            if decided:
                score[r, 0] = np.sum(att.outcome == SUCCESS) / decided
            if len(att.outcome):
                score[r, 1] = -np.sum(att.outcome == COLLISION) / len(att.outcome)
        self.best.offer(params, score, steps, np.asarray(diverged_at) < 0)

    def evaluate(self, ts, finished: bool) -> list[tuple]:
        """eval.csv rows of every run's policy in ``ts`` when the chunk that led to it
        is evaluated (it reached the next multiple, or training has ``finished`` and
        its final policies were not evaluated yet); none otherwise. A row's env step
        is its run's ``ts.step``, its ``wall_s`` the seconds since the command started
        when the chunk ended."""
        wall_s = process_age()
        steps = self.shard.get(ts.step)
        step = int(steps.max())  # the lockstep count: every run still training has it
        if not (step >= self.due_at(self.done + 1) or (finished and step % self.every)):
            return []
        self.done = step // self.every
        res = self.rollout(ts.params, self.keys, ts.strategy, ts.hyper, self.env_params)
        res = self.shard.get(res)
        if self.best is not None:
            self._offer(ts, steps)
        out = []
        for r, fields in enumerate(self.fields):
            att = run_attempts(res.steps, r, self.n_episodes, self.limit)
            n = {k: int(np.sum(att.outcome == k)) for k in (SUCCESS, COLLISION, TIMEOUT, CUT)}
            successes, attempts = n[SUCCESS], len(att.outcome)
            decided = attempts - n[CUT]
            out.append(
                (
                    *fields,
                    int(steps[r]),
                    f"{wall_s:.2f}",
                    f"{float(np.mean(res.ret[r])):.6g}",
                    f"{float(np.mean(res.goals[r])):.6g}",
                    f"{float(np.mean(res.collided[r])):.6g}",
                    attempts,
                    successes,
                    f"{successes / decided:.6g}" if decided else "nan",
                    n[COLLISION],
                    n[TIMEOUT],
                    n[CUT],
                    *(() if self.free is None else self._explored(ts, r)),
                )
            )
        return out

    def _explored(self, ts, r: int) -> tuple[str, str]:
        """Run ``r``'s first goal and coverage so far (run.coverage)."""
        if r == 0:
            ex = self.shard.get(ts.explored)
            self._now = (np.asarray(ex.first_goal), np.asarray(coverage(ex.visits, self.free)))
        first, share = self._now
        return ("" if first[r] < 0 else str(int(first[r])), f"{float(share[r]):.6g}")
