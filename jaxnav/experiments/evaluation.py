"""Testing the policies of a finished run: load them, play the paper's test on each
test maze (:mod:`jaxnav.experiments.rollout`), write the results and their tables.

Defaults are the run's ``run.test_mazes`` and ``run.test_episodes``; the training
environment's settings (preset, beams, step limit, reward, noise, observation
layout) stay as trained and only the maze changes. Writes, atomically::

    RUN_DIR/eval/results.csv        strategy, seed, mode, maze, episode, return, goals, collided,
                                    length, and the episode's sums over its goal attempts:
                                    attempts, successes, timeouts, path_m, spl_sum, time_s
    RUN_DIR/eval/tables.md          paper-form tables, across-seed statistics, the navigation
                                    metrics, the paper's numbers
    RUN_DIR/eval/trajectories.npz   the first test episode of the config's seed, per strategy
                                    and maze, step by step (for jaxnav.report.plots)

The reference drivers' rows (the oracle's and DWA's, on the same test keys) are read
from the user's cache where an earlier test drove exactly the same test
(:mod:`jaxnav.experiments.refcache`), and driven and kept there otherwise.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.agent.trainer import run_inputs
from jaxnav.core import agents, baselines, families, rundir, worlds
from jaxnav.core.config import Config, load_config
from jaxnav.core.errors import ConfigError, JaxnavError, RunError
from jaxnav.core.families import family_text
from jaxnav.core.sweep import with_swept
from jaxnav.env import from_config
from jaxnav.experiments.baselines import planner_problem
from jaxnav.experiments.navigation import ShortestPaths, failure_points, navigation_counts
from jaxnav.experiments.refcache import ReferenceTest
from jaxnav.experiments.rollout import (
    MODES,
    Policies,
    drawn_name,
    first_episode,
    padded_mazes,
    run_tests,
)
from jaxnav.report.results import (
    RESULT_COLUMNS,
    Episodes,
    Failures,
    episode_rows,
    episodes_npz,
    failures_npz,
)
from jaxnav.report.tables import tables_markdown
from jaxnav.world.generators import SPLITS


class LoadedRun(NamedTuple):
    config: Config
    policies: Policies


def load_run(run_dir: str | Path, overrides: Sequence[str] = ()) -> LoadedRun:
    """Config and trained policies of a finished run (RunError if it cannot be used).
    ``overrides``: ``env.KEY=VALUE`` settings the policies are tested in instead of
    those they trained in (:func:`test_overrides`)."""
    run_dir = rundir.existing(run_dir, finished=True)
    cfg_path, params_path = run_dir / rundir.CONFIG, run_dir / rundir.PARAMS
    cfg = tested_config(cfg_path, overrides)
    env, env_params = from_config(cfg, prepare=False)
    if env.generates:  # trained on drawn mazes: tested on the fixed test mazes by name
        # (and on drawn ones: drawn_policies). A fixed maze has no grid of shortest
        # paths, so a geodesic run's test there scores the dense reward (progress
        # along the straight line).
        reward = "dense" if env.reward == "geodesic" else env.reward
        fixed = {
            "generator": "",
            "maze_bank": 0,
            "maze_bank_refresh": 0,
            "broad_phase": "auto",  # a fixed maze has no lattice
            "progress_path": "straight",
        }
        env = dataclasses.replace(env, reward=reward, **fixed)
    network = agents.get(cfg.agent).network_of(cfg, env)
    template = network.init(jax.random.PRNGKey(0), jnp.zeros(env.obs_size))
    dropped = diverged_runs(run_dir)
    all_labels = cfg.run_labels()
    kept = [r for r, label in enumerate(all_labels) if label not in dropped]
    labels = [all_labels[r] for r in kept]
    if dropped:
        names = ", ".join(f"{s} seed {n}" for s, n in sorted(dropped))
        print(f"note: not testing the runs that diverged in training: {names}", file=sys.stderr)
    if not labels:
        raise RunError(f"{run_dir}: every run diverged in training; nothing to test")
    trees = []
    for strategy, seed in labels:
        tree = rundir.load_params(params_path, strategy, seed)
        if not all(np.isfinite(a).all() for a in jax.tree.leaves(tree)):
            raise RunError(f"{params_path}: {strategy} seed {seed} has non-finite parameters")
        try:
            shapes_ok = jax.tree.structure(tree) == jax.tree.structure(template) and all(
                np.shape(a) == np.shape(b)
                for a, b in zip(jax.tree.leaves(tree), jax.tree.leaves(template))
            )
        except Exception:
            shapes_ok = False
        if not shapes_ok:
            raise RunError(
                f"{params_path} does not match the network of {cfg_path} ({strategy} seed {seed})"
            )
        trees.append(tree)
    params = jax.tree.map(lambda *xs: jnp.asarray(np.stack(xs), jnp.float32), *trees)
    # A run limited by total_steps ends at different episodes: epsilon at its floor.
    episodes = cfg.episodes if cfg.episodes is not None else 2**30
    inputs = run_inputs(cfg)
    strategy = inputs.strategy[kept]
    hyper = jax.tree.map(lambda a: a[kept], inputs.hyper)
    all_fields = cfg.run_fields()
    fields = [all_fields[r] for r in kept]
    policies = Policies(labels, fields, params, env, env_params, network, strategy, hyper, episodes)
    return LoadedRun(cfg, policies)


def test_overrides(overrides: Sequence[str]) -> Sequence[str]:
    """``overrides`` if each is an environment setting (``env.KEY=VALUE``): a test
    changes the world the policies drive in, never how they were trained; a change
    the network cannot read (another observation size) is refused when the policies
    load."""
    for o in overrides:
        if not o.startswith("env."):
            raise ConfigError(
                f"{o}: a run is tested with other environment settings only (env.KEY=VALUE)"
            )
    return overrides


def tested_config(cfg_path: Path, overrides: Sequence[str] = ()) -> Config:
    """The config a run's policies are tested in: the run's, with ``overrides``
    (:func:`test_overrides`), and every training-only setting off (the moving
    cylinders at their own pace, real collisions: :meth:`Config.tested`) unless an
    override sets it. A run trained on drawn mazes is tested with a new layout every
    episode whatever ``env.new_maze_every`` it trained with, so its config is read
    with that (an override such as ``env.restart_goal=new``, which needs it, holds)."""
    overrides = list(test_overrides(overrides))
    if load_config(str(cfg_path)).env.generator and not any(
        o.startswith("env.new_maze_every=") for o in overrides
    ):
        overrides = ["env.new_maze_every=1", *overrides]
    return load_config(str(cfg_path), overrides).tested(overrides)


def trained_on(cfg: Config) -> str:
    """What a run trained on: its maze, or its drawn mazes' family."""
    e = cfg.env
    if e.generator:
        return f"{family_text(e)} ({e.split} split)"
    return e.maze


