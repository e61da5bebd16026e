"""Use every CPU core: one XLA CPU device per core, set before JAX starts.

XLA runs the many small operations of a training step on one thread per device,
so on a CPU-only machine one device leaves the other cores idle. The commands
(``jaxnav train``, ``jaxnav reproduce``, ``jaxnav evaluate``) therefore
ask for one CPU device per usable core, and the run axis is sharded over them
(:mod:`jaxnav.agent.sharding`). On a GPU machine the GPUs stay the default devices.

Set ``XLA_FLAGS=--xla_force_host_platform_device_count=N`` yourself to choose N;
results agree across device counts to float32 rounding, and are bit-identical for
the same count.
"""

import os
import sys

_FLAG = "--xla_force_host_platform_device_count"


def use_all_cores() -> None:
    """Ask XLA for one CPU device per usable core, unless JAX already started or the
    user chose a device count."""
    if "jax" in sys.modules:
        return
    flags = os.environ.get("XLA_FLAGS", "")
    if _FLAG in flags:
        return
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    if cores > 1:
        os.environ["XLA_FLAGS"] = f"{flags} {_FLAG}={cores}".strip()
