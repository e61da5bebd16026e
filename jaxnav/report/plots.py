"""``python -m jaxnav.plots RUN_DIR [--mazes M ...] [--window W]``: figures of a run.

Writes into RUN_DIR/plots/ (each file atomically):

* ``training_curves.png``: episode return vs episode for EBE and epsilon-greedy
  (paper Fig. 2(b) and 4(c)): a trailing moving average per seed, then the mean
  over seeds and its 95% bootstrap interval.
* ``exploration.png``: EBE's per-step entropy H(s) and epsilon over training
  (explore.csv), mean and 95% bootstrap interval over seeds.
* ``trajectory_<maze>.png``: each test maze with its walls and obstacles and the
  path of both policies (the config's first seed) over the first test episode,
  the goals they reached and where they collided.
* ``episode.gif``: an animation of that test episode of one policy (EBE if
  trained) on the first test maze: robot, LiDAR beams, goal.

``python -m jaxnav.evaluate RUN_DIR --robustness`` draws ``robustness.png`` beside
its table with :func:`plot_robustness`: the mean return over seeds under each
perturbation, a bar per strategy with its 95% bootstrap interval.

The test episodes are those ``jaxnav.evaluate`` recorded in eval/trajectories.npz
(episode 1 of the config's seed); a run that has not been evaluated on these mazes
gets the first two figures only. Every figure is drawn from files: nothing here
runs the environment or a network.
"""

from __future__ import annotations

import csv
import io
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402
from PIL import Image  # noqa: E402

from jaxnav.core import (
    cli,  # noqa: E402
    rundir,  # noqa: E402
)
from jaxnav.core.config import load_config  # noqa: E402
from jaxnav.core.errors import ConfigError, JaxnavError, RunError  # noqa: E402
from jaxnav.core.sweep import row_arm, swept_columns
from jaxnav.report import drawing, stats  # noqa: E402
from jaxnav.report.results import (  # noqa: E402
    arm_strategy,
    arms_in,
    display_name,
    read_episodes_npz,
    read_results,
    result_modes,
    robustness_summary,
    scores_over_mazes,
)
from jaxnav.world.maps import Maze, make_maze  # noqa: E402

COLORS = {"ebe": "tab:blue", "epsilon_greedy": "tab:orange", "boltzmann": "tab:green"}
COLORMAPS = {"ebe": "Blues", "epsilon_greedy": "Oranges", "boltzmann": "Greens"}


def arm_colors(arms) -> dict[str, Any]:
    """A colour per arm: its strategy's colour, or, where a strategy has several sweep
    points, shades of the strategy's colour map from light to dark in point order."""
    out: dict[str, Any] = {}
    for s in COLORS:
        mine = [a for a in arms if arm_strategy(a) == s]
        if len(mine) == 1:
            out[mine[0]] = COLORS[s]
        for i, a in enumerate(mine if len(mine) > 1 else []):
            out[a] = plt.get_cmap(COLORMAPS[s])(0.35 + 0.6 * i / (len(mine) - 1))
    return out


FOOTPRINT = 0.105  # m, TurtleBot3 burger disc (the 0.13 m collision radius is drawn dashed)
GIF_MAX_BYTES = 1_000_000
GIF_MAX_FRAMES = 60


# ----------------------------------------------------------------------------
# Files
# ----------------------------------------------------------------------------


def _save_fig(fig, path: Path, **kw) -> Path:
    """Render a figure and write the file whole or not at all."""
    buf = io.BytesIO()
    fig.savefig(buf, format=path.suffix.lstrip("."), **kw)
    plt.close(fig)
    rundir.atomic_write_bytes(path, buf.getvalue())
    return path


