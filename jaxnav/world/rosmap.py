"""A ROS map_server map as a maze: the YAML file SLAM writes beside its PGM or PNG image.

The YAML keys are map_server's (ROS 1 ``map_server``, ROS 2 ``nav2_map_server``)::

    image: office.pgm          # relative to the YAML file
    resolution: 0.05           # m per pixel
    origin: [-10.0, -8.0, 0.0] # the lower-left pixel's corner (x, y, yaw); yaw must be 0
    negate: 0                  # 1: white is occupied
    occupied_thresh: 0.65      # occupancy above this: occupied
    free_thresh: 0.196         # occupancy below this: free
    mode: trinary              # trinary, scale or raw

A pixel's occupancy is (255 - v) / 255 for its value v (v / 255 with ``negate``; a colour
pixel's value is the mean of its colour channels, as map_server takes it). Only the free
pixels are free: occupied *and unknown* pixels are walls, and so is everything beyond
the image (one occupied cell is laid around it). In ``raw`` mode a pixel is free where
its value is 0. Each occupied cell is the whole square of its pixel.

A ROS map has no start: jaxnav reads its own optional keys beside map_server's (which
map_server ignores): ``start: [x, y, yaw]`` (default: the free point farthest from every
wall, facing +x) and ``goal: [x, y]`` (the first goal of every reset; default drawn).

A bad file is refused in one line (:class:`jaxnav.core.errors.MazeError`): a missing or
unreadable image, an image that is not PGM or PNG, a resolution that is not positive, a
rotated origin, thresholds out of order, a map of more than :data:`MAX_CELLS` cells, a
start in a wall, no free room reachable from the start.
"""

from __future__ import annotations

import os

import numpy as np

from jaxnav.core.errors import MazeError
from jaxnav.core.shipped import shipped_path
from jaxnav.world.gridmaze import grid_bounds, grid_maze, reachable_raster
from jaxnav.world.maps import MAX_COORDINATE, ROBOT_RADIUS, Maze
from jaxnav.world.occupancy import make_occupancy

MAX_CELLS = 4096 * 4096  # cells of a map at most (16.8 million: 16 MiB of occupancy)
IMAGE_FORMATS = (".pgm", ".png")
MODES = ("trinary", "scale", "raw")
KEYS = {
    "image",
    "resolution",
    "origin",
    "negate",
    "occupied_thresh",
    "free_thresh",
    "mode",
    "start",
    "goal",
    "name",
}


