"""BARN's 300 worlds converted from the challenge's own files into the compact data
jaxnav ships (``jaxnav/configs/barn/barn.npz``), NumPy only.

The source is The BARN Challenge's repository (``Daffan/the-barn-challenge``, MIT
licence, Zifan Xu 2022): ``jackal_helper/worlds/BARN/world_N.world`` (Gazebo SDF 1.6) and
``jackal_helper/worlds/BARN/path_files/path_N.npy`` (the reference path, grid cells).
Every filled cell of a world is a model ``unit_cylinder_K``, a static cylinder of radius
0.075 m whose first ``<pose>`` (the one before the file's ``<state>`` block) is its
centre. The converter checks each fact it relies on and refuses a file that breaks one:

* every cylinder has radius 0.075 m and stands on the 0.15 m lattice x = -4.425 + 0.15 j
  (j = 0..29), y = 0.075 + 0.15 i (i = 0..63): BARN's 30 x 30 field (its rows 0..29 along
  x, columns along y from 5.175 m) above a walled start corridor (y < 5.1);
* the field's rows 0 and 29 (x = -4.425 and -0.075) are full side walls, and the
  corridor (its back wall at y = 0.075, its sides on the same two lines) is the same
  in every world;
* the generator leaves out the cylinders whose eight neighbours are all filled: a cell
  sealed off from the open field by touching cylinders (not 8-connected to it through
  free cells, nor to the start) is marked occupied, as it is in the generator's grid
  (nothing outside can see or reach it, so this changes no range and no collision).

The data, one row per world in index order: ``cylinders`` and ``occupied``, the 64 x
30 cells of jaxnav's grid (row i along y, column j along x, origin (-4.5, 0)) packed
into bits (``np.packbits`` of each world's row-major cells); ``paths`` the reference
path's cells (BARN's (row, col), int8, padded with -1) and ``path_length`` its length
in metres as ``run.py`` measures it today (cells to metres as
``path_coord_to_gazebo_coord``, the start (-2.25, 3) prepended and the goal (-2.25, 13)
appended) and ``path_length_2022`` with the start BARN used before February 2024 and
``report_test.py`` still uses, (-2, 3). ``np.savez`` writes the same bytes for the same
arrays, so ``checks/barn_convert.py`` re-derives the shipped file byte for byte.
"""

from __future__ import annotations

import io
import re
from collections.abc import Callable

import numpy as np

N_WORLDS = 300
ROWS, COLS = 64, 30  # jaxnav's grid: along y, along x
RES = 0.15  # m
RADIUS = 0.075  # m
ORIGIN = (-4.5, 0.0)  # the grid's lower-left corner
FIELD_ROW = 34  # jaxnav row of BARN's field column 0 (y = 5.175)
START = (-2.25, 3.0)  # run.py since February 2024
START_2022 = (-2.0, 3.0)  # run.py before, report_test.py still
GOAL_OFFSET = (0.0, 10.0)  # the goal relative to the start
MAX_PATH = 64
WORLD = "jackal_helper/worlds/BARN/world_{}.world"
PATH = "jackal_helper/worlds/BARN/path_files/path_{}.npy"

_MODEL = re.compile(
    r"<model name='unit_cylinder_\d+'>\s*<static>(\d)</static>\s*<pose frame=''>([^<]*)</pose>"
    r"(.*?)</model>",
    re.S,
)


class BarnFormatError(ValueError):
    """A BARN source file that breaks a fact the converter relies on."""


def cylinders_of(text: str, where: str) -> np.ndarray:
    """bool[64, 30]: the cells of a world file holding a cylinder."""
    head = text.split("<state ")[0]
    models = _MODEL.findall(head)
    if not models or len(models) != head.count("<model name='unit_cylinder_"):
        raise BarnFormatError(f"{where}: cylinder models not as expected")
    grid = np.zeros((ROWS, COLS), bool)
    for static, pose, body in models:
        radii = set(re.findall(r"<radius>([^<]*)</radius>", body))
        if static != "1" or radii != {"0.075000"}:
            raise BarnFormatError(f"{where}: a cylinder is not static of radius 0.075")
        x, y, *rest = (float(v) for v in pose.split())
        if any(rest):
            raise BarnFormatError(f"{where}: a cylinder is lifted or turned")
        j, i = (x - ORIGIN[0]) / RES - 0.5, (y - ORIGIN[1]) / RES - 0.5
        if abs(j - round(j)) > 1e-6 or abs(i - round(i)) > 1e-6:
            raise BarnFormatError(f"{where}: a cylinder is off the 0.15 m lattice ({x}, {y})")
        i, j = round(i), round(j)
        if not (0 <= i < ROWS and 0 <= j < COLS) or grid[i, j]:
            raise BarnFormatError(f"{where}: a cylinder outside the field or doubled")
        grid[i, j] = True
    return grid


