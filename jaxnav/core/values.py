"""Config values as people write them, in YAML files and as ``key=value`` overrides.

Numbers as people write them (``1e-4``, ``1_000_000``), nested mappings flattened to
dotted keys, and each value checked against its setting's type with a one-line
:class:`ConfigError` naming the key. :mod:`jaxnav.core.config` uses these.
"""

from __future__ import annotations

import math
import re
import types
import typing
from typing import Any

import yaml

from jaxnav.core.errors import ConfigError


def yaml_mark(error: yaml.YAMLError) -> Any:
    """Where a YAML error lies, as a person would point at it: the mark of what the
    parser was reading when it failed (a key left without its colon, an open bracket
    or quote), else where it noticed (for those, the next line)."""
    return getattr(error, "context_mark", None) or getattr(error, "problem_mark", None)


def flatten(d: dict, prefix: str = "") -> dict[str, Any]:
    out = {}
    for k, v in d.items():
        if not isinstance(k, str):
            raise ConfigError(f"config: key {k!r} must be a string")
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, name + "."))
        else:
            out[name] = v
    return out


def type_name(t) -> str:
    args = typing.get_args(t)
    origin = typing.get_origin(t)
    if origin in (types.UnionType, typing.Union):
        inner = [a for a in args if a is not type(None)]
        return type_name(inner[0]) + " or null"
    if origin is tuple:
        return f"list of {type_name(args[0])}"
    return {int: "an integer", float: "a number", bool: "true or false", str: "a string"}[t]


# A number as people write one: 1e-4, 5E3, 1_000_000, -2.5. YAML 1.1 (PyYAML) reads
# "1e-4" (no dot) and "1_000" in a file as strings; they are numbers here.
_NUMBER = re.compile(r"[+-]?(\d[\d_]*(\.[\d_]*)?|\.\d[\d_]*)([eE][+-]?\d+)?")


def parse_number(value: Any) -> int | float | None:
    """An int or float from a YAML scalar (int, float or numeric string), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return value
    if isinstance(value, str):
        text = value.strip()
        if text.lower() in (".inf", "+.inf", "-.inf", ".nan", "inf", "-inf", "nan"):
            return math.nan if "nan" in text.lower() else math.inf
        if _NUMBER.fullmatch(text) and "__" not in text and not text.endswith("_"):
            number = float(text.replace("_", ""))
            is_int = number.is_integer() and not any(c in text for c in ".eE")
            return int(text.replace("_", "")) if is_int else number
    return None


def coerce(name: str, value: Any, t) -> Any:
    """Check ``value`` against type ``t``; return it in canonical form."""
    origin = typing.get_origin(t)
    args = typing.get_args(t)
    bad = ConfigError(f"config: {name} must be {type_name(t)}, got {value!r}")
    if origin in (types.UnionType, typing.Union):
        if value is None:
            return None
        inner = [a for a in args if a is not type(None)][0]
        return coerce(name, value, inner)
    if origin is tuple:
        if isinstance(value, str) or not isinstance(value, (list, tuple)):
            raise bad
        return tuple(coerce(name, v, args[0]) for v in value)
    if t is bool:
        if not isinstance(value, bool):
            raise bad
        return value
    if t in (int, float):
        number = parse_number(value)
        if number is None:
            raise bad
        if not math.isfinite(number):
            raise ConfigError(f"config: {name} must be a finite number, got {value!r}")
        if t is float:
            return float(number)
        if number != int(number):
            raise bad
        return int(number)
    if t is str:
        if not isinstance(value, str):
            raise bad
        return value
    raise bad


def parse_override(item: str) -> tuple[str, Any]:
    if "=" not in item:
        raise ConfigError(f"config: override '{item}' must look like key=value")
    key, raw = item.split("=", 1)
    key = key.strip()
    try:
        value = yaml.safe_load(raw) if raw.strip() else None
    except yaml.YAMLError:
        value = raw
    return key, value
