"""Drawn-maze families by name: the registry every part of jaxnav reads.

A family is what ``env.generator`` names: a kind of random maze drawn inside jit. Its
part without JAX is declared here, once: its own settings (a dataclass of
:func:`jaxnav.core.settings.setting` fields, each a config key ``env.NAME`` and a field
of ``jaxnav.env.NavEnv``, both laid out by :func:`settings_after`), its refusal of
settings that do not go together (one line naming the setting, checked when a config
loads and when the environment is built), a few words about it and whether it has the
shortest paths the geodesic reward reads. Its draw lives in :mod:`jaxnav.world`: a
function of the settings giving the family's static, hashable shape, whose
``draw(key, split) -> (maze, goal f32[2])`` the environment calls; it is named here as
``"module:function"`` and imported when first used, so this module imports no JAX::

    from jaxnav.core import families

    families.register("empty", "my_module:empty_room", about="an empty square room")

A family with ``shortest_paths`` also gives ``cell_distances(maze)``,
``geodesic_target(maze, cell_dist, pos, goal)`` and ``waypoint(maze, cell_dist, pos,
goal, lookahead)`` (:mod:`jaxnav.world.generators`).
``env.generator: ""`` (the fixed maze ``env.maze``) is no family. A family registered
after the config is built (a test's, a plug-in's) can declare no settings of its own:
they could no longer become config keys.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from jaxnav.core.errors import ConfigError
from jaxnav.core.refs import resolve
from jaxnav.core.settings import AT_LEAST_1, NON_NEGATIVE, UNIT, setting

# The robot's diameter (2 x jaxnav.world.maps.ROBOT_RADIUS): a grid cell must be wider.
ROBOT_DIAMETER = 0.26
# jaxnav.world.maps.GOAL_CLEARANCE: a drawn start or goal is this far from every surface.
GOAL_CLEARANCE = 0.35
MAX_CYLINDERS = 64
MIN_CYLINDER_ROOM = 1.5  # m: every start has a goal 0.4 m away (GOAL_START_CLEARANCE)
MAX_CYLINDER_ROOM = 16.0  # m: the occupancy raster of a cylinder room is 0.1 m cells
# A cylinder field is refused when its cylinders, each grown by CYLINDER_GROWTH (about
# jaxnav.world.cylinders.PASS_CLEARANCE: the robot's radius and half a raster cell's
# diagonal), could cover more than MAX_CYLINDER_COVER of the room: a free path and a
# far goal would then be rare.
CYLINDER_GROWTH = 0.2
MAX_CYLINDER_COVER = 0.5
DOOR_MARGIN = 0.05  # m of wall left at least on either side of a door (rooms)


@dataclass(frozen=True)
class Family:
    """One maze family as registered."""

    name: str
    build: Callable[[Any], Any] | str  # env -> the static shape; or "module:function"
    settings: type | None  # its own settings, a dataclass of setting() fields
    problem: Callable[[Any], str | None]  # env -> one line naming the setting, or None
    text: Callable[[Any], str]  # env -> the family in a few words ("4 x 4 grid mazes")
    title: Callable[[Any], str]  # env -> the family in a figure's title
    about: str
    shortest_paths: bool  # the geodesic reward can follow its shortest paths
    # env -> the most cells along a side of the lattice its walls stand on, for a family
    # whose LiDAR can walk that lattice (its shape gives beam_ranges(maze, origin, dirs)
    # and n_segments, jaxnav.world.lattice); None: the LiDAR tests every wall.
    lattice: Callable[[Any], int] | None = None

    def shape(self, env: Any) -> Any:
        """The family's static shape from ``env``'s settings (an EnvConfig or a
        ``jaxnav.env.NavEnv``): a hashable object with ``draw(key, split)``."""
        return resolve(self.build)(env)


_REGISTRY: dict[str, Family] = {}
_LAID_OUT: list[str] = []  # the settings already laid out as dataclass fields


def register(
    name: str,
    build: Callable[[Any], Any] | str,
    settings: type | None = None,
    problem: Callable[[Any], str | None] | None = None,
    text: Callable[[Any], str] | None = None,
    title: Callable[[Any], str] | None = None,
    about: str = "",
    shortest_paths: bool = False,
    lattice: Callable[[Any], int] | None = None,
) -> Family:
    """Add a family named ``name`` (the value of ``env.generator``); ``text`` defaults to
    "NAME mazes", ``title`` to ``text``, ``problem`` to none."""
    if name in _REGISTRY:
        raise ConfigError(f"maze family {name!r} is registered already")
    if not name.isidentifier():
        raise ConfigError(f"maze family name {name!r} must be an identifier")
    if settings is not None and _LAID_OUT:
        raise ConfigError(
            f"maze family {name!r}: its settings would not be config keys (the config is "
            "built already); declare them in jaxnav.core.families"
        )
    text = text or (lambda env: f"{name} mazes")
    _REGISTRY[name] = Family(
        name,
        build,
        settings,
        problem or (lambda env: None),
        text,
        title or text,
        about,
        shortest_paths,
        lattice,
    )
    return _REGISTRY[name]


def unregister(name: str) -> None:
    """Remove a family added by :func:`register` (tests use it to tidy up)."""
    _REGISTRY.pop(name, None)


def names() -> tuple[str, ...]:
    """Every family's name, in registration order (the built-in ones first)."""
    return tuple(_REGISTRY)


