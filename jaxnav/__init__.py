"""jaxnav: TurtleBot3 maze navigation and DQN with entropy-based exploration, in JAX.

Names are imported lazily, so ``jaxnav.robot.deploy`` (NumPy only) loads on a robot's
computer without JAX.
"""

import importlib
import time as _time

# When Python first read jaxnav (a command's process: near its start). A process that
# a shell replaced by Python (the last command of ``bash -c``) began long before.
_STARTED = _time.monotonic()

__version__ = "0.1.0"

_EXPORTS = {
    "EnvParams": "jaxnav.env",
    "EnvState": "jaxnav.env",
    "NavEnv": "jaxnav.env",
    "lidar_scan": "jaxnav.world.sensor",
    "make": "jaxnav.env",
    "Maze": "jaxnav.world.maps",
    "MazeError": "jaxnav.core.errors",
    "make_maze": "jaxnav.world.maps",
    "stack_mazes": "jaxnav.world.maps",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'jaxnav' has no attribute {name!r}")
