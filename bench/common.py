"""Shared pieces of the peer benchmarks: our trainer's figure, interpreters, the machine.

Our trainer is always measured by ``bench/train_throughput.py --case`` (its
``run_case``) in a subprocess, so every script reports the same thing for "ours"
and each measurement has a process to itself.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"
PEER_VENV_PYTHON = ROOT / ".venv-peers" / "bin" / "python"
MARK = "RESULT "  # a child process prints one line "RESULT {json}"


def child_env(extra: dict | None = None) -> dict:
    """Environment of a child process: jaxnav importable from the checkout."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.update(extra or {})
    return env


def cores() -> int:
    """Usable CPU cores."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def device_env(devices: int) -> dict:
    """Child environment with ``devices`` CPU devices (XLA_FLAGS), as jaxnav's commands
    ask for one per core."""
    if devices <= 1:
        return child_env()
    flags = os.environ.get("XLA_FLAGS", "")
    return child_env(
        {"XLA_FLAGS": f"{flags} --xla_force_host_platform_device_count={devices}".strip()}
    )


def ours_train(
    seeds: int,
    beams: int,
    steps: int,
    reps: int,
    capacity: int,
    python: str | None = None,
    timeout: float = 1800,
    devices: int | None = None,
) -> dict:
    """Our trainer's transitions/s (``train_throughput.run_case``) in its own process, on
    one CPU device per core unless ``devices`` says otherwise (as ``jaxnav train``)."""
    cmd = [
        python or sys.executable,
        str(BENCH / "train_throughput.py"),
        "--case",
        f"{seeds},{beams}",
        "--steps",
        str(steps),
        "--reps",
        str(reps),
        "--capacity",
        str(capacity),
    ]
    env = device_env(cores() if devices is None else devices)
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
    if out.returncode != 0:
        tail = (out.stderr.strip().splitlines() or ["no output"])[-1]
        raise RuntimeError(f"train_throughput --case {seeds},{beams} failed: {tail}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_marked(cmd: list[str], timeout: float = 1800, env: dict | None = None) -> dict:
    """Run a child that prints ``RESULT {json}``; its dict, or RuntimeError with the last
    line of its stderr."""
    out = subprocess.run(
        cmd, capture_output=True, text=True, env=env or child_env(), timeout=timeout
    )
    for line in out.stdout.splitlines():
        if line.startswith(MARK):
            return json.loads(line[len(MARK) :])
    tail = (out.stderr.strip().splitlines() or out.stdout.strip().splitlines() or ["no output"])[-1]
    raise RuntimeError(f"{' '.join(cmd[1:3])} failed: {tail}")


def find_python(module: str, prefer: str | None = None) -> str | None:
    """An interpreter that can import ``module``: ``prefer``, this one, or .venv-peers."""
    candidates = [prefer] if prefer else [sys.executable, str(PEER_VENV_PYTHON)]
    for py in candidates:
        if not py or not Path(py).exists():
            continue
        ok = subprocess.run(
            [
                py,
                "-c",
                "import importlib.util, sys; "
                f"sys.exit(importlib.util.find_spec('{module}') is None)",
            ],
            capture_output=True,
        )
        if ok.returncode == 0:
            return py
    return None


def budget_arguments(ap: argparse.ArgumentParser, unit: str, seeds: int, steps: int) -> None:
    """The options of a script that trains with greedy evaluations (``run.eval_every``):
    ``--quick``, ``--seeds`` (per ``unit``), ``--steps`` and ``--eval-every``;
    :func:`budget` fills in their defaults."""
    ap.add_argument("--quick", action="store_true", help="2 seeds, tiny budgets: checks it runs")
    ap.add_argument("--seeds", type=int, help=f"seeds per {unit} ({seeds}; --quick 2)")
    ap.add_argument("--steps", type=int, help=f"env steps per run ({steps:,}; --quick 2,048)")
    ap.add_argument(
        "--eval-every", type=int, help="env steps between evaluations (5,120; --quick 1,024)"
    )
    ap.set_defaults(full_budget=(seeds, steps))


def budget(args: argparse.Namespace) -> None:
    """:func:`budget_arguments`' defaults, for ``--quick`` or not, into ``args``."""
    quick = args.quick
    seeds, steps = args.full_budget
    args.seeds = args.seeds or (2 if quick else seeds)
    args.steps = args.steps or (2048 if quick else steps)
    # a multiple of PQN's 512 env steps per update in configs/pqn.yaml
    args.eval_every = args.eval_every or (1024 if quick else 5120)


