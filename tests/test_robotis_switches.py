"""The ROBOTIS-faithful switches of the environment (docs/paper.md, "ROBOTIS' code in detail"):
each against an independent reference, and each off by default without a trace."""

from __future__ import annotations

import random

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _nav_reference import lidar, maze_geometry, ray_distances

from jaxnav.env import ROBOTIS_SWITCHES, STRAIGHT, EnvState, make
from jaxnav.robot.scan import nearest_rays
from jaxnav.world.maps import load_maze_file, make_maze, robotis_goal_grid


def _respawn_goal_support(draws: int = 20000) -> set[tuple[float, float]]:
    """Every point respawnGoal.py's rejection loop returns, transcribed from its code
    (stage 1 and 2 alike: obstacles at (+-0.6, +-0.6), a box around the origin)."""
    obstacles = [(0.6, 0.6), (0.6, -0.6), (-0.6, 0.6), (-0.6, -0.6)]
    rng = random.Random(0)
    seen = set()
    for _ in range(draws):
        goal_x = rng.randrange(-12, 13) / 10.0
        goal_y = rng.randrange(-12, 13) / 10.0
        check = any(abs(goal_x - ox) <= 0.4 and abs(goal_y - oy) <= 0.4 for ox, oy in obstacles)
        check = check or (abs(goal_x - 0.0) <= 0.4 and abs(goal_y - 0.0) <= 0.4)
        if not check:
            seen.add((goal_x, goal_y))
    return seen


def test_robotis_goal_grid_is_respawn_goals_support():
    ours = {(float(x), float(y)) for x, y in robotis_goal_grid()}
    assert ours == _respawn_goal_support()
    assert (0.6, 0.0) in ours and (0.0, 0.0) not in ours and (0.6, 0.6) not in ours


def test_robotis_goals_of_each_maze_are_reachable_and_scaled():
    for name, scale in [("square4", 1.0), ("square2", 0.5), ("square8", 2.0)]:
        m = make_maze(name)
        assert float(m.robotis_scale) == pytest.approx(scale)
        n = int(m.n_robotis_goals)
        pts = np.asarray(m.robotis_goals)[:n]
        # square4 and square8 keep the whole grid; square2's outer points hit the walls.
        if name != "square2":
            want = np.sort(robotis_goal_grid() * scale, axis=0)
            np.testing.assert_allclose(np.sort(pts, axis=0), want, rtol=1e-6)
        half = float(m.bounds[2])
        assert np.all(np.abs(pts) <= half - 0.13 + 1e-6)
        assert n >= 8


def _goal_chain(env, params, n: int) -> np.ndarray:
    _, state = env.reset(jax.random.PRNGKey(0), params)
    draw = jax.jit(env.draw_goal)
    goals = [np.asarray(state.goal)]
    key = jax.random.PRNGKey(1)
    for _ in range(n):
        key, k = jax.random.split(key)
        goals.append(np.asarray(draw(k, jnp.asarray(goals[-1]), params)))
    return np.asarray(goals)


def test_robotis_sampler_follows_respawn_goal_rules():
    env, params = make("square4", goal_sampler="robotis")
    goals = _goal_chain(env, params, 400)
    np.testing.assert_allclose(goals[0], [0.6, 0.0], atol=1e-6)  # the first goal
    grid = {(round(x, 1), round(y, 1)) for x, y in robotis_goal_grid()}
    assert {(round(float(x), 1), round(float(y), 1)) for x, y in goals} <= grid
    step = np.abs(np.diff(goals, axis=0))
    # A new goal is rejected when both |dx| < 1 and |dy| < 1 from the last.
    assert np.all((step[:, 0] >= 1 - 1e-5) | (step[:, 1] >= 1 - 1e-5))
    assert len({tuple(g) for g in goals.round(1)}) > 100  # it spreads over the grid


def test_gazebo_beam_layout_matches_reference_and_looks_ahead_twice():
    env, params = make("square4_obstacles", beam_layout="gazebo", n_beams=24)
    walls, circles = maze_geometry(params.maze)
    pos, yaw = np.array([0.3, -0.2]), 0.4
    ours = np.asarray(env.observe(jax.random.PRNGKey(0), jnp.asarray(pos), yaw, pos, params))
    angles = yaw + 2 * np.pi * np.arange(24) / 23  # Gazebo: 24 samples over [0, 2 pi]
    ref = np.clip(ray_distances(pos[None], angles[None], walls, circles)[0], 0.12, 3.5)
    np.testing.assert_allclose(ours[:24], ref, atol=1e-4)
    assert ours[0] == pytest.approx(ours[23], abs=1e-5)


