"""Sim-to-sim transfer: a run's trained policies in MuJoCo beside jaxnav's own test.

Every trained policy of a run, exported as for the robot
(:func:`jaxnav.robot.export.export_policy`, run greedily by the NumPy
:class:`jaxnav.robot.deploy.Policy`, no fine-tuning), drives a TurtleBot3 burger in
MuJoCo physics (:mod:`jaxnav.robot.mujoco_model`) through the paper's test
(:mod:`jaxnav.robot.mujoco_rollout`), beside jaxnav's own result for the same
policies. This module reads the run's test constants and goal sets from its config
and mazes (:func:`task_of`, :func:`goals_of`) and writes the results.

jaxnav's own result is the greedy rows of ``RUN_DIR/eval/results.csv`` when they
cover the same mazes, strategies and seeds, else a fresh greedy test
(:mod:`jaxnav.experiments.evaluation`'s loading,
:func:`jaxnav.experiments.rollout.run_tests`). :func:`sim2sim` writes::

    FILE (default RUN_DIR/sim2sim/sim2sim.csv)   simulator, strategy, seed, maze,
        episodes, return, goals, collision_rate, length: per-seed means
    FILE with .md   the gap: return, goals per episode and collision rate per
        strategy over all seeds and mazes, jaxnav beside MuJoCo, with 95% bootstrap
        intervals over seeds, then per maze (:func:`jaxnav.report.sim2sim_tables.gap_markdown`)

MuJoCo is imported only by this pipeline (optional extra ``sim``): without it, every
other module of jaxnav works and :func:`sim2sim` says how to install it. The command
is :mod:`jaxnav.commands.sim2sim`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from jaxnav.core import cli, rundir
from jaxnav.core.config import Config, load_config
from jaxnav.core.errors import JaxnavError
from jaxnav.env import from_config
from jaxnav.experiments.evaluation import diverged_runs, load_run
from jaxnav.experiments.rollout import padded_mazes, run_tests
from jaxnav.report.results import EPISODE_COLUMNS, episode_rows, ordered_unique, read_results
from jaxnav.report.sim2sim_tables import SUMMARY_COLUMNS, gap_markdown
from jaxnav.robot.deploy import Policy
from jaxnav.robot.export import export_policy
from jaxnav.robot.mujoco_model import TIMESTEP, mujoco_module
from jaxnav.robot.mujoco_rollout import (
    LIDAR_NOISE_STD,
    N_RAYS,
    Burger,
    Episodes,
    Goals,
    Task,
    play,
    sim_rng,
)
from jaxnav.world.maps import ROBOTIS_FIRST_GOAL, ROBOTIS_GOAL_SEPARATION, Maze, make_maze


def task_of(cfg: Config) -> Task:
    """The test constants of a run's config (its env's params and settings)."""
    env, p = from_config(cfg, prepare=False)
    if env.reward == "geodesic" or env.progress_path == "geodesic":
        raise JaxnavError(
            "sim2sim scores the dense, sparse and progress (straight) rewards in MuJoCo, "
            "not a reward along the maze's shortest path (env.reward / env.progress_path "
            "geodesic)"
        )
    return Task(
        omegas=np.asarray(p.omegas, np.float64),
        R_plus=float(p.R_plus),
        R_minus=float(p.R_minus),
        reward_span=float(p.reward_span),
        reward_distance_exp=bool(p.reward_distance_exp),
        goal_radius=float(p.goal_radius),
        max_steps=int(p.max_steps),
        goal_min_separation=float(p.goal_min_separation),
        goal_candidates=int(env.goal_candidates),
        goal_sampler=env.goal_sampler,
        min_range=float(p.min_range),
        max_range=float(p.max_range),
        reward_kind=env.reward,
        progress_scale=float(p.progress_scale),
        step_penalty=float(p.step_penalty),
        proximity_penalty=float(p.proximity_penalty),
        proximity_distance=float(p.proximity_distance),
        change_penalty=float(p.change_penalty),
        robot_radius=float(p.robot_radius),
    )


def goals_of(maze: Maze, task: Task) -> Goals:
    """The goal set of a test maze under the run's goal sampler."""
    if task.goal_sampler == "robotis":
        n, s = int(maze.n_robotis_goals), float(maze.robotis_scale)
        points = np.asarray(maze.robotis_goals, np.float64)[:n]
        sep = (ROBOTIS_GOAL_SEPARATION - 0.05) * s  # decides exactly on the 0.1 s grid
        return Goals(points, True, sep, np.asarray(ROBOTIS_FIRST_GOAL) * s, task.goal_candidates)
    points = np.asarray(maze.goal_points, np.float64)[: int(maze.n_goal_points)]
    return Goals(points, False, task.goal_min_separation, None, task.goal_candidates)