def read_map_yaml(path: str, where: str) -> dict:
    """The map file's mapping, its keys known and typed (one line naming what is wrong)."""
    import yaml

    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except FileNotFoundError:
        raise MazeError(f"{where}: no such file") from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        raise MazeError(f"{where}: not a readable YAML file") from None
    if not isinstance(doc, dict) or "image" not in doc:
        raise MazeError(f"{where}: expected a mapping with an 'image' key")
    unknown = set(map(str, doc)) - KEYS
    if unknown:
        raise MazeError(f"{where}: unknown key {sorted(unknown)[0]!r}")
    for key in ("image", "resolution", "origin"):
        if key not in doc:
            raise MazeError(f"{where}: missing {key!r}")
    res = doc["resolution"]
    if isinstance(res, bool) or not isinstance(res, (int, float)) or not res > 0:
        raise MazeError(f"{where}: resolution must be a positive number of metres per pixel")
    origin = _numbers(doc["origin"], 3, "origin must be [x, y, yaw]", where)
    if origin[2] != 0.0:
        raise MazeError(f"{where}: origin yaw must be 0 (a rotated map is not supported)")
    if np.abs(origin[:2]).max() > MAX_COORDINATE:
        raise MazeError(f"{where}: origin lies beyond 1 km; map coordinates are metres")
    occ = doc.get("occupied_thresh", 0.65)
    free = doc.get("free_thresh", 0.196)
    for key, v in (("occupied_thresh", occ), ("free_thresh", free)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v <= 1.0:
            raise MazeError(f"{where}: {key} must be a number in [0, 1]")
    if not free <= occ:
        raise MazeError(f"{where}: free_thresh must not exceed occupied_thresh")
    mode = doc.get("mode", "trinary")
    if mode not in MODES:
        raise MazeError(f"{where}: mode must be {', '.join(MODES)}")
    negate = doc.get("negate", 0)
    if negate not in (0, 1, True, False):
        raise MazeError(f"{where}: negate must be 0 or 1")
    return {
        "image": str(doc["image"]),
        "resolution": float(res),
        "origin": origin[:2],
        "negate": bool(negate),
        "free_thresh": float(free),
        "mode": mode,
        "start": None
        if doc.get("start") is None
        else _numbers(doc["start"], 3, "start must be [x, y, yaw]", where),
        "goal": None
        if doc.get("goal") is None
        else _numbers(doc["goal"], 2, "goal must be [x, y]", where),
    }


def _numbers(value, n: int, says: str, where: str) -> np.ndarray:
    try:
        arr = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        arr = np.zeros(0)
    if arr.shape != (n,) or not np.isfinite(arr).all():
        raise MazeError(f"{where}: {says}")
    return arr


def read_image(path: str, where: str) -> np.ndarray:
    """f64[rows, cols]: the image's pixel values scaled to 0..255 (colour channels
    averaged, alpha dropped), row 0 the image's top."""
    if not os.path.isfile(path):
        raise MazeError(f"{where}: image {path} not found")
    if os.path.splitext(path)[1].lower() not in IMAGE_FORMATS:
        raise MazeError(f"{where}: image {path} is not a PGM or PNG file")
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            if img.format not in ("PPM", "PNG"):  # Pillow reads PGM as its PPM family
                raise MazeError(f"{where}: image {path} is not a PGM or PNG file")
            if img.size[0] * img.size[1] > MAX_CELLS:
                raise MazeError(
                    f"{where}: image {path} has {img.size[0]} x {img.size[1]} pixels, more "
                    f"than the {MAX_CELLS} cells a map may have"
                )
            if img.mode == "P":
                img = img.convert("RGBA" if "transparency" in img.info else "RGB")
            arr = np.asarray(img)
            mode = img.mode
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError):
        raise MazeError(f"{where}: image {path} cannot be read as a PGM or PNG image") from None
    arr = arr.astype(np.float64)
    if mode.startswith("I;16") or mode == "I":  # 16-bit grey: to 0..255
        arr = arr * (255.0 / 65535.0)
    if arr.ndim == 3:
        channels = 3 if mode in ("RGB", "RGBA") else 1
        arr = arr[..., :channels].mean(axis=-1)
    if arr.ndim != 2 or arr.size == 0:
        raise MazeError(f"{where}: image {path} holds no pixels")
    return arr


def free_cells(pixels: np.ndarray, spec: dict) -> np.ndarray:
    """bool[H, W] which cells are free, row 0 the map's bottom (the image flipped)."""
    if spec["mode"] == "raw":
        free = pixels == 0.0
    else:
        p = pixels / 255.0 if spec["negate"] else (255.0 - pixels) / 255.0
        free = p < spec["free_thresh"]
    return free[::-1]


def load_ros_map(path: str) -> Maze:
    """The maze of a ROS map_server YAML file (format in the module docstring)."""
    where = f"map file {path}"
    path = shipped_path(path)
    spec = read_map_yaml(path, where)
    image = os.path.join(os.path.dirname(os.path.abspath(path)), spec["image"])
    free = free_cells(read_image(image, where), spec)
    res = spec["resolution"]
    occupied = np.pad(~free, 1, constant_values=True)  # beyond the image: unknown, a wall
    origin = spec["origin"] - res
    grid = make_occupancy(occupied, origin, res)
    start = spec["start"]
    if start is None:
        start = _roomiest(grid, where)
    return grid_maze(grid, start, where, goal=spec["goal"])


def _roomiest(grid, where: str) -> np.ndarray:
    """The default start: the free point farthest from every occupied cell (the first
    of equals in raster order), facing +x."""
    bounds = grid_bounds(grid)
    pts, clear, _ = reachable_raster(grid, bounds, bounds[:2], ROBOT_RADIUS)
    i = int(np.argmax(clear))
    if not clear[i] >= ROBOT_RADIUS:
        raise MazeError(f"{where}: no free cell has room for the robot")
    return np.array([pts[i, 0], pts[i, 1], 0.0])


__all__ = ["IMAGE_FORMATS", "MAX_CELLS", "load_ros_map", "read_image", "read_map_yaml"]