def train_evaluating(items: list[str], args: argparse.Namespace, log) -> dict:
    """One whole ``jaxnav train ITEMS`` command of ``args.seeds`` seeds and
    ``args.steps`` env steps per run, with a greedy evaluation of ``args.eval_episodes``
    episodes every ``args.eval_every`` steps, timed from launch to exit with an empty
    compilation cache. Chunks are one evaluation period long (PQN: whole updates), so
    every chunk end is an evaluation and none is cut. Returns its eval.csv ``rows``,
    ``summary`` (summary.json) and ``wall_s``."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        cmd = [
            sys.executable,
            "-m",
            "jaxnav.commands.train",
            *items,
            f"seeds={args.seeds}",
            "episodes=null",
            f"total_steps={args.steps}",
            f"run.eval_every={args.eval_every}",
            f"run.eval_episodes={args.eval_episodes}",
            f"run.chunk_steps={args.eval_every}",
            "--out",
            str(out),
            "--quiet",
        ]
        log("$ " + " ".join(["python", *cmd[1:]]))
        t0 = time.perf_counter()
        p = subprocess.run(
            cmd,
            cwd=ROOT,
            env=child_env({"JAXNAV_CACHE": str(Path(tmp) / "cache")}),
            capture_output=True,
        )
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            err = p.stderr.decode(errors="replace").strip().splitlines() or ["?"]
            raise RuntimeError(f"jaxnav.commands.train failed: {err[-1]}")
        with open(out / "eval.csv") as f:
            rows = list(csv.DictReader(f))
        summary = json.loads((out / "summary.json").read_text())
    return {"rows": rows, "summary": summary, "wall_s": wall}


def reference_success(items: list[str], seeds: int, episodes: int, log) -> dict[str, float]:
    """The oracle's and DWA's mean success over ``seeds`` test keys in the world of a
    training command's ``items`` (its config and overrides), through the greedy
    evaluation's test (``episodes`` episodes per seed, the training environment):
    ``jaxnav evaluate --baseline`` in a subprocess, its results read back."""
    from jaxnav.report.navigation import seed_metrics
    from jaxnav.report.results import read_results

    config, *overrides = items
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in ("oracle", "dwa"):
            dest = Path(tmp) / name
            cmd = [sys.executable, "-m", "jaxnav.commands.evaluate", "--baseline", name, config,
                   *overrides, "--seeds", str(seeds), "--episodes", str(episodes),
                   "--out", str(dest)]  # fmt: skip
            log("$ " + " ".join(["python", *cmd[1:]]))
            p = subprocess.run(cmd, cwd=ROOT, env=child_env(), capture_output=True)
            if p.returncode != 0:
                err = p.stderr.decode(errors="replace").strip().splitlines() or ["?"]
                raise RuntimeError(f"jaxnav evaluate --baseline failed: {err[-1]}")
            res = read_results((dest / "results.csv").read_text())
            per_seed = [seed_metrics(v)["success"] for v in res.values()]
            out[name] = sum(per_seed) / len(per_seed)
    return out


def machine() -> str:
    """One line: CPU model, cores, load, jax version."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        import jax

        jx = f"jax {jax.__version__} ({jax.default_backend()})"
    except ImportError:
        jx = "no jax"
    return (
        f"{model}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}, {jx}, "
        f"Python {platform.python_version()}"
    )
