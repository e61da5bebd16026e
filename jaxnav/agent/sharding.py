"""Lay the run axis (seeds x strategies) over every device with JAX's own sharding.

Runs are independent, so the leading run axis of every array of the training state
is split over a one-dimensional ``Mesh`` of all ``jax.devices()`` (on every host);
everything else (mazes, config) is a constant of the compiled program and so is
replicated. One device behaves exactly as an unsharded program.

The training chunk runs each device's runs as one vmapped batch
(:meth:`RunSharding.per_device`, ``shard_map``): what the step decides for the whole
batch (:func:`any_run`, whether some run is due a target copy) is decided per device,
with no collective between devices.

A run count that does not divide the device count is padded with copies of the
last run; the padding is computed, never written (host reads slice it off).

Multi-host: when the usual variables are set (``JAX_COORDINATOR_ADDRESS``,
``JAX_NUM_PROCESSES``, ``JAX_PROCESS_ID``), :func:`initialize` calls
``jax.distributed.initialize()``; each process then computes the runs on its own
devices, host reads gather every run, and only process 0 writes files.
"""

from __future__ import annotations

import os
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

_ENV_VARS = ("JAX_COORDINATOR_ADDRESS", "JAX_NUM_PROCESSES", "JAX_PROCESS_ID")
_initialized = False


@jax.custom_batching.custom_vmap
def any_run(x: jax.Array) -> jax.Array:
    """bool[]: ``x`` for one run; vmapped over runs, whether any run's ``x`` holds, one
    value for the whole batch (not batched), so that a ``lax.cond`` on it stays a
    branch instead of becoming a select that computes both sides for every run."""
    return x


@any_run.def_vmap
def _any_run_vmap(axis_size: int, in_batched: list[bool], x: jax.Array):
    del axis_size
    return (jnp.any(x, axis=0) if in_batched[0] else x), False


def initialize() -> None:
    """Start ``jax.distributed`` if its environment variables are set (once)."""
    global _initialized
    if _initialized or not all(os.environ.get(v) for v in _ENV_VARS):
        return
    jax.distributed.initialize(
        coordinator_address=os.environ["JAX_COORDINATOR_ADDRESS"],
        num_processes=int(os.environ["JAX_NUM_PROCESSES"]),
        process_id=int(os.environ["JAX_PROCESS_ID"]),
    )
    _initialized = True


def is_writer() -> bool:
    """True in the one process that writes files."""
    return jax.process_index() == 0


class RunSharding:
    """Placement of ``n_runs`` runs over all devices (padded to a multiple of them)."""

    def __init__(self, n_runs: int, devices: list | None = None):
        self.devices = list(devices if devices is not None else jax.devices())
        self.n_devices = len(self.devices)
        self.n_runs = n_runs
        self.padded = -(-n_runs // self.n_devices) * self.n_devices
        self.mesh = Mesh(np.asarray(self.devices), ("runs",))
        self.sharding = NamedSharding(self.mesh, PartitionSpec("runs"))

    def pad(self, x: np.ndarray) -> np.ndarray:
        """Pad the leading run axis of a host array with copies of its last row."""
        extra = self.padded - x.shape[0]
        if extra == 0:
            return x
        return np.concatenate([x, np.repeat(x[-1:], extra, axis=0)])

    def put(self, tree: Any) -> Any:
        """Host arrays [n_runs or padded, ...] -> global arrays sharded over runs."""

        def one(x):
            x = self.pad(np.asarray(x))
            return jax.make_array_from_callback(x.shape, self.sharding, lambda idx: x[idx])

        return jax.tree.map(one, tree)

    def get(self, tree: Any) -> Any:
        """Global arrays -> host NumPy arrays of the real runs (padding dropped)."""

        def one(x):
            if jax.process_count() > 1 and not x.is_fully_addressable:
                from jax.experimental import multihost_utils

                x = multihost_utils.process_allgather(x, tiled=True)
            return np.asarray(x)[: self.n_runs]

        return jax.tree.map(one, tree)

    def per_device(self, fn, n_args: int):
        """``fn`` (vmapped over runs; its first argument and every output carry the run
        axis, the other ``n_args - 1`` arguments are the same for every run) run on each
        device's own runs: what ``fn`` reduces over the run axis (:func:`any_run`) is
        reduced over that device's runs, with no collective between devices."""
        runs, same = PartitionSpec("runs"), PartitionSpec()
        specs = (runs,) + (same,) * (n_args - 1)
        # check_vma off: the trainer's loops start their logs from constants that the
        # runs then fill, which the check would ask to be marked as varying by hand
        return jax.shard_map(fn, mesh=self.mesh, in_specs=specs, out_specs=runs, check_vma=False)

    def device_count_of(self, x: jax.Array) -> int:
        """How many devices hold parts of ``x``."""
        return len(x.sharding.device_set)
