"""What every command shares: its argument parser and its one error handler.

A command's ``main`` builds a :class:`Parser` and hands its work to :func:`run`,
which turns a :class:`~jaxnav.core.errors.JaxnavError` (or an ``OSError`` from the
file system) into one line on stderr and exit status 2, and Ctrl-C into 130.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
from collections.abc import Callable
from pathlib import Path

from jaxnav.core import startup
from jaxnav.core.errors import JaxnavError
from jaxnav.core.settings import SEED, problem

EXIT_ERROR = 2
EXIT_INTERRUPTED = startup.EXIT_INTERRUPTED
_depth = [0]  # run() calls under way (a command may run another's main)


def command_name(prog: str) -> str:
    """How error lines name a command: its parser's ``prog``, ``jaxnav train``, without a
    ``python -m`` a caller may have put before it."""
    return prog.removeprefix("python -m ")


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``jaxnav <command>: error: message``, exit 2. A
    command's ``prog`` (``jaxnav <command>``) reads as the user ran it in its help and
    its lines: ``python -m jaxnav <command>`` where no ``jaxnav`` script runs it."""

    def __init__(self, *args, prog: str | None = None, **kwargs):
        if prog and prog.startswith("jaxnav "):
            prog = startup.invocation(prog.removeprefix("jaxnav "))
        super().__init__(*args, prog=prog, **kwargs)

    def error(self, message):
        self.exit(EXIT_ERROR, f"{command_name(self.prog)}: error: {message}\n")


def seed(text: str) -> int:
    """The type of a ``--seed`` option: an integer a PRNG key holds, as a config's
    ``seed`` (a larger one would silently repeat a smaller one, or overflow)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    says = problem(SEED, value)
    if says:
        raise argparse.ArgumentTypeError(f"{says}, got {value}")
    return value


def resume_advice(command: str, argv: list[str], out: str | os.PathLike) -> str:
    """The line a resumable pipeline prints on Ctrl-C: the same command with the same
    options (``--quick``, sizes), plus ``--resume --out DIR``, as it was run
    (``jaxnav reproduce`` or ``python -m jaxnav reproduce``)."""
    kept, skip = [], False
    for a in argv:
        if skip:
            skip = False
            continue
        if a == "--out":
            skip = True
            continue
        if a == "--resume" or a.startswith("--out="):
            continue
        kept.append(a)
    words = [*kept, "--resume", "--out", str(out)]
    return f"interrupted; continue with {startup.invocation(command)} {shlex.join(words)}"


def add_overwrite(parser: argparse.ArgumentParser, what: str = "the output") -> None:
    """The one ``--overwrite`` flag every command that writes results takes."""
    parser.add_argument(
        "--overwrite", action="store_true", help=f"replace {what} if it exists already"
    )


def add_sizes(parser: argparse.ArgumentParser, default_seeds: int, quick: dict) -> None:
    """The size options of the commands that run the paper's experiments (reproduce,
    ablation): ``--seeds``, ``--quick`` (the sizes in ``quick``), and the overrides
    ``--episodes``, ``--max-steps``, ``--test-episodes``; :func:`chosen_sizes` reads them."""
    parser.add_argument(
        "--seeds",
        type=int,
        metavar="N",
        help=f"seeds per strategy (default {default_seeds}; {quick['seeds']} with --quick)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"a small version that checks everything runs: {quick['seeds']} seeds, "
        f"{quick['episodes']} episodes of at most {quick['max_steps']} steps, "
        f"{quick['test_episodes']} test episodes",
    )
    parser.add_argument(
        "--episodes", type=int, metavar="N", help="training episodes per seed (overrides)"
    )
    parser.add_argument(
        "--max-steps",
        type=int,
        metavar="N",
        help="steps per episode, training and test (overrides)",
    )
    parser.add_argument(
        "--test-episodes",
        type=int,
        metavar="N",
        help="consecutive test episodes per seed and maze (overrides)",
    )


def chosen_sizes(args: argparse.Namespace, default_seeds: int, quick: dict) -> tuple[int, dict]:
    """(seeds, {episodes, max_steps, test_episodes}) from :func:`add_sizes`' options: an
    option given wins, then ``--quick``'s size, then the default (seeds) or None (the
    config's). JaxnavError where one is below 1."""
    q = quick if args.quick else {}
    seeds = args.seeds if args.seeds is not None else q.get("seeds", default_seeds)
    sizes = {}
    for name in ("episodes", "max_steps", "test_episodes"):
        given = getattr(args, name)
        sizes[name] = given if given is not None else q.get(name)
    for name, value in (("seeds", seeds), *sizes.items()):
        if value is not None and value < 1:
            raise JaxnavError(f"--{name.replace('_', '-')} must be at least 1")
    return seeds, sizes


