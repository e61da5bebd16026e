"""The settings beyond the paper that help a policy drive, each against an independent
reference: the action sets' kinematics against a hand-made wheel model and the
unicycle's integral, the pooled scan and the normalised observation against the NumPy
ray caster, the progress reward and its penalties by hand, the scan history, the
learning rate's linear decay against Adam's update on a constant gradient."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _nav_reference import clearance as reference_clearance
from _nav_reference import displacement as reference_displacement
from _nav_reference import lidar, maze_geometry, path_min_clearance, turned_changes_by_hand

import jaxnav
from jaxnav.core.config import ConfigError, load_config
from jaxnav.core.settings import ACTION_SETS
from jaxnav.world.sensor import pooled_ranges

WHEEL_MAX = 265 * 0.033 / 41.69988758  # m/s, by hand (tests/test_wheel_limit.py)
V_CMD_MAX = 0.033 * 2 * math.pi * 61 / 60  # the firmware's command clip
W_CMD_MAX = V_CMD_MAX / 0.08


def _by_hand(v: float, w: float) -> tuple[float, float]:
    """The burger's firmware, worked by hand: commands clipped, then each wheel."""
    v, w = np.clip(v, -V_CMD_MAX, V_CMD_MAX), np.clip(w, -W_CMD_MAX, W_CMD_MAX)
    left = np.clip(v - 0.08 * w, -WHEEL_MAX, WHEEL_MAX)
    right = np.clip(v + 0.08 * w, -WHEEL_MAX, WHEEL_MAX)
    return (left + right) / 2, (right - left) / 0.16


@pytest.mark.parametrize("name", ["paper_stop", "vw", "vw_reverse"])
@pytest.mark.parametrize("wheel_limit", [False, True])
def test_every_action_of_a_set_drives_its_command_through_the_wheel_model(name, wheel_limit):
    env, params = jaxnav.make("square8", actions=name, wheel_limit=wheel_limit)
    table = ACTION_SETS[name]
    assert env.num_actions == len(table)
    obs, state = env.reset(jax.random.PRNGKey(0), params)
    step = jax.jit(env.step)
    for a, (v, w) in enumerate(table):
        vd, wd = _by_hand(v, w) if wheel_limit else (v, w)
        _, s2, *_ = step(jax.random.PRNGKey(1), state, jnp.int32(a), params)
        moved = np.asarray(s2.pos - state.pos, np.float64)
        expected = reference_displacement(float(state.yaw), wd, vd, 0.2)
        np.testing.assert_allclose(moved, expected, atol=2e-6)
        turned = math.remainder(float(s2.yaw) - float(state.yaw), 2 * math.pi)
        assert turned == pytest.approx(wd * 0.2, abs=2e-6)
        travel = float(env.travel(params, state, jnp.int32(a)))
        assert travel == pytest.approx(abs(vd) * 0.2, abs=1e-7)


def test_every_set_stays_within_the_burgers_teleop_limits():
    for table in (t for t in ACTION_SETS.values() if t is not None):
        assert all(abs(v) <= 0.22 and abs(w) <= 2.84 for v, w in table)
    assert (0.0, 0.0) in ACTION_SETS["paper_stop"] and (0.0, 0.0) in ACTION_SETS["vw"]


@pytest.mark.parametrize("m", [2, 3, 4])
def test_a_pooled_scan_is_the_least_of_each_sector_of_a_finer_numpy_scan(m):
    maze = jaxnav.make("stage4")[1].maze
    walls, circles = maze_geometry(maze)
    n = 24
    pos, yaw = np.array([[-0.7, 0.0]]), np.array([0.4])
    fine = lidar(pos, yaw, walls, circles, n * m)[0]  # clipped; pooling commutes with it
    # sector k: the m fine beams around observed beam k's direction
    idx = np.arange(n)[:, None] * m + np.arange(m)[None, :] - m // 2
    expected = fine[idx % (n * m)].min(axis=1)
    ours = np.clip(np.asarray(pooled_ranges(jnp.asarray(fine, jnp.float32), n)), 0.12, 3.5)
    np.testing.assert_allclose(ours, expected, rtol=1e-6)
    env, params = jaxnav.make("stage4", scan_beams=n * m, observation="normalised")
    obs = env.observe(jax.random.PRNGKey(0), jnp.asarray(pos[0]), jnp.float32(0.4),
                      jnp.zeros(2), params)  # fmt: skip
    np.testing.assert_allclose(np.asarray(obs[:n]) * 3.5, expected, atol=2e-5)


