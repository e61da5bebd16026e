"""jaxnav: TurtleBot3 maze navigation and DQN with entropy-based exploration, in JAX."""

from jaxnav.env import EnvParams, EnvState, NavEnv, lidar_scan, make
from jaxnav.maps import Maze, MazeError, make_maze, stack_mazes

__version__ = "0.1.0"

__all__ = [
    "EnvParams",
    "EnvState",
    "NavEnv",
    "Maze",
    "MazeError",
    "lidar_scan",
    "make",
    "make_maze",
    "stack_mazes",
]