def check_output(path: str | os.PathLike, overwrite: bool, *, is_dir: bool = False) -> Path:
    """Refuse, before any work starts, an output that cannot or may not be written.

    ``path`` must not exist unless ``overwrite`` (then it must be of the right kind: a
    file for a file output, a folder for a folder output), and its parent folder must
    exist. Returns the path; raises :class:`JaxnavError` with one line otherwise.
    """
    path = Path(path)
    kind = "folder" if is_dir else "file"
    if path.exists():
        if path.is_dir() != is_dir:  # --overwrite would not help: say so first
            raise JaxnavError(f"{path} exists and is not a {kind}: choose another path")
        if not overwrite:
            raise JaxnavError(f"{path} exists already (--overwrite replaces it)")
    parent = path.absolute().parent
    if not parent.is_dir():
        raise JaxnavError(f"cannot write {path}: the folder {parent} does not exist")
    return path


def machine_memory() -> int | None:
    """This machine's physical memory in bytes, where the system says."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def gib(n: float) -> str:
    return f"{n / 2**30:.1f} GiB"


def confirm_memory(
    estimate: int, yes: bool, memory: int | None = None, ask=input, what: str = "replay memory"
) -> None:
    """Before allocating ``estimate`` bytes: more than this machine's memory is refused;
    more than half of it needs ``--yes``, or a "y" where stdin is a terminal (elsewhere
    it is refused with the estimate). Raises :class:`JaxnavError` with one line."""
    memory = machine_memory() if memory is None else memory
    if memory is None or estimate <= memory // 2:
        return
    need = f"this run needs about {gib(estimate)} of {what}"
    if estimate > memory:
        raise JaxnavError(f"{need}, more than this machine's {gib(memory)}: use fewer seeds")
    if yes:
        return
    if sys.stdin is not None and sys.stdin.isatty():
        answer = ask(f"{need}, over half of this machine's {gib(memory)}. Go on? [y/N] ")
        if answer.strip().lower() in ("y", "yes"):
            return
        raise JaxnavError("not started")
    raise JaxnavError(f"{need}, over half of this machine's {gib(memory)}: --yes starts it")


def os_error_text(e: OSError) -> str:
    """An OSError as one line: what failed and on which path."""
    what = e.strerror or type(e).__name__
    return f"{what}: {e.filename}" if e.filename else what


def one_line(text: str) -> str:
    """``text`` on one line: a newline a user typed into a key or path shows as \\n."""
    return text.replace("\r", "\\r").replace("\n", "\\n")


def run(
    prog: str, work: Callable[[], int | None], interrupted: str | Callable[[], str] = "interrupted"
) -> int:
    """Call ``work()``; one line and exit status 2 for a user's problem.

    Returns ``work``'s status (0 if it returns None), 2 after a JaxnavError or
    OSError, 130 after Ctrl-C (``interrupted`` says how to go on; a function is asked
    at the moment, after the tidy-ups). In a command's process Ctrl-C is answered by
    :func:`jaxnav.core.startup.catch_interrupts`, which ends the process there and then
    with this line; the ``KeyboardInterrupt`` branch is for callers without it.
    """
    prog = command_name(prog)
    startup.catch_interrupts_in_command()  # where the command did not do it first thing
    before = startup.interrupt_text(prog, interrupted)
    startup.exit_status(None)
    _depth[0] += 1
    try:
        status = work()
    except JaxnavError as e:
        print(f"{prog}: error: {one_line(str(e))}", file=sys.stderr)
        status = EXIT_ERROR
    except OSError as e:
        print(f"{prog}: error: {one_line(os_error_text(e))}", file=sys.stderr)
        status = EXIT_ERROR
    except KeyboardInterrupt:
        text = interrupted() if callable(interrupted) else interrupted
        print(f"\n{prog}: {text}", file=sys.stderr)
        status = EXIT_INTERRUPTED
    except BaseException:  # a bug: Python's own traceback and exit status
        startup.exit_status(None)
        raise
    finally:
        _depth[0] -= 1
        if _depth[0]:  # a command run inside another: its line again; else the last stays
            startup.interrupt_text(*before)
    status = 0 if status is None else status
    startup.exit_status(status)
    return status
