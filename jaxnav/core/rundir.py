"""A run directory on disk: its layout, the checks on it, and every write into it.

Layout (``jaxnav train`` writes it; ``evaluate``, ``plots``, ``export``
and ``reproduce`` read it)::

    config.yaml          the resolved config (every field)
    metrics.csv          one row per strategy, seed and episode
    explore.csv          mean exploration probability per strategy, seed and 100 steps
    checkpoints/last.npz training state after the last finished chunk, but the
                         replay slots: those are in rows-00000.npz, rows-00001.npz,
                         ..., one per chunk, as many as last.npz says (while training)
    params.npz           final Q-network parameters, "<strategy>/seed<k>/<layer>/<name>"
    summary.json         wall-clock, steps, steps/s, start-up and compile seconds,
                         lockstep share, last-50-episode means
    eval/, plots/        results of jaxnav evaluate and jaxnav plots
    tensorboard/         training curves for TensorBoard (run.tensorboard: true)
    .lock                held by the process that trains into the directory

What a finished run keeps. The checkpoints exist so that a killed run can go on:
``last.npz`` is the training state (parameters, target network, optimizer, the
replay buffer's counters, the episode ring) and the row segments hold the replay
buffer itself, the bulk (up to 28.8 MB per strategy and seed for the paper's 500 x
500 steps: an 8-seed paper run kept 434 MB of them). Once ``params.npz`` and ``summary.json`` are
written nothing reads them: ``evaluate``, ``export``, ``plots`` and ``sim2sim`` read
``params.npz``, the config and the logs, and a run cannot be extended (``--resume``
takes the config the run was started with, so a finished run has nothing left to
train and ``--resume`` of it only reports its summary). So the last write of a run
removes ``checkpoints/`` (:func:`remove_checkpoints`), unless ``jaxnav train
--keep-checkpoints``. A finished ``configs/smoke.yaml`` run keeps about 0.2 MB
(params.npz 107 kB, the two CSVs 13 kB, plots/ 90 kB) instead of 4 MB with its
checkpoints (last.npz 0.34 MB and four 0.9 MB segments).

Every file is written whole or not at all (:func:`atomic_write`: a temporary
file, fsync, rename); the CSV logs grow by appending, and the checkpoint records
their lengths, so a resumed run first cuts them back to what the checkpoint
covers (:meth:`CsvLog.truncate`). Every ``.npz`` is read with
``allow_pickle=False``. No JAX here: ``jaxnav.robot.deploy`` and the checks run without it.
"""

from __future__ import annotations

import csv
import fcntl
import io
import json
import os
import shutil
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from jaxnav.core.errors import RunError

CONFIG = "config.yaml"
METRICS = "metrics.csv"
EXPLORE = "explore.csv"
EVAL = "eval.csv"  # the greedy evaluations while the run trains (run.eval_every)
CHECKPOINT = "checkpoints/last.npz"
PARAMS = "params.npz"
SUMMARY = "summary.json"
LOCK = ".lock"
# What a run directory may hold: its files, and the folders of checkpoints,
# evaluation and figures. Overwriting a run removes these and nothing else.
RUN_ENTRIES = (
    CONFIG,
    METRICS,
    EXPLORE,
    EVAL,
    PARAMS,
    SUMMARY,
    "checkpoints",
    "eval",
    "plots",
    "tensorboard",
)


# ----------------------------------------------------------------------------
# Writing
# ----------------------------------------------------------------------------


