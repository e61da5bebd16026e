"""What a command sets before JAX starts: devices and the compilation cache."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from jaxnav.core.startup import cache_dir

ROOT = Path(__file__).resolve().parent.parent


def test_the_cache_directory_follows_the_users_choice(monkeypatch, tmp_path):
    monkeypatch.delenv("JAXNAV_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "jaxnav" / "jax"
    monkeypatch.setenv("JAXNAV_CACHE", str(tmp_path / "mine"))
    assert cache_dir() == tmp_path / "mine"
    for off in ("off", "0", "OFF"):
        monkeypatch.setenv("JAXNAV_CACHE", off)
        assert cache_dir() is None


def _cache_seen_by_jax(env: dict) -> str:
    code = (
        "from jaxnav.core.startup import before_jax; before_jax(); import jax; "
        "print(jax.config.jax_compilation_cache_dir)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True, check=True
    )
    return out.stdout.strip()


@pytest.mark.slow  # 7 s on 2 cores
def test_a_command_starts_jax_with_the_cache_unless_told_otherwise(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_", "JAXNAV_"))}
    assert _cache_seen_by_jax({**env, "JAXNAV_CACHE": str(tmp_path)}) == str(tmp_path)
    assert _cache_seen_by_jax({**env, "JAXNAV_CACHE": "off"}) in ("", "None")
    theirs = {**env, "JAXNAV_CACHE": str(tmp_path), "JAX_COMPILATION_CACHE_DIR": "/elsewhere"}
    assert _cache_seen_by_jax(theirs) == "/elsewhere"


@pytest.mark.slow  # 4 s on 2 cores
def test_a_command_started_by_a_command_uses_its_own_cache(tmp_path):
    """A study times each training command with an empty cache of its own
    (JAXNAV_CACHE), though the study itself set JAX_COMPILATION_CACHE_DIR, which the
    command inherits: a parent's directory is not the user's choice."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_", "JAXNAV_"))}
    code = (
        "import os, subprocess, sys; from jaxnav.core.startup import before_jax; before_jax(); "
        "child = {**os.environ, 'JAXNAV_CACHE': sys.argv[1]}; "
        "sys.exit(subprocess.run([sys.executable, '-c', sys.argv[2]], env=child).returncode)"
    )
    seen = (
        "from jaxnav.core.startup import before_jax; before_jax(); import jax; "
        "print(jax.config.jax_compilation_cache_dir)"
    )
    parent = {**env, "JAXNAV_CACHE": str(tmp_path / "parent")}
    for child, want in ((str(tmp_path / "child"), str(tmp_path / "child")), ("off", ("", "None"))):
        out = subprocess.run(
            [sys.executable, "-c", code, child, seen],
            env=parent, cwd=ROOT, capture_output=True, text=True, check=True,
        )  # fmt: skip
        got = out.stdout.strip()
        assert got in want if isinstance(want, tuple) else got == want


@pytest.mark.slow  # 3 s on 2 cores
def test_the_commands_age_leaves_out_what_a_shell_ran_before_it():
    """``bash -c 'sleep 3 && python ...'``: the shell hands Python its own process, so
    /proc's start is the shell's; the age counts from Python's start-up instead (it
    printed 3.05 here)."""
    code = "from jaxnav.core.startup import process_age; print(process_age())"
    line = f"sleep 3 && exec {sys.executable} -c '{code}'"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    age = float(subprocess.run(["bash", "-c", line], env=env, capture_output=True, text=True,
                               check=True).stdout)  # fmt: skip
    assert 0.0 <= age < 2.0, age
    alone = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert 0.0 < float(alone.stdout) < 2.0  # Python's own start-up still counts
