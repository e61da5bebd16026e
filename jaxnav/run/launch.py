"""Starting a training run in its directory and resuming one, and what a Ctrl-C leaves
of it: a run without a checkpoint has nothing worth resuming, so what the command made
goes; otherwise it stays resumable from its last checkpoint (:func:`interrupted_text`
says which). The host loop itself is :class:`jaxnav.run.training.Run`.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import shutil
from pathlib import Path
from typing import Any

from jaxnav.agent.sharding import is_writer
from jaxnav.core import rundir, startup, worlds
from jaxnav.core.config import Config, dump_config, load_config
from jaxnav.core.errors import ConfigError
from jaxnav.run.training import Run
from jaxnav.world.maps import make_maze


def _writer_lock(out: Path):
    """The run directory's lock, held by the process that writes (process 0)."""
    return rundir.Lock(out) if is_writer() else contextlib.nullcontext()


# What a Ctrl-C left of the run this process trains: its directory, whether the
# command made it, and how far it got; interrupted_text says it in words.
_interrupt: dict[str, Any] = {}


def interrupted_text() -> str:
    """The line ``jaxnav train`` ends with on Ctrl-C: what it left and how to go on."""
    out, left = _interrupt.get("out"), _interrupt.get("left")
    if out is None:
        return "interrupted"
    if _interrupt.get("finished"):
        return (
            f"interrupted after training finished: the results are in {out} "
            f"({startup.invocation('plots')} {out} draws its figures)"
        )
    if left == "removed":
        return f"interrupted before the first checkpoint; {out} was removed"
    if left == "emptied":
        return f"interrupted before the first checkpoint; {out} was left empty"
    resume = startup.invocation("train")
    return f"interrupted; the run can be resumed with {resume} --resume {shlex.quote(str(out))}"


@contextlib.contextmanager
def _tidy_on_interrupt(out: Path, made: bool | None):
    """On Ctrl-C within the block: a run without a checkpoint has nothing worth
    resuming, so what this command wrote goes (``made``: the whole directory, which it
    created; False: its contents, the directory was there before; None, a resume:
    nothing). Otherwise only this process's half-written temporary files go."""
    _interrupt.clear()
    _interrupt.update(out=out)

    def tidy() -> None:
        if not is_writer() or not out.is_dir():
            return
        resumable = (out / rundir.CHECKPOINT).is_file() or (out / rundir.PARAMS).is_file()
        if resumable or made is None:
            rundir.remove_stale_temps(out, pid=os.getpid())
        elif made:
            shutil.rmtree(out, ignore_errors=True)
            _interrupt.update(left="removed")
        else:
            rundir.empty(out)
            _interrupt.update(left="emptied")

    with startup.on_interrupt(tidy):
        yield


def check_test_mazes(cfg: Config) -> None:
    """Read every maze of ``run.test_mazes`` (a name or a maze file): one that does not
    exist or load is a ConfigError naming it, before anything is trained or written,
    not a failure at the test after training."""
    for maze in worlds.expand(cfg.run.test_mazes):  # a set (barn:test): each of its mazes
        try:
            make_maze(maze)
        except ValueError as e:
            raise ConfigError(f"config: run.test_mazes: {e}") from None


def train_new(
    cfg: Config,
    out: Path,
    quiet: bool = False,
    overwrite: bool = False,
    keep_checkpoints: bool = False,
) -> dict[str, Any]:
    """Start a new run in ``out`` (absent or empty; with ``overwrite``, an existing run
    directory is emptied first, under its lock) and train it to the end."""
    check_test_mazes(cfg)  # and Run builds the env first: a bad maze leaves no directory
    run = Run(cfg, out, quiet, keep_checkpoints)
    run.on_finished = lambda: _interrupt.update(finished=True)
    _ = run.start_params  # run.init_from read and checked before any file is written
    replace = overwrite and (out / rundir.CONFIG).is_file()
    with _tidy_on_interrupt(out, made=not out.exists()):
        with startup.no_interrupt():
            if is_writer() and not replace:
                rundir.create(out)
        with _writer_lock(out):
            if is_writer():
                with startup.no_interrupt():
                    if replace:
                        rundir.clear(out)
                    rundir.atomic_write_text(out / rundir.CONFIG, dump_config(cfg))
            return run.finish(run.train(run.fresh_state()))


def resume(out: Path, quiet: bool = False, keep_checkpoints: bool = False) -> dict[str, Any]:
    """Continue a run from its last checkpoint (or from the start if it has none). A
    finished run whose checkpoints are gone has nothing left to train: its summary."""
    out = rundir.existing(out)
    cfg = load_config(str(out / rundir.CONFIG))
    if rundir.finished(out):
        with _writer_lock(out):
            if is_writer():
                rundir.remove_stale_temps(out)
                rundir.remove_checkpoints(out)  # left by a finish that was killed
            # as a resume with nothing left to train reports it: no start-up this time
            return {**rundir.read_summary(out), "startup_s": None, "compile_s": None}
    run = Run(cfg, out, quiet, keep_checkpoints)
    run.on_finished = lambda: _interrupt.update(finished=True)
    with _tidy_on_interrupt(out, made=None), _writer_lock(out):
        if is_writer():
            rundir.remove_stale_temps(out)
            run.checkpoint.parent.mkdir(exist_ok=True)  # killed before create() finished
        if run.checkpoint.is_file():
            ts = run.restored_state()
        else:  # killed before its first checkpoint: start over
            if is_writer():
                run.metrics.path.unlink(missing_ok=True)
                run.explore.path.unlink(missing_ok=True)
                (out / rundir.EVAL).unlink(missing_ok=True)
            ts = run.fresh_state()
        return run.finish(run.train(ts))
