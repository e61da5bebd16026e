"""``python -m jaxnav.list`` (``jaxnav list``): what there is to choose from.

The built-in mazes with a line each, the shipped configs (a built-in config's name
works wherever a config path does: ``jaxnav train smoke``), and every setting with
its default and whether a sweep may vary it (:mod:`jaxnav.core.sweep`).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from jaxnav.core import cli
from jaxnav.core.config import FIELD_TYPES, Config, builtin_configs, config_to_dict
from jaxnav.core.sweep import SWEEPABLE
from jaxnav.world.maps import BUILTIN_MAZES


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict) and k != "sweep":
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def catalog() -> str:
    """The listing as text."""
    lines = ["built-in mazes (env.maze=NAME, or a maze .yaml file):"]
    width = max(map(len, BUILTIN_MAZES))
    lines += [f"  {name:<{width}}  {what}" for name, what in BUILTIN_MAZES.items()]
    lines += ["", "shipped configs (jaxnav train NAME):"]
    configs = builtin_configs()
    width = max(map(len, configs))
    lines += [f"  {name:<{width}}  {what}" for name, what in configs.items()]
    defaults = _flat(config_to_dict(Config()))
    lines += ["", "settings (key=value on the command line; * = can be swept, sweep.KEY=[...]):"]
    width = max(map(len, FIELD_TYPES))
    for key in FIELD_TYPES:
        mark = "*" if key in SWEEPABLE else " "
        value = defaults[key]
        shown = "null" if value is None else value
        lines.append(f"  {mark} {key:<{width}}  {shown}")
    lines.append("  (the preset, paper or robotis, changes some defaults: see docs/training.md)")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.Parser(
        prog="python -m jaxnav.list",
        description="List the built-in mazes, the shipped configs and every setting.",
    )
    parser.parse_args(argv)
    return cli.run(parser.prog, lambda: print(catalog()))


if __name__ == "__main__":
    sys.exit(main())
