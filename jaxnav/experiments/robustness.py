"""Robustness: the paper's test replayed under sensor and start-pose perturbations.

Each setting of :data:`PERTURBATIONS` (range noise, beam dropout, odometry noise,
random start poses) replaces the training environment's setting, on the training
maze (or ``--mazes``); every other setting stays as trained. Writes, atomically::

    RUN_DIR/eval/robustness.csv     strategy, seed, perturbation, maze, episode, return,
                                    goals, collided, length
    RUN_DIR/eval/robustness.md      per perturbation and strategy: mean return over seeds
                                    [95% CI], its change from the unperturbed row,
                                    goals per episode, collision rate
    RUN_DIR/eval/robustness.png     return per perturbation and strategy

The unperturbed setting (``none``) is the plain test: its rows equal results.csv's
for the same mazes and episodes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from jaxnav.core import rundir
from jaxnav.core.errors import JaxnavError
from jaxnav.core.settings import REALISM
from jaxnav.core.sweep import with_swept
from jaxnav.env import ENV_FIELDS, PARAM_FIELDS, EnvParams, NavEnv
from jaxnav.experiments.evaluation import LoadedRun, load_run, test_setup
from jaxnav.experiments.rollout import padded_mazes, run_tests
from jaxnav.report import plots
from jaxnav.report.results import ROBUSTNESS_COLUMNS, UNPERTURBED, episode_rows
from jaxnav.report.tables import robustness_markdown

# The sweep: name -> settings that replace the training environment's; every other
# setting keeps its training value. A key is an EnvParams field (data: the compiled
# rollout is reused) or a NavEnv field (static: one compile per setting). Add a row
# to extend the sweep; the first row is the reference the others are compared with.
PERTURBATIONS: dict[str, dict[str, Any]] = {
    UNPERTURBED: {},
    "range_noise_0.02": {"lidar_noise_std": 0.02},
    "range_noise_0.05": {"lidar_noise_std": 0.05},
    "range_noise_0.1": {"lidar_noise_std": 0.1},
    "beam_dropout_0.05": {"beam_dropout": 0.05},
    "beam_dropout_0.2": {"beam_dropout": 0.2},
    "odom_noise_0.05": {"odom_noise": (0.05, 0.05)},
    "random_start": {"random_start": True},
}


def perturb(
    env: NavEnv, env_params: EnvParams, overrides: dict[str, Any]
) -> tuple[NavEnv, EnvParams]:
    """The environment with ``overrides`` replacing its settings (raises JaxnavError).

    The observation must keep its size: the policy's network is fixed.
    """
    unknown = sorted(set(overrides) - PARAM_FIELDS - ENV_FIELDS)
    if unknown:
        raise JaxnavError(f"unknown environment setting '{unknown[0]}' in a perturbation")
    static = {k: v for k, v in overrides.items() if k in ENV_FIELDS}
    data = {k: v for k, v in overrides.items() if k in PARAM_FIELDS}
    try:
        new_env = dataclasses.replace(env, **static)
    except (TypeError, ValueError) as e:
        raise JaxnavError(f"perturbation {overrides}: {e}") from None
    if new_env.obs_size != env.obs_size:
        raise JaxnavError(f"perturbation {overrides} changes the observation size")
    return new_env, env_params.replace(**data)


def realism_settings(env: NavEnv, env_params: EnvParams) -> dict[str, Any]:
    """The sensor and start-pose settings of an environment (``jaxnav.core.settings.REALISM``)."""
    return {k: getattr(env_params if k in PARAM_FIELDS else env, k) for k in REALISM}


def robustness(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    perturbations: dict[str, dict[str, Any]] = PERTURBATIONS,
    say: Callable[[str], None] | None = None,
) -> tuple[LoadedRun, list[str], str]:
    """Test every run of ``run_dir`` under each perturbation of the training env.

    The plain test (:func:`evaluate`'s rollout, keys and episodes) with the env's
    settings replaced; defaults: the training maze, ``run.test_episodes``.
    ``say``: called with a line before each perturbation's test (progress), if given.
    Returns (run, maze names, robustness.csv text).
    """
    run = load_run(run_dir)
    names, n_episodes = test_setup(run, maze_names, n_episodes, [run.config.env.maze])
    if not perturbations:
        raise JaxnavError("no perturbations to test")
    pol = run.policies
    settings = {p: perturb(pol.env, pol.env_params, ov) for p, ov in perturbations.items()}
    mazes = padded_mazes(names)
    rows = []
    for i, (p, (env, env_params)) in enumerate(settings.items()):
        if say is not None:
            what = f"{len(pol.labels)} policies on {', '.join(names)}"
            say(f"testing {what} under {p} ({i + 1} of {len(settings)})")
        # record=True: the same program as evaluate()'s, so "none" repeats it exactly.
        # A perturbed setting replaces the run's own where it swept it.
        hyper = pol.hyper.replace(**{k: None for k in perturbations[p] if hasattr(pol.hyper, k)})
        perturbed = pol._replace(env=env, env_params=env_params, hyper=hyper)
        results = run_tests(perturbed, mazes, n_episodes, record=True)
        rows += episode_rows(pol.fields, names, results, n_episodes, p)
    columns = with_swept(ROBUSTNESS_COLUMNS, run.config.sweep)
    return run, names, rundir.csv_text(columns, rows)


def robustness_to_dir(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    out: str | Path | None = None,
    perturbations: dict[str, dict[str, Any]] = PERTURBATIONS,
    say: Callable[[str], None] | None = None,
) -> Path:
    """The robustness sweep; write robustness.csv, .md and .png (each atomically) into
    ``out``; ``say`` as :func:`robustness`'s."""
    run, _, text = robustness(run_dir, maze_names, n_episodes, perturbations, say)
    name = Path(run_dir).name
    pol = run.policies
    md = robustness_markdown(
        text,
        run.config.env.maze,
        realism_settings(pol.env, pol.env_params),
        perturbations,
        title=f"Robustness of {name} to sensor noise",
        figure="robustness.png",
    )
    out = Path(out) if out is not None else Path(run_dir) / "eval"
    out.mkdir(parents=True, exist_ok=True)
    rundir.atomic_write_text(out / "robustness.csv", text)
    rundir.atomic_write_text(out / "robustness.md", md)
    plots.plot_robustness(text, out / "robustness.png", title=f"{name}: return under perturbations")
    return out
