"""Golden numbers: whole commands' result files, byte for byte, against their sha256
committed here.

A change that moves a trained parameter or a test result in the last bit fails here,
whatever its commit message says. Each case runs the command as a user does, in its own
process, with two CPU devices whatever the machine has (the run axis is laid over the
devices, and a program of another width may round differently).

When a case fails on purpose, put the new values (the failure prints them all) in
``GOLDEN`` and say in the commit message why the numbers changed; a change that only
reorders floating-point work (an XLA fusion, a broadcast moved) says "numbers change at
rounding level". The values were computed with jax and jaxlib 0.10.2, NumPy 2.4 on an
x86-64 CPU (AMD EPYC); another version of XLA or another CPU may round differently.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
DEVICES = 2

# name -> (commands, {result file: sha256}); a command is argv after `python -m jaxnav`,
# with RUN standing for the case's run directory.
CASES = {
    # the smoke config cut to 10 episodes: the quick tier's check
    "smoke, 10 episodes": (
        [["train", "smoke", "episodes=10", "--out", "RUN", "--quiet"]],
        {
            "metrics.csv": "134daf4596d6dab696af201823542d952a2065dfe81d431ce7630ecc681210bb",
            "params.npz": "c1e083cb181271c8f1cf5348712a0e6c9566266f5caa48b7734cdc467920b950",
        },
    ),
    "jaxnav train smoke": (
        [["train", "smoke", "--out", "RUN", "--quiet"]],
        {
            "metrics.csv": "9d98c25d0e80b409f60a56e99efb3d43158ff3a9838d275ee4b9bb13d8bdd442",
            "params.npz": "fb920276f5a35d3fe26a9d81902b8978a16ee399057fee1173053359bbe4077e",
        },
    ),
    # paper_obstacles at the size of `jaxnav reproduce --quick`
    "paper_obstacles, reproduce --quick's size": (
        [
            [
                "train",
                "paper_obstacles",
                "seeds=2",
                "episodes=50",
                "env.max_steps=200",
                "run.test_episodes=3",
                "run.chunk_steps=10000",
                "--out",
                "RUN",
                "--quiet",
            ]
        ],
        {
            "metrics.csv": "80a5f81bf3a6d6fe99ab31c287f622ff645623a87bb276d68849b59fe4783afc",
            "params.npz": "73eeb18db87005472fd4a6a7a153ed163e993d2d9786d5004058140ddb0c8fa3",
        },
    ),
    # a drive config's test: the policies in both modes, the oracle and DWA beside them,
    # on stage 4 (moving cylinders) and stage4_humble
    "drive_stage4, its test": (
        [
            [
                "train",
                "drive_stage4",
                "seeds=2",
                "total_steps=4096",
                "env.max_steps=100",
                "run.test_episodes=2",
                "run.chunk_steps=4096",
                "run.eval_every=0",
                "--out",
                "RUN",
                "--quiet",
            ],
            ["evaluate", "RUN"],
        ],
        {
            "eval/results.csv": "bf3387df0feb7da9b72d0705d8900f39bd050ebe06b7d25d442a063a6e9d0568",
        },
    ),
}
QUICK = {"smoke, 10 episodes"}


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _run_case(commands: list[list[str]], run: Path) -> None:
    flags = os.environ.get("XLA_FLAGS", "").split()
    flags = [f for f in flags if not f.startswith("--xla_force_host_platform_device_count")]
    flags.append(f"--xla_force_host_platform_device_count={DEVICES}")
    env = dict(
        os.environ,
        XLA_FLAGS=" ".join(flags),
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    )
    for argv in commands:
        argv = [str(run) if a == "RUN" else a for a in argv]
        done = subprocess.run(
            [sys.executable, "-m", "jaxnav", *argv], env=env, capture_output=True, text=True
        )
        assert done.returncode == 0, f"jaxnav {' '.join(argv)} failed:\n{done.stderr[-2000:]}"


def golden_mismatch(name: str, run: Path) -> str | None:
    """None where the case's files hash to the committed values; else the message."""
    _, want = CASES[name]
    got = {f: _sha256(run / f) for f in want}
    if got == want:
        return None
    lines = [
        f"The result files of the golden case {name!r} changed:",
        *(f"  {f}: {got[f]} (committed {want[f]})" for f in want if got[f] != want[f]),
        "",
        "If the change is meant, put these values in CASES in tests/test_golden.py:",
        *(f'            "{f}": "{got[f]}",' for f in want),
        "and say in the commit message why the numbers changed; for a change that only",
        "reorders floating-point work (an XLA fusion, a broadcast moved, a new jax) say",
        "'numbers change at rounding level'. If it is not meant, the commit changed",
        "behaviour that it should have kept: git bisect with this test finds the commit.",
        "(Values from jax 0.10.2 on an x86-64 CPU, 2 CPU devices; another XLA or CPU may",
        "round differently.)",
    ]
    return "\n".join(lines)


@pytest.mark.slow  # 11 s on 2 cores
@pytest.mark.parametrize(
    "name",
    [n if n in QUICK else pytest.param(n, marks=pytest.mark.slow) for n in CASES],
)
def test_the_numbers_are_the_committed_ones(name, tmp_path):
    commands, _ = CASES[name]
    run = tmp_path / "run"
    _run_case(commands, run)
    problem = golden_mismatch(name, run)
    assert problem is None, problem


def test_a_moved_number_fails_with_what_to_do(tmp_path):
    """The check itself: a result file one byte off is caught, and the message names
    the file, prints the values to commit and says what the commit must say."""
    name = "smoke, 10 episodes"
    _, want = CASES[name]
    run = tmp_path / "run"
    run.mkdir()
    # files whose hashes are not the committed ones
    (run / "metrics.csv").write_text("strategy,seed,episode,return\nebe,0,0,1.0\n")
    np.savez(run / "params.npz", w=np.zeros(3, np.float32))
    message = golden_mismatch(name, run)
    assert message is not None
    assert "metrics.csv" in message and "params.npz" in message
    assert _sha256(run / "metrics.csv") in message
    assert "numbers change at rounding level" in message
    assert "commit message" in message
