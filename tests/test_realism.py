"""Sensor and start-pose realism options of the environment (off in the paper)."""

import jax
import numpy as np
import pytest

import jaxnav
from jaxnav.env import scale_maze
from jaxnav.world.maps import clearance
from jaxnav.world.sensor import lidar_scan


def _rollout(env, params, key, n=200):
    obs, st = env.reset(key, params)

    def body(carry, k):
        st = carry
        ka, ks = jax.random.split(k)
        a = jax.random.randint(ka, (), 0, 5)
        obs, st, r, term, trunc, info = env.step(ks, st, a, params)
        return st, (obs, st, term | trunc)

    _, out = jax.lax.scan(body, st, jax.random.split(key, n))
    return obs, out


@pytest.mark.slow  # 3 s on 2 cores
def test_options_off_change_nothing():
    env0, p0 = jaxnav.make("square4_obstacles")
    env1, p1 = jaxnav.make(
        "square4_obstacles",
        beam_dropout=0.0,
        odom_noise=(0.0, 0.0),
        random_start=False,
        maze_scale=(1.0, 1.0),
    )
    a = jax.jit(_rollout, static_argnums=(0, 3))(env0, p0, jax.random.PRNGKey(3))
    b = jax.jit(_rollout, static_argnums=(0, 3))(env1, p1, jax.random.PRNGKey(3))
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)):
        np.testing.assert_array_equal(x, y)


@pytest.mark.slow  # 5 s on 2 cores
def test_beam_dropout_reads_max_range_at_the_given_rate():
    env, params = jaxnav.make("square2", beam_dropout=0.3)  # every true range < 3.5 here
    keys = jax.random.split(jax.random.PRNGKey(0), 2000)
    obs, _ = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    lost = np.asarray(obs[:, :24]) == params.max_range
    assert lost.mean() == pytest.approx(0.3, abs=0.01)


@pytest.mark.slow
def test_dropout_leaves_the_range_noise_of_the_kept_beams_unchanged():
    # Dropout draws from its own key: the beams it keeps read what they read without it.
    env0, p = jaxnav.make("square2", lidar_noise_std=0.01)  # every range < 3.5 here
    env1, _ = jaxnav.make("square2", lidar_noise_std=0.01, beam_dropout=0.3)
    keys = jax.random.split(jax.random.PRNGKey(7), 500)
    o0, _ = jax.vmap(env0.reset, in_axes=(0, None))(keys, p)
    o1, _ = jax.vmap(env1.reset, in_axes=(0, None))(keys, p)
    r0, r1 = np.asarray(o0[:, :24]), np.asarray(o1[:, :24])
    kept = r1 != p.max_range
    assert kept.mean() == pytest.approx(0.7, abs=0.02)
    np.testing.assert_array_equal(r1[kept], r0[kept])
    np.testing.assert_array_equal(o1[:, 24:], o0[:, 24:])


@pytest.mark.slow
def test_odometry_noise_moves_heading_and_distance_not_ranges():
    env0, p = jaxnav.make("square4")
    env1, _ = jaxnav.make("square4", odom_noise=(0.05, 0.05))
    keys = jax.random.split(jax.random.PRNGKey(1), 4000)
    o0, _ = jax.vmap(env0.reset, in_axes=(0, None))(keys, p)
    o1, _ = jax.vmap(env1.reset, in_axes=(0, None))(keys, p)
    np.testing.assert_array_equal(o0[:, :24], o1[:, :24])
    dh = np.angle(np.exp(1j * np.asarray(o1[:, 24] - o0[:, 24])))  # wrapped difference
    dd = np.asarray(o1[:, 25] - o0[:, 25])
    assert 0.03 < dh.std() < 0.2 and 0.03 < dd.std() < 0.08


@pytest.mark.slow
def test_random_start_is_free_and_varied():
    env, params = jaxnav.make("square4_obstacles", random_start=True)
    keys = jax.random.split(jax.random.PRNGKey(2), 500)
    _, st = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    pos = np.asarray(st.pos)
    assert np.unique(pos.round(3), axis=0).shape[0] > 100
    maze = params.maze
    assert (clearance(pos, maze.walls(), maze.obstacles()) > 0.3).all()
    assert np.asarray(st.yaw).std() > 1.0
    # after a collision the next episode starts somewhere new, goal kept
    _, (obs, states, done) = jax.jit(_rollout, static_argnums=(0, 3))(
        env, params, jax.random.PRNGKey(5), 400
    )
    ends = np.flatnonzero(np.asarray(done))
    assert len(ends) >= 2
    starts = np.asarray(states.pos)[ends]
    assert np.unique(starts.round(3), axis=0).shape[0] == len(ends)


@pytest.mark.slow
def test_maze_scale_scales_walls_goals_and_scan():
    env, params = jaxnav.make("square4", maze_scale=(0.8, 1.25))
    keys = jax.random.split(jax.random.PRNGKey(4), 300)
    obs, st = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    scale = np.asarray(st.scale)
    assert scale.min() >= 0.8 and scale.max() <= 1.25 and scale.std() > 0.1
    for i in range(0, 300, 37):
        m = scale_maze(params.maze, st.scale[i])
        np.testing.assert_allclose(np.abs(m.walls()).max(), 1.85 * scale[i], rtol=1e-6)
        want = lidar_scan(m, st.pos[i], st.yaw[i], 24, 0.12, 3.5)
        np.testing.assert_allclose(obs[i, :24], want, atol=1e-6)
        goal = np.asarray(st.goal[i])
        assert (np.abs(goal) <= 1.85 * scale[i] - 0.35 * scale[i] + 1e-4).all()
    # a kept goal follows the maze into the next episode's scale
    _, (o, states, done) = jax.jit(_rollout, static_argnums=(0, 3))(
        env, params, jax.random.PRNGKey(6), 400
    )
    ends = np.flatnonzero(np.asarray(done))
    assert len(ends) >= 1
    e = ends[0]
    before = np.asarray(states.goal[e - 1]) / float(states.scale[e - 1])
    after = np.asarray(states.goal[e]) / float(states.scale[e])
    np.testing.assert_allclose(before, after, atol=1e-5)


def test_bad_realism_values_are_rejected():
    with pytest.raises(ValueError, match="beam_dropout"):
        jaxnav.make("square4", beam_dropout=1.5)
    with pytest.raises(ValueError, match="maze_scale"):
        jaxnav.make("square4", maze_scale=(1.5, 1.0))
