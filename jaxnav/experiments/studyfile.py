"""A study file as read: its kind, its keys checked by type, and ``key=value``
overrides dotted into its mappings.

``jaxnav study FILE`` runs a study file of any kind (:data:`KINDS`): a ladder (a file
with ``rungs:``, :mod:`jaxnav.experiments.ladder`), or a file that names its kind,
``kind: driving`` (:mod:`jaxnav.experiments.driving`) or ``kind: sim2sim``
(:mod:`jaxnav.experiments.campaign`). Each kind reads its file through
:func:`read_text` and :func:`mapping`, so a problem anywhere is one line naming the file
and the key, and overrides work alike in every kind.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import yaml

from jaxnav.core.config import Config, build_config
from jaxnav.core.errors import ConfigError
from jaxnav.core.shipped import CONFIG_DIR
from jaxnav.core.values import flatten, parse_override, yaml_mark

KINDS = ("ladder", "driving", "sim2sim")


def kind_of(path: str) -> str | None:
    """A YAML file's kind of study (``rungs:`` makes a ladder, ``kind:`` names the
    others), or None for a file that is no study (a config). An unknown kind is one line."""
    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except (OSError, yaml.YAMLError, UnicodeDecodeError):
        return None
    if not isinstance(doc, dict):
        return None
    if "kind" in doc:
        if doc["kind"] not in KINDS:
            raise ConfigError(
                f"study {path}: unknown kind {doc['kind']!r} (known: {', '.join(KINDS)})"
            )
        return doc["kind"]
    return "ladder" if "rungs" in doc else None


def mapping(text: str, where: str) -> dict:
    """A study file's YAML text as its mapping of keys (one line if it is not one)."""
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = yaml_mark(e)
        raise ConfigError(
            f"{where} is not valid YAML" + (f" at line {mark.line + 1}" if mark else "")
        ) from None
    if not isinstance(doc, dict):
        raise ConfigError(f"{where} must hold a mapping of keys")
    return doc


def typed(doc: dict, keys: dict[str, type], where: str) -> None:
    """Every key of ``doc`` is one of ``keys`` and of its type (an integer is no bool)."""
    for k, v in doc.items():
        if k not in keys:
            raise ConfigError(f"{where}: unknown key {k!r} (known: {', '.join(keys)})")
        want = keys[k]
        if want is int and (isinstance(v, bool) or not isinstance(v, int)):
            raise ConfigError(f"{where}: {k} must be an integer, not {v!r}")
        if want is not int and not isinstance(v, want):
            raise ConfigError(f"{where}: {k} must be a {want.__name__}, not {v!r}")


def required(doc: dict, keys: Sequence[str], where: str) -> None:
    for k in keys:
        if k not in doc:
            raise ConfigError(f"{where}: {k} is required")


def at_least_one(doc: dict, keys: Sequence[str], where: str) -> None:
    for k in keys:
        if k in doc and doc[k] < 1:
            raise ConfigError(f"{where}: {k} must be at least 1")


def name_of(name: Any, where: str) -> str:
    """An agent's, rung's or arm's name: letters, digits and underscores (a folder's)."""
    if not isinstance(name, str) or not name.replace("_", "").isalnum():
        raise ConfigError(f"{where}: name {name!r} must be letters, digits and underscores")
    return name


def read_text(
    path: str,
    overrides: Sequence[str],
    parse: Callable[[str, str], Any],
    keys: dict[str, type],
    open_keys: Sequence[str] = ("settings",),
) -> Any:
    """The study of a file parsed by ``parse(text, where)``, with ``key=value``
    overrides of its keys (dotted into its mappings: ``seeds=4``,
    ``settings.env.max_steps=100``). With overrides the study's text, which its folder
    keeps and ``--resume`` compares, is the overridden document. ``keys``: the file's
    top-level keys; ``open_keys``: the mappings where an override may add a key."""
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        raise ConfigError(f"study: no such file {path}") from None
    except (IsADirectoryError, UnicodeDecodeError):
        raise ConfigError(f"study: {path} is not a YAML text file") from None
    where = f"study {path}"
    if overrides:
        parse(text, where)  # the file's own problems first, named as its own
        doc = yaml.safe_load(text)
        for item in overrides:
            key, value = parse_override(item)
            set_dotted(doc, key, value, where, keys, open_keys)
        head = f"# {Path(path).name} with {' '.join(overrides)}\n"
        text = head + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
    return parse(text, where)


def set_dotted(
    doc: dict, key: str, value: Any, where: str, keys: dict[str, type], open_keys: Sequence[str]
) -> None:
    """Set ``doc``'s entry at the dotted ``key``; a top-level key must be one of
    ``keys``, a named entry must exist, and only ``open_keys`` mappings take new keys."""
    parts = key.split(".")
    if parts[0] not in keys:
        raise ConfigError(f"{where}: unknown key {parts[0]!r} (known: {', '.join(keys)})")
    node, open_ = doc, False
    for i, part in enumerate(parts[:-1]):
        open_ = open_ or part in open_keys
        if part not in node:
            if not open_:
                raise ConfigError(f"{where}: {'.'.join(parts[: i + 1])} is not in the study")
            node[part] = {}
        node = node[part]
        if not isinstance(node, dict):
            raise ConfigError(f"{where}: {'.'.join(parts[: i + 1])} is not a mapping")
    node[parts[-1]] = value  # a leaf's name and value are checked with the whole study


def base_values(config: str) -> dict[str, Any]:
    """A shipped config's settings as flat dotted keys, for a study's layers over them."""
    with open(CONFIG_DIR / f"{config}.yaml") as f:
        return flatten(yaml.safe_load(f) or {})


def build(values: dict[str, Any], where: str) -> Config:
    """A cell's config from its settings; a problem is one line naming the cell."""
    try:
        return build_config(values)
    except ConfigError as e:
        raise ConfigError(f"study: {where}: {str(e).removeprefix('config: ')}") from None