def diverged_runs(run_dir: Path) -> set[tuple[str, int]]:
    """(strategy, seed) of the runs summary.json lists as diverged (dropped in training)."""
    try:
        summary = json.loads((run_dir / rundir.SUMMARY).read_text())
        return {(d["strategy"], int(d["seed"])) for d in summary.get("diverged", [])}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return set()


def test_setup(
    run: LoadedRun, maze_names: Sequence[str] | None, n_episodes: int | None, default: list[str]
) -> tuple[list[str], int]:
    """The test mazes (default ``default``) and episode count (default the config's)."""
    names = worlds.expand(maze_names if maze_names else default)  # a set: its worlds
    if not names and not run.config.env.generator:
        raise JaxnavError("no test mazes: name some, or set run.test_mazes in the config")
    if len(set(names)) != len(names):
        raise JaxnavError("a maze is listed twice")
    n_episodes = run.config.run.test_episodes if n_episodes is None else n_episodes
    if n_episodes < 1:
        raise JaxnavError("--episodes must be at least 1")
    return names, n_episodes


def evaluate(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    modes: Sequence[str] = MODES,
    more_drawn: dict[str, Config] | None = None,
    references: Sequence[str] = baselines.names(),
    say: Callable[[str], None] | None = None,
    overrides: Sequence[str] = (),
    family_splits: bool = True,
) -> tuple[LoadedRun, list[str], str, Episodes, Failures]:
    """Test every run of ``run_dir`` in ``modes`` (both: greedy, then exploring).

    ``more_drawn``: results name -> a config whose drawn mazes (its ``env.split``)
    the policies are tested in too, for example a larger size of the run's family.
    ``references``: the reference drivers (:mod:`jaxnav.experiments.baselines`) that
    take the greedy test beside the policies, once per seed on the same keys.
    ``say``: called with a line before each test starts (progress), if given.
    ``overrides``: environment settings to test in instead of the trained ones.
    ``family_splits``: a run trained on drawn mazes is tested on its family's train and
    test layouts too (False: on the mazes named only).
    Returns (run, maze names, results.csv text, the first greedy test episode of
    the config's seed per maze and strategy, where each arm's failed greedy attempts
    ended in each test maze, pooled over its seeds).
    """
    run = load_run(run_dir, overrides)
    names, n_episodes = test_setup(run, maze_names, n_episodes, run.config.run.test_mazes)
    labels = run.policies.labels
    mazes = padded_mazes(names) if names else []  # a drawn run may test on its splits only
    paths = ShortestPaths(float(run.policies.env_params.robot_radius))

    def counts(policies: Policies, mazes, results):
        """Each maze's, run's and episode's sums over its goal attempts."""
        p = policies.env_params
        step_m, dt = float(p.v) * float(p.dt), float(p.dt)
        limit = policies.env.attempt_steps(p)
        return [
            navigation_counts(res, maze, n_episodes, step_m, dt, paths, limit)
            for maze, res in zip(mazes, results)
        ]

    rows, episodes, failures = [], {}, {}
    tell = say or (lambda _: None)
    for mode in modes:
        results = []
        if mazes:
            tell(f"testing {len(labels)} policies, {mode}, on {', '.join(names)}")
            results = run_tests(
                run.policies, mazes, n_episodes, record=mode == "greedy", mode=mode, navigation=True
            )
        nav = counts(run.policies, mazes, results)
        rows += episode_rows(run.policies.fields, names, results, n_episodes, mode, nav)
        refs = _usable(references, run.policies.env) if mode == "greedy" else []
        for ref in refs if mazes else ():
            test = ReferenceTest(ref, run.policies, mazes, n_episodes)
            tell(f"the {ref} on {', '.join(names)}{_FROM_CACHE if test.cached else ''}")
            res, nav = test.run(counts)
            rows += episode_rows(test.fields, names, res, n_episodes, mode, nav)
        if mode == "greedy":
            limit = run.policies.env.attempt_steps(run.policies.env_params)
            for name, res in zip(names, results):
                per_run = failure_points(res, n_episodes, limit)
                failures[name] = {
                    arm: {
                        k: np.concatenate(
                            [per_run[i][k] for i, (a, _) in enumerate(labels) if a == arm]
                        )
                        for k in ("collision", "timeout")
                    }
                    for arm in dict.fromkeys(a for a, _ in labels)
                }
            first = [i for i, (_, seed) in enumerate(labels) if seed == run.config.seed]
            episodes = {
                name: {labels[i][0]: first_episode(res, i) for i in first}
                for name, res in zip(names, results)
            }
        # The family's train layouts (drawn with the test's keys), then its test
        # layouts, which training never saw: their difference is the gap.
        drawn_tests = [
            (drawn_name(run.config, split), drawn_policies(run, split))
            for split in (SPLITS if family_splits and drawn_splits(run.config) else ())
        ]
        drawn_tests += [
            (name, drawn_policies(run, cfg.env.split, cfg))
            for name, cfg in (more_drawn or {}).items()
        ]
        for name, drawn in drawn_tests:
            tell(f"testing {len(labels)} policies, {mode}, on {name}")
            template = [drawn.env_params.maze]
            results = run_tests(drawn, template, n_episodes, mode=mode, navigation=True)
            nav = counts(drawn, template, results)
            rows += episode_rows(drawn.fields, [name], results, n_episodes, mode, nav)
            for ref in _usable(refs, drawn.env):
                test = ReferenceTest(ref, drawn, template, n_episodes)
                tell(f"the {ref} on {name}{_FROM_CACHE if test.cached else ''}")
                res, nav = test.run(counts)
                rows += episode_rows(test.fields, [name], res, n_episodes, mode, nav)
    columns = with_swept(RESULT_COLUMNS, run.config.sweep)
    return run, names, rundir.csv_text(columns, rows), episodes, failures


