"""The training command end to end: learning, determinism, resume, bad input."""

import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav.agent.trainer import make_train, run_inputs
from jaxnav.commands.train import main
from jaxnav.core import rundir
from jaxnav.core.config import load_config
from jaxnav.env import from_config
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.run import launch
from jaxnav.run.checkpoint import chunk_slots
from jaxnav.run.launch import train_new
from jaxnav.run.training import Run

ROOT = Path(__file__).resolve().parent.parent
TINY = ["seeds=2", "episodes=8", "env.max_steps=100", "run.chunk_steps=100", "dqn.batch_size=16"]
# A chunk of chunk_steps and a checkpoint after each, as the kills and resumes here expect.
TINY += ["run.chunk_s=0", "run.checkpoint_s=0"]


def _metrics(run_dir):
    with open(run_dir / "metrics.csv") as f:
        return list(csv.DictReader(f))


def _params(run_dir):
    with np.load(run_dir / "params.npz") as d:
        return {k: d[k] for k in d.files}


def _random_policy_return(cfg, episodes=64):
    """Mean episode return of uniformly random actions in the config's environment."""
    env, params = from_config(cfg)

    def episode(key):
        k0, key = jax.random.split(key)
        obs, st = env.reset(k0, params)

        def body(carry, _):
            st, key, ret, alive = carry
            key, ka, ks = jax.random.split(key, 3)
            a = jax.random.randint(ka, (), 0, env.num_actions)
            _, st, r, term, trunc, _ = env.step(ks, st, a, params)
            ret = ret + jnp.where(alive, r, 0.0)
            return (st, key, ret, alive & ~(term | trunc)), None

        (_, _, ret, _), _ = jax.lax.scan(body, (st, key, 0.0, True), None, cfg.env.max_steps)
        return ret

    keys = jax.random.split(jax.random.PRNGKey(123), episodes)
    return float(jnp.mean(jax.jit(jax.vmap(episode))(keys)))


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    cfg = load_config(str(ROOT / "configs" / "smoke.yaml"))
    out = tmp_path_factory.mktemp("smoke") / "run"
    train_new(cfg, out, quiet=True)
    return cfg, out


@pytest.mark.slow
def test_smoke_run_writes_the_run_directory(smoke_run):
    cfg, out = smoke_run
    for name in ("config.yaml", "metrics.csv", "explore.csv", "params.npz", "summary.json"):
        assert (out / name).is_file(), name
    assert not (out / "checkpoints").exists()  # a finished run needs no checkpoint
    rows = _metrics(out)
    assert list(rows[0]) == [
        "strategy",
        "seed",
        "episode",
        "return",
        "length",
        "goals",
        "collided",
        "explore",
    ]
    assert len(rows) == cfg.n_runs * cfg.episodes
    assert {(r["strategy"], r["seed"]) for r in rows} == {
        (s, str(k)) for s in cfg.strategies for k in range(cfg.seeds)
    }
    assert set(_params(out)) >= {
        "ebe/seed1/params/Dense_2/kernel",
        "epsilon_greedy/seed0/params/Dense_0/bias",
    }
    assert load_config(str(out / "config.yaml")) == cfg  # the snapshot resolves to the same config
    summary = json.loads((out / "summary.json").read_text())
    assert summary["env_steps"] == sum(int(r["length"]) for r in rows)
    # runs end at different steps, and the finished ones wait in lockstep
    assert 0.5 < summary["lockstep_useful"] < 1
    assert 0 < summary["compile_s"] < summary["startup_s"]


@pytest.mark.slow  # 8 s on 2 cores
def test_smoke_run_beats_a_random_policy(smoke_run):
    cfg, out = smoke_run
    rows = _metrics(out)
    random_return = _random_policy_return(cfg)
    for strategy in cfg.strategies:
        last = [
            float(r["return"])
            for r in rows
            if r["strategy"] == strategy and int(r["episode"]) >= cfg.episodes - 10
        ]
        assert np.mean(last) > random_return + 100, (strategy, np.mean(last), random_return)


@pytest.mark.slow
def test_same_seed_same_numbers_and_seeds_differ(smoke_run, tmp_path):
    cfg, out = smoke_run
    train_new(cfg, tmp_path / "again", quiet=True)
    assert (tmp_path / "again" / "metrics.csv").read_bytes() == (out / "metrics.csv").read_bytes()
    a, b = _params(out), _params(tmp_path / "again")
    assert all(np.array_equal(a[k], b[k]) for k in a)
    # vmapped seeds are really different runs
    assert not np.array_equal(
        a["ebe/seed0/params/Dense_0/kernel"], a["ebe/seed1/params/Dense_0/kernel"]
    )
    rows = _metrics(out)
    r0 = [r["return"] for r in rows if r["strategy"] == "ebe" and r["seed"] == "0"]
    r1 = [r["return"] for r in rows if r["strategy"] == "ebe" and r["seed"] == "1"]
    assert r0 != r1


