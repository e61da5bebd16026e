"""The tests of finished runs: their policies played on test mazes, jitted.

The rollout itself, the paper's test protocol, is :func:`jaxnav.agent.rollout.make_rollout`
(re-exported here with its records). Every policy runs in one vmapped ``lax.scan``
per maze; test mazes are padded to one shape (:func:`padded_mazes`), so the scan
compiles once. Both strategies of a seed use the same test key (:func:`eval_keys`).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any, NamedTuple

import jax
import numpy as np

from jaxnav.agent.hyper import Hyper
from jaxnav.agent.networks import QNetwork
from jaxnav.agent.rollout import (  # noqa: F401  (re-exported: the tests' records)
    EVAL_SALT,
    EpisodeMazes,
    Rollout,
    Steps,
    Trajectory,
    eval_keys,
    make_rollout,
)
from jaxnav.agent.sharding import RunSharding
from jaxnav.core.config import Config
from jaxnav.env import EnvParams, NavEnv
from jaxnav.world.maps import MAX_GOAL_POINTS, Maze, make_maze, pad_maze

MODES = ("greedy", "exploring")  # how a policy acts in a test (see make_rollout)


class Policies(NamedTuple):
    """Trained policies and the environment they were trained in."""

    labels: list[tuple[str, int]]  # (arm, seed) per policy, the params' leading axis
    fields: list[tuple]  # (strategy, swept values, seed) per policy, as results.csv writes
    params: Any  # flax params, every leaf with a leading policy axis
    env: NavEnv  # the training env (static settings)
    env_params: EnvParams  # the training env's params
    network: QNetwork
    strategy: np.ndarray  # i32[policies] registered strategy number
    hyper: Hyper  # each policy's settings in training (a sweep point's), [policies]
    episodes_trained: int  # episodes each policy trained for (epsilon's last value)


def padded_mazes(names: Sequence[str]) -> list[Maze]:
    """Mazes by name or YAML path, padded to one shape so one compile serves all.

    Goal points are padded to MAX_GOAL_POINTS (they are only indexed, so this costs
    nothing) and the shape then depends only on the largest wall and obstacle
    counts: most maze sets share a compiled rollout.
    """
    mazes = [make_maze(n) for n in names]
    s = max(m.segments.shape[0] for m in mazes)
    c = max(m.circles.shape[0] for m in mazes)
    g = max([MAX_GOAL_POINTS] + [m.goal_points.shape[0] for m in mazes])
    return [pad_maze(m, s, c, g) for m in mazes]


@functools.lru_cache(maxsize=16)
def _compiled_rollout(
    env: NavEnv,
    network: QNetwork,
    n_episodes: int,
    max_steps: int,
    record: bool,
    exploring,
    navigation: bool = False,
):
    """jit(vmap(rollout)) over runs, one per setting: equal shapes never recompile.
    Each device plays its own runs as one batch (:meth:`RunSharding.per_device`): what
    the rollout decides over its batch (:func:`jaxnav.world.lazy.draw_where`: a drawn
    maze, or a planner's field, computed only where one is needed) is decided on each
    device for its runs, with no collective between devices at every step and no
    device computing another's draws."""
    rollout = make_rollout(env, network, n_episodes, max_steps, record, exploring, navigation)
    batch = jax.vmap(rollout, in_axes=(0, 0, 0, 0, None))

    def per_run(runs, env_params):
        return batch(*runs, env_params)

    return jax.jit(RunSharding(1).per_device(per_run, 2))


def run_tests(
    policies: Policies,
    mazes: Sequence[Maze],
    n_episodes: int,
    record: bool = False,
    mode: str = "greedy",
    navigation: bool = False,
) -> list[Rollout]:
    """One vmapped rollout of every policy per maze in a test ``mode``; NumPy results
    (``record``: with the trajectory; ``navigation``: with what the navigation
    metrics need, :func:`make_rollout`)."""
    if mode not in MODES:
        raise ValueError(f"unknown test mode {mode!r}")
    exploring = policies.episodes_trained if mode == "exploring" else None
    # The run axis is laid over every device, as in training.
    shard = RunSharding(len(policies.labels))
    params = shard.put(jax.tree.map(np.asarray, policies.params))
    keys = shard.put(np.asarray(eval_keys(policies.labels)))
    strategy = shard.put(np.asarray(policies.strategy, np.int32))
    hyper = shard.put(jax.tree.map(np.asarray, policies.hyper))
    max_steps = int(policies.env_params.max_steps)
    fn = _compiled_rollout(
        policies.env, policies.network, n_episodes, max_steps, record, exploring, navigation
    )
    out = []
    for maze in mazes:
        res = fn((params, keys, strategy, hyper), policies.env_params.replace(maze=maze))
        out.append(shard.get(res))
    return out


def drawn_name(cfg: Config, split: str = "test") -> str:
    """The results' maze name of a run's drawn mazes of a split: ``grid:test``."""
    return f"{cfg.env.generator}:{split}"


def first_episode(res: Rollout, r: int) -> dict[str, Any]:
    """The first test episode of run r of a recorded Rollout, cut to its length."""
    n = int(res.length[r, 0])
    tr = res.trajectory
    return {
        "pos": tr.pos[r, :n],
        "yaw": tr.yaw[r, :n],
        "goal": tr.goal[r, :n],
        "ranges": tr.ranges[r, :n],
        "reward": tr.reward[r, :n],
        "reached": tr.reached[r, :n],
        **({} if tr.circles is None else {"circles": tr.circles[r, :n]}),
        "collided": bool(res.collided[r, 0]),
        "return": float(res.ret[r, 0]),
        "goals": int(res.goals[r, 0]),
        "length": n,
    }
