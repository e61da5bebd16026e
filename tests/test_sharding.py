"""Seeds laid over 4 forced CPU devices give the single-device results."""

import json
import os
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav.agent.sharding import any_run

ROOT = Path(__file__).resolve().parent.parent
TINY = ["episodes=6", "env.max_steps=80", "run.chunk_steps=100", "dqn.batch_size=16"]

_PROBE = """
import sys, jax
from jaxnav.core.config import load_config
from jaxnav.run.training import Run
cfg = load_config(None, sys.argv[1:])
run = Run(cfg, None, quiet=True)
ts = run.fresh_state()
leaf = ts.params["params"]["Dense_0"]["kernel"]
print(len(jax.devices()), run.shard.padded, run.shard.device_count_of(leaf), leaf.shape[0])
"""


def _run(tmp_path, name, devices, seeds):
    env = dict(os.environ)
    if devices > 1:
        env["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={devices}"
    out = tmp_path / name
    cmd = [
        sys.executable,
        "-m",
        "jaxnav.commands.train",
        f"seeds={seeds}",
        *TINY,
        "--out",
        str(out),
        "--quiet",
    ]
    subprocess.run(cmd, check=True, cwd=ROOT, env=env, capture_output=True)
    return out


def _close(a_dir, b_dir):
    # XLA compiles a per-device batch of 1 or 2 runs differently from a batch of
    # all of them, so results agree to float32 rounding, not bit for bit.
    a, b = np.load(a_dir / "params.npz"), np.load(b_dir / "params.npz")
    assert sorted(a.files) == sorted(b.files)
    for k in a.files:
        np.testing.assert_allclose(a[k], b[k], rtol=1e-4, atol=1e-5, err_msg=k)
    ra = np.genfromtxt(a_dir / "metrics.csv", delimiter=",", skip_header=1, usecols=range(1, 8))
    rb = np.genfromtxt(b_dir / "metrics.csv", delimiter=",", skip_header=1, usecols=range(1, 8))
    np.testing.assert_allclose(ra, rb, rtol=1e-4, atol=1e-3)


def test_any_run_is_one_value_for_the_batch_so_a_cond_on_it_stays_a_branch():
    assert bool(any_run(jnp.bool_(True))) and not bool(any_run(jnp.bool_(False)))
    due = jnp.array([False, True, False])
    np.testing.assert_array_equal(jax.vmap(any_run)(due), [True, True, True])
    assert not np.asarray(jax.vmap(any_run)(jnp.zeros(3, bool))).any()

    def sync(due, params, target):
        copy = lambda: jnp.where(due, params, target)  # noqa: E731
        return jax.lax.cond(any_run(due), copy, lambda: target)

    params, target = jnp.arange(3.0), -jnp.arange(3.0)
    np.testing.assert_array_equal(jax.vmap(sync)(due, params, target), [0.0, 1.0, -2.0])
    jaxpr = str(jax.make_jaxpr(jax.vmap(sync))(due, params, target))
    assert "cond[" in jaxpr and "select_n" not in jaxpr.split("cond[")[0]


_COMPILED = """
import sys, jax, numpy as np
from jaxnav.core.config import load_config
from jaxnav.run.training import Run
run = Run(load_config(None, sys.argv[1:]), None, quiet=True)
print(run.chunk.lower(run.fresh_state(), np.int32(0)).compile().as_text())
"""


@pytest.mark.slow
def test_each_device_decides_the_target_copy_of_its_own_runs_without_a_collective():
    """jaxnav train's chunk on 2 devices: the periodic target copy is a conditional,
    and deciding it needs no communication between the devices."""
    text = subprocess.run(
        [sys.executable, "-c", _COMPILED, "seeds=2", *TINY],
        check=True,
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2"),
    ).stdout
    assert "num_partitions=2" in text and " conditional(" in text
    assert not any(op in text for op in ("all-reduce(", "all-gather(", "collective-permute("))


@pytest.mark.slow
def test_sharded_run_matches_single_device_and_pads_odd_seed_counts(tmp_path):
    one = _run(tmp_path, "one", 1, seeds=3)
    four = _run(tmp_path, "four", 4, seeds=3)  # 6 runs on 4 devices: padded to 8
    _close(one, four)
    assert json.loads((four / "summary.json").read_text())["devices"] == 4
    probe = subprocess.run(
        [sys.executable, "-c", _PROBE, "seeds=3", *TINY],
        check=True,
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=4"),
    )
    n_dev, padded, spread, rows = map(int, probe.stdout.split())
    assert (n_dev, padded, spread, rows) == (4, 8, 4, 8)  # really spread over 4 devices


@pytest.mark.slow
def test_two_processes_write_one_run_directory_equal_to_one_process_with_two_devices(tmp_path):
    """jax.distributed on localhost: 2 processes x 1 CPU device == 1 process x 2 devices."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    args = [sys.executable, "-m", "jaxnav.commands.train", "seeds=2", *TINY, "--quiet"]
    procs = []
    for pid in range(2):
        env = dict(
            os.environ,
            JAX_COORDINATOR_ADDRESS=f"127.0.0.1:{port}",
            JAX_NUM_PROCESSES="2",
            JAX_PROCESS_ID=str(pid),
            XLA_FLAGS="--xla_force_host_platform_device_count=1",
        )
        procs.append(
            subprocess.Popen(
                args + ["--out", str(tmp_path / "multi")],
                cwd=ROOT,
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        )
    assert [p.wait(timeout=300) for p in procs] == [0, 0]
    summary = json.loads((tmp_path / "multi" / "summary.json").read_text())
    assert (summary["processes"], summary["devices"]) == (2, 2)
    single = tmp_path / "single"
    subprocess.run(
        args + ["--out", str(single)],
        check=True,
        cwd=ROOT,
        capture_output=True,
        env=dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2"),
    )
    assert (tmp_path / "multi" / "metrics.csv").read_bytes() == (
        single / "metrics.csv"
    ).read_bytes()
    a, b = np.load(tmp_path / "multi" / "params.npz"), np.load(single / "params.npz")
    assert all(np.array_equal(a[k], b[k]) for k in a.files)
