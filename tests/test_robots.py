"""Robot profiles (env.robot, or robot: at the top): the burger changes nothing, another
robot's numbers become defaults a user still overrides, its limits scale the commands,
a narrower LiDAR spreads its beams edge to edge, and the episode may end at its goal."""

from __future__ import annotations

import math

import _nav_reference as ref
import jax
import numpy as np
import pytest

import jaxnav
from jaxnav.core import robots
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.core.settings import ACTION_SETS
from jaxnav.env import from_config


def test_the_burger_profile_gives_no_defaults_so_the_paper_config_is_unchanged():
    assert robots.defaults("burger") == {}
    plain, burger = load_config(None), load_config(None, ["robot=burger"])
    assert plain == burger and plain.env.robot == "burger"
    assert plain.env_kwargs()["robot_radius"] == 0.13 and plain.env_kwargs()["max_range"] == 3.5


def test_a_profile_sets_defaults_that_the_user_still_overrides():
    cfg = load_config(None, ["robot=jackal"])
    jackal = robots.get("jackal")
    assert cfg.env.robot_radius == jackal.radius and cfg.env.lidar_fov == 270.0
    assert cfg.env.max_range == 10.0 and cfg.env.n_beams == 720
    cfg = load_config(None, ["env.robot=jackal", "env.n_beams=36", "env.robot_radius=0.3"])
    assert cfg.env.n_beams == 36 and cfg.env.robot_radius == 0.3
    with pytest.raises(ConfigError, match="env.robot must be one of"):
        load_config(None, ["robot=r2d2"])
    with pytest.raises(ConfigError, match="short name"):
        load_config(None, ["robot=jackal", "env.robot=jackal"])


def test_a_robots_action_set_is_the_burgers_scaled_by_its_limits():
    _, burger = jaxnav.make("square4", actions="vw")
    _, jackal = jaxnav.make("square4", actions="vw", robot="jackal")
    table = ACTION_SETS["vw"]
    np.testing.assert_array_equal(burger.speeds, np.float32([v for v, _ in table]))
    np.testing.assert_allclose(jackal.speeds, [v * 2.0 / 0.22 for v, _ in table], rtol=1e-6)
    np.testing.assert_allclose(jackal.omegas, [w * 4.0 / 2.84 for _, w in table], rtol=1e-6)


def test_a_top_speed_scales_the_sets_speeds_and_leaves_its_turns_and_the_driven_arc_exact():
    _, jackal = jaxnav.make("square4", actions="vw_reverse", robot="jackal")
    env, capped = jaxnav.make("square4", actions="vw_reverse", robot="jackal", top_speed=0.5)
    table = ACTION_SETS["vw_reverse"]
    np.testing.assert_allclose(capped.speeds, [v * 0.5 / 0.22 for v, _ in table], rtol=1e-6)
    np.testing.assert_array_equal(capped.omegas, jackal.omegas)
    assert float(np.max(capped.speeds)) == pytest.approx(0.5)
    # the step drives the capped command: straight ahead at the top speed for one period
    _, state = env.reset(jax.random.PRNGKey(0), capped)
    speeds, omegas = np.asarray(capped.speeds), np.asarray(capped.omegas)
    ahead = int(np.flatnonzero((omegas == 0) & (speeds > 0.4))[0])
    _, after, *_ = env.step_env(jax.random.PRNGKey(1), state, ahead, capped)
    moved = float(np.hypot(*(np.asarray(after.pos) - np.asarray(state.pos))))
    assert moved == pytest.approx(0.5 * float(capped.dt), rel=1e-5)
    # the burger's set is unchanged without it, and a config's top speed reaches the env
    _, cfg_params = from_config(load_config(None, ["env.actions=vw", "env.top_speed=0.11"]))
    np.testing.assert_allclose(cfg_params.speeds, [v / 2 for v, _ in ACTION_SETS["vw"]], rtol=1e-6)