def drawn_splits(cfg: Config) -> bool:
    """Whether a run's test draws its family's layouts: a drawn family without a set of
    fixed test worlds (BARN's are tested by name, run.test_mazes)."""
    e = cfg.env
    return bool(e.generator) and families.get(e.generator).fixed_test is None


_FROM_CACHE = " (its rows from the cache of earlier tests)"


def _usable(references: Sequence[str], env) -> list[str]:
    """The reference drivers that can drive in ``env``; a note for each that cannot."""
    out = []
    for ref in references:
        why = planner_problem(ref, env)
        if why:
            print(f"note: no {ref} rows: {why}", file=sys.stderr)
        else:
            out.append(ref)
    return out


def drawn_policies(run: LoadedRun, split: str = "test", cfg: Config | None = None) -> Policies:
    """A run trained on drawn mazes, its policies in the family's ``split``: every
    test episode in a maze of its own, drawn as in training (whatever
    ``env.new_maze_every`` training kept a layout for, the test draws a new one every
    episode, so N test episodes are N layouts); the test split's layouts are those
    training never draws. ``cfg``: draw from this config's family instead (the same
    sensor and observation)."""
    env, env_params = from_config(cfg if cfg is not None else run.config, prepare=False)
    env = dataclasses.replace(env, split=split, new_maze_every=1)
    return run.policies._replace(env=env, env_params=env_params)