def listing(choices: tuple[str, ...]) -> str:
    """``"a, b or c"`` (``"none"`` for no choices)."""
    if not choices:
        return "none"
    return " or ".join(filter(None, (", ".join(choices[:-1]), choices[-1])))


def get(name: str) -> Family:
    """The family named ``name``; an unknown name is a ConfigError listing them all."""
    if name not in _REGISTRY:
        raise ConfigError(
            f"config: env.generator {name!r} is no maze family (choose from {listing(names())})"
        )
    return _REGISTRY[name]


def with_shortest_paths() -> tuple[str, ...]:
    """The families whose shortest paths the geodesic reward can follow."""
    return tuple(n for n, f in _REGISTRY.items() if f.shortest_paths)


def with_lattice() -> tuple[str, ...]:
    """The families whose LiDAR can walk the lattice their walls stand on."""
    return tuple(n for n, f in _REGISTRY.items() if f.lattice is not None)


def family_text(env: Any) -> str:
    """A drawn-maze family in a few words ("4 x 4 grid mazes"); ``env`` is an EnvConfig
    or a ``jaxnav.env.NavEnv``."""
    return get(env.generator).text(env)


# env.generator's rule: "" or a registered family, said with the families registered
# when it is checked.
GENERATOR_RULE = (
    lambda v: v == "" or v in _REGISTRY,
    lambda: f'must be "" (the fixed env.maze), {listing(names())}',
)


def settings_after(after: str):
    """A class decorator, applied before ``dataclass``: every registered family's
    settings become fields of the class, after its field ``after``, in registration
    order. ``jaxnav.core.sections.EnvConfig`` and ``jaxnav.env.NavEnv`` take them so."""

    def lay_out(cls):
        own = dict(cls.__dict__.get("__annotations__", {}))
        if after not in own:
            raise TypeError(f"{cls.__name__} has no field {after!r}")
        added: dict[str, Any] = {}
        for family in _REGISTRY.values():
            if family.settings is None:
                continue
            types = typing.get_type_hints(family.settings)
            for f in dataclasses.fields(family.settings):
                if f.name in own or f.name in added:
                    raise TypeError(f"{family.name}: setting {f.name!r} is declared twice")
                added[f.name] = types[f.name]
                setattr(cls, f.name, dataclasses.field(default=f.default, metadata=f.metadata))
        annotations = {}
        for name, kind in own.items():
            annotations[name] = kind
            if name == after:
                annotations.update(added)
        cls.__annotations__ = annotations
        _LAID_OUT.extend(added)
        return cls

    return lay_out


