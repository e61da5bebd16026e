"""What a command sets up before JAX starts: one CPU device per core
(:mod:`jaxnav.core.cpu`) and JAX's persistent compilation cache.

XLA's compile of the training chunk takes seconds to tens of seconds on a CPU; the
cache keeps the compiled program on disk, so a second run of the same config (or a
resume, or the same test maze again) starts without compiling. A cached program is
the same executable, so the numbers do not change.

Where the cache lives: ``JAX_COMPILATION_CACHE_DIR`` if the user set it; else
``$JAXNAV_CACHE``; else ``$XDG_CACHE_HOME/jaxnav/jax`` (``~/.cache/jaxnav/jax``).
``JAXNAV_CACHE=off`` turns it off. The cache is not pruned (a program of the paper
config is a few MB); delete the directory to empty it. No JAX here: it must run
before JAX is imported.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from jaxnav.core.cpu import use_all_cores

_IMPORTED = time.monotonic()  # fallback start where /proc is missing


def process_age() -> float:
    """Seconds since this process started: from /proc on Linux (interpreter start-up
    included), elsewhere since this module was imported."""
    try:
        with open("/proc/self/stat") as f:  # field 22: start time in clock ticks since boot
            start = int(f.read().rsplit(")", 1)[1].split()[19]) / os.sysconf("SC_CLK_TCK")
        with open("/proc/uptime") as f:
            return max(float(f.read().split()[0]) - start, 0.0)
    except (OSError, ValueError, IndexError):
        return time.monotonic() - _IMPORTED


def cache_dir() -> Path | None:
    """The compilation cache's directory, or None when it is off."""
    chosen = os.environ.get("JAXNAV_CACHE", "")
    if chosen.lower() in ("off", "0", "false", "no"):
        return None
    if chosen:
        return Path(chosen).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "jaxnav" / "jax"


def use_compilation_cache() -> None:
    """Point JAX's persistent compilation cache at :func:`cache_dir`, unless JAX
    already started, the user chose a directory for JAX, or it is off."""
    if "jax" in sys.modules or "JAX_COMPILATION_CACHE_DIR" in os.environ:
        return
    path = cache_dir()
    if path is None:
        return
    os.environ["JAX_COMPILATION_CACHE_DIR"] = str(path)


def before_jax() -> None:
    """Everything a command sets before JAX starts."""
    use_all_cores()
    use_compilation_cache()