def test_the_normalised_observation_by_hand():
    env, params = jaxnav.make("square4_obstacles", observation="normalised", actions="vw")
    walls, circles = maze_geometry(params.maze)
    pos, yaw, goal = np.array([0.3, -0.4]), 0.7, np.array([-1.2, 1.1])
    last = np.array([0.11, -0.75])
    obs = np.asarray(
        env.observe(jax.random.PRNGKey(0), jnp.asarray(pos), jnp.float32(yaw),
                    jnp.asarray(goal), params, last_command=jnp.asarray(last))
    )  # fmt: skip
    ranges = lidar(pos[None], np.array([yaw]), walls, circles, 24)[0]
    d = goal - pos
    heading = math.remainder(math.atan2(d[1], d[0]) - yaw, 2 * math.pi)
    expected = [*(ranges / 3.5), heading / math.pi, min(np.hypot(*d), 3.5) / 3.5, 0.5, -0.75 / 2.84]
    np.testing.assert_allclose(obs, expected, atol=2e-5)
    assert env.obs_size == 28 and np.all(np.abs(obs) <= 1)


def test_the_progress_reward_and_its_penalties_by_hand():
    env, params = jaxnav.make(
        "square4_obstacles",
        reward="progress",
        R_plus=10.0,
        R_minus=-10.0,
        progress_scale=5.0,
        step_penalty=0.01,
        proximity_penalty=0.5,
        proximity_distance=0.3,
    )
    _, state = env.reset(jax.random.PRNGKey(0), params)
    # near the cylinder at (0.6, 0.6), heading past it, the goal far off
    state = state.replace(pos=jnp.asarray([0.6, 0.25]), yaw=jnp.float32(0.0),
                          goal=jnp.asarray([-1.5, -1.5]))  # fmt: skip
    walls, circles = maze_geometry(params.maze)
    for a, omega in enumerate((-1.5, -0.75, 0.0, 0.75, 1.5)):
        _, s2, r, term, _, info = env.step_env(jax.random.PRNGKey(1), state, jnp.int32(a), params)
        assert not bool(term) and not bool(info["goal_reached"])
        before = np.hypot(0.6 + 1.5, 0.25 + 1.5)
        after = np.hypot(*(np.asarray(s2.pos) - [-1.5, -1.5]))
        c = path_min_clearance(np.array([0.6, 0.25]), 0.0, omega, walls, circles) - 0.13
        near = np.clip(1 - c / 0.3, 0, 1)
        assert near > 0  # the cylinder's edge is 0.2 m off: within 0.3 m of clearance
        expected = 5.0 * (before - after) - 0.01 - 0.5 * near
        assert float(r) == pytest.approx(expected, abs=2e-4)


def test_a_collision_and_a_goal_pay_their_constants_under_the_progress_reward():
    env, params = jaxnav.make("square4", reward="progress", R_plus=10.0, R_minus=-7.0)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    at_wall = state.replace(pos=jnp.asarray([1.7, 0.0]), yaw=jnp.float32(0.0))
    _, _, r, term, *_ = env.step_env(jax.random.PRNGKey(1), at_wall, jnp.int32(2), params)
    assert bool(term) and float(r) == -7.0
    near_goal = state.replace(goal=state.pos + jnp.asarray([0.2, 0.0]))
    _, _, r, _, _, info = env.step_env(jax.random.PRNGKey(1), near_goal, jnp.int32(2), params)
    assert bool(info["goal_reached"]) and float(r) == 10.0


@pytest.mark.slow  # 3 s on 2 cores
@pytest.mark.parametrize("collision", ["disc", "lidar"])
@pytest.mark.parametrize("margin", [0.0, 0.03, 0.08])
def test_a_collision_margin_ends_the_episode_within_the_padded_footprint(margin, collision):
    """env.collision_margin: a robot standing still (the vw set's stop) and facing a wall
    collides, pays R- and ends its episode exactly where its centre is closer to the wall
    than the robot's radius plus the margin, by a NumPy point-to-wall distance (which the
    beam straight ahead reads too); 0 is the real disc."""
    env, params = jaxnav.make(
        "square4",
        actions="vw",
        reward="progress",
        R_minus=-7.0,
        collision_margin=margin,
        collision=collision,
    )
    stop = ACTION_SETS["vw"].index((0.0, 0.0))
    walls, circles = maze_geometry(params.maze)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    xs = np.linspace(1.60, 1.80, 41)  # towards the wall at x = 1.85
    centres = np.stack([xs, np.zeros_like(xs)], axis=1)
    gap = reference_clearance(centres, walls, circles)
    outcomes = []
    for centre, g in zip(centres, gap, strict=True):
        at = state.replace(pos=jnp.asarray(centre, jnp.float32), yaw=jnp.float32(0.0))
        _, _, r, term, _, info = env.step_env(jax.random.PRNGKey(1), at, jnp.int32(stop), params)
        expected = g < params.robot_radius + margin
        if abs(g - (params.robot_radius + margin)) > 1e-4:  # clear of the threshold
            assert bool(info["collision"]) == expected == bool(term), (centre, g)
            assert (float(r) == -7.0) == expected
        outcomes.append(bool(info["collision"]))
    assert any(outcomes) and not all(outcomes)


