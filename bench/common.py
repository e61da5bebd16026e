"""Shared pieces of the peer benchmarks: our trainer's figure, interpreters, the machine.

Our trainer is always measured by ``bench/train_throughput.py --case`` (its
``run_case``) in a subprocess, so every script reports the same thing for "ours"
and each measurement has a process to itself.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
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
    one CPU device per core unless ``devices`` says otherwise (as ``jaxnav.train``)."""
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