def test_the_normalised_observation_scales_the_last_command_by_the_robots_limits():
    kw = {"actions": "vw", "observation": "normalised", "robot": "jackal"}
    env, params = jaxnav.make("square8", **kw)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    top = int(np.argmax(np.asarray(params.speeds)))  # full speed, turning hard
    obs, *_ = env.step_env(jax.random.PRNGKey(1), state, top, params)
    n = env.n_beams
    v, w = np.asarray(params.speeds)[top], np.asarray(params.omegas)[top]
    np.testing.assert_allclose(obs[n + 2 : n + 4], [v / 2.0, w / 4.0], rtol=1e-6)


def test_a_narrower_lidar_spreads_its_beams_from_edge_to_edge():
    env, params = jaxnav.make("square4", lidar_fov=270.0, n_beams=7)
    angles = np.asarray(env.beam_angles())
    np.testing.assert_allclose(angles, np.linspace(-0.75 * math.pi, 0.75 * math.pi, 7), atol=1e-6)
    obs, _ = env.reset(jax.random.PRNGKey(0), params)  # at the origin facing +x
    walls, circles = ref.maze_geometry(params.maze)
    want = ref.ray_distances(np.zeros((1, 2)), angles[None], walls, circles)[0]
    np.testing.assert_allclose(obs[:7], np.clip(want, 0.12, 3.5), atol=1e-4)


@pytest.mark.parametrize(
    "override,says",
    [
        (["robot=jackal", "env.wheel_limit=true"], "burger's firmware"),
        (["robot=jackal", "env.scan_beams=1440"], "edge to edge"),
        (
            [
                "robot=jackal",
                "env.actions=continuous",
                "env.reward=progress",
                "env.speed_range=[0, 3]",
            ],
            "jackal's limits",
        ),
        # continuous commands' limits do nothing to a discrete action set
        (["robot=jackal", "env.actions=vw", "env.speed_range=[0, 1]"], "action set's"),
        (["env.actions=vw", "env.max_yaw_rate=1.0"], "action set's"),
        (["env.beyond_limits=true"], "leave them unset"),
        # a top speed for a set that has none, or beyond the robot's
        (["env.top_speed=0.1"], "env.actions paper has no set"),
        (["env.actions=continuous", "env.reward=progress", "env.top_speed=0.1"], "no set"),
        (["robot=jackal", "env.actions=vw", "env.top_speed=2.5"], "beyond the jackal's"),
        (["env.actions=vw", "env.top_speed=0"], "above 0"),
    ],
)
def test_what_a_robot_cannot_do_is_refused_in_one_line(override, says):
    with pytest.raises(ConfigError, match=says):
        load_config(None, override)


def test_with_goal_ends_reaching_the_goal_ends_the_episode_and_keeps_the_goal():
    env, params = jaxnav.make("square4", goal_ends=True)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    state = state.replace(pos=state.goal - jax.numpy.asarray([0.1, 0.0]), yaw=0.0)
    _, after, _, terminated, _, info = env.step_env(jax.random.PRNGKey(1), state, 2, params)
    assert bool(info["goal_reached"]) and bool(terminated)
    np.testing.assert_array_equal(after.goal, state.goal)


def test_a_new_robot_is_one_registry_entry():
    toy = robots.register(
        robots.Robot(
            name="toy",
            about="a test robot",
            footprint=(0.2, 0.2),
            radius=0.15,
            max_v=0.44,
            max_omega=2.84,
            accel=None,
            lidar="none",
            lidar_beams=24,
            lidar_fov=360.0,
            lidar_range=(0.12, 3.5),
            sources=("this test",),
            defaults={"env.robot_radius": 0.15},
        )
    )
    try:
        cfg = load_config(None, ["robot=toy", "env.actions=vw"])
        _, params = from_config(cfg)
        assert float(params.robot_radius) == 0.15
        assert float(np.max(params.speeds)) == pytest.approx(0.44)
    finally:
        robots._REGISTRY.pop(toy.name)