def test_a_run_with_a_collision_margin_is_tested_with_real_collisions(tmp_path):
    """env.collision_margin shapes training only: the test and the periodic evaluation
    count real collisions unless a test setting asks for the margin."""
    from jaxnav.core.config import dump_config
    from jaxnav.experiments.evaluation import tested_config
    from jaxnav.run.greedy import evaluation_env

    cfg = load_config(None, ["env.maze=stage4", "env.collision_margin=0.05"])
    path = tmp_path / "config.yaml"
    path.write_text(dump_config(cfg))
    assert tested_config(path).env.collision_margin == 0.0
    assert tested_config(path, ["env.collision_margin=0.02"]).env.collision_margin == 0.02
    env, _ = jaxnav.make("stage4", collision_margin=0.05, motion_pace=(0.5, 2.0))
    tested = evaluation_env(env)
    assert (tested.collision_margin, tested.motion_pace) == (0.0, (1.0, 1.0))


def test_the_scan_history_holds_the_previous_scans_newest_first():
    env, params = jaxnav.make("stage4", observation="normalised", scan_history=2)
    obs0, s = env.reset(jax.random.PRNGKey(0), params)
    n = env.n_beams
    assert env.obs_size == 3 * n + 4 and obs0.shape == (env.obs_size,)
    np.testing.assert_array_equal(obs0[n + 4 :], np.tile(obs0[:n], 2))  # a start: copies
    obs1, s1, *_ = env.step(jax.random.PRNGKey(1), s, jnp.int32(2), params)
    obs2, s2, *_ = env.step(jax.random.PRNGKey(2), s1, jnp.int32(2), params)
    np.testing.assert_array_equal(obs2[n + 4 : 2 * n + 4], obs1[:n])
    np.testing.assert_array_equal(obs2[2 * n + 4 :], obs0[:n])


@pytest.mark.slow  # 3 s on 2 cores
def test_the_history_changes_are_each_beams_change_since_each_earlier_scan():
    """With env.history_changes the history part is (this scan - that scan) x 10 clipped
    to [-1, 1], computed here from the plain history of the same steps."""
    plain, params = jaxnav.make("stage4", observation="normalised", scan_history=2)
    changes, _ = jaxnav.make(
        "stage4", observation="normalised", scan_history=2, history_changes=True
    )
    n = plain.n_beams
    obs_c, s_c = changes.reset(jax.random.PRNGKey(0), params)
    obs, s = plain.reset(jax.random.PRNGKey(0), params)
    np.testing.assert_array_equal(obs_c[n + 4 :], 0.0)  # a start: no change yet
    seen = 0.0
    for k in range(12):  # full speed ahead: the walls and the cylinders come closer
        key = jax.random.PRNGKey(k + 1)
        obs, s, *_ = plain.step(key, s, jnp.int32(12), params)
        obs_c, s_c, *_ = changes.step(key, s_c, jnp.int32(12), params)
        np.testing.assert_array_equal(obs_c[: n + 4], obs[: n + 4])
        past = np.asarray(obs[n + 4 :]).reshape(2, n)
        want = np.clip((np.asarray(obs[:n])[None] - past) * 10.0, -1.0, 1.0)
        np.testing.assert_allclose(np.asarray(obs_c[n + 4 :]).reshape(2, n), want, atol=1e-6)
        seen = max(seen, float(np.abs(want).max()))
    assert seen > 0.1
    space = changes.observation_space(params)
    assert float(space.low[-1]) == -1.0 and float(space.high[-1]) == 1.0


def test_turned_changes_follow_their_rule_beam_by_beam():
    from jaxnav.world.sensor import turned_changes

    rng = np.random.default_rng(3)
    now = rng.uniform(0.05, 1.0, 24).astype(np.float32)
    old = rng.uniform(0.05, 1.0, (3, 24)).astype(np.float32)
    turned = np.array([0.1, -2.9, 4.0], np.float32)  # either way, and past pi
    got = np.asarray(turned_changes(jnp.asarray(now), jnp.asarray(old), jnp.asarray(turned)))
    np.testing.assert_allclose(got, turned_changes_by_hand(now, old, turned), atol=1e-5)


