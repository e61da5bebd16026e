"""What every command shares: its argument parser and its one error handler.

A command's ``main`` builds a :class:`Parser` and hands its work to :func:`run`,
which turns a :class:`~jaxnav.core.errors.JaxnavError` (or an ``OSError`` from the
file system) into one line on stderr and exit status 2, and Ctrl-C into 130.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path

from jaxnav.core.errors import JaxnavError

EXIT_ERROR = 2
EXIT_INTERRUPTED = 130


def command_name(prog: str) -> str:
    """``python -m jaxnav.train`` -> ``jaxnav.train``: how error lines name a command."""
    return prog.removeprefix("python -m ")


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``jaxnav.<command>: error: message``, exit 2."""

    def error(self, message):
        self.exit(EXIT_ERROR, f"{command_name(self.prog)}: error: {message}\n")


def add_overwrite(parser: argparse.ArgumentParser, what: str = "the output") -> None:
    """The one ``--overwrite`` flag every command that writes results takes."""
    parser.add_argument(
        "--overwrite", action="store_true", help=f"replace {what} if it exists already"
    )


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


def os_error_text(e: OSError) -> str:
    """An OSError as one line: what failed and on which path."""
    what = e.strerror or type(e).__name__
    return f"{what}: {e.filename}" if e.filename else what


def one_line(text: str) -> str:
    """``text`` on one line: a newline a user typed into a key or path shows as \\n."""
    return text.replace("\r", "\\r").replace("\n", "\\n")


def run(prog: str, work: Callable[[], int | None], interrupted: str = "interrupted") -> int:
    """Call ``work()``; one line and exit status 2 for a user's problem.

    Returns ``work``'s status (0 if it returns None), 2 after a JaxnavError or
    OSError, 130 after Ctrl-C (``interrupted`` says how to go on).
    """
    prog = command_name(prog)
    try:
        status = work()
    except JaxnavError as e:
        print(f"{prog}: error: {one_line(str(e))}", file=sys.stderr)
        return EXIT_ERROR
    except OSError as e:
        print(f"{prog}: error: {one_line(os_error_text(e))}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print(f"\n{prog}: {interrupted}", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0 if status is None else status