# ----------------------------------------------------------------------------
# A run's policies in MuJoCo and in jaxnav
# ----------------------------------------------------------------------------


def policy_labels(run_dir: Path, cfg: Config, seeds: Sequence[int] | None) -> list[tuple[str, int]]:
    """(strategy, seed) of the run's policies to test: ``seeds`` (default all), without
    those that diverged in training."""
    dropped = diverged_runs(run_dir)
    labels = [label for label in cfg.run_labels() if label not in dropped]
    if seeds:
        have = ordered_unique(s for _, s in labels)
        missing = [s for s in seeds if s not in have]
        if missing:
            raise JaxnavError(
                f"{run_dir} has no policy of seed {missing[0]} (seeds: {', '.join(map(str, have))})"
            )
        labels = [(st, s) for st, s in labels if s in seeds]
    if not labels:
        raise JaxnavError(f"{run_dir}: no policy to test (every run diverged in training)")
    return labels


def mujoco_results(
    run_dir: Path,
    cfg: Config,
    names: Sequence[str],
    labels: Sequence[tuple[str, int]],
    n_episodes: int,
    noise_std: float = LIDAR_NOISE_STD,
    timestep: float = TIMESTEP,
    progress=None,
    wheel_limit: bool = False,
) -> dict[tuple[str, str, int], Episodes]:
    """{(maze, strategy, seed): Episodes} of every exported policy in MuJoCo, the burger's
    commands clipped by its firmware's wheel limits with ``wheel_limit``."""
    task = task_of(cfg)
    policies = {label: Policy.from_arrays(export_policy(run_dir, *label)) for label in labels}
    out = {}
    for name in names:
        maze = make_maze(name)
        robot = Burger(maze, timestep, task.min_range, task.max_range, wheel_limit)
        goals, start = goals_of(maze, task), np.asarray(maze.start, np.float64)
        surfaces = (maze.walls().astype(np.float64), maze.obstacles().astype(np.float64))
        t0 = time.perf_counter()
        for strategy, seed in labels:
            rng = sim_rng(seed, name)
            res = play(
                policies[(strategy, seed)],
                robot,
                start,
                goals,
                task,
                n_episodes,
                rng,
                noise_std,
                surfaces,
            )
            out[(name, strategy, seed)] = res
        if progress:
            progress(
                f"{name}: {len(labels)} policies x {n_episodes} episodes in MuJoCo, "
                f"{time.perf_counter() - t0:.0f} s"
            )
    return out


def jaxnav_results(
    run_dir: Path, names: Sequence[str], labels: Sequence[tuple[str, int]]
) -> tuple[dict[tuple[str, str, int], Episodes], str]:
    """({(maze, strategy, seed): Episodes} of jaxnav's greedy test, where they came from):
    RUN_DIR/eval/results.csv if it covers every test, else a fresh greedy test with the
    config's test episodes."""
    path = run_dir / "eval" / "results.csv"
    keys = [(m, s, k) for m in names for s, k in labels]
    res = read_results(path.read_text(), "greedy") if path.is_file() else {}
    source = f"{path} (greedy)"
    if not all(k in res for k in keys):
        run = load_run(run_dir)
        n = run.config.run.test_episodes
        tests = run_tests(run.policies, padded_mazes(names), n, mode="greedy")
        rows = episode_rows(run.policies.labels, names, tests, n, "greedy")
        res = read_results(rundir.csv_text(EPISODE_COLUMNS, rows), "greedy")
        source = f"jaxnav.experiments.rollout greedy test, {n} episodes"
    out = {
        k: Episodes(res[k]["return"], res[k]["goals"], res[k]["collided"] > 0, res[k]["length"])
        for k in keys
    }
    return out, source


