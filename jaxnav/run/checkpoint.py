"""A training run's checkpoint: the trainer's state as named arrays, and back.

The replay buffer's per-slot arrays are stored incrementally (row segments, below);
the rest of the state, in ``checkpoints/last.npz``, says how many segments it covers.
:mod:`jaxnav.run.training` writes and reads them through these functions.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.agent import replay
from jaxnav.core import agents, rundir
from jaxnav.core.config import Config
from jaxnav.core.errors import ConfigError, RunError

# The replay buffer's per-slot arrays. A checkpoint stores them incrementally: each
# chunk's checkpoint writes the slots written in that chunk to a segment file of its
# own (ROW_SEGMENT), and checkpoints/last.npz, the rest of the state, says how many
# segments it covers; restoring applies them in order. So a checkpoint costs what its
# chunk added, not the whole buffer, which grows to 28 MB per run in a paper run.
# In memory they are the words of each slot's record (replay.Buffer.records); a
# checkpoint names them one by one, as they were before the records.
_BUFFER_ROWS = tuple(name for name, _ in replay.SLOT_FIELDS)
_RECORDS = ".buffer.records"
ROW_SEGMENT = "checkpoints/rows-{:05d}.npz"


# ----------------------------------------------------------------------------
# Pytrees <-> named arrays
# ----------------------------------------------------------------------------


def leaf_names(tree) -> list[str]:
    """The names of a pytree's leaves (``jax.tree_util.keystr`` of each path)."""
    paths, _ = jax.tree_util.tree_flatten_with_path(tree)
    return [jax.tree_util.keystr(p) for p, _ in paths]


# The ring of finished episodes (the trainer's ``metrics``, agent.episodes.Episodes):
# the host copies its new episodes into metrics.csv after every chunk and never reads
# them again, so a checkpoint leaves the ring out (a restored one is zeros, and the
# episodes it held are in metrics.csv). Sized for the most episodes a chunk can end,
# it was 105 of drive_stage4's 114 MB checkpoint.
_RING = ".metrics.ep_"


# A run's bank of drawn layouts (the state's ``bank``): drawn once, at the start, from
# the run's key (jaxnav.world.layouts.bank_key) where env.maze_bank_refresh is 0, so a
# checkpoint leaves it out and a resumed run draws it again (the same layouts: the same
# key, the same program). It was about 50 MB a seed of drive_anywhere's checkpoint. A
# bank that is renewed while training (maze_bank_refresh > 0) is stored.
_BANK = r"\.bank(\W|$)"  # its leaves' names


def _is_buffer_rows(name: str) -> bool:
    return name == _RECORDS


def without_rows(ts: Any, keep_bank: bool = True) -> Any:
    """The training state a checkpoint stores: without the replay buffer's per-slot
    arrays (a state without a replay buffer, PQN's, keeps them as none), without the
    ring of finished episodes, and without the bank of layouts unless ``keep_bank``
    (one that is renewed while training)."""
    if not keep_bank and getattr(ts, "bank", None) is not None:
        ts = ts.replace(bank=None)
    metrics = getattr(ts, "metrics", None)
    if metrics is not None:
        ring = [
            f.name
            for f in dataclasses.fields(metrics)
            if f.name.startswith("ep_") and getattr(metrics, f.name) is not None
        ]
        ts = ts.replace(metrics=metrics.replace(**dict.fromkeys(ring)))
    if getattr(ts, "buffer", None) is None:
        return ts
    return ts.replace(buffer=ts.buffer.replace(records=None))


def rows_at(ts: Any, slots: jax.Array) -> dict[str, jax.Array]:
    """The replay buffer's per-slot arrays at ``slots`` (i32[n]) of every run (none
    without a replay buffer)."""
    if getattr(ts, "buffer", None) is None:
        return {}
    slotted = ts.buffer.replace(records=ts.buffer.records[:, slots])
    return {r: getattr(slotted, r) for r in _BUFFER_ROWS}


def chunk_slots(step_before: np.ndarray, step_after: np.ndarray, capacity: int) -> np.ndarray:
    """The buffer slots a chunk wrote (i32[n]): runs that step, step together, each
    adding slot ``step % capacity`` per step, so they are those of the steps from the
    most advanced run's step before the chunk to its step after (the last
    ``capacity`` of them)."""
    first, last = int(step_before.max()), int(step_after.max())
    steps = np.arange(max(first, last - capacity), last)
    return (steps % capacity).astype(np.int32)