def evaluate_to_dir(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    out: str | Path | None = None,
    modes: Sequence[str] = MODES,
    more_drawn: dict[str, Config] | None = None,
    references: Sequence[str] = baselines.names(),
    say: Callable[[str], None] | None = None,
    overrides: Sequence[str] = (),
    family_splits: bool = True,
) -> Path:
    """Evaluate; write results.csv, tables.md, trajectories.npz and, for fixed test
    mazes, failures.npz (each atomically) into ``out``. ``overrides``: environment
    settings to test in instead of the trained ones (the tables' title names them);
    ``family_splits``: as :func:`evaluate`'s."""
    run, names, text, episodes, failures = evaluate(
        run_dir,
        maze_names,
        n_episodes,
        modes,
        more_drawn,
        references,
        say,
        overrides,
        family_splits,
    )
    title = f"Test results of {Path(run_dir).name}"
    if overrides:
        title += f", tested with {' '.join(overrides)}"
    tables = tables_markdown(text, trained_on(run.config), run.config.seed, title=title)
    out = Path(out) if out is not None else Path(run_dir) / "eval"
    out.mkdir(parents=True, exist_ok=True)
    goal_radius = float(run.policies.env_params.goal_radius)
    rundir.atomic_write_text(out / "results.csv", text)
    rundir.atomic_write_text(out / "tables.md", tables)
    rundir.atomic_write_bytes(out / "trajectories.npz", episodes_npz(episodes, goal_radius))
    if failures:
        seeds = len({seed for _, seed in run.policies.labels})
        n = n_episodes if n_episodes is not None else run.config.run.test_episodes
        rundir.atomic_write_bytes(out / "failures.npz", failures_npz(failures, seeds, n))
    elif (out / "failures.npz").is_file():  # a test of drawn mazes only: no map to put them on
        (out / "failures.npz").unlink()
    return out
