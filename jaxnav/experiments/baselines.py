"""The reference drivers through the very test the learned policies take: the oracle
(:class:`jaxnav.planners.oracle.Oracle`) and the dynamic window approach
(:class:`jaxnav.planners.dwa.DWA`), played by the same rollout, on the same test keys,
episodes, step limits and attempt counting as ``jaxnav evaluate``.

In a run's evaluation each reference driver takes the place of the run's policies once
per seed (the seed's test key, the environment settings of that seed's first run), so
its rows in results.csv (``strategy`` = its name) sit beside the learned policies' with
intervals over the same seeds. On its own (``jaxnav evaluate --baseline``) it drives
any world: a built-in maze, a maze file, or a config's world (its maze or drawn family).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence

import jax
import numpy as np
import yaml

from jaxnav.core import baselines, rundir
from jaxnav.core.config import Config, load_config, resolve_config_path
from jaxnav.core.errors import JaxnavError
from jaxnav.dqn import run_inputs
from jaxnav.env import EnvParams, NavEnv, from_config
from jaxnav.experiments.navigation import ShortestPaths, navigation_counts
from jaxnav.experiments.rollout import Policies, drawn_name, padded_mazes, run_tests
from jaxnav.planners.dwa import DWA
from jaxnav.planners.oracle import Oracle
from jaxnav.planners.raster import raster_for
from jaxnav.report.results import RESULT_COLUMNS, episode_rows
from jaxnav.world.generators import SPLITS
from jaxnav.world.maps import Maze, make_maze

RASTER_CELL = 0.05  # m: the oracle's raster


def planner_problem(name: str, env: NavEnv) -> str | None:
    """Why the reference driver ``name`` cannot drive in ``env`` (one line), or None."""
    if name not in baselines.BASELINES:
        return f"no baseline {name!r} (choose from {', '.join(baselines.names())})"
    if name == "oracle" and env.scales_maze:
        return "the oracle cannot plan with env.maze_scale (its raster has the maze's own size)"
    return None


def planner_of(name: str, env: NavEnv, mazes: Sequence[Maze]):
    """The reference driver ``name`` for ``env``, sized for ``mazes`` (the mazes it
    will drive in: the test mazes, or a drawn family's template). JaxnavError if it
    cannot drive there."""
    why = planner_problem(name, env)
    if why:
        raise JaxnavError(why)
    if name == "oracle":
        return Oracle(env, raster_for(mazes, RASTER_CELL))
    return DWA(env)


def in_place_of(name: str, policies: Policies, mazes: Sequence[Maze]) -> Policies:
    """The reference driver ``name`` in the place of a run's ``policies``: one per
    distinct seed (its test key), with the settings of that seed's first run (its swept
    environment settings apply as they do to the run)."""
    first: dict[int, int] = {}
    for i, (_, seed) in enumerate(policies.labels):
        first.setdefault(seed, i)
    idx = np.asarray(list(first.values()))
    swept = len(policies.fields[0]) - 2  # (strategy, swept values..., seed)
    return policies._replace(
        labels=[(name, seed) for seed in first],
        fields=[(name, *[""] * swept, seed) for seed in first],
        params=np.zeros(len(idx), np.float32),
        network=planner_of(name, policies.env, mazes),
        strategy=np.zeros(len(idx), np.int32),
        hyper=jax.tree.map(lambda a: np.asarray(a)[idx], policies.hyper),
    )


def world_policies(
    name: str, cfg: Config, seeds: Sequence[int], env: NavEnv, env_params: EnvParams
) -> Policies:
    """The reference driver ``name`` on its own in a config's world (``env``, its
    ``env_params``), one driver per seed of ``seeds``."""
    one = dataclasses.replace(cfg, strategies=cfg.strategies[:1], seeds=1, sweep=())
    hyper = run_inputs(one).hyper
    n = len(seeds)
    template = Policies(
        labels=[(name, s) for s in seeds],
        fields=[(name, s) for s in seeds],
        params=np.zeros(n, np.float32),
        env=env,
        env_params=env_params,
        network=None,
        strategy=np.zeros(n, np.int32),
        hyper=jax.tree.map(lambda a: np.repeat(np.asarray(a), n, axis=0), hyper),
        episodes_trained=0,
    )
    return template._replace(network=planner_of(name, env, [env_params.maze]))


def world_config(world: str, overrides: Sequence[str] = ()) -> Config:
    """The config of a world named on the command line: a config (a shipped config's
    name or a YAML config file: its maze or drawn family and every environment setting),
    else a maze (a built-in maze's name or a maze file) in the default settings, the
    paper's; ``overrides`` (``key=value``) apply on top."""
    path = resolve_config_path(world)
    if os.path.isfile(path) and not _is_maze_file(path):
        return load_config(path, list(overrides))
    make_maze(world)  # a maze, or a one-line error naming what it is not
    return load_config(None, [f"env.maze={world}", *overrides])


def _is_maze_file(path: str) -> bool:
    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except (OSError, yaml.YAMLError):
        return False
    return isinstance(doc, dict) and "outline" in doc


def evaluate_world(name: str, cfg: Config, n_seeds: int, n_episodes: int) -> tuple[str, list[str]]:
    """The reference driver ``name`` through the test in a config's world: ``n_seeds``
    test keys (the seeds ``cfg.seed``, ... that a run of the config would have),
    ``n_episodes`` consecutive episodes each, on its maze, or on a drawn family's train
    and test layouts. Returns (results.csv text, the results' maze names)."""
    env, env_params = from_config(cfg)
    seeds = [cfg.seed + i for i in range(n_seeds)]
    if env.generates:
        tests = [
            (drawn_name(cfg, split), dataclasses.replace(env, split=split)) for split in SPLITS
        ]
        mazes = [[env_params.maze]] * len(tests)
    else:
        tests = [(cfg.env.maze, env)]
        mazes = [padded_mazes([cfg.env.maze])]
    why = planner_problem(name, env)
    if why:
        raise JaxnavError(why)
    paths = ShortestPaths(float(env_params.robot_radius))
    step_m, dt = float(env_params.v) * float(env_params.dt), float(env_params.dt)
    limit = env.attempt_steps(env_params)
    rows = []
    for (maze_name, test_env), maze in zip(tests, mazes):
        driver = world_policies(name, cfg, seeds, test_env, env_params)
        (res,) = run_tests(driver, maze, n_episodes, navigation=True)
        nav = [navigation_counts(res, maze[0], n_episodes, step_m, dt, paths, limit)]
        rows += episode_rows(driver.fields, [maze_name], [res], n_episodes, "greedy", nav)
    return rundir.csv_text(RESULT_COLUMNS, rows), [t[0] for t in tests]


__all__ = [
    "RASTER_CELL",
    "evaluate_world",
    "in_place_of",
    "planner_of",
    "planner_problem",
    "world_config",
    "world_policies",
]
