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

import csv
import dataclasses
import io
import os
from collections.abc import Sequence
from typing import NamedTuple

import jax
import numpy as np
import yaml

from jaxnav.agent.trainer import run_inputs
from jaxnav.core import baselines, families, rundir, worlds
from jaxnav.core.config import Config, load_config
from jaxnav.core.errors import JaxnavError
from jaxnav.core.shipped import resolve_config_path
from jaxnav.env import EnvParams, NavEnv, from_config
from jaxnav.experiments.navigation import ShortestPaths, attempt_paths
from jaxnav.experiments.rollout import Policies, drawn_name, padded_mazes, run_tests
from jaxnav.planners.dwa import BARN_SETTINGS, DWA, barn_dwa
from jaxnav.planners.oracle import Oracle, holds_for
from jaxnav.planners.raster import ORACLE_CELL, raster_for
from jaxnav.planners.search import opening
from jaxnav.report.navigation import (
    COLLISION,
    CUT,
    SUCCESS,
    TIMEOUT,
    Attempts,
    episode_counts,
)
from jaxnav.report.results import RESULT_COLUMNS, episode_rows
from jaxnav.world.generators import SPLITS
from jaxnav.world.maps import Maze, make_maze

RASTER_CELL = ORACLE_CELL  # m: the oracle's raster


def planner_problem(name: str, env: NavEnv) -> str | None:
    """Why the reference driver ``name`` cannot drive in ``env`` (one line), or None."""
    if name not in baselines.BASELINES:
        return f"no baseline {name!r} (choose from {', '.join(baselines.names())})"
    if name == "oracle" and env.scales_maze:
        return "the oracle cannot plan with env.maze_scale (its raster has the maze's own size)"
    return None


def planner_of(name: str, env: NavEnv, mazes: Sequence[Maze], env_params: EnvParams):
    """The reference driver ``name`` for ``env``, sized for ``mazes`` (the mazes it
    will drive in: the test mazes, or a drawn family's template). The oracle gets the
    searched way out of the start of each of ``mazes`` that needs one
    (:func:`jaxnav.planners.search.opening`; ``env_params``: the test's settings).
    JaxnavError if it cannot drive there."""
    why = planner_problem(name, env)
    if why:
        raise JaxnavError(why)
    if name == "oracle":
        found = (opening(env, env_params.replace(maze=maze)) for maze in mazes)
        openings = tuple(o for o in found if o is not None)
        holds = holds_for(env, env_params, mazes)
        return Oracle(env, raster_for(mazes, RASTER_CELL), holds=holds, openings=openings)
    return DWA(env)


def in_place_of(name: str, policies: Policies, mazes: Sequence[Maze]) -> Policies:
    """The reference driver ``name`` in the place of a run's ``policies``: one per
    distinct seed (its test key), with the settings of that seed's first run (its swept
    environment settings apply as they do to the run). A run with continuous actions
    gets drivers that plan over the discrete twin (``NavEnv.discrete_twin``: the vw
    set) in the same world, on the same test keys."""
    seats = seats_of(name, policies)
    return seats._replace(network=planner_of(name, seats.env, mazes, seats.env_params))


def seats_of(name: str, policies: Policies) -> Policies:
    """:func:`in_place_of` without its planner (``network`` None): the drivers' labels,
    fields, test settings and world, everything but the planner built for the mazes."""
    first: dict[int, int] = {}
    for i, (_, seed) in enumerate(policies.labels):
        first.setdefault(seed, i)
    idx = np.asarray(list(first.values()))
    swept = len(policies.fields[0]) - 2  # (strategy, swept values..., seed)
    env, env_params = policies.env.discrete_twin(policies.env_params)  # continuous: vw
    return policies._replace(
        labels=[(name, seed) for seed in first],
        fields=[(name, *[""] * swept, seed) for seed in first],
        params=np.zeros(len(idx), np.float32),
        env=env,
        env_params=env_params,
        network=None,
        strategy=np.zeros(len(idx), np.int32),
        hyper=jax.tree.map(lambda a: np.asarray(a)[idx], policies.hyper),
    )


