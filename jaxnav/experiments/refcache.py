"""The reference drivers' test rows kept in the user's cache, so that a second test of
the same world (another run or strategy on the same seeds, a re-evaluation, a resumed
pipeline) reads them instead of driving the oracle and DWA again.

An entry is one driver's test on one set of test mazes: each maze's per-episode
return, goals, collision and length, and each episode's sums over its goal attempts
(what results.csv writes of it). Its file is named by the sha256 of everything those
numbers depend on apart from the code (:func:`identity`): the driver and its own
settings, the world (the environment's every static setting, its parameters, every
test maze's geometry), the drivers' test keys (their seeds), their per-run settings,
the episode count and the devices the test is laid over. The entry holds that digest,
a stamp of the code and libraries that computed it (:func:`stamp`: jaxnav's own
source, JAX, NumPy, SciPy, the machine's kind) and a checksum of its numbers. An
entry whose stamp or checksum does not match, or that cannot be read whole, is
ignored: the test is driven again and the entry rewritten. Nothing is trusted that
was not written by this code for exactly this test.

Where: :func:`jaxnav.core.startup.reference_cache_dir` (``~/.cache/jaxnav/references``;
``JAXNAV_REFERENCE_CACHE`` moves it, ``=off`` turns it off, as ``JAXNAV_CACHE=off``
does). An entry is a few kB per maze; delete the folder to empty it.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import io
import platform
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import jax
import numpy as np

import jaxnav
from jaxnav.core import rundir
from jaxnav.core.startup import reference_cache_dir
from jaxnav.experiments.baselines import RASTER_CELL, planner_of, seats_of
from jaxnav.experiments.rollout import Policies, Rollout, run_tests
from jaxnav.planners.dwa import DWA
from jaxnav.planners.oracle import Oracle
from jaxnav.world.maps import Maze

FORMAT = 1  # the entry's layout; a new one makes every older entry stale
EPISODE_FIELDS = ("ret", "goals", "collided", "length")
_PLANNERS = {"oracle": Oracle, "dwa": DWA}
# what a driver's counts are computed with: (drivers, mazes, results) -> per maze, per
# driver, {column: f[episodes]} (jaxnav.experiments.navigation.navigation_counts)
Counts = Callable[[Policies, Sequence[Maze], list[Rollout]], list[list[dict[str, np.ndarray]]]]


class ReferenceTest:
    """A reference driver's greedy test in the place of a run's ``policies`` on
    ``mazes`` (:func:`jaxnav.experiments.baselines.in_place_of`): its entry is looked
    up when made (``cached``: a sound one is there), and :meth:`run` reads it, or
    drives the test and writes the entry."""

    def __init__(self, name: str, policies: Policies, mazes: Sequence[Maze], n_episodes: int):
        self.name, self.mazes, self.n_episodes = name, list(mazes), n_episodes
        self.seats = seats_of(name, policies)
        self.fields = self.seats.fields  # results.csv's leading fields per driver
        self.key = identity(name, self.seats, self.mazes, n_episodes)
        self.path = _entry_path(self.key)
        self.hit = None
        if self.path is not None:
            self.hit = _read(self.path, self.key, len(mazes), len(self.fields), n_episodes)
        self.cached = self.hit is not None

    def run(self, count: Counts) -> tuple[list[Rollout], list[list[dict[str, np.ndarray]]]]:
        """(per maze the drivers' episodes, per maze and driver each episode's sums over
        its attempts, as ``count`` gives them)."""
        if self.hit is not None:
            return self.hit
        seats = self.seats
        network = planner_of(self.name, seats.env, self.mazes, seats.env_params)
        driver = seats._replace(network=network)
        results = run_tests(driver, self.mazes, self.n_episodes, navigation=True)
        counts = count(driver, self.mazes, results)
        if self.path is not None:
            _write(self.path, self.key, results, counts)
        return results, counts


# ----------------------------------------------------------------------------
# The key and the stamp
# ----------------------------------------------------------------------------


def identity(name: str, seats: Policies, mazes: Sequence[Maze], n_episodes: int) -> str:
    """sha256 (hex) of what a reference driver's test rows depend on, but the code: the
    driver's name and class settings, the raster cell, the world (static settings,
    parameters, each test maze), the drivers' seeds and per-run settings, the episodes,
    the test mode, and how many devices the drivers are laid over."""
    h = hashlib.sha256()
    planner = _PLANNERS[name]
    settings = {
        f.name: f.default
        for f in dataclasses.fields(planner)
        if f.default is not dataclasses.MISSING
    }
    parts = {
        "format": FORMAT,
        "driver": name,
        "planner": f"{planner.__module__}.{planner.__qualname__}",
        "settings": settings,
        "raster_cell": RASTER_CELL,
        "env": seats.env,
        "env_params": seats.env_params,
        "mazes": list(mazes),
        "seeds": [seed for _, seed in seats.labels],
        "hyper": seats.hyper,
        "episodes": int(n_episodes),
        "mode": "greedy",
        "devices": jax.device_count(),
    }
    _feed(h, parts)
    return h.hexdigest()


@functools.lru_cache(maxsize=1)
def stamp() -> str:
    """The code and libraries an entry was computed with: the sha256 of every source
    file of jaxnav, and the versions of JAX, jaxlib, NumPy and SciPy, the machine's
    processor kind and JAX's backend. An entry from any other is stale."""
    import jaxlib
    import scipy

    h = hashlib.sha256()
    root = Path(jaxnav.__file__).resolve().parent
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode() + b"\0")
        h.update(path.read_bytes() + b"\0")
    libs = (
        f"jax {jax.__version__}; jaxlib {jaxlib.__version__}; numpy {np.__version__}; "
        f"scipy {scipy.__version__}; python {sys.version_info[:2]}; "
        f"{platform.machine()}; {jax.default_backend()} {jax.devices()[0].device_kind}"
    )
    return f"{FORMAT}|{h.hexdigest()}|{libs}"


