"""Ctrl-C at any moment: one line, exit status 130, no traceback, and a run directory
that can be resumed, is finished, or is gone (never a crash, never a half-written file)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from jaxnav.core import rundir

ROOT = Path(__file__).resolve().parent.parent

# A command-like script: the handler first, then work that a Ctrl-C meets in Python
# code, inside a no_interrupt block, or where the main thread does not look for
# signals (SIGINT blocked on it: as in native code that never checks).
SCRIPT = """
import atexit, signal, sys, time
from pathlib import Path
from jaxnav.core import startup
startup.catch_interrupts()
from jaxnav.core import cli

mode, out = sys.argv[1], Path(sys.argv[2])

def work():
    with startup.on_interrupt(lambda: (out / "tidied").write_text("yes")):
        if mode == "native":
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        if mode == "block":
            with startup.no_interrupt():
                print("ready", flush=True)
                time.sleep(float(sys.argv[3]))
                (out / "written").write_text("whole")
        elif mode != "exiting":
            print("ready", flush=True)
        if mode == "done":
            print("unflushed")
            return 3
        if mode == "exiting":  # the work is done; Ctrl-C comes while the process ends
            atexit.register(lambda: (print("ready", flush=True), time.sleep(30)))
            return 0
        time.sleep(30)

sys.exit(cli.run("python -m jaxnav.demo", work, interrupted=lambda: "stopped; " + out.name))
"""


def _ignore_sigint() -> None:
    """As a shell starts a job with ``&`` (or ``nohup`` does): SIGINT ignored."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _start(*args: str, background: bool = False) -> subprocess.Popen:
    cmd = [sys.executable, "-c", SCRIPT, *args]
    pipes = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    preexec = _ignore_sigint if background else None
    return subprocess.Popen(cmd, cwd=ROOT, preexec_fn=preexec, **pipes)


def _ready(proc: subprocess.Popen) -> None:
    assert proc.stdout.readline() == "ready\n"


def _interrupted(proc: subprocess.Popen, timeout: float = 30) -> tuple[float, str]:
    """Send Ctrl-C; (seconds until the process ended, its stderr). It must end with 130."""
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=timeout)
    took = time.monotonic() - t0
    assert proc.returncode == 130, (proc.returncode, err)
    return took, err


