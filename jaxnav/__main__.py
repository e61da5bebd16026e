"""``jaxnav COMMAND [ARGS ...]``: every command under one name.

Each command is a module of :mod:`jaxnav.commands` (``jaxnav train CONFIG`` runs
:mod:`jaxnav.commands.train`); ``python -m jaxnav train CONFIG`` is the same without
the entry point, and ``python -m jaxnav.train CONFIG`` the main command's own form;
``jaxnav --help`` lists them, ``jaxnav COMMAND --help`` shows one.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence

# command -> (what it does in one line, whether it runs JAX)
COMMANDS: dict[str, tuple[str, bool]] = {
    "train": ("train every seed and strategy of a config in one compiled program", True),
    "evaluate": ("test a finished run's policies on the test mazes (greedy and exploring)", True),
    "baselines": (
        "the oracle and DWA through the test of every shipped world, and their page",
        True,
    ),
    "plots": ("draw a run's figures from its files", False),
    "render": ("draw a maze with the robot, a goal and LiDAR beams, or a sheet of samples", True),
    "mazes": ("write drawn mazes of a family as maze files (start, goal, shortest path)", True),
    "export": ("write one trained policy to a portable NumPy file for a robot", True),
    "drive": ("play a pretrained policy in any world without training, beside the oracle", True),
    "reproduce": ("the paper's two experiments end to end, and report.md", True),
    "ablation": ("both experiments under each ROBOTIS-faithful switch", True),
    "study": (
        "a config's sweep or a study file trained, tested and written up from its data",
        True,
    ),
    "sim2sim": ("a run's policies driving a TurtleBot3 burger in MuJoCo physics", True),
    "imitate": ("policies fit to the oracle's actions, written as a finished run", True),
    "probe": ("diagnostics: collisions' causes, cut attempts' waits, moving worlds' reach", True),
    "list": ("the built-in mazes, the shipped configs and every setting", False),
    "publish": ("rewrite the docs' parts computed from committed data", False),
}


def usage() -> str:
    width = max(map(len, COMMANDS))
    lines = [
        "usage: jaxnav COMMAND [ARGS ...]   (jaxnav COMMAND --help for one command; "
        "jaxnav --version)",
        "",
        "commands:",
    ]
    lines += [f"  {name:<{width}}  {what}" for name, (what, _) in COMMANDS.items()]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help", "help"):
        print(usage())
        return 0
    if args[0] in ("-V", "--version"):
        from importlib.metadata import PackageNotFoundError, version

        try:
            print(f"jaxnav {version('jaxnav')}")
        except PackageNotFoundError:  # run from a checkout that was not installed
            print("jaxnav (not installed: no version)")
        return 0
    name, rest = args[0], args[1:]
    if name not in COMMANDS:
        print(f"jaxnav: error: unknown command {name!r}\n\n{usage()}", file=sys.stderr)
        return 2
    from jaxnav.core.startup import before_jax, catch_interrupts_in_command

    catch_interrupts_in_command()  # first thing: Ctrl-C ends any command cleanly
    if COMMANDS[name][1]:  # before JAX starts: one CPU device per core, compile cache
        before_jax()
    return importlib.import_module(f"jaxnav.commands.{name}").main(rest)


if __name__ == "__main__":
    sys.exit(main())