@pytest.mark.slow
def test_compiled_train_function_matches_the_host_loop(tmp_path):
    cfg = load_config(None, TINY)
    train_new(cfg, tmp_path / "run", quiet=True)
    final = jax.jit(jax.vmap(make_train(cfg)))(*run_inputs(cfg))
    assert np.all(np.asarray(final.episode) == cfg.episodes)
    p = _params(tmp_path / "run")
    k = np.asarray(final.params["params"]["Dense_2"]["kernel"])
    np.testing.assert_array_equal(k[0], p["ebe/seed0/params/Dense_2/kernel"])
    np.testing.assert_array_equal(k[3], p["epsilon_greedy/seed1/params/Dense_2/kernel"])


@pytest.mark.slow
def test_resume_after_sigkill_gives_identical_results(tmp_path):
    ref, killed = tmp_path / "ref", tmp_path / "killed"
    cmd = [sys.executable, "-m", "jaxnav.commands.train", *TINY, "--quiet"]
    subprocess.run(cmd + ["--out", str(ref)], check=True, cwd=ROOT)
    proc = subprocess.Popen(cmd + ["--out", str(killed)], cwd=ROOT)
    ckpt = killed / "checkpoints" / "last.npz"
    deadline = time.time() + 120
    while not ckpt.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not (killed / "params.npz").exists(), "the run finished before it could be killed"
    subprocess.run(
        [sys.executable, "-m", "jaxnav.commands.train", "--resume", str(killed), "--quiet"],
        check=True,
        cwd=ROOT,
    )
    assert (killed / "metrics.csv").read_bytes() == (ref / "metrics.csv").read_bytes()
    assert (killed / "explore.csv").read_bytes() == (ref / "explore.csv").read_bytes()
    a, b = _params(ref), _params(killed)
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    share = [json.loads((d / "summary.json").read_text())["lockstep_useful"] for d in (ref, killed)]
    assert share[0] == share[1]  # the lockstep count is checkpointed with the state


