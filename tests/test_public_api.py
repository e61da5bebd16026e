"""The public environment API (``jaxnav.make``, ``jaxnav.env.from_config``, then
``reset``/``step``) gives params that hold what the settings ask for, or refuses in one
line: no setting silently has no effect there (the bank of layouts, the pace
curriculum's point, the bank's refresh, a sweep of an environment setting)."""

from __future__ import annotations

import jax
import numpy as np
import pytest

import jaxnav
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.env import bank_key, from_config

BANK = 6


def _layouts(segments) -> set[bytes]:
    return {np.asarray(s).tobytes() for s in segments}


@pytest.mark.slow  # 3 s on 2 cores
def test_from_config_draws_the_bank_and_every_reset_picks_its_layout_from_it():
    cfg = load_config("grid4", [f"env.maze_bank={BANK}"])
    env, params = from_config(cfg, jax.random.PRNGKey(3))
    assert params.bank is not None
    bank = _layouts(params.bank[0].segments)
    assert len(bank) == BANK  # six different layouts
    # The bank is the family's own draw from the documented key.
    want = env.draw_bank(bank_key(jax.random.PRNGKey(3)))
    np.testing.assert_array_equal(np.asarray(params.bank[0].segments), want[0].segments)
    keys = jax.random.split(jax.random.PRNGKey(1), 48)
    _, states = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
    seen = _layouts(states.maze.segments)
    assert seen <= bank  # only the bank's layouts come up ...
    assert len(seen) >= 4  # ... and more than one of them
    # Without the bank the same resets draw layouts of their own.
    plain, p0 = from_config(load_config("grid4"))
    assert p0.bank is None
    _, drawn = jax.jit(jax.vmap(plain.reset, in_axes=(0, None)))(keys, p0)
    assert not _layouts(drawn.maze.segments) <= bank


@pytest.mark.slow  # 3 s on 2 cores
def test_make_draws_the_bank_from_a_default_key_and_the_same_key_gives_the_same_bank():
    kw = {"generator": "grid", "grid_rows": 3, "grid_cols": 3, "maze_bank": 4}
    _, a = jaxnav.make(**kw)
    _, b = jaxnav.make(**kw, key=jax.random.PRNGKey(0))
    _, c = jaxnav.make(**kw, key=jax.random.PRNGKey(1))
    np.testing.assert_array_equal(np.asarray(a.bank[0].segments), np.asarray(b.bank[0].segments))
    assert _layouts(a.bank[0].segments) != _layouts(c.bank[0].segments)


def test_the_trainers_own_build_leaves_the_bank_to_each_run():
    cfg = load_config("grid4", [f"env.maze_bank={BANK}"])
    assert from_config(cfg, prepare=False)[1].bank is None


def test_pace_curriculum_needs_its_point_and_the_params_hold_it():
    with pytest.raises(ConfigError, match=r"progress=.*env.at_progress"):
        jaxnav.make("stage3", motion_pace=(0.2, 0.6), pace_curriculum=0.5)
    env, params = jaxnav.make("stage3", motion_pace=(0.2, 0.6), pace_curriculum=0.5, progress=0.25)
    # A quarter of training is half of a curriculum over half of it: halfway to [1, 1].
    np.testing.assert_allclose(np.asarray(params.pace_range), [0.6, 0.8], rtol=1e-6)
    np.testing.assert_allclose(np.asarray(env.at_progress(params, 1.0).pace_range), [1.0, 1.0])


def test_a_bank_refresh_is_refused_with_the_call_to_make():
    with pytest.raises(ConfigError, match=r"env.with_bank\(params, key\)") as err:
        from_config(load_config("grid4", ["env.maze_bank=4", "env.maze_bank_refresh=1000"]))
    assert "\n" not in str(err.value)


def test_a_config_that_sweeps_an_environment_setting_is_refused_with_the_call_to_make():
    cfg = load_config("smoke", ["sweep.env.lidar_noise_std=[0.0, 0.01]"])
    with pytest.raises(ConfigError, match=r"env.lidar_noise_std.*config.at\(point\)"):
        from_config(cfg)
    point = cfg.points()[1]
    _, params = from_config(cfg.at(point))
    assert float(params.lidar_noise_std) == pytest.approx(0.01)
