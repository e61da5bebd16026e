"""What a command sets up before JAX starts: one CPU device per core
(:mod:`jaxnav.core.cpu`) and JAX's persistent compilation cache.

XLA's compile of the training chunk takes seconds to tens of seconds on a CPU; the
cache keeps the compiled program on disk, so a second run of the same config (or a
resume, or the same test maze again) starts without compiling. A cached program is
the same executable, so the numbers do not change.

Where the cache lives: ``JAX_COMPILATION_CACHE_DIR`` if the user set it; else
``$JAXNAV_CACHE``; else ``$XDG_CACHE_HOME/jaxnav/jax`` (``~/.cache/jaxnav/jax``).
``JAXNAV_CACHE=off`` turns it off. The cache is not pruned (a program of the paper
config is a few MB); delete the directory to empty it. No JAX here: it must run
before JAX is imported. The reference drivers' test rows have a cache of their own
beside it (:func:`reference_cache_dir`).

Ctrl-C (:func:`catch_interrupts`). Python's own answer to SIGINT, a
``KeyboardInterrupt`` raised wherever the main thread happens to be, is unsafe in a
JAX program: raised while XLA compiles (jaxlib waits for the compile on a thread of
its own and checks for signals meanwhile), it abandons a compile that goes on
running; the interpreter then shuts down under it and the compile thread crashes
(a segmentation fault), and raised inside an import it leaves a half-made native
module whose teardown crashes the same way. So a command replaces it, before it
imports anything heavy, with a handler that never unwinds: it runs the tidy-ups the
command registered (:func:`on_interrupt`), prints one line
(``jaxnav.<command>: interrupted; ...``, the text :mod:`jaxnav.core.cli` was
given) and ends the process with ``os._exit(130)``. Writes that must not be cut in
the middle run under :func:`no_interrupt`, and a Ctrl-C waits for them; a second
Ctrl-C does not. When the main thread is busy in native code that does not look
for signals (a long chunk of training), a watcher thread woken by the signal acts
for it after a second. At the end of a command the process leaves with its status
as soon as the ``atexit`` handlers have run, skipping the second or so of module
teardown in which a Ctrl-C would otherwise kill it by the signal. SIGTERM (``kill``,
a job scheduler's stop) is answered the same way, its line saying ``stopped by
SIGTERM`` where a Ctrl-C's says ``interrupted``, with its own status, 143 (what a
shell reports for it), also in a job started with ``&`` or ``nohup``, where SIGINT
is ignored.
"""

from __future__ import annotations

import atexit
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from jaxnav.core.cpu import use_all_cores

# When Python first read jaxnav (jaxnav/__init__.py), else when this module was.
_IMPORTED = getattr(sys.modules.get("jaxnav"), "_STARTED", time.monotonic())
# Python's own start-up before it reads jaxnav takes well under this; a longer gap
# between the process's start and that means the process ran something else first.
STARTUP_SLACK_S = 2.0
# The JAX_COMPILATION_CACHE_DIR a jaxnav command set itself, not the user: a command
# started by another (a study's training commands, a benchmark's) inherits both.
_SET_BY_JAXNAV = "JAXNAV_CACHE_SET"
_OFF = ("off", "0", "false", "no")  # what turns a cache off


def process_age() -> float:
    """Seconds since this command started: from /proc on Linux (interpreter start-up
    included), elsewhere since Python first read jaxnav. /proc counts from the
    process's creation, and a shell that runs Python as its last command (``bash -c
    'pip install ... && jaxnav train ...'``, a CI step, a Docker ``RUN``) hands it its
    own process: where /proc's start lies more than :data:`STARTUP_SLACK_S` before
    Python read jaxnav, the shell's time is not the command's, and the age counts
    from that read instead."""
    read = time.monotonic() - _IMPORTED
    try:
        with open("/proc/self/stat") as f:  # field 22: start time in clock ticks since boot
            start = int(f.read().rsplit(")", 1)[1].split()[19]) / os.sysconf("SC_CLK_TCK")
        with open("/proc/uptime") as f:
            age = max(float(f.read().split()[0]) - start, 0.0)
    except (OSError, ValueError, IndexError):
        return read
    return age if age - read <= STARTUP_SLACK_S else read


def cache_dir() -> Path | None:
    """The compilation cache's directory, or None when it is off."""
    chosen = os.environ.get("JAXNAV_CACHE", "")
    if chosen.lower() in _OFF:
        return None
    if chosen:
        return Path(chosen).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "jaxnav" / "jax"


def reference_cache_dir() -> Path | None:
    """Where the reference drivers' test rows are kept
    (:mod:`jaxnav.experiments.refcache`), or None when that cache is off:
    ``$JAXNAV_REFERENCE_CACHE`` if set (``off`` turns it off), else ``references``
    beside the compilation cache's default, ``$XDG_CACHE_HOME/jaxnav/references``
    (``~/.cache/jaxnav/references``). ``JAXNAV_CACHE=off`` turns both caches off."""
    chosen = os.environ.get("JAXNAV_REFERENCE_CACHE", "")
    if chosen.lower() in _OFF or os.environ.get("JAXNAV_CACHE", "").lower() in _OFF:
        return None
    if chosen:
        return Path(chosen).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "jaxnav" / "references"