def atomic_write(path: str | os.PathLike, write: Callable[[BinaryIO], Any]) -> None:
    """Write a whole file or nothing: ``write(f)`` into a temporary file beside it,
    fsync, rename."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        with open(tmp, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    atomic_write(path, lambda f: f.write(data))


def atomic_write_npz(path: str | os.PathLike, arrays: dict[str, np.ndarray]) -> None:
    """An uncompressed ``.npz`` of plain arrays written straight to its file, whole or
    not at all (no second copy in memory: a checkpoint holds the replay buffers)."""
    atomic_write(path, lambda f: np.savez(f, **arrays))


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def remove_stale_temps(run_dir: str | os.PathLike, pid: int | None = None) -> int:
    """Remove the temporary files a killed writer left in a run directory (call it
    holding the run's lock, so no live writer owns them), or only those of process
    ``pid``; how many there were."""
    pattern = ".*.tmp*" if pid is None else f".*.tmp{pid}"
    stale = [p for p in Path(run_dir).rglob(pattern) if p.is_file()]
    for p in stale:
        p.unlink(missing_ok=True)
    return len(stale)


def npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """An uncompressed ``.npz`` of plain arrays (no pickle), in memory."""
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def read_npz(path: str | os.PathLike, what: str = "") -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` (no pickle); RunError for a missing or damaged file."""
    path = Path(path)
    label = what or str(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except FileNotFoundError:
        raise RunError(f"{label} does not exist") from None
    except Exception as e:  # truncated, not a zip, pickled object arrays, ...
        raise RunError(f"{label} cannot be read ({type(e).__name__})") from None


def csv_text(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue()


class CsvLog:
    """A CSV file that grows by appending rows (the header is written once)."""

    def __init__(self, path: str | os.PathLike, header: Sequence[str]):
        self.path, self.header = Path(path), tuple(header)

    def size(self) -> int:
        """Bytes in the file now (0 if it does not exist)."""
        return self.path.stat().st_size if self.path.exists() else 0

    def append(self, rows: Sequence[Sequence[Any]]) -> int:
        """Append rows (the header first if the file is new), fsync; return its size.

        All or nothing: an append that fails part-way (a full disk) cuts the file back
        to its size before, then raises."""
        before = self.size()
        text = csv_text(self.header, rows)
        if before:
            text = text.split("\n", 1)[1]
        try:
            with open(self.path, "a", newline="") as f:
                f.write(text)
                f.flush()
                os.fsync(f.fileno())
        except BaseException:
            self.restore(before)
            raise
        return self.size()

    def truncate(self, size: int) -> None:
        """Cut the file back to ``size`` bytes (rows written after a checkpoint)."""
        if self.size() < size:
            raise RunError(f"{self.path} is shorter than its checkpoint says (damaged)")
        with open(self.path, "r+b") as f:
            f.truncate(size)

    def restore(self, size: int) -> None:
        """Best effort after a failed write: the file as it was at ``size`` bytes (absent
        at 0). Errors are swallowed: the caller is already raising the first one."""
        try:
            if size == 0:
                self.path.unlink(missing_ok=True)
            elif self.size() > size:
                with open(self.path, "r+b") as f:
                    f.truncate(size)
        except OSError:
            pass

    def read(self) -> list[dict[str, str]]:
        if not self.path.is_file():
            raise RunError(f"{self.path.parent} has no {self.path.name}")
        with open(self.path, newline="") as f:
            return list(csv.DictReader(f))

    def group_by_run(self, runs: Sequence[Sequence[Any]]) -> None:
        """Rewrite the file (atomically) with its rows grouped by run, in the order of
        ``runs`` (each run's leading fields), each run's rows in the order they were
        appended. The host loop appends each chunk's rows run by run, so without this
        the rows' order would follow where the chunks ended, which the host sets by
        time; grouped, a finished run's file is the same whatever its chunks were. The
        bytes are the same lines, so the file keeps its size."""
        if not self.path.is_file():
            return
        order = {tuple(map(str, fields)): i for i, fields in enumerate(runs)}
        width = len(runs[0]) if runs else 0
        head, *lines = self.path.read_text().splitlines(keepends=True)
        rank = [order.get(tuple(row[:width]), len(order)) for row in csv.reader(lines)]
        ranked = sorted(range(len(lines)), key=rank.__getitem__)  # stable
        if ranked != list(range(len(lines))):
            atomic_write_text(self.path, head + "".join(lines[i] for i in ranked))


# ----------------------------------------------------------------------------
# The directory
# ----------------------------------------------------------------------------


def create(out: str | os.PathLike) -> Path:
    """Make a new, empty run directory (RunError if it exists and holds anything)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise RunError(f"{out} exists and is not a directory")
    if out.is_dir() and any(out.iterdir()):
        if not (out / CONFIG).is_file():  # neither flag applies: not a run to go on with
            raise RunError(
                f"{out} is not empty and holds no run (no {CONFIG}); choose another --out"
            )
        raise RunError(
            f"run directory {out} already exists and is not empty (--resume {out} continues "
            "it, --overwrite replaces it)"
        )
    try:
        (out / "checkpoints").mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise RunError(f"cannot create run directory {out} ({e.strerror or e})") from None
    return out


def clear(out: str | os.PathLike) -> Path:
    """Empty an existing run directory for a new run (``--overwrite``); call it holding
    the run's lock. RunError if it holds anything a run does not write."""
    out = Path(out)
    if not (out / CONFIG).is_file():
        raise RunError(f"{out} is not a run directory (no {CONFIG}); not overwriting it")
    entries = [p for p in out.iterdir() if p.name != LOCK and not p.name.startswith(".")]
    foreign = sorted(p.name for p in entries if p.name not in RUN_ENTRIES)
    if foreign:
        raise RunError(
            f"{out} holds {foreign[0]!r}, which a run does not write; not overwriting it"
        )
    for p in entries:
        if p.is_dir():
            shutil.rmtree(p)
        else:
            p.unlink()
    remove_stale_temps(out)
    (out / "checkpoints").mkdir()
    return out


def empty(out: str | os.PathLike) -> None:
    """Remove what a run wrote into ``out`` (its files and folders, its lock and
    temporary files), leaving the directory and anything else in it."""
    out = Path(out)
    for name in (*RUN_ENTRIES, LOCK):
        p = out / name
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
    remove_stale_temps(out)


def remove_checkpoints(run_dir: str | os.PathLike) -> None:
    """Remove a finished run's ``checkpoints/`` (call it once ``params.npz`` and
    ``summary.json`` are written, holding the run's lock). ``last.npz`` goes first, so
    a removal cut short leaves no checkpoint that counts a missing segment."""
    folder = Path(run_dir) / "checkpoints"
    (Path(run_dir) / CHECKPOINT).unlink(missing_ok=True)
    if folder.is_dir():
        shutil.rmtree(folder)


def finished(run_dir: str | os.PathLike) -> bool:
    """Training has ended and its checkpoint is gone: ``params.npz`` and ``summary.json``
    written, no ``checkpoints/last.npz``."""
    run_dir = Path(run_dir)
    done = (run_dir / PARAMS).is_file() and (run_dir / SUMMARY).is_file()
    return done and not (run_dir / CHECKPOINT).is_file()


def read_summary(run_dir: str | os.PathLike) -> dict[str, Any]:
    """A run's ``summary.json``; RunError if it is missing or damaged."""
    path = Path(run_dir) / SUMMARY
    try:
        summary = json.loads(path.read_text())
    except FileNotFoundError:
        raise RunError(f"{run_dir} has no {SUMMARY}") from None
    except (OSError, ValueError) as e:
        raise RunError(f"{path} cannot be read ({type(e).__name__})") from None
    if not isinstance(summary, dict):
        raise RunError(f"{path} cannot be read (not a JSON object)")
    return summary


def existing(run_dir: str | os.PathLike, finished: bool = False) -> Path:
    """The checks every reader of a run directory makes; returns it as a Path.

    ``finished``: training must have ended (``params.npz`` written).
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RunError(f"run directory {run_dir} does not exist")
    if not (run_dir / CONFIG).is_file():
        raise RunError(f"{run_dir} is not a run directory (no {CONFIG})")
    if finished and not (run_dir / PARAMS).is_file():
        if in_use(run_dir):
            raise RunError(f"{run_dir} is being trained by another process: wait for it to finish")
        raise RunError(f"{run_dir} has no {PARAMS} (training has not finished; resume it first)")
    return run_dir


def in_use(run_dir: str | os.PathLike) -> bool:
    """Whether another process holds the run directory's :class:`Lock` (trains it now)."""
    path = Path(run_dir) / LOCK
    if not path.is_file():
        return False
    fd = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    finally:
        os.close(fd)


class Lock:
    """Exclusive use of a run directory by one process (``with Lock(run_dir):``).

    An advisory ``flock`` on ``RUN_DIR/.lock``: the kernel drops it when the process
    ends, however it ends, so a killed run never leaves the directory locked.
    """

    def __init__(self, run_dir: str | os.PathLike):
        self.path = Path(run_dir) / LOCK
        self.fd: int | None = None

    def __enter__(self) -> Lock:
        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(self.fd)
            self.fd = None
            raise RunError(
                f"run directory {self.path.parent} is in use by another process"
            ) from None
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
            self.fd = None


# ----------------------------------------------------------------------------
# Parameters
# ----------------------------------------------------------------------------


def params_key(strategy: str, seed: int, name: str) -> str:
    """Entry of one array of one run in ``params.npz``: ``<strategy>/seed<k>/<name>``."""
    return f"{strategy}/seed{seed}/{name}"


def runs_in(params_path: str | os.PathLike) -> dict[str, list[int]]:
    """{strategy: [seeds]} stored in a ``params.npz``."""
    runs: dict[str, set[int]] = {}
    for name in read_npz(params_path):
        parts = name.split("/")
        if len(parts) > 2 and parts[1].startswith("seed") and parts[1][4:].isdigit():
            runs.setdefault(parts[0], set()).add(int(parts[1][4:]))
    return {s: sorted(v) for s, v in runs.items()}


def load_params(path: str | os.PathLike, strategy: str, seed: int) -> dict[str, Any]:
    """The parameters of one run as a nested dict of NumPy arrays (flax's layout)."""
    prefix = params_key(strategy, seed, "")
    tree: dict[str, Any] = {}
    found = False
    for k, v in read_npz(path).items():
        if not k.startswith(prefix):
            continue
        found = True
        node = tree
        parts = k[len(prefix) :].split("/")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = v
    if not found:
        raise RunError(f"{path} has no parameters for {strategy} seed {seed}")
    return tree
