"""The study runner's machinery, which every pipeline that trains and tests runs
through: a cell (a named config trained in its own run directory), training it (new,
resumed from its last checkpoint, or reused when finished, with the seconds it took),
testing it, the output folder's resume check, progress lines, the machine and the code.

The ladder and the other kinds of study file (``jaxnav study FILE``), the sweep study,
the reproduction and the ablation all express their experiments as cells and train and
test them here, so a run is reused, resumed or refused by one rule everywhere.
"""

from __future__ import annotations

import json
import os
import platform
import re
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import jax

from jaxnav.core.config import Config, load_config
from jaxnav.core.errors import JaxnavError
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.run.launch import resume, train_new

Say = Callable[[str], None]


@dataclass(frozen=True)
class Cell:
    """One training run of a study: its name in progress lines and reports, its config
    and its run directory."""

    name: str
    cfg: Config
    run: Path


def sayer(tag: str, quiet: bool) -> Say:
    """The progress lines of a pipeline: ``[tag] message`` on stderr, none when quiet."""

    def say(msg: str) -> None:
        if not quiet:
            print(f"[{tag}] {msg}", file=sys.stderr, flush=True)

    return say


def check_out(out: Path, resume_ok: bool, saved: tuple[Path, str] | None = None) -> None:
    """Refuse an output folder before any work: a file, or a folder with something in
    it unless ``resume_ok``; ``saved`` (a file in it and the text it must hold) refuses a
    folder that holds another study."""
    if out.exists() and not out.is_dir():
        raise JaxnavError(f"{out} exists and is not a directory")
    if out.is_dir() and any(out.iterdir()):
        if not resume_ok:
            raise JaxnavError(
                f"output directory {out} already exists and is not empty "
                "(use --resume to continue it)"
            )
        if saved is not None and (not saved[0].is_file() or saved[0].read_text() != saved[1]):
            raise JaxnavError(f"{out} holds another study; use another --out")


def check_request(out: Path, seeds: int, sizes: dict[str, int | None], resume_ok: bool) -> None:
    """A pipeline's sizes (at least 1 each) and its output folder (:func:`check_out`)."""
    if seeds < 1:
        raise JaxnavError("--seeds must be at least 1")
    for flag, v in sizes.items():
        if v is not None and v < 1:
            raise JaxnavError(f"{flag} must be at least 1")
    check_out(out, resume_ok)


def check_settings(cell: Cell) -> bool:
    """Whether the cell's run was started; one started with other settings than the
    cell's is refused."""
    run_dir = cell.run
    started = (run_dir / "config.yaml").is_file()
    if started and load_config(str(run_dir / "config.yaml")) != cell.cfg:
        what = "trained" if (run_dir / "params.npz").is_file() else "started"
        raise JaxnavError(f"{run_dir} was {what} with other settings; use another --out")
    return started


def train(cell: Cell, quiet: bool, say: Say) -> tuple[float, str]:
    """Train (or reuse, or resume) one cell; (seconds, note) for the report. A run
    directory started with other settings is refused."""
    cfg, run_dir, name = cell.cfg, cell.run, cell.name
    t0 = time.perf_counter()
    arms = len(cfg.arms())
    what = f"{arms} arms" if cfg.sweep else f"{arms} strategies"
    where = f"{cfg.env.generator} mazes" if cfg.env.generator else cfg.env.maze
    note = f"{cfg.seeds} seeds x {what} on {where}"
    started = check_settings(cell)
    if (run_dir / "params.npz").is_file():
        say(f"{name}: reusing the finished training in {run_dir}")
        note += ", reused (trained before"
        try:  # report the earlier training's time, not the ~0 s of reusing it
            wall = float(json.loads((run_dir / "summary.json").read_text())["wall_clock_s"])
            t0 -= wall
            note += "; time from its summary.json, chunks only, no compile)"
        except (OSError, ValueError, KeyError, TypeError):
            note += ")"
    elif started:
        say(f"{name}: resuming training in {run_dir}")
        resume(run_dir, quiet=quiet)
        note += ", resumed"
    else:
        budget = f"{cfg.episodes} episodes" if cfg.episodes is not None else ""
        if cfg.total_steps is not None:
            budget += (" or " if budget else "") + f"{cfg.total_steps:,} env steps"
        say(f"{name}: training {cfg.n_runs} runs ({note}), {budget} each")
        train_new(cfg, run_dir, quiet=quiet)
    return time.perf_counter() - t0, note


def test(cell: Cell, **kwargs) -> Path:
    """The cell's policies tested (:func:`jaxnav.experiments.evaluation.evaluate_to_dir`,
    its keyword arguments), into ``RUN/eval/``; that folder."""
    return evaluate_to_dir(cell.run, **kwargs)


def sim2sim_argv(
    run: Path,
    seeds: list[int],
    episodes: int | None = None,
    out: Path | None = None,
    wheel_limit: bool = False,
) -> list[str]:
    """The command that tests a run's policies of ``seeds`` in MuJoCo (``jaxnav sim2sim``
    in its own process: only that command imports MuJoCo); ``out``: its CSV, replaced."""
    argv = [sys.executable, "-m", "jaxnav.commands.sim2sim", str(run), "--seeds", *map(str, seeds)]
    if episodes is not None:
        argv += ["--episodes", str(episodes)]
    if out is not None:
        argv += ["--out", str(out), "--overwrite"]
    return argv + (["--wheel-limit"] if wheel_limit else [])


def machine_info() -> dict[str, str]:
    """CPU model, cores, memory, Python, JAX version and backend."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count() or 0
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(re.search(r"MemTotal:\s+(\d+)", f.read()).group(1))
            mem = f"{kb / 2**20:.1f} GiB"
    except (OSError, AttributeError):
        pass
    devices = jax.devices()
    return {
        "CPU": cpu,
        "cores": f"{usable} usable ({os.cpu_count()} in the machine)",
        "memory": mem or "unknown",
        "OS": f"{platform.system()} {platform.release()} {platform.machine()}",
        "Python": platform.python_version(),
        "JAX": f"{jax.__version__}, backend {jax.default_backend()} "
        f"({len(devices)} x {devices[0].device_kind})",
    }


def machine_line() -> str:
    """The machine in one line, as the published pages name it."""
    info = machine_info()
    return f"{info['CPU']}, {info['cores']}, {info['memory']}, JAX {info['JAX']}"


def code_version() -> str:
    """The commit of the code that runs (``git rev-parse --short HEAD`` in the package's
    checkout), or ``unknown`` outside a git checkout."""
    here = Path(__file__).resolve().parent
    try:
        done = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=here, capture_output=True, text=True
        )
    except OSError:
        return "unknown"
    return done.stdout.strip() if done.returncode == 0 and done.stdout.strip() else "unknown"