def use_compilation_cache() -> None:
    """Point JAX's persistent compilation cache at :func:`cache_dir`, unless JAX
    already started, the user chose a directory for JAX, or it is off."""
    if "jax" in sys.modules:
        return
    chosen = os.environ.get("JAX_COMPILATION_CACHE_DIR")
    if chosen is not None and chosen != os.environ.get(_SET_BY_JAXNAV):
        return  # the user's directory
    # Unset, or set by a jaxnav process this one was started from (a child inherits
    # the variable; a study times its commands with a cache of their own): this
    # command's own choice.
    path = cache_dir()
    if path is None:
        os.environ.pop("JAX_COMPILATION_CACHE_DIR", None)
        os.environ.pop(_SET_BY_JAXNAV, None)
        return
    os.environ["JAX_COMPILATION_CACHE_DIR"] = os.environ[_SET_BY_JAXNAV] = str(path)


def before_jax() -> None:
    """Everything a command sets before JAX starts."""
    catch_interrupts_in_command()
    use_all_cores()
    use_compilation_cache()


# ----------------------------------------------------------------------------
# Ctrl-C
# ----------------------------------------------------------------------------

EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143  # 128 + SIGTERM, as a shell reports a job ended by it
WATCHER_GRACE_S = 1.0  # how long the watcher leaves the main thread to answer a Ctrl-C


class _Interrupts:
    """The state of :func:`catch_interrupts` (one per process)."""

    def __init__(self) -> None:
        self.installed = False
        self.prog = ""  # the command, as its one line names it
        self.text: str | Callable[[], str] = "interrupted"
        self.tidy: list[Callable[[], None]] = []
        self.status: int | None = None  # what the command returned, for the fast exit
        self.signals = 0  # Ctrl-Cs (and SIGTERMs) received
        self.code = EXIT_INTERRUPTED  # 130 for a Ctrl-C, 143 for a SIGTERM
        self.pending = False  # a Ctrl-C waits for the end of a no_interrupt block
        self.depth = 0  # the main thread's no_interrupt blocks open
        self.writing = threading.RLock()  # held through a no_interrupt block
        self.leaving = threading.Lock()  # taken by the thread that ends the process


_state = _Interrupts()


def _command_name() -> str:
    """``jaxnav train`` for ``python -m jaxnav.commands.train`` and ``python -m
    jaxnav.train``, ``jaxnav`` for ``python -m jaxnav``; the script's name otherwise."""
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    if spec is not None and spec.name:
        name = spec.name.removesuffix(".__main__").removeprefix("jaxnav.commands.")
        return f"jaxnav {name.removeprefix('jaxnav.')}" if name != "jaxnav" else name
    return Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "jaxnav"


def in_command() -> bool:
    """Whether this process is a command: ``python -m jaxnav.<command>``, ``python -m
    jaxnav`` or the ``jaxnav`` script (not a test runner or a notebook that calls a
    command's ``main``)."""
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    if spec is not None:
        return (spec.name or "").startswith("jaxnav.")
    return bool(sys.argv) and Path(sys.argv[0]).name == "jaxnav"


def invocation(command: str) -> str:
    """How to run a command the way this process was run: ``jaxnav train`` from the
    ``jaxnav`` script, ``python -m jaxnav train`` from ``python -m`` (where the script
    may not be on the PATH)."""
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    if spec is None and sys.argv and Path(sys.argv[0]).name == "jaxnav":
        return f"jaxnav {command}"
    return f"python -m jaxnav {command}"


def catch_interrupts_in_command() -> None:
    """:func:`catch_interrupts` where this process is a command (:func:`in_command`):
    what every command's start-up calls, harmless where a command's ``main`` runs
    inside another program."""
    if in_command():
        catch_interrupts()


def catch_interrupts() -> None:
    """Make Ctrl-C end this command at once with one line and exit status 130, and
    SIGTERM with 143 (see the module's docstring). For a command's process only,
    called first thing: a library user's or a test runner's Ctrl-C stays theirs.
    Nothing happens off the main thread or on a second call; a signal that someone
    else handles or ignores stays theirs: SIGINT is ignored in a job started with
    ``&`` or under ``nohup``, and its SIGTERM (``kill PID``) is still answered."""
    if _state.installed or threading.current_thread() is not threading.main_thread():
        return
    ours = [
        sig
        for sig, default in (
            (signal.SIGINT, signal.default_int_handler),
            (signal.SIGTERM, signal.SIG_DFL),
        )
        if signal.getsignal(sig) is default
    ]
    if not ours:
        return
    _state.installed = True
    _state.prog = _command_name()
    for sig in ours:
        signal.signal(sig, _on_sigint)
    try:
        read, write = os.pipe()
        os.set_blocking(write, False)
        signal.set_wakeup_fd(write, warn_on_full_buffer=False)
    except (OSError, ValueError):
        pass  # the handler alone still answers, when the main thread runs Python
    else:
        threading.Thread(target=_watch, args=(read,), name="jaxnav-interrupt", daemon=True).start()
    atexit.register(_fast_exit)  # first registered: runs after every other handler


