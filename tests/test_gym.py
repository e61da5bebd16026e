"""The Gymnasium wrapper: Gymnasium's own checker, registration, and a trajectory
identical to the JAX environment's for the documented seeding."""

from __future__ import annotations

import jax
import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import jaxnav  # noqa: E402
from jaxnav.interop.gym import ENV_IDS, NavGymEnv, env_id  # noqa: E402
from jaxnav.world.maps import BUILTIN_MAZES, MazeError  # noqa: E402

# Range noise makes every observation depend on its key, so equal trajectories
# mean the wrapper spends keys exactly as documented; a short step limit brings
# truncations (and start-pose restarts) into a short test; square2 is small enough
# for collisions too.
NOISY = dict(lidar_noise_std=0.01, max_steps=30)
# The wrapper's compiled step and a separately compiled step_env may be fused
# differently by XLA: equal up to float32 rounding, not bit for bit.
TOL = dict(rtol=1e-5, atol=1e-5)


@pytest.fixture(scope="module")
def noisy_env():
    return NavGymEnv("square2", **NOISY)


def test_passes_gymnasium_env_checker():
    from gymnasium.utils.env_checker import check_env

    env = gym.make("jaxnav/Square4-v0", render_mode="rgb_array")
    check_env(env.unwrapped)


def test_every_builtin_maze_is_registered_and_makes():
    assert set(ENV_IDS) == set(BUILTIN_MAZES)
    assert env_id("square4_obstacles") == "jaxnav/Square4Obstacles-v0"
    for id_ in ENV_IDS.values():
        assert id_ in gym.registry
    env = gym.make("jaxnav/Square4-v0")
    obs, info = env.reset(seed=0)
    assert obs.shape == (26,) and obs.dtype == np.float32 and info == {}
    assert env.action_space == gym.spaces.Discrete(5)
    obs, reward, terminated, truncated, info = env.step(2)
    assert obs in env.observation_space
    assert isinstance(reward, float) and terminated is False and truncated is False
    assert set(info) == {"goal_reached", "collision"}


def test_make_passes_overrides_to_the_jax_env():
    env = gym.make("jaxnav/Square4Obstacles-v0", n_beams=36, preset="robotis")
    assert env.observation_space.shape == (36 + 2 + 2,)  # stage 2: min range and its beam
    assert env.unwrapped.jax_params.R_plus == 200.0
    assert env.reset(seed=1)[0].shape == (40,)


def test_module_prefixed_id_imports_the_module():
    env = gym.make("jaxnav.interop.gym:jaxnav/Triangle-v0")
    assert env.spec.id == "jaxnav/Triangle-v0"
    assert env.spec.kwargs == {"maze": "triangle"}


def test_unknown_id_maze_or_option_is_an_error():
    with pytest.raises(gym.error.Error):
        gym.make("jaxnav/Hexagon-v0")
    with pytest.raises(MazeError):
        NavGymEnv("hexagon")
    with pytest.raises(ValueError, match="unknown environment parameter"):
        NavGymEnv("square4", n_beam=24)
    with pytest.raises(ValueError, match="render_mode"):
        NavGymEnv("square4", render_mode="human")


def test_bad_action_and_step_before_reset_are_errors(noisy_env):
    env = NavGymEnv("square2", **NOISY)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    noisy_env.reset(seed=0)
    for bad in (5, -1, 1.5, [1, 2]):
        with pytest.raises(ValueError, match="action"):
            noisy_env.step(bad)
    with pytest.raises(ValueError, match="unknown reset option"):
        noisy_env.reset(options={"goal": 1})