def world_policies(
    name: str, cfg: Config, seeds: Sequence[int], env: NavEnv, env_params: EnvParams
) -> Policies:
    """The reference driver ``name`` on its own in a config's world (``env``, its
    ``env_params``), one driver per seed of ``seeds``; with ``run.dwa: barn`` DWA is the
    BARN challenge's (:func:`jaxnav.planners.dwa.barn_dwa`), driving continuous commands."""
    one = dataclasses.replace(cfg, strategies=cfg.strategies[:1], seeds=1, sweep=())
    hyper = run_inputs(one).hyper
    barn = name == "dwa" and cfg.run.dwa in ("barn", "barn_map")
    if barn:  # its own velocity samples, commanded as continuous actions
        env = dataclasses.replace(env, **BARN_SETTINGS)
    else:
        env, env_params = env.discrete_twin(env_params)  # continuous actions: the vw set
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
    if barn:
        plan = raster_for([env_params.maze], RASTER_CELL) if cfg.run.dwa == "barn_map" else None
        return template._replace(network=barn_dwa(env, float(env_params.robot_radius), plan))
    return template._replace(network=planner_of(name, env, [env_params.maze], env_params))


def world_config(world: str, overrides: Sequence[str] = ()) -> Config:
    """The config of a world named on the command line: a config (a shipped config's
    name or a YAML config file: its maze or drawn family and every environment setting),
    else a maze (a built-in maze's name or a maze file) in the default settings, the
    paper's; ``overrides`` (``key=value``) apply on top."""
    path = resolve_config_path(world)
    if os.path.isfile(path) and not _is_maze_file(path):  # tested as a run of it is
        return load_config(path, list(overrides)).tested(overrides)
    make_maze(world)  # a maze, or a one-line error naming what it is not
    return load_config(None, [f"env.maze={world}", *overrides])


def _is_maze_file(path: str) -> bool:
    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except (OSError, yaml.YAMLError):
        return False
    return isinstance(doc, dict) and ("outline" in doc or "image" in doc)  # a ROS map too


class WorldTest(NamedTuple):
    """A reference driver through a world's test: results.csv text, its test mazes'
    names, and per test maze each seed's goal attempts with their shortest paths."""

    text: str
    mazes: list[str]
    attempts: dict[str, list[tuple[Attempts, np.ndarray]]]
    limit: int  # the attempt limit (steps)
    step_m: float  # the most a step drives (m)


def evaluate_world(name: str, cfg: Config, n_seeds: int, n_episodes: int) -> WorldTest:
    """The reference driver ``name`` through the test in a config's world: ``n_seeds``
    test keys (the seeds ``cfg.seed``, ... that a run of the config would have),
    ``n_episodes`` consecutive episodes each, on its maze, or on a drawn family's train
    and test layouts."""
    env, env_params = from_config(cfg, prepare=False)
    seeds = [cfg.seed + i for i in range(n_seeds)]
    fixed_test = families.get(env.generator).fixed_test if env.generates else None
    if fixed_test:  # a benchmark's test worlds, each a fixed maze (BARN's 50, or others)
        names = worlds.expand(list(cfg.run.test_mazes) or [fixed_test])
        fixed = dataclasses.replace(env, generator="", maze_bank=0, maze_bank_refresh=0)
        tests = [(name, fixed) for name in names]
        mazes = [[m] for m in padded_mazes(names)]
    elif env.generates:
        tests = [(drawn_name(cfg, s), dataclasses.replace(env, split=s)) for s in SPLITS]
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
    rows, attempts = [], {}
    for (maze_name, test_env), maze in zip(tests, mazes):
        driver = world_policies(name, cfg, seeds, test_env, env_params)
        (res,) = run_tests(driver, maze, n_episodes, navigation=True)
        attempts[maze_name] = attempt_paths(res, maze[0], n_episodes, paths, limit)
        nav = [[episode_counts(a, sp, step_m, dt, n_episodes) for a, sp in attempts[maze_name]]]
        rows += episode_rows(driver.fields, [maze_name], [res], n_episodes, "greedy", nav)
    text = rundir.csv_text(RESULT_COLUMNS, rows)
    return WorldTest(text, [t[0] for t in tests], attempts, limit, step_m)


