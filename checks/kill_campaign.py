"""Kill a training with SIGKILL at random moments, resume after each, and compare.

    python checks/kill_campaign.py [--kills 20] [--seed 0] [--out DIR]

Trains a small config once without interruption (the reference), then trains it
again, killing the process (SIGKILL, no chance to clean up) at ``--kills`` random
moments and resuming with ``jaxnav train --resume`` after each. At the
end metrics.csv, explore.csv and params.npz must equal the reference's byte for
byte. Chunks are short (100 steps) so checkpoints are frequent. Every other kill
waits for the process's k-th checkpoint write to begin (k random in 1..6; its
temporary file appears) and kills it right then, so those kills land while a
checkpoint is being written; the others come at a random moment. The script counts
the kills that left a temporary file behind (resume removes them).

Prints one line per kill and a summary; exits 1 if any file differs.
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CONFIG = [
    "configs/smoke.yaml",
    "seeds=2",
    "episodes=30",
    "env.max_steps=100",
    "run.chunk_steps=100",
    "run.checkpoint_s=0",  # a checkpoint after every chunk (the chunks cut by time)
    "--quiet",
]
FILES = ("metrics.csv", "explore.csv", "params.npz")


def _train(args: list[str]) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "jaxnav.commands.train", *args],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def _temps(run: Path) -> int:
    return sum(1 for p in run.rglob(".*.tmp*"))


def _killed(proc: subprocess.Popen, run: Path, delay: float, writes: int) -> bool:
    """SIGKILL ``proc`` after ``delay`` seconds, or (``writes`` > 0) as soon as its
    ``writes``-th checkpoint write is under way (its temporary file has appeared);
    False if it finished first."""
    deadline = time.perf_counter() + delay
    seen, writing = 0, False
    while proc.poll() is None:
        if writes:
            now = _temps(run) > 0
            seen += now and not writing
            writing = now
            due = seen >= writes
        else:
            due = time.perf_counter() >= deadline
        if due:
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait()
            return True
        time.sleep(0.0005 if writes else 0.01)
    return False


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kills", type=int, default=20)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", help="working directory (default a temporary one)")
    a = p.parse_args()
    rng = random.Random(a.seed)
    work = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="jaxnav-kills-"))
    ref, run = work / "reference", work / "killed"
    shutil.rmtree(ref, ignore_errors=True)
    shutil.rmtree(run, ignore_errors=True)

    t0 = time.perf_counter()
    proc = _train([*CONFIG, "--out", str(ref)])
    if proc.wait() != 0:
        print(f"reference run failed: {proc.stderr.read().strip()}")
        return 1
    full = time.perf_counter() - t0
    print(f"reference: {full:.1f} s uninterrupted (compilation included)")

    kills = in_write = 0
    started = False
    while kills < a.kills:
        if not started:
            shutil.rmtree(run, ignore_errors=True)  # killed before its config was written
        args = ["--resume", str(run), "--quiet"] if started else [*CONFIG, "--out", str(run)]
        proc = _train(args)
        at_write = kills % 2 == 1
        writes = rng.randint(1, 6) if at_write else 0
        delay = rng.uniform(0.5, full)
        if _killed(proc, run, delay, writes):
            kills += 1
            temps = _temps(run)
            in_write += temps > 0
            started = started or (run / "config.yaml").is_file()
            metrics = run / "metrics.csv"
            done = len(metrics.read_text().splitlines()) - 1 if metrics.exists() else 0
            when = f"in checkpoint write {writes}" if at_write else f"after {delay:5.1f} s"
            print(
                f"kill {kills:2d} {when}: {done} episodes logged"
                + (", a temporary file left behind" if temps else "")
            )
            continue
        if proc.returncode != 0:
            print(f"run failed: {proc.stderr.read().strip()}")
            return 1
        print(f"finished before the kill at {delay:.1f} s; starting over")
        shutil.rmtree(run)
        started = False
    # The last resume runs to the end.
    proc = _train(["--resume", str(run), "--quiet"] if started else [*CONFIG, "--out", str(run)])
    if proc.wait() != 0:
        print(f"final resume failed: {proc.stderr.read().strip()}")
        return 1
    same = {f: (ref / f).read_bytes() == (run / f).read_bytes() for f in FILES}
    print(
        f"{kills} kills ({in_write} during a write); after the last resume: "
        + ", ".join(f"{f} {'identical' if ok else 'DIFFERS'}" for f, ok in same.items())
        + f"; {time.perf_counter() - t0:.0f} s in all"
    )
    return 0 if all(same.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
