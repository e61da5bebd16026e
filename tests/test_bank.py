"""A bank of drawn layouts (env.maze_bank): each layout is the family's own draw, the
episodes pick only from the bank, at random, and the layouts they play are distributed
as the layouts drawn one by one; training runs with a bank are deterministic and keep
it in their checkpoints."""

from __future__ import annotations

import csv
import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.env import bank_key
from jaxnav.run.launch import train_new
from jaxnav.world import lazy
from jaxnav.world.state import step_keys

GRID = {"generator": "grid", "grid_rows": 3, "grid_cols": 3, "min_path_cells": 2}


def _banked(n, **kw):
    env, params = jaxnav.make(**{**GRID, **kw})
    env = dataclasses.replace(env, maze_bank=n)
    return env, env.with_bank(params, jax.random.PRNGKey(7))


def _rows(tree, i):
    return jax.tree.map(lambda x: np.asarray(x[i]), tree)


@pytest.mark.slow  # 7 s on 2 cores
def test_each_layout_of_a_bank_is_the_familys_draw_from_its_key():
    env, params = _banked(5)
    keys = jax.random.split(jax.random.PRNGKey(7), 5)
    for i in (0, 3):
        want = env._draw(keys[i])
        for a, b in zip(jax.tree.leaves(_rows(params.bank, i)), jax.tree.leaves(want)):
            np.testing.assert_array_equal(a, np.asarray(b))
    # Without the setting, or with a fixed maze, there is no bank.
    plain, p0 = jaxnav.make(**GRID)
    assert plain.with_bank(p0, jax.random.PRNGKey(0)).bank is None


@pytest.mark.slow  # 7 s on 2 cores
def test_every_episode_plays_a_layout_of_the_bank_and_all_of_them_come_up():
    env, params = _banked(3, new_maze_every=1)
    bank = [np.asarray(s).tobytes() for s in params.bank[0].segments]
    goals = np.asarray(params.bank[1])
    n = 64
    _, st = jax.vmap(env.reset, in_axes=(0, None))(
        jax.random.split(jax.random.PRNGKey(1), n), params
    )
    restart = jax.jit(jax.vmap(env.restart, in_axes=(0, 0, None)))
    seen = []
    for k in range(4):
        for i in range(n):
            layout = bank.index(np.asarray(st.maze.segments[i]).tobytes())  # in the bank
            np.testing.assert_array_equal(np.asarray(st.goal[i]), goals[layout])
            np.testing.assert_allclose(st.pos[i], st.maze.start[i, :2], atol=1e-6)
            seen.append(layout)
        _, st = restart(jax.random.split(jax.random.PRNGKey(10 + k), n), st, params)
    counts = np.bincount(seen, minlength=3)
    assert counts.min() > 0.2 * len(seen)  # picked at random, each about a third


@pytest.mark.slow  # 5 s on 2 cores
def test_a_bank_of_one_layout_is_the_fixed_maze_case():
    env, params = _banked(1, new_maze_every=1)
    keys = jax.random.split(jax.random.PRNGKey(2), 8)
    obs, st = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    assert (np.asarray(st.maze.segments) == np.asarray(params.bank[0].segments[0])).all()
    assert np.ptp(np.asarray(st.goal), axis=0).max() == 0  # one start, one goal
    assert np.ptp(np.asarray(obs), axis=0).max() == 0  # so one first observation


@pytest.mark.slow
def test_the_layouts_episodes_play_are_distributed_as_layouts_drawn_one_by_one():
    """Over thousands of layouts: the standing walls and the start-goal distance of the
    layouts picked from a bank have the distribution of the layouts drawn on demand
    (two-sample Kolmogorov-Smirnov distance under its 1% critical value)."""
    n = 2048
    env, params = _banked(4096, new_maze_every=1, split="test")
    plain, p0 = jaxnav.make(**GRID, split="test")
    reset = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))
    _, banked = reset(jax.random.split(jax.random.PRNGKey(3), n), params)
    _, drawn = jax.jit(jax.vmap(plain.reset, in_axes=(0, None)))(
        jax.random.split(jax.random.PRNGKey(4), n), p0
    )

    def stats(st):
        walls = np.asarray(st.maze.segment_mask).sum(1)
        gap = np.linalg.norm(np.asarray(st.goal) - np.asarray(st.maze.start[:, :2]), axis=1)
        return walls, gap

    critical = 1.63 * np.sqrt(2 / n)  # alpha = 0.01
    for a, b in zip(stats(banked), stats(drawn)):
        grid = np.union1d(a, b)
        cdf_a = np.searchsorted(np.sort(a), grid, side="right") / n
        cdf_b = np.searchsorted(np.sort(b), grid, side="right") / n
        assert np.abs(cdf_a - cdf_b).max() < critical
    # The test split's layouts only: the bank was drawn from the env's split.
    from jaxnav.world import generators as gen

    open_ = ~np.asarray(banked.maze.segment_mask[:, : env.family.n_walls])
    assert (np.asarray(jax.vmap(gen.layout_split)(jnp.asarray(open_))) == 1).all()