@pytest.mark.parametrize(
    "argv, message",
    [
        (["dqn.gama=0.5"], "unknown key 'dqn.gama'"),
        (["dqn.gamma=high"], "dqn.gamma must be a number"),
        (["seeds=2.5"], "seeds must be an integer"),
        (["strategies=[ebe, softmax]"], "unknown strategy 'softmax'"),
        (["env.maze=nowhere"], "unknown maze 'nowhere'"),
        (["env.motion_pace=[0,1]"], "maze 'square4' has none"),
        (["--resume", "/nonexistent/run"], "does not exist"),
        (["/nonexistent/config.yaml"], "no such file"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, message, capsys, tmp_path):
    if argv[0] != "--resume":
        argv = argv + ["--out", str(tmp_path / "run")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "run").exists()


def test_broken_maze_file_is_rejected_before_anything_is_written(tmp_path, capsys):
    maze = tmp_path / "bad.yaml"
    maze.write_text("outline: [[0, 0], [1, 0], [1, 1]]\n")  # not closed
    assert main([f"env.maze={maze}", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert "not closed" in err and not (tmp_path / "run").exists()


@pytest.mark.slow  # its fixture is a slow test's
def test_existing_run_directory_is_not_overwritten(smoke_run, capsys):
    _, out = smoke_run
    before = (out / "metrics.csv").read_bytes()
    assert main(["configs/smoke.yaml", "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert (out / "metrics.csv").read_bytes() == before


@pytest.mark.slow
def test_three_strategies_train_in_one_program_and_the_command_draws_the_curves(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["configs/smoke.yaml", "seeds=1", "episodes=3", "env.max_steps=30", "--quiet"]
    argv += ["strategies=[ebe, boltzmann, epsilon_greedy]", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    figure = out / "plots" / "training_curves.png"
    assert f"training curves: {figure}" in printed
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = _metrics(out)
    assert [r["strategy"] for r in rows if r["episode"] == "0"] == [
        "ebe",
        "boltzmann",
        "epsilon_greedy",
    ]
    for r in rows:  # each strategy's exploration is a probability
        assert 0.0 <= float(r["explore"]) <= 1.0


def test_tensorboard_without_its_writer_is_one_line_before_anything_is_written(
    tmp_path, capsys, monkeypatch
):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "tensorboardX" else real(name, *a),
    )
    assert main(["configs/smoke.yaml", "run.tensorboard=true", "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip()
    assert "run.tensorboard needs tensorboardX" in err and "\n" not in err
    assert not (tmp_path / "r").exists()


@pytest.mark.slow
@pytest.mark.parametrize(  # 150: the ring wraps in a chunk; prioritised: its sum tree too
    "replay", ["dqn.buffer_size=1000000", "dqn.buffer_size=150", "dqn.prioritised=true"]
)
def test_a_checkpoint_restores_the_whole_state_from_its_row_segments(tmp_path, replay):
    cfg = load_config(None, [*TINY, "episodes=3", replay])
    out = tmp_path / "run"
    run = Run(cfg, out, quiet=True)
    rundir.create(out)
    ts = run.fresh_state()
    for _ in range(3):  # three chunks of 100 steps, one segment each
        before = run.shard.get(ts.step).copy()
        ts, _ = run.chunk(ts, np.int32(run.steps_needed(ts)))
        slots = chunk_slots(before, run.shard.get(ts.step), cfg.buffer_capacity)
        run.save(ts, [], [], slots)
    live = run.shard.get(ts)
    again = Run(cfg, out, quiet=True)
    restored = again.shard.get(again.restored_state())
    assert again.segments == 3 and len(list((out / "checkpoints").glob("rows-*.npz"))) == 3
    # Everything but the ring of finished episodes, which the host has copied to
    # metrics.csv and the checkpoint leaves out (restored as zeros).
    flat = jax.tree_util.tree_flatten_with_path
    for (path, a), (_, b) in zip(flat(live)[0], flat(restored)[0], strict=True):
        ring = jax.tree_util.keystr(path).startswith(".metrics.ep_")
        np.testing.assert_array_equal(np.zeros_like(a) if ring else a, b)


@pytest.mark.slow
def test_a_finished_run_keeps_no_checkpoints_and_evaluates(smoke_run, tmp_path):
    _, out = smoke_run
    assert not list(out.rglob("rows-*.npz")) and not list(out.rglob("*.npz.tmp*"))
    assert rundir.finished(out)
    evaluated = evaluate_to_dir(out, ["square2"], 1, tmp_path / "eval")
    assert (evaluated / "results.csv").is_file()


@pytest.mark.slow
def test_keep_checkpoints_and_resume_of_a_finished_run(tmp_path, capsys):
    out = tmp_path / "run"
    assert main([*TINY, "episodes=3", "--keep-checkpoints", "--quiet", "--out", str(out)]) == 0
    segments = sorted(p.name for p in (out / "checkpoints").glob("rows-*.npz"))
    assert segments and (out / rundir.CHECKPOINT).is_file() and not rundir.finished(out)
    params, summary = (out / rundir.PARAMS).read_bytes(), (out / rundir.SUMMARY).read_bytes()
    # resumed, nothing is left to train: the same parameters, and the checkpoints go
    assert main(["--resume", str(out), "--quiet"]) == 0
    assert (out / rundir.PARAMS).read_bytes() == params and rundir.finished(out)
    assert not (out / "checkpoints").exists()
    # again, without checkpoints: its summary, nothing written
    summary = (out / rundir.SUMMARY).read_bytes()
    capsys.readouterr()
    assert main(["--resume", str(out), "--quiet"]) == 0
    assert f"results in {out}/" in capsys.readouterr().out
    assert (out / rundir.PARAMS).read_bytes() == params
    assert (out / rundir.SUMMARY).read_bytes() == summary


@pytest.mark.parametrize("existed", [False, True])
def test_interrupted_before_the_first_checkpoint_leaves_nothing_of_its_own(
    tmp_path, capsys, monkeypatch, existed
):
    """Ctrl-C where no handler ends the process (a KeyboardInterrupt): what the command
    made goes, never a directory that was there before; one line, 130."""

    def interrupted(self, ts):
        raise KeyboardInterrupt

    monkeypatch.setattr(Run, "train", interrupted)
    out = tmp_path / "run"
    if existed:
        out.mkdir()
    assert main([*TINY, "--quiet", "--out", str(out)]) == 130
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    if existed:
        assert err.endswith(f"{out} was left empty") and out.is_dir() and not any(out.iterdir())
    else:
        assert err.endswith(f"{out} was removed") and not out.exists()
    assert launch.interrupted_text().endswith(("was left empty", "was removed"))
