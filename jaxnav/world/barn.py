"""BARN: the 300 worlds of The BARN Challenge (Perille et al., SSRR 2020; ICRA 2022-2025)
as jaxnav mazes, its splits, its protocol's numbers and its score.

Each world is an occupancy grid of discs (:mod:`jaxnav.world.occupancy`): 64 x 30 cells
of 0.15 m from (-4.5, 0), every occupied cell a cylinder of radius 0.075 m at its
centre (the data converted from the challenge's files, :mod:`jaxnav.world.barn_convert`;
``jaxnav/configs/barn/``, MIT licence, with the attribution). Nothing lies beyond the
grid: past the field (y > 9.6 m) the ground is open, as in Gazebo.

The protocol of the challenge's ``run.py``, ``test.sh`` and ``report_test.py``: the
robot starts at (-2.25, 3.0) facing +y (before February 2024: (-2, 3)); the goal is
10 m ahead, (-2.25, 13.0), reached within 1 m; a collision or 100 s is a failure. The
test worlds are those of ``test.sh``, 0, 6, 12, ..., 294 (50), each run 10 times,
averaged per world, then over worlds; the other 250 train. The score of a run is
success x OT / clip(AT, 2 OT, 8 OT), OT the reference path's length over 2 m/s, AT the
time taken (:mod:`jaxnav.report.barn`); until February 2024 ``run.py``'s clip was (4 OT, 8 OT) and
``report_test.py``'s until March 2026, and the published figures use that one.

Names: ``barn:N`` a world, ``barn:test`` and ``barn:train`` (and ``barn:all``) the
sets; ``env.generator: barn`` draws a world of its split for each episode (training on
the 250). ``jaxnav evaluate --baseline dwa barn`` tests the shipped ``barn`` config's
world.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.core.worlds import BARN_SETS, _is_barn_world
from jaxnav.world import barn_convert as bc
from jaxnav.world.gridmaze import grid_maze
from jaxnav.world.maps import Maze
from jaxnav.world.occupancy import DEFAULT_NEAR, DEFAULT_RANGE, fit, make_occupancy

DATA = Path(__file__).resolve().parent.parent / "configs" / "barn" / "barn.npz"
START = (bc.START[0], bc.START[1], math.pi / 2)
GOAL = (bc.START[0] + bc.GOAL_OFFSET[0], bc.START[1] + bc.GOAL_OFFSET[1])
GOAL_RADIUS = 1.0  # m: success within 1 m of the goal
TIME_LIMIT = 100.0  # s
TEST = BARN_SETS["barn:test"]  # test.sh: 0, 6, ..., 294
TRAIN = BARN_SETS["barn:train"]
# The region the planners' raster covers and goals are drawn from: the grid, and the
# open ground past the field up to beyond the goal.
BOUNDS = (-6.0, 0.0, 1.5, 14.5)


@functools.cache
def data() -> dict[str, np.ndarray]:
    """The shipped data: ``cylinders`` and ``occupied`` bool[300, 64, 30], ``paths``,
    ``path_length`` and ``path_length_2022`` (:mod:`jaxnav.world.barn_convert`)."""
    with np.load(DATA) as z:
        out = {k: z[k] for k in z.files}
    out["cylinders"] = bc.unpack(out["cylinders"])
    out["occupied"] = bc.unpack(out["occupied"])
    return out


def world_index(name: str) -> int | None:
    """N of a world's name ``barn:N`` (0 <= N < 300), else None."""
    return int(name.partition(":")[2]) if _is_barn_world(name) else None


def grid_of(n: int):
    """World ``n``'s occupancy grid (discs of 0.075 m on 0.15 m cells)."""
    return make_occupancy(data()["occupied"][n], bc.ORIGIN, bc.RES, bc.RADIUS)


@functools.cache
def load_barn(name: str) -> Maze:
    """The maze of ``barn:N``: its grid, BARN's start and goal (:func:`_base`'s maze with
    world N's cells)."""
    n = world_index(name)
    if n is None:
        raise ValueError(f"{name!r} is not a BARN world (barn:0 ... barn:299)")
    cells = int(data()["cylinders"][n].sum())
    return _base().replace(grid=grid_of(n), n_obstacles=jnp.asarray(cells, jnp.int32))


class BarnWorlds(NamedTuple):
    """The ``barn`` maze family: a world of the split drawn uniformly for each layout
    (train: the 250, test: the 50 of ``test.sh``), BARN's start and goal. Its grid is
    walked and windowed as the environment asks (``reach``, ``window``)."""

    reach: int
    window: int

    def draw(self, key, split: str = "train"):
        worlds = jnp.asarray(TRAIN if split == "train" else TEST, jnp.int32)
        n = worlds[jax.random.randint(key, (), 0, len(worlds))]
        template = _template()
        cells = jnp.asarray(data()["occupied"])[n]
        grid = template.grid.replace(occupied=cells, reach=self.reach, window=self.window)
        return template.replace(grid=grid), jnp.asarray(GOAL, jnp.float32)


@functools.cache
def _base() -> Maze:
    """World 0's maze (:func:`jaxnav.world.gridmaze.grid_maze`: its start checked), its
    goals cut to those outside the field (y < 5.1 or y > 9.6): free in every world, the
    corridor and the ground past the field being the same in all 300. Each world's maze
    is this one with its own cells (goals beyond BARN's own are drawn only with
    ``env.goal_ends`` off or ``env.random_start``)."""
    maze = grid_maze(
        grid_of(0), np.asarray(START), "BARN world 0", goal=np.asarray(GOAL),
        bounds=np.asarray(BOUNDS),
    )  # fmt: skip
    pts = np.asarray(maze.goal_points)[: int(maze.n_goal_points)]
    keep = pts[(pts[:, 1] < 5.1) | (pts[:, 1] > 9.6)]
    shape = np.asarray(maze.goal_points).shape
    return maze.replace(
        goal_points=jnp.asarray(np.resize(keep, shape), jnp.float32),
        n_goal_points=jnp.asarray(len(keep), jnp.int32),
    )


def _template() -> Maze:
    """The family's maze, whose cells each draw replaces."""
    return _base()


def barn_family(env) -> BarnWorlds:
    """The family's shape for ``env`` (a NavEnv or an env config): its grid sized by
    ``env.grid_fit`` where the environment has set it, else the defaults."""
    range_m, near = getattr(env, "grid_fit", (0.0, 0.0))
    grid = fit(grid_of(0), range_m or DEFAULT_RANGE, near or DEFAULT_NEAR)
    return BarnWorlds(grid.reach, grid.window)


__all__ = [
    "DATA",
    "GOAL",
    "GOAL_RADIUS",
    "START",
    "TEST",
    "TIME_LIMIT",
    "TRAIN",
    "BarnWorlds",
    "barn_family",
    "data",
    "load_barn",
    "world_index",
]