def test_turned_changes_see_a_turn_by_whole_beams_as_none_and_no_turn_as_plain_changes():
    """A scan turned by m whole beams (beam i now reads what beam i + m read) changes
    no beam once turned back; with no turn the changes are the plain ones."""
    from jaxnav.world.sensor import history_changes, turned_changes

    rng = np.random.default_rng(4)
    now = rng.uniform(0.05, 1.0, 24).astype(np.float32)
    shifts = [1, -3, 7]
    old = np.stack([np.roll(now, m) for m in shifts])  # old_j[i + m] = now[i]
    turned = jnp.asarray([m * 2 * math.pi / 24 for m in shifts], jnp.float32)
    np.testing.assert_allclose(turned_changes(now, old, turned), 0.0, atol=1e-5)
    assert float(jnp.abs(history_changes(now, old)).max()) == 1.0  # unturned: large
    other = rng.uniform(0.05, 1.0, (3, 24)).astype(np.float32)
    np.testing.assert_array_equal(
        turned_changes(now, other, jnp.zeros(3)), history_changes(now, other)
    )


@pytest.mark.parametrize("turned", [False, True])
def test_turning_in_place_changes_little_once_the_history_is_turned(turned):
    """The robot turns in place (stop, 1.5 rad/s: 17 degrees a step, more than a beam)
    in square4: the plain changes read every beam as moved; turned to the heading now,
    the scans change only where a corner lies between two beams."""
    env, params = jaxnav.make(
        "square4",
        observation="normalised",
        actions="vw",
        scan_history=3,
        history_changes=True,
        history_turned=turned,
    )
    n = env.n_beams
    obs, state = env.reset(jax.random.PRNGKey(0), params)
    step = jax.jit(env.step_env)
    changes = []
    for k in range(6):
        obs, state, *_ = step(jax.random.PRNGKey(k), state, jnp.int32(4), params)
        changes.append(float(np.abs(np.asarray(obs[n + 4 :])).mean()))
    if turned:
        # the history the next step sees: this step's scan first, taken at this heading
        np.testing.assert_allclose(state.scan_yaws, state.yaw - 0.3 * np.arange(3), atol=1e-5)
        assert max(changes) < 0.1
    else:
        assert min(changes) > 0.4


def test_the_learning_rate_falls_linearly_to_zero():
    """Adam on a constant gradient moves each step by its learning rate (its moments
    are then exactly the gradient and its square): the steps are lr (1 - k / N)."""
    from jaxnav.agent.qlearning import optimizer_of

    cfg = load_config("pqn", ["dqn.optimizer=adam", "dqn.lr=0.01"])
    opt = optimizer_of(cfg.dqn, "adam", decay_steps=10)
    params = jnp.zeros(3)
    state = opt.init(params)
    moves = []
    for _ in range(12):
        upd, state = opt.update(jnp.ones(3), state, params)
        moves.append(-float(upd[0]))
    expected = [0.01 * max(0.0, 1 - k / 10) for k in range(12)]
    np.testing.assert_allclose(moves, expected, rtol=1e-5, atol=1e-9)


@pytest.mark.parametrize(
    "overrides, message",
    [
        (["env.scan_beams=30"], "must be 0 or a multiple of env.n_beams"),
        (["env.scan_history=2"], "needs env.observation normalised"),
        (["env.observe_moving=2"], "env.observe_moving is part of the normalised observation"),
        (["env.motion_pace=[0,1]", "env.generator=grid"], "drawn mazes have none"),
        (["env.motion_pace=[1,0.5]"], "env.motion_pace must be"),
        (["env.collision_margin=-0.01"], "env.collision_margin must be in"),
        (["env.collision_margin=0.5"], "env.collision_margin must be in"),
        (["env.observation=normalised", "env.history_changes=true"], "needs env.scan_history"),
        (
            ["env.observation=normalised", "env.scan_history=2", "env.history_turned=true"],
            "needs env.history_changes true",
        ),
        (
            [
                "env.observation=normalised",
                "env.scan_history=2",
                "env.history_changes=true",
                "env.history_turned=true",
                "env.beam_layout=gazebo",
            ],
            "needs env.beam_layout even",
        ),
        (["dqn.lr_decay=true", "total_steps=null"], "dqn.lr_decay needs total_steps"),
        (["env.actions=fast"], "env.actions must be paper or paper_stop or vw or vw_reverse"),
        (["env.reward=progress", "env.proximity_distance=0"], "env.proximity_distance"),
    ],
)
def test_settings_that_cannot_work_are_refused_in_one_line(overrides, message):
    with pytest.raises(ConfigError, match=message):
        load_config(None, overrides)