def corridor() -> np.ndarray:
    """bool[64, 30]: the start corridor's cylinders: its back wall (row 0) and its sides
    (columns 0 and 29) up to the field."""
    grid = np.zeros((ROWS, COLS), bool)
    grid[0] = True
    grid[:FIELD_ROW, 0] = grid[:FIELD_ROW, COLS - 1] = True
    return grid


def sealed_filled(cylinders: np.ndarray) -> np.ndarray:
    """bool[64, 30]: the cylinders and every free cell sealed off from both the open
    space around the grid and the start's cell (not 8-connected to either through free
    cells): what the generator's grid holds there."""
    from scipy import ndimage

    free = np.pad(~cylinders, 1, constant_values=True)  # around the grid: open
    labels, _ = ndimage.label(free, structure=np.ones((3, 3), int))
    i0 = int((START[1] - ORIGIN[1]) / RES) + 1
    j0 = int((START[0] - ORIGIN[0]) / RES) + 1
    keep = {labels[0, 0], labels[i0, j0]} - {0}
    return cylinders | ~np.isin(labels, list(keep))[1:-1, 1:-1]


def path_length(cells: np.ndarray, start) -> float:
    """The reference path's length (m) as BARN's run.py measures it: cell (r, c) at
    (0.15 r - 4.575, 0.15 c + 5.075), the start prepended and the goal appended."""
    pts = np.stack(
        [
            cells[:, 0] * (RADIUS * 2) - RADIUS - 30 * RADIUS * 2,
            cells[:, 1] * (RADIUS * 2) + RADIUS + 5,
        ],
        1,
    )
    goal = (start[0] + GOAL_OFFSET[0], start[1] + GOAL_OFFSET[1])
    path = np.concatenate([[start], pts, [goal]]).astype(np.float64)
    return float(np.sum(np.hypot(*np.diff(path, axis=0).T)))


def convert(read: Callable[[str], bytes]) -> bytes:
    """The shipped data (``barn.npz``'s bytes) from the BARN repository's files, read by
    ``read(path)`` (a path inside the repository). BarnFormatError if a fact fails."""
    cyl = np.zeros((N_WORLDS, ROWS, COLS), bool)
    occ = np.zeros_like(cyl)
    paths = np.full((N_WORLDS, MAX_PATH, 2), -1, np.int8)
    lengths = np.zeros(N_WORLDS)
    lengths_2022 = np.zeros(N_WORLDS)
    walls = corridor()
    for n in range(N_WORLDS):
        where = WORLD.format(n)
        grid = cylinders_of(read(where).decode("utf-8"), where)
        if not (grid[FIELD_ROW:, 0].all() and grid[FIELD_ROW:, COLS - 1].all()):
            raise BarnFormatError(f"{where}: the field's side rows 0 and 29 are not full walls")
        if not np.array_equal(grid[:FIELD_ROW], walls[:FIELD_ROW]):
            raise BarnFormatError(f"{where}: the start corridor is not the usual one")
        cyl[n], occ[n] = grid, sealed_filled(grid)
        cells = np.load(io.BytesIO(read(PATH.format(n))))
        if cells.ndim != 2 or cells.shape[1] != 2 or len(cells) > MAX_PATH:
            raise BarnFormatError(f"{PATH.format(n)}: not an n x 2 path of at most {MAX_PATH}")
        paths[n, : len(cells)] = cells
        lengths[n] = path_length(cells, START)
        lengths_2022[n] = path_length(cells, START_2022)
    out = io.BytesIO()
    np.savez(
        out,
        cylinders=np.packbits(cyl.reshape(N_WORLDS, -1), axis=1),
        occupied=np.packbits(occ.reshape(N_WORLDS, -1), axis=1),
        paths=paths,
        path_length=lengths,
        path_length_2022=lengths_2022,
    )
    return out.getvalue()


def unpack(bits: np.ndarray) -> np.ndarray:
    """bool[N, 64, 30] of the data's packed cells."""
    n = bits.shape[0]
    return np.unpackbits(bits, axis=1)[:, : ROWS * COLS].reshape(n, ROWS, COLS).astype(bool)


__all__ = [
    "BarnFormatError",
    "N_WORLDS",
    "convert",
    "corridor",
    "cylinders_of",
    "path_length",
    "sealed_filled",
    "unpack",
]