def summary_rows(simulator: str, results: dict[tuple[str, str, int], Episodes]):
    """Per-seed rows (simulator, strategy, seed, maze, episodes, return, goals,
    collision_rate, length) of per-episode results: means over the episodes."""
    for (maze, strategy, seed), e in results.items():
        yield (
            simulator,
            strategy,
            seed,
            maze,
            len(e.ret),
            f"{float(np.mean(e.ret)):.4f}",
            f"{float(np.mean(e.goals)):.4f}",
            f"{float(np.mean(e.collided)):.4f}",
            f"{float(np.mean(e.length)):.2f}",
        )


# ----------------------------------------------------------------------------
# The pipeline
# ----------------------------------------------------------------------------


def sim2sim(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    seeds: Sequence[int] | None = None,
    out: str | Path | None = None,
    noise_std: float = LIDAR_NOISE_STD,
    progress=None,
    overwrite: bool = False,
    wheel_limit: bool = False,
) -> tuple[Path, Path]:
    """Test a run's policies in MuJoCo and in jaxnav; write the CSV and its table.
    ``wheel_limit``: the MuJoCo burger's commands go through its firmware's wheel
    limits (:func:`jaxnav.world.kinematics.firmware_limit`); jaxnav's test stays in
    the run's own settings.

    An ``out`` CSV or its .md table that exists already is refused before any work
    unless ``overwrite``; the default output, in the run directory, is replaced.
    Returns the paths of the CSV and of the markdown table.
    """
    mujoco = mujoco_module()  # before any work: say at once if MuJoCo is missing
    run_dir = rundir.existing(run_dir, finished=True)
    cfg = load_config(str(run_dir / rundir.CONFIG))
    if n_episodes is not None and n_episodes < 1:
        raise JaxnavError("--episodes must be at least 1")
    if not (math.isfinite(noise_std) and noise_std >= 0):
        raise JaxnavError(f"--lidar-noise must be a finite number >= 0, not {noise_std}")
    names = list(maze_names) if maze_names else list(cfg.run.test_mazes)
    if len(set(names)) != len(names):
        raise JaxnavError("a maze is listed twice")
    for name in names:
        make_maze(name)  # a bad maze fails before any simulation
    n_episodes = cfg.run.test_episodes if n_episodes is None else n_episodes
    labels = policy_labels(run_dir, cfg, seeds)
    given = out is not None
    out = Path(out) if given else run_dir / "sim2sim" / "sim2sim.csv"
    md = out.with_suffix(".md")
    if out.parent == run_dir / "sim2sim":
        out.parent.mkdir(exist_ok=True)
    if given:
        for path in (out, md):
            cli.check_output(path, overwrite)
    jx, source = jaxnav_results(run_dir, names, labels)
    mj = mujoco_results(
        run_dir,
        cfg,
        names,
        labels,
        n_episodes,
        noise_std,
        progress=progress,
        wheel_limit=wheel_limit,
    )
    text = rundir.csv_text(
        SUMMARY_COLUMNS, [*summary_rows("jaxnav", jx), *summary_rows("mujoco", mj)]
    )
    table = gap_markdown(text, f"Sim-to-sim gap of {run_dir.name}: jaxnav and MuJoCo")
    table += (
        f"\njaxnav: {source}. MuJoCo {mujoco.__version__}: physics step {TIMESTEP} s, "
        f"LiDAR noise sigma {noise_std} m, {N_RAYS} rays"
        f"{', commands clipped by the firmware wheel limits' if wheel_limit else ''}.\n"
    )
    rundir.atomic_write_text(out, text)
    rundir.atomic_write_text(md, table)
    return out, md