def interrupt_text(prog: str, text: str | Callable[[], str]) -> tuple[str, str | Callable[[], str]]:
    """What the line printed on Ctrl-C says after ``prog:``; ``text`` may be a function,
    called after the tidy-ups (it may say what they left). Returns the previous pair."""
    before = _state.prog, _state.text
    _state.prog, _state.text = prog, text
    return before


def exit_status(status: int | None) -> None:
    """The status the command ends with, once it is known (see :func:`_fast_exit`)."""
    _state.status = status


@contextmanager
def on_interrupt(tidy: Callable[[], None]) -> Iterator[None]:
    """Within the block, a Ctrl-C calls ``tidy()`` (innermost first) before the process
    ends. ``tidy`` runs while the main thread is stopped at a Python instruction or
    in native code, never inside a :func:`no_interrupt` block; its errors are ignored.
    Where no handler is installed, a ``KeyboardInterrupt`` through the block calls it."""
    _state.tidy.append(tidy)
    try:
        yield
    except KeyboardInterrupt:  # no handler installed (a library caller): tidy all the same
        try:
            tidy()
        except Exception:
            pass
        raise
    finally:
        _state.tidy.remove(tidy)


@contextmanager
def no_interrupt() -> Iterator[None]:
    """A block that a Ctrl-C does not cut: the process ends when the block does (a
    second Ctrl-C ends it at once). For writes that belong together."""
    with _state.writing:
        main = threading.current_thread() is threading.main_thread()
        _state.depth += main
        try:
            yield
        finally:
            _state.depth -= main
    if main and _state.depth == 0 and _state.pending:
        _leave()


def _on_sigint(signum, frame) -> None:
    """The SIGINT handler: runs on the main thread, between two Python instructions or
    where native code checks for signals (jaxlib does while it compiles). SIGTERM's too."""
    if signum == signal.SIGTERM:
        _state.code = EXIT_TERMINATED
    _state.signals += 1
    if _state.signals > 1 and (_state.pending or _state.leaving.locked()):
        _say_and_exit()  # a second Ctrl-C: no more waiting
    if _state.depth > 0:
        _state.pending = True  # inside a no_interrupt block: leave when it ends
        return
    _leave()


def _watch(fd: int) -> None:
    """The watcher thread: woken by every signal Python handles; a SIGINT that the main
    thread has not answered after WATCHER_GRACE_S is answered here (the main thread is
    then in native code that does not check for signals, such as a training chunk)."""
    while True:
        try:
            data = os.read(fd, 64)
        except InterruptedError:
            continue
        except OSError:
            return
        if not data:
            return
        if signal.SIGINT not in data and signal.SIGTERM not in data:
            continue
        deadline = time.monotonic() + WATCHER_GRACE_S
        while time.monotonic() < deadline and not _state.leaving.locked():
            time.sleep(0.02)
        if not _state.leaving.locked():
            _leave()


def _leave() -> None:
    """Tidy up, say the line, end the process (130). One thread does it; another that
    arrives blocks until the process is gone."""
    if not _state.leaving.acquire(blocking=False):
        threading.Event().wait()  # the other thread is ending the process
    with _state.writing:  # let a no_interrupt block on the main thread finish
        for tidy in reversed(list(_state.tidy)):
            try:
                tidy()
            except Exception:
                pass
        _say_and_exit()


def _say_and_exit() -> None:
    try:
        text = _state.text() if callable(_state.text) else _state.text
    except Exception:
        text = "interrupted"
    if _state.code == EXIT_TERMINATED and text.startswith("interrupted"):
        text = "stopped by SIGTERM" + text.removeprefix("interrupted")  # not a Ctrl-C
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:
            pass
    lead = "\n" if _line_open() else ""
    line = f"{lead}{_state.prog}: {text}\n" if _state.prog else f"{lead}{text}\n"
    try:
        os.write(2, line.encode(errors="replace"))
    finally:
        os._exit(_state.code)


def _line_open() -> bool:
    """Whether stderr's last line may be unfinished: a terminal (its ``^C``) or a
    progress bar still drawn there."""
    try:
        if sys.stderr is not None and sys.stderr.isatty():
            return True
    except (OSError, ValueError):
        pass
    tqdm = getattr(sys.modules.get("tqdm"), "tqdm", None)
    return bool(getattr(tqdm, "_instances", ()))


def _fast_exit() -> None:
    """The last ``atexit`` handler: once the command has returned its status, end the
    process with it now. What is left of Python's shutdown (tearing down modules,
    JAX's among them) takes a second or more and holds nothing of the command's, and
    in it a Ctrl-C would kill the process by the signal instead of ending it with 130."""
    if _state.status is None:
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:
            pass
    os._exit(_state.status)