# ----------------------------------------------------------------------------
# grid: jaxnav.world.generators
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class GridSettings:
    grid_rows: int = setting(4, "grid: rows of cells", rule=AT_LEAST_1)
    grid_cols: int = setting(4, "grid: columns of cells", rule=AT_LEAST_1)
    grid_cell: float = setting(
        1.0,
        "grid: a cell's side, m",
        rule=(lambda v: v > ROBOT_DIAMETER, f"must be more than {ROBOT_DIAMETER} m"),
    )
    grid_loops: float = setting(
        0.0, "grid: fraction of the perfect maze's closed walls opened (loops)", rule=UNIT
    )
    # rooms reads it too: its rooms are a grid's cells
    min_path_cells: int = setting(
        1,
        "grid, rooms: cells (rooms) between the start and the first goal along the maze, at least",
        rule=AT_LEAST_1,
    )


def grid_problem(rows: int, cols: int, cell: float, loops: float, min_path: int) -> str | None:
    """What is wrong with a grid maze family's settings together, one line naming the
    setting, or None (each setting's own rule is checked before)."""
    if rows < 1:
        return "env.grid_rows must be at least 1"
    if cols < 1:
        return "env.grid_cols must be at least 1"
    if rows * cols < 2:
        return "env.grid_rows x env.grid_cols must be at least 2 cells (1 x 1 has no goal)"
    if not cell > ROBOT_DIAMETER:
        return f"env.grid_cell must be more than the robot's diameter ({ROBOT_DIAMETER} m)"
    if not 0.0 <= loops <= 1.0:
        return "env.grid_loops must be in [0, 1]"
    if min_path > rows + cols - 2:
        return (
            f"env.min_path_cells must be at most grid_rows + grid_cols - 2 = {rows + cols - 2} "
            "(corner to corner)"
        )
    return None


register(
    "grid",
    "jaxnav.world.generators:grid_family",
    GridSettings,
    problem=lambda e: grid_problem(
        e.grid_rows, e.grid_cols, e.grid_cell, e.grid_loops, e.min_path_cells
    ),
    text=lambda e: f"{e.grid_rows} x {e.grid_cols} grid mazes",
    title=lambda e: f"{e.grid_rows} x {e.grid_cols} grid, {e.grid_cell:g} m cells",
    about="a perfect maze on a grid of square cells, loops opened (randomised Kruskal)",
    shortest_paths=True,
    lattice=lambda e: max(e.grid_rows, e.grid_cols),
)


# ----------------------------------------------------------------------------
# cylinders: jaxnav.world.cylinders
# ----------------------------------------------------------------------------


def _pair(x: Any) -> bool:
    return isinstance(x, (tuple, list)) and len(x) == 2


@dataclass(frozen=True)
class CylinderSettings:
    cyl_count: int = setting(
        8,
        "cylinders: cylinders in the room",
        rule=(lambda v: 1 <= v <= MAX_CYLINDERS, f"must be in [1, {MAX_CYLINDERS}]"),
    )
    cyl_radius: tuple[float, ...] = setting(
        (0.1, 0.25),
        "cylinders: radii drawn from [low, high], m",
        rule=(
            lambda x: len(x) == 2 and 0 < x[0] <= x[1],
            "must be [low, high] with 0 < low <= high, m",
        ),
    )
    cyl_room: float = setting(
        4.0,
        "cylinders: the square room's side, m",
        rule=(
            lambda v: MIN_CYLINDER_ROOM <= v <= MAX_CYLINDER_ROOM,
            f"must be in [{MIN_CYLINDER_ROOM:g}, {MAX_CYLINDER_ROOM:g}] m",
        ),
    )
    cyl_min_path: float = setting(
        1.0,
        "cylinders: start to first goal along the free space, m, at least",
        rule=NON_NEGATIVE,
    )


