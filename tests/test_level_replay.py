"""Level replay (pqn.level_replay): each layout's record of attempts against a plain
NumPy count, the top layouts and their weights by hand, the environment picking
layouts at those weights over many draws and recording which one it plays, the
trainer counting every attempt that ended, and the settings that need it refused
without it."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
from jaxnav import pqn
from jaxnav.agent import levels
from jaxnav.agent.hyper import hyper as hyper_of
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError

GRID = {"generator": "grid", "grid_rows": 3, "grid_cols": 3, "min_path_cells": 2}


def _np_record(tries, wins, layout, ended, won, fade):
    """The decayed counts by a plain loop over the attempts."""
    tries, wins = tries * fade, wins * fade
    for i, e, w in zip(layout.ravel(), ended.ravel(), won.ravel()):
        if e:
            tries[i] += 1.0
            wins[i] += 1.0 if w else 0.0
    return tries, wins


def test_record_counts_each_ended_attempt_in_its_layout_and_decays_the_rest():
    rng = np.random.default_rng(0)
    n = 12
    tries = rng.uniform(0, 3, n).astype(np.float32)
    wins = (tries * rng.uniform(0, 1, n)).astype(np.float32)
    layout = rng.integers(0, n, (6, 4)).astype(np.int32)  # repeats: added, not overwritten
    ended = rng.uniform(size=(6, 4)) < 0.5
    won = rng.uniform(size=(6, 4)) < 0.5
    start = levels.Levels(jnp.asarray(tries), jnp.asarray(wins), levels.uniform_cdf(n))
    got = levels.record(
        start, jnp.asarray(layout), jnp.asarray(ended), jnp.asarray(won), 0.9, 0.5, 3,
        jax.random.PRNGKey(0),
    )  # fmt: skip
    want_t, want_w = _np_record(tries.astype(np.float64), wins.astype(np.float64), layout,
                                ended, won, 0.9)  # fmt: skip
    np.testing.assert_allclose(np.asarray(got.tries), want_t, rtol=1e-5)
    np.testing.assert_allclose(np.asarray(got.wins), want_w, rtol=1e-5)
    # the cdf rises to 1 by each layout's weight
    cdf = np.asarray(got.cdf)
    assert cdf[-1] == pytest.approx(1.0) and np.all(np.diff(cdf) > 0)


def test_learnability_is_p_times_one_less_p_and_zero_without_attempts():
    lv = levels.Levels(
        tries=jnp.asarray([0.0, 4.0, 4.0, 4.0, 2.0]),
        wins=jnp.asarray([0.0, 0.0, 2.0, 4.0, 0.5]),
        cdf=levels.uniform_cdf(5),
    )
    np.testing.assert_allclose(
        np.asarray(levels.learnability(lv)), [0.0, 0.0, 0.25, 0.0, 0.25 * 0.75], atol=1e-7
    )


def test_weights_put_the_replay_share_on_the_top_layouts_and_the_rest_on_all():
    score = jnp.asarray([0.1, 0.25, 0.0, 0.2, 0.05, 0.24])
    w = np.asarray(levels.weights(score, 0.6, 2, jax.random.PRNGKey(3)))
    rest = 0.4 / 6
    np.testing.assert_allclose(w, [rest, rest + 0.3, rest, rest, rest, rest + 0.3], rtol=1e-6)
    assert w.sum() == pytest.approx(1.0)
    # ties at 0 are broken at random: the top of an all-zero score is not the first K
    picks = {
        tuple(np.nonzero(np.asarray(levels.weights(jnp.zeros(64), 1.0, 4, k)))[0])
        for k in jax.random.split(jax.random.PRNGKey(0), 8)
    }
    assert len(picks) > 1 and (0, 1, 2, 3) not in picks


def _banked(n):
    env, params = jaxnav.make(**GRID)
    env = dataclasses.replace(env, maze_bank=n)
    return env, env.with_bank(params, jax.random.PRNGKey(7))


def test_the_environment_picks_layouts_at_the_banks_weights_and_records_which():
    env, params = _banked(4)
    w = np.asarray([0.1, 0.0, 0.6, 0.3], np.float32)
    params = params.replace(bank_cdf=jnp.asarray(np.cumsum(w)))
    keys = jax.random.split(jax.random.PRNGKey(1), 4000)
    _, states = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
    picked = np.asarray(states.layout)
    freq = np.bincount(picked, minlength=4) / len(picked)
    # binomial standard error at 4000 draws is under 0.008: 4 of them
    np.testing.assert_allclose(freq, w, atol=0.032)
    # the state's maze is the bank's layout of that index
    segs = np.asarray(params.bank[0].segments)
    np.testing.assert_array_equal(np.asarray(states.maze.segments), segs[picked])
    # a restart in a fresh layout records the new index; steps keep it
    step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
    st = jax.tree.map(lambda x: x[:64], states)
    seen_change = False
    for t in range(40):
        ks = jax.random.split(jax.random.PRNGKey(100 + t), 64)
        _, new, _, term, trunc, _ = step(ks, st, jnp.full(64, 2), params)
        done = np.asarray(term | trunc)
        kept = np.asarray(new.layout)[~done] == np.asarray(st.layout)[~done]
        assert kept.all()
        now = np.asarray(new.layout)
        np.testing.assert_array_equal(np.asarray(new.maze.segments), segs[now])
        seen_change |= bool(np.any(now[done] != np.asarray(st.layout)[done]))
        st = new
    assert seen_change
    # without weights no index is kept: the state is as before
    _, plain = jaxnav.make(**GRID)[0].reset(jax.random.PRNGKey(0), jaxnav.make(**GRID)[1])
    assert plain.layout is None


TINY = [
    "agent=pqn",
    "seeds=1",
    "episodes=null",
    "total_steps=512",
    "env.generator=grid",
    "env.grid_rows=3",
    "env.grid_cols=3",
    "env.maze_bank=16",
    "env.max_steps=20",
    "pqn.num_envs=8",
    "pqn.rollout=16",
    "pqn.minibatches=2",
    "run.chunk_steps=128",
]


def test_an_update_counts_every_attempt_that_ended_in_its_layout():
    cfg = load_config(None, [*TINY, "pqn.level_replay=0.5", "pqn.level_top=0.25",
                             "pqn.level_halflife=1000000000"])  # fmt: skip
    trainer = pqn.make_trainer(cfg)
    hyper = hyper_of(cfg)
    ts = trainer.init(jax.random.PRNGKey(0), jnp.asarray(0), hyper)
    assert ts.levels is not None and float(ts.levels.tries.sum()) == 0.0
    parts = pqn.make_rollouts(cfg)
    # the same rollout the update plays (its key is the update's first split)
    _, k_roll, _ = jax.random.split(ts.key, 3)
    _, ro = parts.play(ts, jnp.asarray(True), k_roll)
    ended = np.asarray(ro.reached | ro.terminated | ro.truncated)
    won = np.asarray(ro.reached) & ended
    want_t, want_w = _np_record(np.zeros(16), np.zeros(16), np.asarray(ro.layout), ended, won, 1.0)
    after, _ = jax.jit(trainer.step)(ts, None)
    np.testing.assert_allclose(np.asarray(after.levels.tries), want_t, atol=1e-3)
    np.testing.assert_allclose(np.asarray(after.levels.wins), want_w, atol=1e-3)
    assert ended.sum() > 0
    # the weights were renewed: 4 layouts carry the replay share
    w = np.diff(np.concatenate([[0.0], np.asarray(after.levels.cdf)]))
    assert np.sum(w > 0.5 / 16 + 1e-4) == 4


@pytest.mark.parametrize(
    ("over", "says"),
    [
        (["pqn.level_top=0.2"], "pqn.level_top is a level replay setting"),
        (["pqn.level_halflife=10"], "pqn.level_halflife is a level replay setting"),
        (["pqn.level_replay=0.5", "env.maze_bank=0"], "it needs drawn mazes"),
        (["pqn.level_replay=0.5", "env.maze_bank_refresh=256"], "env.maze_bank_refresh 0"),
        (["pqn.level_replay=0.5", "pqn.level_top=0.01"], "is no layout"),
        (["pqn.level_replay=1.5"], "must be in [0, 1]"),
        (["pqn.level_replay=0.5", "agent=dqn"], "needs agent pqn"),
    ],
)
def test_level_replay_settings_are_refused_where_they_would_do_nothing(over, says):
    with pytest.raises(ConfigError, match=None) as err:
        load_config(None, [*TINY, *over])
    assert says in str(err.value)


@pytest.mark.slow  # 25 s on 2 cores
def test_a_run_with_level_replay_trains_the_same_twice_and_resumes_the_same(tmp_path):
    """The layouts' record is part of a checkpoint (the bank, drawn once, is not): a run
    cut after its first chunk and resumed ends as the uninterrupted one, byte for byte."""
    import numpy as np
    from _cut_run import cut_after_one_chunk, restores_and_resumes

    from jaxnav.core import rundir
    from jaxnav.run.launch import train_new

    items = [*TINY, "seeds=2", "total_steps=1024", "run.chunk_steps=512", "pqn.level_replay=0.5"]
    cfg = load_config(None, [*items, "pqn.level_top=0.25", "run.test_mazes=[]"])
    a, b = tmp_path / "a", tmp_path / "b"
    train_new(cfg, a, quiet=True)
    train_new(cfg, b, quiet=True)
    for name in (rundir.METRICS, rundir.PARAMS):
        assert (a / name).read_bytes() == (b / name).read_bytes()
    c = tmp_path / "c"
    _, ts = cut_after_one_chunk(cfg, c)
    assert float(np.asarray(ts.levels.tries).sum()) > 0  # attempts were counted
    restores_and_resumes(cfg, c, ts, "levels", a)