def _one_line(err: str, prog: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith(f"{prog}: "), err
    return lines[0]


@pytest.mark.parametrize("mode", ["python", "native"])
def test_ctrl_c_tidies_says_one_line_and_exits_130(tmp_path, mode):
    proc = _start(mode, str(tmp_path))
    _ready(proc)
    took, err = _interrupted(proc)
    assert _one_line(err, "jaxnav.demo") == f"jaxnav.demo: stopped; {tmp_path.name}"
    assert (tmp_path / "tidied").read_text() == "yes"
    assert took < 10, took  # native: the watcher thread acts after a second


@pytest.mark.parametrize("background", [False, True], ids=["foreground", "ampersand"])
def test_sigterm_is_answered_as_ctrl_c_with_status_143(tmp_path, background):
    """In a job started with ``&`` SIGINT is ignored: ``kill PID`` used to end the
    command there without a word."""
    proc = _start("python", str(tmp_path), background=background)
    _ready(proc)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143, (proc.returncode, err)
    assert _one_line(err, "jaxnav.demo") == f"jaxnav.demo: stopped; {tmp_path.name}"
    assert (tmp_path / "tidied").read_text() == "yes"


@pytest.mark.slow
def test_ctrl_c_waits_for_a_no_interrupt_block_but_not_twice(tmp_path):
    proc = _start("block", str(tmp_path), "1.5")
    _ready(proc)
    _interrupted(proc)
    assert (tmp_path / "written").read_text() == "whole"  # the block ran to its end
    assert (tmp_path / "tidied").is_file()

    proc = _start("block", str(tmp_path / "again"), "60")
    _ready(proc)
    proc.send_signal(signal.SIGINT)
    time.sleep(0.5)
    took, err = _interrupted(proc)  # the second Ctrl-C ends it at once
    assert took < 10 and not (tmp_path / "again" / "written").exists()
    _one_line(err, "jaxnav.demo")


def test_a_command_ends_with_its_status_and_its_output_flushed(tmp_path):
    proc = _start("done", str(tmp_path))
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 3 and out == "ready\nunflushed\n" and err == ""


def test_ctrl_c_while_the_process_exits_is_130_too(tmp_path):
    proc = _start("exiting", str(tmp_path))
    _ready(proc)
    _, err = _interrupted(proc)
    assert _one_line(err, "jaxnav.demo") == f"jaxnav.demo: stopped; {tmp_path.name}"


# -- jaxnav train ------------------------------------------------------

TINY = ["configs/smoke.yaml", "seeds=1", "episodes=6", "env.max_steps=100"]
TINY += [
    "run.chunk_steps=100",
    "dqn.batch_size=16",
    "run.chunk_s=0",
    "run.checkpoint_s=0",
    "--quiet",
]


def _train(
    out: Path, *overrides: str, cold: bool = False, background: bool = False
) -> subprocess.Popen:
    env = dict(os.environ)
    if cold:  # compile from scratch: no persistent cache
        env.pop("JAX_COMPILATION_CACHE_DIR", None)
        env["JAXNAV_CACHE"] = "off"
    cmd = [sys.executable, "-m", "jaxnav.commands.train", *TINY, *overrides, "--out", str(out)]
    pipes = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    preexec = _ignore_sigint if background else None
    return subprocess.Popen(cmd, cwd=ROOT, env=env, preexec_fn=preexec, **pipes)


def _when(proc: subprocess.Popen, path: Path, timeout: float = 120) -> None:
    deadline = time.monotonic() + timeout
    while not path.exists():
        assert proc.poll() is None, "the command ended before the moment came"
        assert time.monotonic() < deadline, f"{path} did not appear"
        time.sleep(0.005)


def _left_resumable_finished_or_nothing(out: Path, line: str) -> str:
    """What the interrupted run left, checked against its one line."""
    if not out.exists():
        assert f"{out} was removed" in line, line
        return "absent"
    assert not list(out.rglob(".*.tmp*")), "a half-written file was left"
    if (out / rundir.PARAMS).is_file():
        assert (out / rundir.SUMMARY).is_file() and not (out / "checkpoints").exists()
        assert "after training finished" in line, line
        return "finished"
    assert (out / rundir.CHECKPOINT).is_file(), sorted(p.name for p in out.iterdir())
    assert f"--resume {out}" in line, line
    return "resumable"


@pytest.mark.slow
def test_ctrl_c_at_every_stage_of_training(tmp_path):
    """While Python imports JAX, while XLA compiles the chunk (once a segmentation
    fault), between chunks, and after training (final files, figures, exit)."""
    left = {}
    # importing: nothing written yet
    proc = _train(tmp_path / "importing")
    time.sleep(0.3)
    line = _one_line(_interrupted(proc)[1], "jaxnav train")
    assert line == "jaxnav train: interrupted" and not (tmp_path / "importing").exists()

    # compiling: the directory is made, nothing resumable yet, so it goes
    out = tmp_path / "compiling"
    proc = _train(out, cold=True)
    _when(proc, out / rundir.CONFIG)
    line = _one_line(_interrupted(proc)[1], "jaxnav train")
    left["compiling"] = _left_resumable_finished_or_nothing(out, line)

    # training: after the first checkpoint (of 40); then --resume ends the run
    out = tmp_path / "training"
    proc = _train(out, "episodes=40")
    _when(proc, out / rundir.CHECKPOINT)
    line = _one_line(_interrupted(proc)[1], "jaxnav train")
    left["training"] = _left_resumable_finished_or_nothing(out, line)
    resume = [sys.executable, "-m", "jaxnav.commands.train", "--resume", str(out), "--quiet"]
    subprocess.run(resume, cwd=ROOT, check=True, capture_output=True)
    assert rundir.finished(out)

    # finished: params.npz is written, the command is drawing figures or exiting
    out = tmp_path / "finished"
    proc = _train(out)
    _when(proc, out / rundir.SUMMARY)
    line = _one_line(_interrupted(proc)[1], "jaxnav train")
    left["finished"] = _left_resumable_finished_or_nothing(out, line)

    assert left == {
        "compiling": "absent",
        "training": "resumable",
        "finished": "finished",
    }


@pytest.mark.slow
def test_sigterm_in_a_background_training_leaves_it_resumable_and_says_how(tmp_path):
    out = tmp_path / "run"
    proc = _train(out, "episodes=40", background=True)
    _when(proc, out / rundir.CHECKPOINT)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, (proc.returncode, err)
    line = _one_line(err, "jaxnav train")
    assert line.startswith("jaxnav train: stopped by SIGTERM; ") and "Traceback" not in err
    assert _left_resumable_finished_or_nothing(out, line) in ("resumable", "finished")


@pytest.mark.slow
def test_ctrl_c_in_evaluate_is_the_same_one_line(tmp_path):
    out = tmp_path / "run"
    subprocess.run(
        [sys.executable, "-m", "jaxnav.commands.train", *TINY, "--out", str(out)],
        cwd=ROOT,
        check=True,
        capture_output=True,
    )
    cmd = [sys.executable, "-m", "jaxnav.commands.evaluate", str(out), "--episodes", "1"]
    for delay in (0.3, 3.0):
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        time.sleep(delay)
        if proc.poll() is not None:
            continue  # it finished first: nothing to interrupt
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 130, err
        assert _one_line(err.decode(), "jaxnav evaluate") == "jaxnav evaluate: interrupted"