def checkpoint_arrays(state: Any, host: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Host copies of the training state without its per-slot replay arrays
    (:func:`without_rows`), and the host loop's own counters."""
    arrays = {"state" + n: np.asarray(a) for n, a in zip(leaf_names(state), jax.tree.leaves(state))}
    arrays.update({"host." + k: v for k, v in host.items()})
    return arrays


def state_from_checkpoint(
    arrays: dict[str, np.ndarray],
    segments: list[dict[str, np.ndarray]],
    template: Any,
    path: Path,
    bank: Any = None,
) -> tuple[Any, dict[str, np.ndarray]]:
    """Inverse of :func:`checkpoint_arrays` and the row segments (each ``slots`` and
    one array per per-slot field), against a template of the right shapes. ``bank``: a
    function that draws the runs' bank of layouts again (its leaves in the template's
    order), for a checkpoint that left it out (:func:`without_rows`)."""
    drawn = None
    leaves = []
    for name, leaf in zip(leaf_names(template), jax.tree.leaves(template)):
        if _is_buffer_rows(name):
            leaves.append(_records(leaf, segments, path))
            continue
        if name.startswith(_RING):  # not stored: nothing reads it again
            leaves.append(np.zeros(leaf.shape, leaf.dtype))
            continue
        a = arrays.get("state" + name)
        if a is None and re.match(_BANK, name) and bank is not None:  # drawn again
            drawn = iter(jax.tree.leaves(bank())) if drawn is None else drawn
            a = np.asarray(next(drawn))
        if a is None:
            raise RunError(
                f"checkpoint {path} does not match this run (no {name}: another config or "
                "another jaxnav version)"
            )
        if a.shape != leaf.shape:
            raise RunError(f"checkpoint {path} does not match the run's config ({name})")
        leaves.append(np.asarray(a, leaf.dtype))
    ts = jax.tree.unflatten(jax.tree.structure(template), leaves)
    host = {k[5:]: v for k, v in arrays.items() if k.startswith("host.")}
    return ts, host


def _records(leaf, segments: list[dict[str, np.ndarray]], path: Path) -> np.ndarray:
    """The replay records u32[runs, N, D + 3], from the row segments in order (each
    ``slots`` and the named fields of those slots)."""
    records = np.zeros(leaf.shape, leaf.dtype)
    runs, capacity, _ = records.shape
    for seg in segments:
        fields = {r: seg.get(f"rows.buffer.{r}") for r in _BUFFER_ROWS}
        missing = [r for r, a in fields.items() if a is None or a.shape[0] != runs]
        if missing or seg["slots"].max() >= capacity:
            raise RunError(f"checkpoint {path} does not match the run's config (buffer rows)")
        records[:, seg["slots"]] = np.asarray(replay.pack(**fields))
    return records


def _entry_name(path) -> str:
    """A params leaf's name in ``params.npz`` (``params/Dense_0/kernel``)."""
    return "/".join(str(getattr(k, "key", k)) for k in path)


def params_arrays(cfg: Config, params) -> dict[str, np.ndarray]:
    """``params.npz`` entries: every array of every run, by strategy, seed and layer."""
    arrays = {}
    flat, _ = jax.tree_util.tree_flatten_with_path(params)
    for r, (strategy, seed) in enumerate(cfg.run_labels()):
        for p, leaf in flat:
            name = _entry_name(p)
            arrays[rundir.params_key(strategy, seed, name)] = np.asarray(leaf[r])
    return arrays


# ----------------------------------------------------------------------------
# A warm start: each run's first params from a finished run (run.init_from)
# ----------------------------------------------------------------------------


_RUN_KEY = re.compile(r"^(.+?)/seed(\d+)/")  # rundir.params_key's arm and seed


def start_params(cfg: Config, template) -> dict[str, Any] | None:
    """Each run's starting params, stacked on the run axis like ``template`` (the
    trainer state's params, shapes only), from the ``params.npz`` of the finished run
    ``run.init_from``: the entry of the same strategy and seed, else of the same seed
    under the source's first strategy (a policy trained with another strategy). None
    without ``run.init_from``. ConfigError, one line, where the source is missing, lacks
    a seed, or holds another network."""
    source = cfg.run.init_from
    if not source:
        return None
    where = f"config: run.init_from: {source}"
    if agents.get(cfg.agent).actions != "discrete":
        raise ConfigError(f"{where}: only a Q-learner starts from params.npz (it holds no critic)")
    try:
        arrays = rundir.read_npz(Path(source) / rundir.PARAMS, f"{source}/{rundir.PARAMS}")
    except RunError as e:
        raise ConfigError(f"config: run.init_from: {e}: give a finished training run") from None
    held = [m.groups() for m in map(_RUN_KEY.match, arrays) if m]  # (arm, seed) per entry
    first = held[0][0] if held else None  # the source's first strategy (or sweep arm)
    seeds = sorted({int(seed) for arm, seed in held if arm == first})
    missing = sorted({seed for _, seed in cfg.run_labels()} - set(seeds))
    if missing:
        have = ", ".join(map(str, seeds)) or "none"
        raise ConfigError(f"{where} has no seed {missing[0]} (it holds seeds {have})")
    flat, treedef = jax.tree_util.tree_flatten_with_path(template)
    leaves = []
    for p, leaf in flat:
        name = _entry_name(p)
        per_run = []
        for strategy, seed in cfg.run_labels():
            key = rundir.params_key(strategy, seed, name)
            if key not in arrays and first is not None:
                key = rundir.params_key(first, seed, name)
            if key not in arrays:
                raise ConfigError(f"{where} has no {name} for seed {seed}")
            if arrays[key].shape != leaf.shape[1:]:
                raise ConfigError(
                    f"{where} holds another network: {name} is {arrays[key].shape}, "
                    f"this config's {tuple(leaf.shape[1:])}"
                )
            per_run.append(arrays[key].astype(leaf.dtype))
        leaves.append(np.stack(per_run))
    return jax.tree_util.tree_unflatten(treedef, leaves)


def warm_started(ts: Any, params: Any) -> Any:
    """The trainer state ``ts`` starting from ``params`` (and, with a target network,
    its target too); the optimiser's state is as ``init`` made it."""
    ts = ts.replace(params=params)
    if hasattr(ts, "target_params"):  # buffers of its own: the chunk donates the state
        ts = ts.replace(target_params=jax.tree.map(jnp.copy, params))
    return ts