@pytest.mark.slow
@pytest.mark.parametrize("bank", [0, 4])
def test_a_drawn_step_restarts_as_computing_every_restart_would(bank):
    """NavEnv.step computes drawn mazes' restarts only where an episode ended: the
    same states as the restart computed for every environment and kept where done."""
    env, params = _banked(bank, new_maze_every=2) if bank else jaxnav.make(**GRID)
    n = 40
    _, st = jax.vmap(env.reset, in_axes=(0, None))(
        jax.random.split(jax.random.PRNGKey(5), n), params
    )
    step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))

    def eager(k, s, a):
        o, s2, _, te, tr, _ = env.step_env(k, s, a, params)
        o_re, s_re = env.restart(step_keys(k)[1], s2, params)
        done = te | tr
        return jnp.where(done, o_re, o), jax.tree.map(lambda x, y: jnp.where(done, x, y), s_re, s2)

    eager = jax.jit(jax.vmap(eager))
    ended = 0
    for t in range(30):
        ks = jax.random.split(jax.random.PRNGKey(100 + t), n)
        actions = jax.random.randint(jax.random.PRNGKey(t), (n,), 0, 5)
        obs, new, _, term, trunc, _ = step(ks, st, actions, params)
        want_obs, want = eager(ks, st, actions)
        np.testing.assert_allclose(np.asarray(obs), np.asarray(want_obs), atol=1e-5)
        for a, b in zip(jax.tree.leaves(new), jax.tree.leaves(want)):
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), atol=1e-5)
        ended += int(jnp.sum(term | trunc))
        st = new
    assert ended > n // 2  # many episodes ended on the way


@pytest.mark.slow  # 4 s on 2 cores
def test_draw_where_passes_shared_inputs_whole_and_equals_where():
    env, params = jaxnav.make(**GRID)
    n = 6
    keys = jax.random.split(jax.random.PRNGKey(3), n)
    fresh = jnp.asarray([True, False, True, False, False, True])
    old = jax.vmap(env.draw_maze)(jax.random.split(jax.random.PRNGKey(9), n))

    def draw(k, p):  # uses the shared params: the goal moved by the template's start
        maze, goal = env.draw_maze(k)
        return maze, goal + p.maze.start[:2]

    got = jax.jit(jax.vmap(lambda f, k, o: lazy.draw_where(draw, f, k, o, 2, params)))(
        fresh, keys, old
    )
    want = jax.vmap(lambda f, k, o: lazy._where(f, draw(k, params), o))(fresh, keys, old)
    for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_a_train_bank_and_a_test_bank_share_no_layout():
    """2048 layouts of 3 x 3 grids (a few hundred distinct perfect mazes exist, so each
    bank repeats many) in a train bank and a test bank: no closed-wall set in both."""
    walls = {}
    for split in ("train", "test"):
        env, params = _banked(2048, split=split)
        closed = np.asarray(params.bank[0].segment_mask)
        walls[split] = {row.tobytes() for row in closed}
    assert len(walls["train"]) > 50 and len(walls["test"]) > 50
    assert not walls["train"] & walls["test"]


@pytest.mark.slow  # 4 s on 2 cores
def test_a_bank_is_redrawn_exactly_where_a_runs_steps_pass_a_multiple_of_the_refresh():
    """Three runs, vmapped as the trainers run them: the two whose steps pass a
    multiple of 10 get the bank drawn from their key's refresh key, the third keeps its
    own; with no refresh set nothing changes."""
    env, params = _banked(4)
    env = dataclasses.replace(env, maze_bank_refresh=10)
    keys = jax.random.split(jax.random.PRNGKey(3), 3)
    banks = jax.vmap(env.draw_bank)(keys)
    before, after = jnp.asarray([9, 10, 19]), jnp.asarray([10, 11, 20])
    got = jax.jit(jax.vmap(env.refreshed_bank))(banks, keys, before, after)
    for i, due in enumerate((True, False, True)):
        salt = jax.random.fold_in(keys[i], 0x72656672)
        want = env.draw_bank(salt) if due else _rows(banks, i)
        for a, b in zip(jax.tree.leaves(_rows(got, i)), jax.tree.leaves(want), strict=True):
            np.testing.assert_array_equal(a, np.asarray(b))
    plain = dataclasses.replace(env, maze_bank_refresh=0)
    assert plain.refreshed_bank(banks, keys, before, after) is banks


@pytest.mark.slow  # 7 s on 2 cores
def test_a_training_run_plays_a_new_bank_after_a_refresh():
    """A DQN run refreshing every 40 env steps: after one chunk of 80 steps its bank is
    another (and one with no refresh keeps the bank it began with)."""
    from jaxnav.run.training import Run

    banks = {}
    for refresh in (0, 40):
        items = ["env.generator=grid", "env.maze_bank=16", f"env.maze_bank_refresh={refresh}"]
        items += ["seeds=1", "strategies=[ebe]", "episodes=4", "env.max_steps=40"]
        items += ["run.chunk_steps=80", "run.test_mazes=[]"]
        run = Run(load_config("smoke", items), None, quiet=True)
        ts = run.fresh_state()
        first = np.asarray(jax.tree.leaves(ts.bank)[0])
        ts, _ = run.chunk(ts, np.int32(80))
        banks[refresh] = (first, np.asarray(jax.tree.leaves(ts.bank)[0]))
    np.testing.assert_array_equal(*banks[0])
    assert not np.array_equal(*banks[40])