def _feed(h, x: Any) -> None:
    """Feed ``x`` to the hash ``h`` in one canonical form: its type and value; arrays
    by dtype, shape and bytes; dataclasses and named tuples field by field. TypeError
    for anything else (a function, an object of unknown make): it is not keyed
    silently."""
    if x is None or isinstance(x, bool | int | float | str | bytes):
        h.update(f"{type(x).__name__}:{x!r};".encode())
    elif isinstance(x, np.ndarray | np.generic | jax.Array):
        a = np.ascontiguousarray(np.asarray(x))
        h.update(f"array:{a.dtype.str}:{a.shape};".encode())
        h.update(a.tobytes())
    elif dataclasses.is_dataclass(x) and not isinstance(x, type):
        h.update(f"{type(x).__module__}.{type(x).__qualname__}(".encode())
        for f in dataclasses.fields(x):
            h.update(f"{f.name}=".encode())
            _feed(h, getattr(x, f.name))
        h.update(b")")
    elif isinstance(x, tuple) and hasattr(x, "_fields"):  # a named tuple
        h.update(f"{type(x).__module__}.{type(x).__qualname__}(".encode())
        for k, v in zip(x._fields, x):
            h.update(f"{k}=".encode())
            _feed(h, v)
        h.update(b")")
    elif isinstance(x, tuple | list):
        h.update(f"{type(x).__name__}[{len(x)}](".encode())
        for v in x:
            _feed(h, v)
        h.update(b")")
    elif isinstance(x, dict):
        h.update(f"dict[{len(x)}](".encode())
        for k in sorted(x, key=repr):
            _feed(h, k)
            _feed(h, x[k])
        h.update(b")")
    else:
        raise TypeError(f"a reference test cannot be keyed by a {type(x).__qualname__}")


# ----------------------------------------------------------------------------
# Entries
# ----------------------------------------------------------------------------


def _entry_path(key: str) -> Path | None:
    folder = reference_cache_dir()
    return None if folder is None else folder / f"{key}.npz"


def _payload(results: Sequence[Rollout], counts) -> dict[str, np.ndarray]:
    out = {}
    for m, (res, per_run) in enumerate(zip(results, counts)):
        for f in EPISODE_FIELDS:
            out[f"m{m}/{f}"] = np.asarray(getattr(res, f))
        for col in per_run[0]:
            out[f"m{m}/count/{col}"] = np.stack([np.asarray(c[col]) for c in per_run])
    return out


def _checksum(payload: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for k in sorted(payload):
        h.update(k.encode() + b"\0")
        _feed(h, payload[k])
    return h.hexdigest()


def _write(path: Path, key: str, results: Sequence[Rollout], counts) -> None:
    """The entry, written whole or not at all; a cache that cannot be written is left
    alone (the test's rows are right either way)."""
    payload = _payload(results, counts)
    meta = {"identity": key, "stamp": stamp(), "checksum": _checksum(payload)}
    buf = io.BytesIO()
    np.savez(buf, **payload, **{f"meta/{k}": np.asarray(v) for k, v in meta.items()})
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        rundir.atomic_write_bytes(path, buf.getvalue())
    except OSError as e:
        print(f"note: the reference drivers' cache was not written ({e})", file=sys.stderr)


def _read(path: Path, key: str, n_mazes: int, n_runs: int, n_episodes: int):
    """(results, counts) of a sound entry for exactly this test, else None."""
    try:
        with np.load(path, allow_pickle=False) as f:
            data = {k: f[k] for k in f.files}
    except Exception:  # absent, truncated, not a zip, ...: not an entry
        return None
    meta = {k.removeprefix("meta/"): str(v) for k, v in data.items() if k.startswith("meta/")}
    payload = {k: v for k, v in data.items() if not k.startswith("meta/")}
    if meta.get("identity") != key or meta.get("stamp") != stamp():
        return None  # another test's, or computed by other code: stale
    if meta.get("checksum") != _checksum(payload):
        return None  # damaged
    results, counts = [], []
    for m in range(n_mazes):
        try:
            fields = {f: payload[f"m{m}/{f}"] for f in EPISODE_FIELDS}
        except KeyError:
            return None
        if any(a.shape != (n_runs, n_episodes) for a in fields.values()):
            return None
        results.append(Rollout(**fields, trajectory=None))
        prefix = f"m{m}/count/"
        cols = {k[len(prefix) :]: v for k, v in payload.items() if k.startswith(prefix)}
        if not cols or any(v.shape != (n_runs, n_episodes) for v in cols.values()):
            return None
        counts.append([{c: v[r] for c, v in cols.items()} for r in range(n_runs)])
    return results, counts


__all__ = ["FORMAT", "ReferenceTest", "identity", "stamp"]