@pytest.mark.slow
def test_trajectory_equals_the_jax_step_env_for_the_same_keys(noisy_env):
    env, params = noisy_env.jax_env, noisy_env.jax_params
    step_env = jax.jit(env.step_env)
    auto_step = jax.jit(env.step)
    seed = 3
    rng = np.random.default_rng(0)
    # Drive straight a lot so that collisions happen as well as truncations.
    actions = np.where(rng.random(200) < 0.7, 2, rng.integers(0, 5, 200))

    obs_w, _ = noisy_env.reset(seed=seed)
    key = jax.random.PRNGKey(seed)
    key, sub = jax.random.split(key)
    obs_j, state = env.reset(sub, params)
    np.testing.assert_allclose(obs_w, np.asarray(obs_j), **TOL)

    ends = {"terminated": 0, "truncated": 0}
    for a in actions:
        obs_w, r_w, term_w, trunc_w, info_w = noisy_env.step(int(a))
        key, sub = jax.random.split(key)
        obs_j, new_state, r_j, term_j, trunc_j, info_j = step_env(sub, state, a, params)
        np.testing.assert_allclose(obs_w, np.asarray(obs_j), **TOL)
        assert r_w == pytest.approx(float(r_j), rel=1e-5, abs=1e-5)
        assert (term_w, trunc_w) == (bool(term_j), bool(trunc_j))
        assert info_w == {k: bool(v) for k, v in info_j.items()}
        if term_w or trunc_w:
            ends["terminated" if term_w else "truncated"] += 1
            # The wrapper's reset() is NavEnv.step's auto-reset: same restart state.
            _, auto_state, *_ = auto_step(sub, state, a, params)
            obs_w, _ = noisy_env.reset()
            for leaf_w, leaf_a in zip(
                jax.tree.leaves(noisy_env.state), jax.tree.leaves(auto_state)
            ):
                np.testing.assert_allclose(np.asarray(leaf_w), np.asarray(leaf_a), **TOL)
            # ... and its observation of that state is drawn with the next key.
            state = auto_state
            key, sub = jax.random.split(key)
            obs_j = env.observe(sub, state.pos, state.yaw, state.goal, params, state.scale)
            np.testing.assert_allclose(obs_w, np.asarray(obs_j), **TOL)
        else:
            state = new_state
    assert ends["terminated"] >= 2 and ends["truncated"] >= 2, ends


def test_restart_keeps_the_goal_and_new_goal_option_draws_one(noisy_env):
    noisy_env.reset(seed=11)
    goal = np.asarray(noisy_env.state.goal)
    for _ in range(5):
        noisy_env.step(1)
    noisy_env.reset()
    s = noisy_env.state
    np.testing.assert_array_equal(np.asarray(s.goal), goal)
    np.testing.assert_array_equal(
        np.asarray(s.pos), np.asarray(noisy_env.jax_params.maze.start[:2])
    )
    assert int(s.t) == 0
    goals = set()
    for _ in range(6):
        noisy_env.reset(options={"new_goal": True})
        goals.add(tuple(np.asarray(noisy_env.state.goal).tolist()))
    assert len(goals) > 1


def test_same_seed_same_episode_different_seed_different_goal(noisy_env):
    a = noisy_env.reset(seed=5)[0]
    b = noisy_env.reset(seed=5)[0]
    np.testing.assert_array_equal(a, b)
    goals = set()
    for s in range(6):
        noisy_env.reset(seed=s)
        goals.add(tuple(np.asarray(noisy_env.state.goal).tolist()))
    assert len(goals) > 1
    # JAX seeds are 32-bit: seeds are taken modulo 2**32, as documented.
    c = noisy_env.reset(seed=5 + 2**32)[0]
    np.testing.assert_array_equal(a, c)


def test_render_rgb_array_is_a_picture():
    env = NavGymEnv("square4", render_mode="rgb_array")
    env.reset(seed=0)
    img = env.render()
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8
    assert img.min() < 100 < img.max()  # not blank
    with pytest.warns(UserWarning, match="render_mode"):
        assert NavGymEnv("square4").render() is None


def test_make_of_the_package_and_the_wrapper_agree():
    env, params = jaxnav.make("pentagon")
    w = NavGymEnv("pentagon")
    assert w.observation_space.shape == (env.obs_size,)
    np.testing.assert_array_equal(
        w.observation_space.high, np.asarray(env.observation_space(params).high)
    )


def test_continuous_commands_are_a_box_and_pass_the_checker():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(
        "jaxnav/Square4-v0", actions="continuous", reward="progress", observation="normalised"
    )
    assert isinstance(env.action_space, gym.spaces.Box) and env.action_space.shape == (2,)
    check_env(env.unwrapped, skip_render_check=True)
    env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(np.array([1.0, 0.0], np.float32))
    assert obs.shape == env.observation_space.shape and not terminated
    with pytest.raises(ValueError, match=r"2 finite numbers in \[-1, 1\]"):
        env.step(np.array([2.0, 0.0], np.float32))