def test_a_bank_needs_drawn_mazes_and_a_non_negative_size():
    with pytest.raises(ConfigError, match="env.maze_bank .*needs drawn mazes"):
        load_config("smoke", ["env.maze_bank=16"])
    with pytest.raises(ConfigError, match="env.maze_bank"):
        load_config("grid4", ["env.maze_bank=-1"])
    with pytest.raises(ConfigError, match="env.maze_bank_refresh draws new banks: it needs"):
        load_config("grid4", ["env.maze_bank_refresh=1000"])
    with pytest.raises(ValueError, match="maze_bank"):
        jaxnav.make("square4", maze_bank=4)
    assert load_config("grid4", ["env.maze_bank=64"]).env.maze_bank == 64


def test_the_bank_key_leaves_the_runs_other_keys_alone():
    key = jax.random.PRNGKey(0)
    assert not np.array_equal(np.asarray(bank_key(key)), np.asarray(key))
    assert all(
        not np.array_equal(np.asarray(bank_key(key)), np.asarray(k))
        for k in jax.random.split(key, 3)
    )


@pytest.mark.slow
@pytest.mark.parametrize("refresh", [100, 0], ids=["renewed", "drawn-once"])
@pytest.mark.parametrize("agent", ["dqn", "pqn"])
def test_a_run_with_a_bank_trains_the_same_twice_and_resumes_the_same(agent, refresh, tmp_path):
    """A bank renewed while training is stored in the checkpoint; one drawn once at the
    start is left out and drawn again on resume: either way the resumed run ends as the
    uninterrupted one."""
    from _cut_run import cut_after_one_chunk, restores_and_resumes

    from jaxnav.core import rundir

    items = ["env.generator=grid", "env.maze_bank=32", "seeds=2", "strategies=[ebe]"]
    items += [f"env.maze_bank_refresh={refresh}"]  # the resumed run passes refreshes too
    items += ["env.broad_phase=lattice"]  # tested on a fixed maze too, which has none
    if agent == "pqn":
        items += ["pqn.num_envs=8", "pqn.rollout=8", "pqn.minibatches=2", "episodes=null"]
        items += ["total_steps=1024", "run.chunk_steps=512", "env.max_steps=40"]
    else:
        items += ["episodes=6", "env.max_steps=40", "run.chunk_steps=80"]
    cfg = load_config("pqn" if agent == "pqn" else "smoke", items + ["run.test_mazes=[]"])
    a, b = tmp_path / "a", tmp_path / "b"
    train_new(cfg, a, quiet=True)
    train_new(cfg, b, quiet=True)
    for name in (rundir.METRICS, rundir.PARAMS):
        assert (a / name).read_bytes() == (b / name).read_bytes()
    with open(a / rundir.METRICS) as f:
        assert len(list(csv.DictReader(f))) > 0
    # One chunk, a checkpoint (the bank is part of the state), "killed", resumed: the
    # same numbers as the uninterrupted run.
    c = tmp_path / "c"
    _, ts = cut_after_one_chunk(cfg, c)
    assert jax.tree.leaves(ts.bank)[0].shape[:2] == (cfg.n_runs, 32)
    stored = rundir.read_npz(c / rundir.CHECKPOINT, "checkpoint")
    assert any(k.startswith("state.bank") for k in stored) == bool(refresh)
    restores_and_resumes(cfg, c, ts, "bank", a)
    if agent == "dqn":  # tested as any drawn-maze run: on a fixed maze and drawn layouts
        from jaxnav.experiments.evaluation import evaluate_to_dir

        with open(evaluate_to_dir(a, ["square4"], 1, references=()) / "results.csv") as f:
            mazes = {r["maze"] for r in csv.DictReader(f)}
        assert mazes == {"square4", "grid:train", "grid:test"}


@pytest.mark.slow  # 3 s on 2 cores
def test_train_says_the_banks_memory_and_refuses_one_larger_than_the_machine(tmp_path):
    import subprocess
    import sys

    out = tmp_path / "r"
    big = ["jaxnav.commands.train", "drive_cylinders", "env.maze_bank=10000000", "--out", str(out)]
    run = subprocess.run([sys.executable, "-m", *big], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2, run.stderr
    lines = run.stderr.splitlines()
    assert lines[0].startswith("maze bank: 10000000 layouts of 12.7 KiB"), lines
    assert lines[-1].startswith("jaxnav train: error: this run needs about ")
    assert "of replay and maze-bank memory" in lines[-1] and len(lines) == 2
    assert not out.exists()
    # The per-layout figure is the layout's own arrays.
    env, _ = jaxnav.make(generator="cylinders")
    draw = env._draw(jax.random.PRNGKey(0))
    assert env.layout_bytes() == sum(np.asarray(x).nbytes for x in jax.tree.leaves(draw))
