"""A mix of worlds (env.generator mix): each source comes up at its weight, each layout
is its source's own draw padded to the mix's shape, and a config names what is wrong
in one line."""

from __future__ import annotations

import jax
import numpy as np
import pytest
from scipy import stats

import jaxnav
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.env import bank_key
from jaxnav.world.mix import FixedWorld, mix_family

WORLDS = ("rooms", "square4_obstacles", "square2")
MIX = {
    "generator": "mix",
    "mix_worlds": WORLDS,
    "mix_weights": (1.0, 1.0, 2.0),
    "rooms_rows": 1,
    "rooms_cols": 2,
    "min_path_cells": 1,
}


def _source(maze) -> np.ndarray:
    """Which world each layout is, by what stands in it: rooms have inner walls (more
    than 4 segments), square4_obstacles 4 cylinders, square2 neither (i[N])."""
    segments = np.asarray(maze.segment_mask).sum(-1)
    circles = np.asarray(maze.circle_mask).sum(-1)
    return np.where(segments > 4, 0, np.where(circles == 4, 1, 2))


@pytest.fixture(scope="module")
def banked():
    return jaxnav.make(**MIX, maze_bank=64, key=jax.random.PRNGKey(3))


@pytest.mark.slow  # 5 s on 2 cores
def test_a_bank_holds_each_world_at_its_weight(banked):
    env, params = banked
    counts = np.bincount(_source(params.bank[0]), minlength=3)
    assert counts.tolist() == [16, 16, 32]  # 64 layouts shared 1 : 1 : 2
    assert env.family.shares(64) == (16, 16, 32)
    assert env.family.shares(3) == (1, 1, 1)  # every world has a place, however small


@pytest.mark.slow  # its fixture is a slow test's
def test_every_reset_draws_a_layout_of_the_bank_each_world_at_its_weight(banked):
    env, params = banked
    keys = jax.random.split(jax.random.PRNGKey(1), 800)
    _, states = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
    got = np.bincount(_source(states.maze), minlength=3)
    want = np.asarray([0.25, 0.25, 0.5]) * len(keys)
    assert stats.chisquare(got, want).pvalue > 1e-3, got
    bank = {np.asarray(s).tobytes() for s in params.bank[0].segments}
    assert {np.asarray(s).tobytes() for s in states.maze.segments} <= bank


def test_one_draw_picks_a_world_at_its_weight():
    mix = mix_family(type("E", (), {**MIX, "rooms_size": 2.0, "rooms_door": 0.8,
                                   "rooms_loops": 0.0, "maze_scale": (1.0, 1.0)})())  # fmt: skip
    draw = jax.jit(jax.vmap(lambda k: mix.draw(k, "train")))
    maze, _ = draw(jax.random.split(jax.random.PRNGKey(5), 600))
    got = np.bincount(_source(maze), minlength=3)
    assert stats.chisquare(got, np.asarray([0.25, 0.25, 0.5]) * 600).pvalue > 1e-3, got


@pytest.mark.slow  # its fixture is a slow test's
def test_a_fixed_world_is_its_maze_with_a_goal_of_its_own_points(banked):
    env, params = banked
    mix = env.family
    key = jax.random.PRNGKey(9)
    maze, goal = FixedWorld("square4_obstacles").draw(key)
    fixed = jaxnav.make_maze("square4_obstacles")
    np.testing.assert_array_equal(np.asarray(maze.circles), np.asarray(fixed.circles))
    points = np.asarray(fixed.goal_points)[: int(fixed.n_goal_points)]
    assert np.min(np.linalg.norm(points - np.asarray(goal), axis=1)) < 1e-6
    # in the bank: the same draw, padded to the mix's shape (its keys fold in the world)
    bank_maze, bank_goal = params.bank[0], params.bank[1]
    k1 = jax.random.split(jax.random.fold_in(bank_key(jax.random.PRNGKey(3)), 1), 16)[0]
    want_maze, want_goal = mix.padded_draw(1, k1, "train")
    first = int(np.flatnonzero(_source(bank_maze) == 1)[0])
    np.testing.assert_array_equal(np.asarray(bank_goal[first]), np.asarray(want_goal))
    np.testing.assert_array_equal(
        np.asarray(bank_maze.segments[first]), np.asarray(want_maze.segments)
    )


@pytest.mark.parametrize(
    "items, message",
    [
        (["env.generator=mix"], "env.mix_worlds must name at least one world"),
        (["env.generator=mix", "env.mix_worlds=[rooms, mix]"], "cannot hold mix itself"),
        (
            ["env.generator=mix", "env.mix_worlds=[rooms, grid]", "env.mix_weights=[1]"],
            "has 1 weights for 2 worlds",
        ),
        (["env.generator=mix", "env.mix_worlds=[rooms]"], "set env.maze_bank"),
        (
            ["env.generator=mix", "env.mix_worlds=[rooms]", "env.maze_bank=8", "env.rooms_rows=0"],
            "env.rooms_rows must be at least 1",
        ),
    ],
)
def test_a_mix_that_cannot_be_made_is_one_line(items, message):
    with pytest.raises(ConfigError, match=message) as e:
        load_config(None, items)
    assert "\n" not in str(e.value)


def test_a_world_that_is_neither_a_family_nor_a_maze_is_one_line():
    cfg = load_config(None, ["env.generator=mix", "env.mix_worlds=[nowhere]", "env.maze_bank=4"])
    with pytest.raises(ValueError, match="unknown maze 'nowhere'") as e:
        jaxnav.env.from_config(cfg)
    assert "\n" not in str(e.value)