def test_deploy_reads_the_gazebo_layout():
    # 360 LDS-01 rays at 1 degree: beam k of 24 at 360 k / 23 degrees, the last one ahead.
    idx = nearest_rays(360, 0.0, np.deg2rad(1.0), 24, "gazebo")
    np.testing.assert_array_equal(idx, np.round(np.arange(24) * 360 / 23).astype(int) % 360)
    assert idx[0] == idx[-1] == 0


def _pinhole_maze(tmp_path, centre, radius):
    f = tmp_path / "pin.yaml"
    f.write_text(
        "outline: [[-1.85, -1.85], [1.85, -1.85], [1.85, 1.85], [-1.85, 1.85], [-1.85, -1.85]]\n"
        f"obstacles:\n  - circle: [{centre[0]:.6f}, {centre[1]:.6f}, {radius}]\n"
        "start: [0.0, 0.0, 0.0]\n"
    )
    return load_maze_file(str(f))


def _step_straight(maze, **kw):
    env, params = make(maze, **kw)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    _, _, _, terminated, _, info = env.step_env(
        jax.random.PRNGKey(1), state, jnp.asarray(STRAIGHT), params
    )
    return bool(terminated)


def test_lidar_collision_misses_an_obstacle_between_beams(tmp_path):
    # After one straight step the robot is at (0.03, 0); a 1 cm pin 0.13 m away at 7.5
    # degrees sits between beams 0 and 1 (15 degrees apart) and 0.12 m from the centre:
    # inside the 0.13 m disc, outside the burger's 0.105 m footprint.
    a = np.deg2rad(7.5)
    maze = _pinhole_maze(tmp_path, (0.03 + 0.13 * np.cos(a), 0.13 * np.sin(a)), 0.01)
    walls, circles = maze_geometry(maze)
    scan = lidar(np.array([[0.03, 0.0]]), np.zeros(1), walls, circles, 24)
    assert scan.min() > 0.13  # the reference scan misses the pin
    assert _step_straight(maze)  # the exact disc does not
    assert not _step_straight(maze, collision="lidar")


def test_lidar_collision_from_the_nearest_beam(tmp_path):
    # A pin straight ahead: beam 0 reads 0.125 m after the step, below 0.13 m, while the
    # centre's clearance stays above the footprint.
    maze = _pinhole_maze(tmp_path, (0.03 + 0.135, 0.0), 0.01)
    assert _step_straight(maze, collision="lidar")
    far = _pinhole_maze(tmp_path, (0.03 + 0.16, 0.0), 0.01)
    assert not _step_straight(far, collision="lidar") and not _step_straight(far)


def test_action_delay_is_the_same_motion_one_step_later():
    env_d, params = make("square4", action_delay=True)
    env_n, _ = make("square4")
    rng = np.random.default_rng(0)
    actions = rng.integers(0, 5, 40)
    shifted = np.concatenate([[STRAIGHT], actions[:-1]])
    _, sd = env_d.reset(jax.random.PRNGKey(0), params)
    _, sn = env_n.reset(jax.random.PRNGKey(0), params)
    step_d, step_n = jax.jit(env_d.step_env), jax.jit(env_n.step_env)
    for t in range(40):
        k = jax.random.PRNGKey(100 + t)
        _, sd, *_ = step_d(k, sd, jnp.asarray(actions[t]), params)
        _, sn, *_ = step_n(k, sn, jnp.asarray(shifted[t]), params)
        np.testing.assert_allclose(np.asarray(sd.pos), np.asarray(sn.pos), atol=1e-6)
        assert int(sd.pending_action) == actions[t]


def test_switches_off_leave_no_trace():
    env, params = make("square4")
    assert {k: getattr(env, k) for k in ROBOTIS_SWITCHES} == {
        k: v[0] for k, v in ROBOTIS_SWITCHES.items()
    }
    _, state = env.reset(jax.random.PRNGKey(0), params)
    # the fields of the switches, of drawn mazes, of the optional observation parts
    # (the last command, the scan history), of the cylinders' pace and of level replay's
    # layout index are absent, not zeros
    optional = (
        "pending_action",
        "maze",
        "maze_episodes",
        "cell_dist",
        "last_command",
        "scans",
        "scan_yaws",
        "pace",
        "layout",
    )
    assert all(getattr(state, k) is None for k in optional)
    assert len(jax.tree.leaves(state)) == len(EnvState.__dataclass_fields__) - len(optional)


def test_bad_switch_values_are_refused():
    for k, v in [("collision", "box"), ("goal_sampler", "grid"), ("beam_layout", "odd")]:
        with pytest.raises(ValueError, match=k):
            make("square4", **{k: v})