def cylinders_problem(
    count: int, radius, room: float, min_path: float, scale_low: float = 1.0
) -> str | None:
    """What is wrong with a cylinders family's settings together, one line naming the
    setting, or None (each setting's own rule is checked before). ``scale_low`` is
    env.maze_scale's low end."""
    if not 1 <= count <= MAX_CYLINDERS:
        return f"env.cyl_count must be in [1, {MAX_CYLINDERS}]"
    if not (_pair(radius) and 0 < radius[0] <= radius[1]):
        return "env.cyl_radius must be [low, high] with 0 < low <= high, m"
    if not MIN_CYLINDER_ROOM <= room <= MAX_CYLINDER_ROOM:
        return f"env.cyl_room must be in [{MIN_CYLINDER_ROOM:g}, {MAX_CYLINDER_ROOM:g}] m"
    free = room - 2 * GOAL_CLEARANCE
    if 2 * radius[1] >= free:
        return f"env.cyl_radius high must be less than (env.cyl_room - 0.7) / 2 = {free / 2:.3g} m"
    cover = count * math.pi * (radius[1] + CYLINDER_GROWTH) ** 2 / room**2
    if cover > MAX_CYLINDER_COVER:
        return (
            f"env.cyl_count: {count} cylinders of radius up to {radius[1]:g} m crowd a "
            f"{room:g} m room too much for a free path (grown by {CYLINDER_GROWTH} m for the "
            f"robot they could cover {cover:.1%} of it, at most {MAX_CYLINDER_COVER:.0%}): "
            "fewer or smaller cylinders, or a larger env.cyl_room"
        )
    if min_path < 0 or min_path > free / 2:
        return (
            f"env.cyl_min_path must be in [0, {free / 2:.3g}] m (half the side of the room's "
            "free part, so that every start has a goal that far)"
        )
    if scale_low < 1.0:
        return (
            "env.maze_scale must not shrink a cylinder field (low at least 1): the "
            "cylinders would move closer and keep their radii, closing the free path"
        )
    return None


def _cylinders_text(e: Any) -> str:
    lo, hi = e.cyl_radius
    return f"{e.cyl_count} cylinders (r {lo:g}-{hi:g} m) in a {e.cyl_room:g} m room"


register(
    "cylinders",
    "jaxnav.world.cylinders:cylinders_family",
    CylinderSettings,
    problem=lambda e: cylinders_problem(
        e.cyl_count, e.cyl_radius, e.cyl_room, e.cyl_min_path, min(e.maze_scale)
    ),
    text=_cylinders_text,
    about="round obstacles in a square room, a free path to the goal guaranteed",
)


# ----------------------------------------------------------------------------
# rooms: jaxnav.world.rooms
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class RoomsSettings:
    rooms_rows: int = setting(2, "rooms: rows of rooms", rule=AT_LEAST_1)
    rooms_cols: int = setting(2, "rooms: columns of rooms", rule=AT_LEAST_1)
    rooms_size: float = setting(
        2.0,
        "rooms: a room's side, m",
        rule=(lambda v: v > 2 * GOAL_CLEARANCE, f"must be more than {2 * GOAL_CLEARANCE:g} m"),
    )
    rooms_door: float = setting(
        0.6,
        "rooms: a door's width, m",
        rule=(
            lambda v: v > ROBOT_DIAMETER,
            f"must be wider than the robot's diameter ({ROBOT_DIAMETER} m)",
        ),
    )
    rooms_loops: float = setting(
        0.0, "rooms: fraction of the walls left without a door that get one (loops)", rule=UNIT
    )