# The shipped worlds: the configs' (their maze or drawn family, with their settings),
# then the built-in mazes and maze files no config trains on, in the default settings.
SHIPPED_WORLDS = (
    "paper_no_obstacles",
    "paper_obstacles",
    "stage3",
    "stage4",
    "grid4",
    "cylinders",
    "rooms",
    "square2",
    "square8",
    "triangle",
    "pentagon",
    "pentagon_obstacles",
    "stage3_humble",
    "stage4_humble",
    "configs/mazes/corridor.yaml",
)
GOOD = 0.98  # the oracle's success below which the page says why


def drive_worlds(
    worlds: Sequence[str], n_seeds: int, n_episodes: int, log=lambda text: None
) -> tuple[str, list[str]]:
    """Both reference drivers through each world's test: (the page's data file text,
    results.csv's columns after a ``world`` column; the page's notes on each test maze
    where the oracle's success is below :data:`GOOD`, from its attempts)."""
    rows, notes = [], []
    for world in worlds:
        name, *overrides = world.split()  # a world may carry settings: "stage3 env.actions=vw"
        cfg = world_config(name, overrides)
        for name in baselines.names():
            log(f"{name} in {world}")
            test = evaluate_world(name, cfg, n_seeds, n_episodes)
            rows += [[world, *row] for row in list(csv.reader(io.StringIO(test.text)))[1:]]
            if name == "oracle":
                notes += _shortfalls(world, cfg, test)
    return rundir.csv_text(("world", *RESULT_COLUMNS), rows), notes


def _shortfalls(world: str, cfg: Config, test: WorldTest) -> list[str]:
    """Why the oracle fails where it does, from its attempts: time-outs whose shortest
    path is longer than the attempt limit lets the robot drive, collisions with
    cylinders that move."""
    out = []
    for maze, per_seed in test.attempts.items():
        outcome = np.concatenate([a.outcome for a, _ in per_seed])
        shortest = np.concatenate([sp for _, sp in per_seed])
        decided = outcome != CUT
        success = float(np.mean(outcome[decided] == SUCCESS)) if decided.any() else float("nan")
        if not success < GOOD:
            continue
        where = world if maze == world else f"{world} ({maze})"
        reach = test.limit * test.step_m
        moving = not cfg.env.generator and make_maze(cfg.env.maze).motion is not None
        parts = [f"{where}: the oracle's success is {success:.3f}"]
        timeouts = outcome == TIMEOUT
        if timeouts.any():
            far = shortest[timeouts]
            longer = int(np.sum(far > reach))
            parts.append(
                f"{int(timeouts.sum())} time-outs, {longer} of them to goals whose shortest "
                f"path ({_span(far)} m) is longer than the {reach:g} m its "
                f"{test.limit}-step attempt limit lets the robot drive at its speed"
            )
            if moving and longer < timeouts.sum():
                parts.append(
                    "the others in a world whose cylinders move: the robot found no plan that "
                    "stays clear of them all the way to the goal, kept clear instead, and the "
                    "attempts ran out"
                )
        collisions = int(np.sum(outcome == COLLISION))
        if collisions:
            parts.append(
                f"{collisions} collisions"
                + (
                    ", in a world whose cylinders move, where with the paper's actions the "
                    "robot cannot stop to let one pass"
                    if moving and cfg.env.actions == "paper"
                    else ""
                )
            )
        out.append("; ".join(parts) + ".")
    return out


def _span(x: np.ndarray) -> str:
    lo, hi = float(np.min(x)), float(np.max(x))
    return f"{lo:.1f}" if abs(hi - lo) < 0.05 else f"{lo:.1f}-{hi:.1f}"


__all__ = [
    "GOOD",
    "RASTER_CELL",
    "SHIPPED_WORLDS",
    "WorldTest",
    "drive_worlds",
    "evaluate_world",
    "in_place_of",
    "planner_of",
    "planner_problem",
    "seats_of",
    "world_config",
    "world_policies",
]