def _gif_bytes(fig, update, frames: Sequence[int], dpi: int, fps: int = 10) -> bytes:
    """An animated GIF of ``fig`` after ``update(t)`` for each frame t (as PillowWriter)."""
    width, height = (int(round(x * dpi)) for x in fig.get_size_inches())
    images = []
    for t in frames:
        update(t)
        buf = io.BytesIO()
        fig.savefig(buf, format="rgba", dpi=dpi)
        images.append(
            Image.frombuffer("RGBA", (width, height), buf.getbuffer(), "raw", "RGBA", 0, 1)
        )
    out = io.BytesIO()
    images[0].save(
        out, format="GIF", save_all=True, append_images=images[1:], duration=1000 // fps, loop=0
    )
    return out.getvalue()


def _read_csv(path: Path) -> list[dict[str, str]]:
    return rundir.CsvLog(path, ()).read()


def _curves(rows, x_col: str, y_col: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{arm: (x f[T], y f[seeds, T])}, cut to the x values every seed reached."""
    by: dict[str, dict[int, dict[float, float]]] = {}
    for r in rows:
        by.setdefault(row_arm(r), {}).setdefault(int(r["seed"]), {})[float(r[x_col])] = float(
            r[y_col]
        )
    out = {}
    for s in arms_in(by):
        seeds = sorted(by[s])
        common = sorted(set.intersection(*(set(by[s][k]) for k in seeds)))
        if not common:
            continue
        x = np.asarray(common)
        y = np.asarray([[by[s][k][v] for v in common] for k in seeds])
        out[s] = (x, y)
    return out


def safe_name(maze: str) -> str:
    """A maze name or path as a file-name part (``configs/mazes/corridor.yaml`` -> ``corridor``)."""
    stem = Path(maze).stem if maze.endswith((".yaml", ".yml")) else maze
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", stem) or "maze"


# ----------------------------------------------------------------------------
# Drawing helpers
# ----------------------------------------------------------------------------


def draw_maze(ax, maze: Maze, start: bool = True) -> None:
    """Walls and obstacles (:func:`jaxnav.report.drawing.draw_maze`), the start pose as a grey
    square with an arrow (not a robot disc: the paths are the robot here)."""
    drawing.draw_maze(ax, maze, pose=())
    if start:
        sx, sy, syaw = np.asarray(maze.start, np.float64)
        ax.plot([sx], [sy], marker="s", color="0.3", ms=5, zorder=4)
        ax.annotate(
            "",
            xy=(sx + 0.3 * math.cos(syaw), sy + 0.3 * math.sin(syaw)),
            xytext=(sx, sy),
            arrowprops=dict(arrowstyle="->", color="0.3", lw=1.2),
            zorder=4,
        )


def _band(ax, x, y, color, label):
    mean, low, high = stats.bootstrap_band(y)
    ax.plot(x, mean, color=color, lw=1.6, label=label)
    if y.shape[0] > 1:
        ax.fill_between(x, low, high, color=color, alpha=0.25, lw=0)


# ----------------------------------------------------------------------------
# Training figures
# ----------------------------------------------------------------------------


def plot_training_curves(run_dir: Path, out: Path, window: int | None = None) -> Path:
    """Episode return vs episode, smoothed, mean and 95% interval over seeds."""
    curves = _curves(_read_csv(run_dir / "metrics.csv"), "episode", "return")
    colors = arm_colors(list(curves))
    if not curves:
        raise RunError(f"{run_dir / 'metrics.csv'} has no episodes")
    n_ep = max(len(x) for x, _ in curves.values())
    w = window or int(np.clip(n_ep // 20, 1, 50))
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for s, (x, y) in curves.items():
        _band(
            ax,
            x + 1,
            stats.moving_average(y, w),
            colors[s],
            f"{display_name(s)} ({y.shape[0]} seeds)",
        )
    ax.set_xlabel("episode")
    ax.set_ylabel("episode return")
    ax.set_title(
        f"Training on {_train_maze(run_dir)}: return, moving average over {w} episodes\n"
        f"mean over seeds and 95% bootstrap interval",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    return _save_fig(fig, out, dpi=110)


def plot_exploration(run_dir: Path, out: Path, window: int = 10) -> Path:
    """Each strategy's exploration per 100-step block over training: EBE's entropy
    H(s), epsilon, Boltzmann's chance of a non-greedy action."""
    curves = _curves(_read_csv(run_dir / "explore.csv"), "step", "explore")
    colors = arm_colors(list(curves))
    if not curves:
        raise RunError(f"{run_dir / 'explore.csv'} has no rows")
    labels = {
        "ebe": "EBE: entropy H(s) (= chance of a random action)",
        "epsilon_greedy": "epsilon-greedy: epsilon",
        "boltzmann": "Boltzmann: chance of a non-greedy action",
    }
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for s, (x, y) in curves.items():
        label = labels[arm_strategy(s)]
        if s != arm_strategy(s):  # a sweep point: its values after the strategy's text
            label = f"{label} ({s.partition(' ')[2]})"
        _band(ax, x, stats.moving_average(y, window), colors[s], f"{label}, {y.shape[0]} seeds")
    ax.set_xlabel("environment step (per seed)")
    ax.set_ylabel("exploration probability")
    ax.set_ylim(0, 1.02)
    ax.set_title(
        "Exploration over training (means over 100-step blocks, moving average over "
        f"{window} blocks)\n"
        "mean over seeds and 95% bootstrap interval",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=9)
    fig.tight_layout()
    return _save_fig(fig, out, dpi=110)


def _train_maze(run_dir: Path) -> str:
    try:
        return load_config(str(run_dir / "config.yaml")).env.maze
    except ConfigError:
        return "?"


# ----------------------------------------------------------------------------
# Test-episode figures
# ----------------------------------------------------------------------------


def plot_trajectory(
    maze: Maze, name: str, episodes: dict[str, dict], seed: int, goal_radius: float, out: Path
) -> Path:
    """One test maze with both policies' paths over one test episode."""
    fig, ax = plt.subplots(figsize=(5.6, 5.6))
    draw_maze(ax, maze)
    for s, ep in episodes.items():
        _draw_path(ax, s, ep, goal_radius)
    _marker_legend(ax)
    ax.set_title(f"{name}: first test episode, seed {seed}", fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=8, ncol=1, frameon=False)
    fig.tight_layout()
    return _save_fig(fig, out, dpi=100, bbox_inches="tight")


def _draw_path(ax, strategy: str, ep: dict, goal_radius: float) -> None:
    """One policy's path, the goals it reached, the goal it was heading for, a crash."""
    c = COLORS[arm_strategy(strategy)]
    pos = ep["pos"]
    end = "collided" if ep["collided"] else "no collision"
    ax.plot(
        pos[:, 0],
        pos[:, 1],
        color=c,
        lw=1.3,
        alpha=0.9,
        zorder=5,
        label=f"{display_name(strategy)}: return {ep['return']:.0f}, {ep['goals']} goals, {end}",
    )
    hit = ep["reached"]
    if hit.any():
        g = ep["goal"][hit]
        ax.scatter(
            g[:, 0], g[:, 1], marker="*", s=130, color=c, edgecolors="black", lw=0.6, zorder=7
        )
        for gx, gy in g:  # the goal counts as reached inside this circle
            ax.add_patch(
                Circle((gx, gy), goal_radius, facecolor=c, edgecolor="none", alpha=0.15, zorder=2)
            )
    if not hit[-1]:  # the goal it was still heading for
        gx, gy = ep["goal"][-1]
        ax.add_patch(
            Circle((gx, gy), goal_radius, facecolor="none", edgecolor=c, lw=1.5, ls="--", zorder=6)
        )
    if ep["collided"]:  # at the pose before the colliding step; edge: whose
        ax.scatter(
            [pos[-1, 0]],
            [pos[-1, 1]],
            marker="X",
            s=130,
            color="red",
            edgecolors=c,
            lw=1.6,
            zorder=8,
        )


def _marker_legend(ax) -> None:
    """Legend entries for the markers (drawn empty, in grey)."""
    ax.scatter(
        [], [], marker="*", s=100, color="0.7", edgecolors="black", lw=0.6, label="goal reached"
    )
    ax.scatter(
        [],
        [],
        marker="o",
        s=60,
        facecolors="none",
        edgecolors="0.4",
        linestyle="--",
        label="goal not yet reached",
    )
    ax.scatter([], [], marker="X", s=80, color="red", edgecolors="0.4", lw=1.2, label="collision")


def animate_episode(
    maze: Maze,
    name: str,
    ep: dict,
    strategy: str,
    seed: int,
    goal_radius: float,
    out: Path,
    max_frames: int = GIF_MAX_FRAMES,
) -> Path:
    """An animated GIF of one test episode: robot, LiDAR beams, goal, trail.

    One figure draw per frame; no tick labels (they cost most of a frame), a 1 m
    scale bar instead. Halves the frames until < 1 MB.
    """
    n = ep["length"]
    while True:
        stride = max(1, math.ceil(n / max_frames))
        frames = list(range(0, n, stride))
        if frames[-1] != n - 1:
            frames.append(n - 1)
        fig, update = _episode_figure(maze, name, ep, strategy, seed, goal_radius)
        gif = _gif_bytes(fig, update, frames, dpi=75)
        plt.close(fig)
        if len(gif) <= GIF_MAX_BYTES or max_frames <= 10:
            rundir.atomic_write_bytes(out, gif)
            return out
        max_frames //= 2


def _episode_figure(maze: Maze, name: str, ep: dict, strategy: str, seed: int, goal_radius):
    """The animation's figure and its ``update(t)``, which moves the artists to step t."""
    n = ep["length"]
    n_beams = ep["ranges"].shape[1]
    beam_idx = np.arange(0, n_beams, max(1, n_beams // 36))  # at most ~36 drawn beams
    beam_ang = 2 * np.pi * beam_idx / n_beams
    cum_ret = np.cumsum(ep["reward"])
    cum_goals = np.cumsum(ep["reached"])
    fig, ax = plt.subplots(figsize=(4.0, 4.2))
    draw_maze(ax, maze, start=False)
    ax.set_axis_off()
    x0, x1 = ax.get_xlim()
    y0, _ = ax.get_ylim()
    ax.plot([x0 + 0.02 * (x1 - x0), x0 + 0.02 * (x1 - x0) + 1.0], [y0, y0], color="black", lw=2)
    ax.text(x0 + 0.02 * (x1 - x0) + 0.5, y0, "1 m", ha="center", va="bottom", fontsize=7)
    color = COLORS[arm_strategy(strategy)]
    (trail,) = ax.plot([], [], color=color, lw=1.0, alpha=0.7, zorder=4)
    beams = [ax.plot([], [], color="tab:red", lw=0.5, alpha=0.5, zorder=2)[0] for _ in beam_idx]
    body = Circle((0, 0), FOOTPRINT, facecolor=color, edgecolor="black", lw=0.8, zorder=6)
    ax.add_patch(body)
    (nose,) = ax.plot([], [], color="black", lw=1.2, zorder=7)
    goal = Circle(
        (0, 0), goal_radius, facecolor="limegreen", edgecolor="darkgreen", alpha=0.6, zorder=5
    )
    ax.add_patch(goal)
    title = ax.set_title("two\nlines", fontsize=8)  # room for the real title
    fig.tight_layout()

    def update(t):
        p, yaw = ep["pos"][t], ep["yaw"][t]
        trail.set_data(ep["pos"][: t + 1, 0], ep["pos"][: t + 1, 1])
        for line, a, r in zip(beams, beam_ang, ep["ranges"][t, beam_idx]):
            line.set_data([p[0], p[0] + r * np.cos(yaw + a)], [p[1], p[1] + r * np.sin(yaw + a)])
        body.center = (p[0], p[1])
        nose.set_data(
            [p[0], p[0] + FOOTPRINT * np.cos(yaw)], [p[1], p[1] + FOOTPRINT * np.sin(yaw)]
        )
        goal.center = tuple(ep["goal"][t])
        crash = " - collision" if ep["collided"] and t == n - 1 else ""
        title.set_text(
            f"{name}, {display_name(strategy)} seed {seed}: step {t + 1}/{n}\n"
            f"return {cum_ret[t]:.0f}, goals {int(cum_goals[t])}{crash}"
        )

    return fig, update


def first_episodes(run_dir: Path, maze_names: Sequence[str] | None = None):
    """(config, maze names, mazes, goal radius, first test episodes of the config's
    seed) from eval/trajectories.npz; None if the run was not evaluated on these mazes."""
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
    return cfg, names, [make_maze(n) for n in names], goal_radius, episodes


def plot_test_episodes(
    run_dir: Path, out_dir: Path, maze_names: Sequence[str] | None = None
) -> list[Path]:
    """Trajectory figures for every test maze and the GIF, from the first seed
    (none if the run was not evaluated on these mazes)."""
    found = first_episodes(run_dir, maze_names)
    if found is None:
        return []
    cfg, names, mazes, goal_radius, episodes = found
    written = []
    for name, maze in zip(names, mazes):
        out = out_dir / f"trajectory_{safe_name(name)}.png"
        written.append(plot_trajectory(maze, name, episodes[name], cfg.seed, goal_radius, out))
    arms = cfg.arm_names()
    strategy = next((a for a in arms if arm_strategy(a) == "ebe"), arms[0])
    ep = episodes[names[0]][strategy]
    written.append(
        animate_episode(
            mazes[0], names[0], ep, strategy, cfg.seed, goal_radius, out_dir / "episode.gif"
        )
    )
    return written


# ----------------------------------------------------------------------------
# Robustness
# ----------------------------------------------------------------------------


def plot_robustness(robustness_csv: str, out: Path, title: str = "Robustness") -> Path:
    """Mean return over seeds per perturbation (x) and strategy (bars), 95% bootstrap
    CI as error bars; one panel per maze. From robustness.csv text."""
    rows = robustness_summary(robustness_csv)
    mazes = list(dict.fromkeys(r.maze for r in rows))
    perts = list(dict.fromkeys(r.perturbation for r in rows))
    strategies = arms_in(r.strategy for r in rows)
    colors = arm_colors(strategies)
    width = 0.8 / len(strategies)
    fig, axes = plt.subplots(
        len(mazes), 1, figsize=(max(6.0, 0.9 * len(perts) + 1.5), 3.6 * len(mazes)), squeeze=False
    )
    for ax, m in zip(axes[:, 0], mazes):
        for j, s in enumerate(strategies):
            by = {r.perturbation: r for r in rows if r.maze == m and r.strategy == s}
            xs = [i for i, p in enumerate(perts) if p in by]
            iv = [by[perts[i]].mean for i in xs]
            mean = np.asarray([v.value for v in iv])
            low = np.asarray([v.low for v in iv])
            high = np.asarray([v.high for v in iv])
            yerr = None
            if not np.isnan(low).any():  # one seed: no interval
                yerr = np.stack([mean - low, high - mean])
            n = by[perts[xs[0]]].n_seeds if xs else 0
            ax.bar(
                np.asarray(xs) + (j - (len(strategies) - 1) / 2) * width,
                mean,
                width,
                yerr=yerr,
                capsize=3,
                color=colors[s],
                label=f"{display_name(s)} ({n} seeds)",
            )
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.set_xticks(range(len(perts)))
        ax.set_xticklabels(perts, rotation=30, ha="right", fontsize=8)
        ax.set_ylabel("mean test return")
        ax.set_title(f"{title} on {m}\nmean over seeds, 95% bootstrap interval", fontsize=10)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return _save_fig(fig, out, dpi=110)


def plot_sweep(results_csv: str, out: Path, title: str = "Sweep") -> Path | None:
    """A swept run's test return against the swept values, one panel per test mode:
    per strategy the mean over seeds of the per-seed score (averaged over the test
    mazes) with its 95% bootstrap interval; a strategy with one point (not reading the
    swept key) is a horizontal band. None without a swept column."""
    header = next(csv.reader(io.StringIO(results_csv)), [])
    keys = swept_columns(header)
    if not keys:
        return None
    modes = result_modes(results_csv)
    fig, axes = plt.subplots(1, len(modes), figsize=(5.2 * len(modes), 4.0), squeeze=False)
    for ax, mode in zip(axes[0], modes):
        results = read_results(results_csv, mode)  # (maze, arm, seed) -> episodes
        mazes = list(dict.fromkeys(k[0] for k in results))
        by = arms_in(k[1] for k in results)
        seeds = sorted({k[2] for k in results})
        score = {a: scores_over_mazes(results, mazes, a, seeds) for a in by}
        # an arm's point: its swept values ("ebe ebe_temperature=0.1" -> "0.1")
        point = {a: ", ".join(p.split("=", 1)[1] for p in a.split(" ")[1:]) for a in by}
        ticks = list(dict.fromkeys(p for p in point.values() if p))
        numeric = all(_is_number(t) for t in ticks)
        xs = {t: float(t) if numeric else i for i, t in enumerate(ticks)}
        colors = COLORS
        for s in COLORS:
            arms = [a for a in arms_in(by) if arm_strategy(a) == s]
            if not arms:
                continue
            ivs = [stats.mean_ci(score[a]) for a in arms]
            n = len(score[arms[0]])
            if len(arms) == 1 and not point[arms[0]]:
                iv = ivs[0]
                ax.axhline(
                    iv.value, color=colors[s], lw=1.4, label=f"{display_name(s)} ({n} seeds)"
                )
                if not np.isnan(iv.low):
                    ax.axhspan(iv.low, iv.high, color=colors[s], alpha=0.15, lw=0)
                continue
            x = np.asarray([xs[point[a]] for a in arms])
            mean = np.asarray([iv.value for iv in ivs])
            low, high = np.asarray([iv.low for iv in ivs]), np.asarray([iv.high for iv in ivs])
            yerr = None if np.isnan(low).any() else np.stack([mean - low, high - mean])
            ax.errorbar(
                x,
                mean,
                yerr=yerr,
                color=colors[s],
                marker="o",
                capsize=3,
                lw=1.4,
                label=f"{display_name(s)} ({n} seeds)",
            )
        if numeric and ticks and min(xs.values()) > 0 and max(xs.values()) / min(xs.values()) >= 10:
            ax.set_xscale("log")
        if not numeric:
            ax.set_xticks(range(len(ticks)))
            ax.set_xticklabels(ticks, rotation=30, ha="right", fontsize=8)
        ax.set_xlabel(", ".join(keys))
        ax.set_ylabel("test return (mean over mazes and episodes)")
        ax.set_title(f"{title}: {mode} test\nmean over seeds, 95% bootstrap interval", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return _save_fig(fig, out, dpi=110)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


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
    results = run_dir / "eval" / "results.csv"
    if results.is_file():
        swept = plot_sweep(results.read_text(), out / "sweep.png", f"Sweep of {run_dir.name}")
        written += [swept] if swept is not None else []
    tests = plot_test_episodes(run_dir, out, maze_names)
    if not tests:
        print(
            f"jaxnav.plots: {run_dir} has no test episodes of these mazes: run "
            f"python -m jaxnav.evaluate {run_dir} for the trajectory figures",
            file=sys.stderr,
        )
    return written + tests


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="python -m jaxnav.plots",
        description="Training curves, exploration, test-maze trajectories and an episode GIF "
        "of a run, written into RUN_DIR/plots/.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--mazes", nargs="+", metavar="M", help="test mazes (default run.test_mazes)")
    p.add_argument(
        "--window",
        type=int,
        metavar="W",
        help="moving-average window in episodes (default episodes/20)",
    )
    args = p.parse_args(argv)

    def work() -> None:
        if args.window is not None and args.window < 1:
            raise JaxnavError("--window must be at least 1")
        for path in make_plots(args.run_dir, args.mazes, args.window):
            print(path)

    return cli.run(p.prog, work)