def rooms_problem(
    rows: int,
    cols: int,
    size: float,
    door: float,
    loops: float,
    min_path: int,
    scale_low: float = 1.0,
) -> str | None:
    """What is wrong with a rooms family's settings together, one line naming the
    setting, or None (each setting's own rule is checked before). ``scale_low`` is
    env.maze_scale's low end."""
    if rows < 1:
        return "env.rooms_rows must be at least 1"
    if cols < 1:
        return "env.rooms_cols must be at least 1"
    if rows * cols < 2:
        return "env.rooms_rows x env.rooms_cols must be at least 2 rooms"
    if not door > ROBOT_DIAMETER:
        return f"env.rooms_door must be wider than the robot's diameter ({ROBOT_DIAMETER} m)"
    if not size > 2 * GOAL_CLEARANCE:
        return f"env.rooms_size must be more than {2 * GOAL_CLEARANCE:g} m"
    if door > size - 2 * DOOR_MARGIN + 1e-9:
        return (
            f"env.rooms_door must be at most env.rooms_size - {2 * DOOR_MARGIN:g} m "
            f"= {size - 2 * DOOR_MARGIN:.3g} m"
        )
    if not 0.0 <= loops <= 1.0:
        return "env.rooms_loops must be in [0, 1]"
    if min_path > rows + cols - 2:
        return (
            f"env.min_path_cells must be at most rooms_rows + rooms_cols - 2 = "
            f"{rows + cols - 2} (corner room to corner room)"
        )
    if not door * scale_low > ROBOT_DIAMETER:
        return (
            f"env.maze_scale low ({scale_low:g}) shrinks env.rooms_door ({door:g} m) to the "
            f"robot's diameter ({ROBOT_DIAMETER} m) or less"
        )
    return None


register(
    "rooms",
    "jaxnav.world.rooms:rooms_family",
    RoomsSettings,
    problem=lambda e: rooms_problem(
        e.rooms_rows,
        e.rooms_cols,
        e.rooms_size,
        e.rooms_door,
        e.rooms_loops,
        e.min_path_cells,
        min(e.maze_scale),
    ),
    text=lambda e: f"{e.rooms_rows} x {e.rooms_cols} rooms mazes ({e.rooms_door:g} m doors)",
    about="a grid of square rooms joined by doors along a random spanning tree",
    shortest_paths=True,
)


# ----------------------------------------------------------------------------
# mix: jaxnav.world.mix
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class MixSettings:
    mix_worlds: tuple[str, ...] = setting(
        (),
        "mix: the worlds each episode's layout comes from: maze families (drawn with their "
        "own env settings) and fixed mazes (built-in names or maze files)",
    )
    mix_weights: tuple[float, ...] = setting(
        (),
        "mix: each world's weight, as many as env.mix_worlds (empty: equal weights)",
    )


def mix_problem(worlds: tuple[str, ...], weights: tuple[float, ...], bank: int) -> str | None:
    """What is wrong with a mix's settings together, one line naming the setting, or
    None. A world that is no family is taken for a maze, loaded when the environment is
    built (a missing one is refused then, in one line)."""
    if not worlds:
        return "env.mix_worlds must name at least one world (a maze family or a maze)"
    if "mix" in worlds:
        return "env.mix_worlds cannot hold mix itself"
    if len(set(worlds)) != len(worlds):
        return "env.mix_worlds names a world twice (weigh it with env.mix_weights instead)"
    if weights and len(weights) != len(worlds):
        return (
            f"env.mix_weights has {len(weights)} weights for {len(worlds)} worlds "
            "(env.mix_worlds): give one each, or none for equal weights"
        )
    if any(not w > 0 for w in weights):
        return "env.mix_weights must all be positive"
    if bank < 1:
        return (
            "env.generator mix picks each layout from a bank of them: set env.maze_bank "
            "(4096 is a good start)"
        )
    return None


def _mix_problem(e: Any) -> str | None:
    problem = mix_problem(tuple(e.mix_worlds), tuple(e.mix_weights), e.maze_bank)
    for name in () if problem else e.mix_worlds:  # a family's own rules hold in a mix
        if name in _REGISTRY:
            problem = problem or _REGISTRY[name].problem(e)
    return problem


def _mix_text(e: Any) -> str:
    weights = list(e.mix_weights) or [1.0] * len(e.mix_worlds)
    total = sum(weights)
    return "a mix of " + ", ".join(
        f"{name} ({w / total:.0%})" for name, w in zip(e.mix_worlds, weights)
    )


register(
    "mix",
    "jaxnav.world.mix:mix_family",
    MixSettings,
    problem=_mix_problem,
    text=_mix_text,
    title=lambda e: f"mix of {len(e.mix_worlds)} worlds",
    about="each episode a layout of one of several worlds (families and fixed mazes) at "
    "given weights, from a bank",
)
