"""Sources of fixed worlds beyond the built-in mazes and maze files, by name: the registry
:func:`jaxnav.world.maps.make_maze` consults before them.

A source claims the maze names it loads (a predicate of the name, no JAX), names the
function that loads one as ``"module:function"`` (imported when first used, so ``core``
imports no JAX and ``world.maps`` does not import its sources), and may name sets of
mazes: a set's name stands for its mazes' names wherever a list of test mazes is given
(``run.test_mazes``, ``evaluate --mazes``)::

    from jaxnav.core import worlds

    worlds.register("ros_map", claims=is_ros_map, load="jaxnav.world.rosmap:load_ros_map")
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from jaxnav.core.refs import resolve


@dataclass(frozen=True)
class Source:
    """One source of worlds as registered."""

    name: str
    claims: Callable[[str], bool]  # maze name or path -> whether this source loads it
    load: Callable[[str], object] | str  # name -> a jaxnav.world.maps.Maze
    sets: Callable[[str], list[str] | None] | None  # a set's name -> its mazes' names
    about: str

    def loader(self) -> Callable[[str], object]:
        return resolve(self.load)


_REGISTRY: dict[str, Source] = {}


def register(
    name: str,
    claims: Callable[[str], bool],
    load: Callable[[str], object] | str,
    sets: Callable[[str], list[str] | None] | None = None,
    about: str = "",
) -> Source:
    """Register a source of worlds (a second registration of a name replaces the first)."""
    src = Source(name, claims, load, sets, about)
    _REGISTRY[name] = src
    return src


def source_of(maze: str) -> Source | None:
    """The source that loads the maze ``maze`` (a name or path), or None."""
    for src in _REGISTRY.values():
        if src.claims(maze):
            return src
    return None


def expand(names: Sequence[str]) -> list[str]:
    """``names`` with every set's name replaced by its mazes' names, in order."""
    out: list[str] = []
    for name in names:
        members = None
        for src in _REGISTRY.values():
            members = src.sets(name) if src.sets is not None else None
            if members is not None:
                break
        out.extend(members if members is not None else [name])
    return out


def sources() -> list[Source]:
    return list(_REGISTRY.values())


def _is_ros_map(name: str) -> bool:
    """A YAML file holding a mapping with an ``image`` key: a ROS map_server map."""
    import os

    if os.path.splitext(name)[1] not in (".yaml", ".yml"):
        return False
    from jaxnav.core.shipped import shipped_path

    path = shipped_path(name)
    if not os.path.isfile(path):
        return False
    import yaml

    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return False
    return isinstance(doc, dict) and "image" in doc and "outline" not in doc


register(
    "ros_map",
    claims=_is_ros_map,
    load="jaxnav.world.rosmap:load_ros_map",
    about="a ROS map_server map: a YAML file (image, resolution, origin, ...) beside its "
    "PGM or PNG image; occupied and unknown cells are walls",
)


# BARN (jaxnav.world.barn): its 300 worlds by name, barn:N, and the sets of the
# challenge's test.sh (0, 6, ..., 294) and the other 250.
BARN_WORLDS = 300
BARN_SETS = {
    "barn:test": tuple(range(0, BARN_WORLDS, 6)),
    "barn:train": tuple(n for n in range(BARN_WORLDS) if n % 6),
    "barn:all": tuple(range(BARN_WORLDS)),
}


def _is_barn_world(name: str) -> bool:
    head, _, tail = name.partition(":")
    return head == "barn" and tail.isdigit() and int(tail) < BARN_WORLDS


def _barn_set(name: str) -> list[str] | None:
    worlds = BARN_SETS.get(name)
    return None if worlds is None else [f"barn:{n}" for n in worlds]


register(
    "barn",
    claims=_is_barn_world,
    load="jaxnav.world.barn:load_barn",
    sets=_barn_set,
    about="The BARN Challenge's 300 worlds (barn:0 ... barn:299; sets barn:test, the 50 of "
    "its test.sh, barn:train, the other 250, barn:all), MIT licence",
)


__all__ = ["BARN_SETS", "BARN_WORLDS", "Source", "expand", "register", "source_of", "sources"]
