"""Every figure of a run, drawn from its files into RUN_DIR/plots/ (each atomically).

* ``training_curves.png``: episode return vs episode per arm (paper Fig. 2(b) and
  4(c)): a trailing moving average per seed, then the mean over seeds and its 95%
  bootstrap interval; more than three arms get a panel each
  (:mod:`jaxnav.report.fig_training`).
* ``exploration.png``: each arm's exploration over training (explore.csv), the same way.
* ``greedy_evaluation.png`` (a run with ``run.eval_every``): success, collision and
  time-out of the greedy evaluations while it trained, against env steps
  (:mod:`jaxnav.report.fig_evaluation`).
* ``sweep.png`` (a swept run): test return against the swept values, per test mode
  (:mod:`jaxnav.report.fig_sweep`).
* ``trajectory_<maze>.png``: each test maze with its walls and obstacles and every
  arm's path (the config's first seed) over the first test episode, the goals reached
  and where they collided (:mod:`jaxnav.report.fig_trajectory`).
* ``failures_<maze>.png``: where each arm's failed goal attempts ended in each test
  maze, over every seed's greedy test (eval/failures.npz;
  :mod:`jaxnav.report.fig_failures`).
* ``episode.gif``: that test episode of one arm (EBE if trained) on the first test
  maze: robot, LiDAR beams, goal (:mod:`jaxnav.report.fig_episode`).

``jaxnav evaluate RUN_DIR --robustness`` draws ``robustness.png`` beside its
table with :func:`plot_robustness` (:mod:`jaxnav.report.fig_robustness`).

The test episodes are those ``jaxnav evaluate`` recorded in eval/trajectories.npz
(episode 1 of the config's seed, greedy test); a run that has not been evaluated on
these mazes gets the training figures only. Every figure is drawn from files: nothing
here runs the environment or a network. The command is ``jaxnav plots``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from jaxnav.core import rundir
from jaxnav.core.config import load_config
from jaxnav.core.errors import RunError
from jaxnav.report.fig_common import (
    COLORMAPS,
    COLORS,
    ArmStyle,
    arm_colors,
    arm_styles,
    mode_title,
    safe_name,
)
from jaxnav.report.fig_episode import FOOTPRINT, GIF_MAX_BYTES, GIF_MAX_FRAMES, animate_episode
from jaxnav.report.fig_evaluation import greedy_evaluation_note, plot_greedy_evaluation
from jaxnav.report.fig_failures import plot_failures
from jaxnav.report.fig_robustness import ROBUSTNESS_MODE, plot_robustness
from jaxnav.report.fig_sweep import plot_sweep
from jaxnav.report.fig_training import plot_exploration, plot_training_curves
from jaxnav.report.fig_trajectory import plot_trajectory
from jaxnav.report.results import arm_strategy, read_episodes_npz, read_failures_npz
from jaxnav.world.maps import make_maze

__all__ = [
    "COLORMAPS",
    "COLORS",
    "FOOTPRINT",
    "GIF_MAX_BYTES",
    "GIF_MAX_FRAMES",
    "RECORDED_MODE",
    "ROBUSTNESS_MODE",
    "ArmStyle",
    "animate_episode",
    "arm_colors",
    "arm_styles",
    "first_episodes",
    "make_plots",
    "mode_title",
    "plot_exploration",
    "plot_failure_maps",
    "plot_failures",
    "plot_greedy_evaluation",
    "plot_robustness",
    "plot_sweep",
    "plot_test_episodes",
    "plot_training_curves",
    "plot_trajectory",
    "safe_name",
]

# The test mode of the episodes in eval/trajectories.npz: jaxnav.experiments.evaluation
# records the greedy test's (the file does not name its mode).
RECORDED_MODE = "greedy"


def first_episodes(run_dir: Path, maze_names: Sequence[str] | None = None):
    """(config, maze names, mazes, goal radius, first test episodes of the config's
    seed, their test mode) from eval/trajectories.npz; None if the run was not
    evaluated on these mazes."""
    cfg = load_config(str(run_dir / rundir.CONFIG))
    names = list(maze_names) if maze_names else list(cfg.run.test_mazes)
    saved = run_dir / "eval" / "trajectories.npz"
    if not saved.is_file():
        return None
    try:
        episodes, goal_radius = read_episodes_npz(saved)
    except (OSError, ValueError, KeyError) as e:
        raise RunError(f"{saved} cannot be read ({type(e).__name__})") from None
    if not all(n in episodes and set(episodes[n]) == set(cfg.arm_names()) for n in names):
        return None
    mazes = [make_maze(n) for n in names]
    return cfg, names, mazes, goal_radius, episodes, RECORDED_MODE


def plot_test_episodes(
    run_dir: Path, out_dir: Path, maze_names: Sequence[str] | None = None
) -> list[Path]:
    """Trajectory figures for every test maze and the GIF, from the first seed
    (none if the run was not evaluated on these mazes)."""
    found = first_episodes(run_dir, maze_names)
    if found is None:
        return []
    cfg, names, mazes, goal_radius, episodes, mode = found
    written = []
    for name, maze in zip(names, mazes):
        out = out_dir / f"trajectory_{safe_name(name)}.png"
        written.append(
            plot_trajectory(maze, name, episodes[name], cfg.seed, goal_radius, out, mode)
        )
    arms = cfg.arm_names()
    arm = next((a for a in arms if arm_strategy(a) == "ebe"), arms[0])
    ep = episodes[names[0]][arm]
    gif = out_dir / "episode.gif"
    written.append(
        animate_episode(mazes[0], names[0], ep, arm, cfg.seed, goal_radius, gif, mode=mode)
    )
    return written


def plot_failure_maps(run_dir: Path, out_dir: Path) -> list[Path]:
    """A failure map per fixed test maze of the run's last evaluation (none without
    eval/failures.npz)."""
    saved = run_dir / "eval" / "failures.npz"
    if not saved.is_file():
        return []
    try:
        failures, seeds, episodes = read_failures_npz(saved)
    except (OSError, ValueError, KeyError) as e:
        raise RunError(f"{saved} cannot be read ({type(e).__name__})") from None
    return [
        plot_failures(
            make_maze(name),
            name,
            per_arm,
            seeds,
            episodes,
            out_dir / f"failures_{safe_name(name)}.png",
        )  # fmt: skip
        for name, per_arm in failures.items()
    ]


def make_plots(
    run_dir: str | Path, maze_names: Sequence[str] | None = None, window: int | None = None
) -> list[Path]:
    """Every figure of a run into RUN_DIR/plots/; returns the written paths."""
    run_dir = rundir.existing(run_dir)
    for name in (rundir.METRICS, rundir.EXPLORE):
        if not (run_dir / name).is_file():
            raise RunError(f"{run_dir} has no {name}")
    for name in maze_names or ():  # check them before anything is drawn
        make_maze(name)
    out = run_dir / "plots"
    out.mkdir(exist_ok=True)
    written = [
        plot_training_curves(run_dir, out / "training_curves.png", window),
        plot_exploration(run_dir, out / "exploration.png"),
    ]
    evaluated = plot_greedy_evaluation(run_dir, out / "greedy_evaluation.png")
    written += [evaluated] if evaluated is not None else []
    results = run_dir / "eval" / "results.csv"
    if results.is_file():
        swept = plot_sweep(results.read_text(), out / "sweep.png", f"Sweep of {run_dir.name}")
        written += [swept] if swept is not None else []
    written += plot_failure_maps(run_dir, out)
    evaluated_note = "" if evaluated is not None else greedy_evaluation_note(run_dir)
    if evaluated_note:
        print(f"jaxnav plots: {evaluated_note}", file=sys.stderr)
    tests = plot_test_episodes(run_dir, out, maze_names)
    if not tests:
        print(f"jaxnav plots: {untested_note(run_dir, maze_names)}", file=sys.stderr)
    return written + tests


def untested_note(run_dir: Path, maze_names: Sequence[str] | None = None) -> str:
    """Why a run has no trajectory figures, naming the mazes and the command that
    records their test episodes."""
    cfg = load_config(str(run_dir / rundir.CONFIG))
    names = list(maze_names) if maze_names else list(cfg.run.test_mazes)
    mazes = ", ".join(names) if names else "its test mazes"
    tested = (run_dir / "eval" / "trajectories.npz").is_file()
    why = "has no test episodes of " + mazes if tested else "was not tested yet"
    more = f" --mazes {' '.join(names)}" if maze_names else ""
    return (
        f"{run_dir} {why}: `jaxnav evaluate {run_dir}{more}` tests it on {mazes} and "
        "records the episodes the trajectory figures and the GIF are drawn from"
    )
