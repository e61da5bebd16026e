"""ROBOTIS' stages 3 and 4: their moving cylinders, seen by the LiDAR and collided with
over the whole step, against an independent NumPy account of the same motion laws."""

from __future__ import annotations

import math

import _nav_reference as ref
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
from jaxnav.world import motion, stages
from jaxnav.world.maps import make_maze, stack_mazes

STRAIGHT = 2  # the paper's action with omega = 0


# ----------------------------------------------------------------------------
# An independent account of the motion laws (from the stage tables, in float64)
# ----------------------------------------------------------------------------


def stage3_centres(time: float, spin: float = 0.5) -> np.ndarray:
    """The four stage-3 cylinders after ``time`` s: (+-0.6, +-0.6) turned by spin * t."""
    a = spin * time
    p = np.array([(0.6, 0.6), (-0.6, 0.6), (-0.6, -0.6), (0.6, -0.6)])
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return p @ rot.T


def waypoint_loop(waypoints, steps, time: float) -> np.ndarray:
    """Where a stage-4 node's obstacle is after ``time`` s: each leg from waypoint i to
    i + 1 at |step i| per 0.1 s, walked leg by leg."""
    pts = [np.asarray(w, float) for w in waypoints] + [np.asarray(waypoints[0], float)]
    durations = [
        np.linalg.norm(pts[i + 1] - pts[i]) / (math.hypot(*steps[i]) / 0.1)
        for i in range(len(steps))
    ]
    t = time % sum(durations)
    for i, d in enumerate(durations):
        if t <= d:
            return pts[i] + (pts[i + 1] - pts[i]) * (t / d)
        t -= d
    return pts[0]


def stage4_centres(time: float) -> np.ndarray:
    return np.stack(
        [
            waypoint_loop(stages.OBSTACLE_1_WAYPOINTS, stages.OBSTACLE_1_STEPS, time),
            waypoint_loop(stages.OBSTACLE_2_WAYPOINTS, stages.OBSTACLE_2_STEPS, time),
        ]
    )


# ----------------------------------------------------------------------------


@pytest.mark.parametrize("time", [0.0, 0.2, 3.7, 12.0, 40.1])
def test_stage3_cylinders_spin_about_the_centre(time):
    m = make_maze("stage3")
    got = np.asarray(motion.positions(m.motion, jnp.float32(time)))
    np.testing.assert_allclose(got, stage3_centres(time), atol=1e-5)


@pytest.mark.parametrize("time", [0.0, 1.0, 9.99, 33.3, 77.0, 151.0, 400.0])
def test_stage4_cylinders_follow_the_nodes_waypoint_loops(time):
    m = make_maze("stage4")
    got = np.asarray(motion.positions(m.motion, jnp.float32(time)))
    np.testing.assert_allclose(got, stage4_centres(time), atol=2e-4)


def test_stage4_loops_are_as_long_as_robotis_nodes_drive_them():
    """The spec's loop lengths (about 17.7 m and 18.5 m) and the plaza's shape."""
    for waypoints, length in (
        (stages.OBSTACLE_1_WAYPOINTS, 17.7),
        (stages.OBSTACLE_2_WAYPOINTS, 18.5),
    ):
        pts = np.asarray(list(waypoints) + [waypoints[0]], float)
        assert np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() == pytest.approx(length, abs=0.1)
    m = make_maze("stage4")
    np.testing.assert_allclose(np.asarray(m.start), [-0.7, 0.0, 0.0])
    np.testing.assert_allclose(np.asarray(m.bounds), [-2.35, -2.35, 2.35, 2.35], atol=1e-6)
    assert len(m.walls()) == 4 + 8 * 4  # the outline and eight 1 x 0.15 m walls
    assert int(m.n_obstacles) == 8 + 2 and m.has_obstacles
    assert len(make_maze("stage4_humble").walls()) == 4 + 7 * 4


def test_the_state_holds_every_cylinder_where_it_is_at_the_step():
    env, params = jaxnav.make("stage3")
    _, state = env.reset(jax.random.PRNGKey(0), params)
    step = jax.jit(env.step_env)
    for t in range(1, 6):
        _, state, *_ = step(jax.random.PRNGKey(t), state, jnp.int32(STRAIGHT), params)
        real = np.asarray(state.circles)[np.asarray(state.circles)[:, 2] > 0]
        np.testing.assert_allclose(real[:, :2], stage3_centres(0.2 * t), atol=1e-5)
        np.testing.assert_allclose(real[:, 2], 0.15)
    env, params = jaxnav.make("square4_obstacles")  # static cylinders are there too
    _, state = env.reset(jax.random.PRNGKey(0), params)
    np.testing.assert_allclose(np.asarray(state.circles), np.asarray(params.maze.circles))


def _observe(env, params, pos, yaw: float, time: float) -> np.ndarray:
    """The observation from pose (pos, yaw) at ``time`` s into an episode (the goal at
    the origin, the maze unscaled)."""
    pose = jnp.asarray(pos, jnp.float32)
    return np.asarray(
        env.observe(jax.random.PRNGKey(0), pose, yaw, jnp.zeros(2), params, 1.0, time)
    )


@pytest.mark.parametrize("name", ["stage3", "stage4"])
def test_the_lidar_sees_the_cylinders_where_they_are_at_the_scan(name):
    env, params = jaxnav.make(name, n_beams=360)
    walls = params.maze.walls().astype(np.float64)
    centres = stage3_centres if name == "stage3" else stage4_centres
    radius = 0.15 if name == "stage3" else 0.12
    rng = np.random.default_rng(0)
    pts = ref.sample_free(rng, params.maze, 6, 0.2)
    for i, pos in enumerate(pts):
        time = 0.2 * (7 * i + 3)
        yaw = float(rng.uniform(-np.pi, np.pi))
        circles = np.concatenate(
            [centres(time), np.full((2 if name == "stage4" else 4, 1), radius)], 1
        )
        want = ref.lidar(pos[None], np.array([yaw]), walls, circles, 360)[0]
        obs = _observe(env, params, pos, yaw, time)
        np.testing.assert_allclose(np.asarray(obs[:360]), want, atol=2e-4)


def _brute_clearance(pos, yaw, omega, dt, centres_at, radius, n=4001) -> float:
    """Dense sampling of the true relative motion over the step (float64)."""
    s = np.linspace(0.0, dt, n)
    robot, _ = ref.unicycle(np.broadcast_to(pos, (n, 2)), np.full(n, yaw), np.full(n, omega), s)
    discs = np.stack([centres_at(si) for si in s])  # [n, M, 2]
    return float((np.linalg.norm(robot[:, None] - discs, axis=-1) - radius).min())


@pytest.mark.parametrize("seed", range(6))
def test_step_clearance_to_moving_cylinders_matches_dense_sampling(seed):
    rng = np.random.default_rng(seed)
    m = make_maze("stage3" if seed % 2 else "stage4")
    centres, radius = (stage3_centres, 0.15) if seed % 2 else (stage4_centres, 0.12)
    for _ in range(5):
        time0 = float(rng.uniform(0, 60))
        disc = centres(time0)[rng.integers(len(centres(time0)))]
        pos = disc + rng.uniform(-0.5, 0.5, 2)  # near a cylinder, so the minimum matters
        yaw, omega = float(rng.uniform(-np.pi, np.pi)), float(rng.choice(ref.OMEGAS))
        got = float(
            motion.moving_clearance(
                m.motion, jnp.asarray(pos, jnp.float32), yaw, omega, 0.15, 0.2, time0
            )
        )
        want = _brute_clearance(pos, yaw, omega, 0.2, lambda s, t0=time0: centres(t0 + s), radius)
        assert got == pytest.approx(want, abs=2e-4)


@pytest.mark.slow  # 3 s on 2 cores
def test_a_robot_driven_into_a_spinning_cylinder_collides_at_the_right_step():
    """Straight ahead from the start of stage 3: the first step whose sampled relative
    motion comes within the robot's radius of a cylinder is the step that ends it."""
    env, params = jaxnav.make("stage3")
    _, state = env.reset(jax.random.PRNGKey(0), params)
    state = state.replace(yaw=jnp.float32(0.3))  # towards the cylinders' ring
    want = None
    for t in range(40):
        pos = np.asarray(state.pos, np.float64)
        c = _brute_clearance(pos, 0.3, 0.0, 0.2, lambda s, t=t: stage3_centres(0.2 * t + s), 0.15)
        if want is None and c < ref.ROBOT_R:
            want = t
        _, state, _, term, _, _ = env.step_env(
            jax.random.PRNGKey(t), state, jnp.int32(STRAIGHT), params
        )
        if bool(term):
            assert t == want
            return
    pytest.fail("the robot never met a cylinder")


def test_a_cylinder_that_grazes_a_still_robot_mid_step_collides():
    """Only the motion over the step catches it: a still robot just outside the
    spinning ring is 0.276 m from a cylinder's centre half-way through the step and
    0.2803 m at both ends, so a test at the ends alone (0.28 m = robot + cylinder
    radius) would miss the contact."""
    m = make_maze("stage3")
    a = math.atan2(0.6, 0.6) + 0.5 * 0.1  # the first cylinder's angle 0.1 s in
    pos = (0.6 * math.sqrt(2) + 0.276) * np.array([math.cos(a), math.sin(a)])
    ends = [np.linalg.norm(stage3_centres(s)[0] - pos) - 0.15 for s in (0.0, 0.2)]
    assert min(ends) > ref.ROBOT_R  # no contact at either end
    clear = motion.moving_clearance(
        m.motion, jnp.asarray(pos, jnp.float32), 0.0, 0.0, 0.0, 0.2, 0.0
    )
    assert float(clear) == pytest.approx(0.276 - 0.15, abs=1e-5)
    assert float(clear) < ref.ROBOT_R


@pytest.mark.parametrize("gap", [0.05, 0.2, 0.45, 0.8])
def test_the_moving_proximity_penalty_is_taken_by_hand_near_a_passing_cylinder(gap):
    """A robot standing still (the vw set's stop) ``gap`` m beyond contact with stage
    4's first cylinder 10 s into an episode: the penalty taken is the setting times
    1 - c / 0.5, c its least clearance to either cylinder over the step, found by
    sampling the cylinders' own laws (0 from 0.5 m on); walls and goal are unchanged."""
    stop, penalty, distance, radius, t = 2, 0.7, 0.5, 0.12, 50
    centre = stage4_centres(0.2 * t)[0]
    out = centre - np.asarray([-0.7, 0.0])  # from the start towards the cylinder
    pos = centre - out / np.linalg.norm(out) * (radius + ref.ROBOT_R + gap)
    rewards = []
    for on in (0.0, penalty):
        kw = {"moving_proximity_penalty": on} if on else {}
        env, params = jaxnav.make("stage4", reward="progress", actions="vw", **kw)
        _, state = env.reset(jax.random.PRNGKey(0), params)
        state = state.replace(pos=jnp.asarray(pos, jnp.float32), t=jnp.int32(t))
        _, _, reward, term, _, info = env.step_env(
            jax.random.PRNGKey(1), state, jnp.int32(stop), params
        )
        assert not bool(term) and not bool(info["goal_reached"])
        rewards.append(float(reward))
    s = np.linspace(0.0, 0.2, 4001)
    discs = np.stack([stage4_centres(0.2 * t + si) for si in s])  # [n, 2, 2]
    c = (np.linalg.norm(discs - pos, axis=-1) - radius).min() - ref.ROBOT_R
    want = penalty * min(max(1.0 - c / distance, 0.0), 1.0)
    assert rewards[0] - rewards[1] == pytest.approx(want, abs=1e-4)
    assert (want > 0) == (gap < distance)


def test_a_moving_proximity_penalty_where_nothing_moves_or_without_progress_is_refused():
    with pytest.raises(ValueError, match="maze 'square4' has none"):
        jaxnav.make("square4", reward="progress", moving_proximity_penalty=1.0)
    with pytest.raises(ValueError, match="needs env.reward progress"):
        jaxnav.make("stage4", moving_proximity_penalty=1.0)


@pytest.mark.slow
def test_mazes_that_move_and_mazes_that_stand_still_stack_and_vmap():
    """A still maze stacked beside stages carries parked cylinders that nothing sees."""
    names = ["square4", "stage3", "stage4"]
    stacked = stack_mazes([make_maze(n) for n in names])
    env, params = jaxnav.make("square4")
    params = jax.vmap(lambda m: params.replace(maze=m))(stacked)
    obs, state = jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), 3), params)
    alone = [jaxnav.make(n)[0].reset(jax.random.PRNGKey(0), jaxnav.make(n)[1]) for n in names]
    for i, (_, s) in enumerate(alone):
        real = np.asarray(state.circles[i])[np.asarray(state.circles[i])[:, 2] > 0]
        np.testing.assert_allclose(real, np.asarray(s.circles)[np.asarray(s.circles)[:, 2] > 0])
    # square4's scan is unchanged by its parked cylinder
    env4, p4 = jaxnav.make("square4")
    np.testing.assert_allclose(
        np.asarray(env4.observe(jax.random.PRNGKey(0), jnp.zeros(2), 0.0, jnp.ones(2), p4)),
        np.asarray(
            env.observe(
                jax.random.PRNGKey(0),
                jnp.zeros(2),
                0.0,
                jnp.ones(2),
                jax.tree.map(lambda x: x[0], params),
            )
        ),
        atol=1e-6,
    )


def test_a_test_rollout_records_the_cylinders_where_they_were_at_each_step():
    from jaxnav.agent.hyper import hyper
    from jaxnav.core import agents
    from jaxnav.core.config import load_config
    from jaxnav.env import from_config
    from jaxnav.experiments.rollout import make_rollout

    cfg = load_config("stage3", ["env.max_steps=30"])
    env, params = from_config(cfg)
    net = agents.get(cfg.agent).network_of(cfg, env)
    weights = net.init(jax.random.PRNGKey(0), jnp.zeros(env.obs_size))
    rollout = make_rollout(env, net, 2, 30, record=True)
    res = jax.jit(rollout)(weights, jax.random.PRNGKey(1), jnp.int32(0), hyper(cfg), params)
    tr = res.trajectory
    for t in range(int(res.length[0])):  # the first episode: time t * dt
        real = np.asarray(tr.circles[t])[np.asarray(tr.circles[t])[:, 2] > 0]
        np.testing.assert_allclose(real[:, :2], stage3_centres(0.2 * t), atol=1e-5)


@pytest.mark.parametrize("name", ["stage3", "stage4"])
def test_observe_moving_gives_the_nearest_cylinders_in_the_robot_frame(name):
    """env.observe_moving against the stage tables' own motion laws, turned into the
    robot's frame by hand: offsets over the sensor's range, the next step's velocity
    over the burger's 0.22 m/s, nearest first, clipped to [-1, 1]."""
    k = 2
    env, params = jaxnav.make(name, observation="normalised", observe_moving=k)
    centres = stage3_centres if name == "stage3" else stage4_centres
    assert env.obs_size == 24 + 4 + 4 * k
    rng = np.random.default_rng(1)
    for i, pos in enumerate(ref.sample_free(rng, params.maze, 8, 0.2)):
        time, yaw = 0.2 * (11 * i + 2), float(rng.uniform(-np.pi, np.pi))
        now, soon = centres(time), centres(time + 0.2)
        turn = np.array([[math.cos(yaw), math.sin(yaw)], [-math.sin(yaw), math.cos(yaw)]])
        offset, velocity = (now - pos) @ turn.T, (soon - now) / 0.2 @ turn.T
        order = np.argsort(np.linalg.norm(offset, axis=1))[:k]
        rows = np.concatenate([offset[order] / 3.5, velocity[order] / 0.22], axis=1)
        want = np.clip(rows, -1.0, 1.0).reshape(-1)
        obs = _observe(env, params, pos, yaw, time)
        np.testing.assert_allclose(np.asarray(obs[-4 * k :]), want, atol=2e-4)
    # a maze with no moving cylinders reads zeros there, in the same layout
    env, params = jaxnav.make("square4_obstacles", observation="normalised", observe_moving=k)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    obs, *_ = env.step_env(jax.random.PRNGKey(1), state, jnp.int32(STRAIGHT), params)
    assert obs.shape == (env.obs_size,) and not np.any(np.asarray(obs[-4 * k :]))


@pytest.mark.parametrize("name, pace", [("stage3", 0.5), ("stage4", 1.5), ("stage4", 0.0)])
def test_a_paced_episode_moves_the_cylinders_along_their_own_laws_at_that_pace(name, pace):
    """env.motion_pace: the cylinders after t steps stand where the stage tables' laws
    put them at pace * t * dt (0: their first pose), seen by the LiDAR there too."""
    env, params = jaxnav.make(name, motion_pace=(pace, pace))
    centres = stage3_centres if name == "stage3" else stage4_centres
    _, state = env.reset(jax.random.PRNGKey(0), params)
    assert float(state.pace) == pytest.approx(pace)
    step = jax.jit(env.step_env)
    for t in range(1, 6):
        obs, state, *_ = step(jax.random.PRNGKey(t), state, jnp.int32(STRAIGHT), params)
        real = np.asarray(state.circles)[np.asarray(state.circles)[:, 2] > 0]
        np.testing.assert_allclose(real[:, :2], centres(pace * 0.2 * t), atol=1e-4)
    walls, radius = params.maze.walls().astype(np.float64), real[0, 2]
    circles = np.concatenate([centres(pace * 0.2 * 5), np.full((len(real), 1), radius)], 1)
    want = ref.lidar(np.asarray(state.pos)[None], np.asarray([state.yaw]), walls, circles, 24)
    np.testing.assert_allclose(np.asarray(obs[:24]), want[0], atol=2e-4)


def test_each_episode_draws_its_pace_and_off_leaves_the_state_as_it_was():
    env, params = jaxnav.make("stage4", motion_pace=(0.5, 2.0))
    paces = [float(env.reset(jax.random.PRNGKey(k), params)[1].pace) for k in range(40)]
    assert 0.5 <= min(paces) < 0.8 and 1.7 < max(paces) <= 2.0  # uniform over the range
    _, restarted = env.restart(
        jax.random.PRNGKey(99), env.reset(jax.random.PRNGKey(0), params)[1], params
    )
    assert float(restarted.pace) not in paces[:1]  # a restart draws again
    env, params = jaxnav.make("stage4")
    _, state = env.reset(jax.random.PRNGKey(0), params)
    assert state.pace is None  # no leaf: the paper's and every other run are unchanged


def test_a_pace_where_nothing_moves_is_refused():
    with pytest.raises(ValueError, match="env.motion_pace paces moving cylinders"):
        jaxnav.make("square4_obstacles", motion_pace=(0.0, 1.0))


def test_the_pace_curriculum_moves_the_range_to_the_own_pace_by_hand():
    """env.pace_curriculum f: at a share p of the budget the range is motion_pace moved
    min(p / f, 1) of the way to [1, 1]; every episode's pace is drawn from it."""
    env, params = jaxnav.make("stage3", motion_pace=(0.0, 0.5), pace_curriculum=0.5, progress=0.0)
    for p, want in ((0.0, (0.0, 0.5)), (0.25, (0.5, 0.75)), (0.5, (1.0, 1.0)), (0.9, (1.0, 1.0))):
        np.testing.assert_allclose(np.asarray(env.at_progress(params, p).pace_range), want)
    late = env.at_progress(params, 0.25)
    paces = [float(env.reset(jax.random.PRNGKey(k), late)[1].pace) for k in range(40)]
    assert 0.5 <= min(paces) < 0.55 and 0.7 < max(paces) <= 0.75
    _, restarted = env.restart(jax.random.PRNGKey(7), env.reset(jax.random.PRNGKey(0), params)[1],
                               env.at_progress(params, 1.0))  # fmt: skip
    assert float(restarted.pace) == 1.0
    # off: the parameters pass through untouched, and the draw is motion_pace's
    env, params = jaxnav.make("stage3", motion_pace=(0.0, 0.5))
    assert env.at_progress(params, 0.7) is params and params.pace_range is None


def test_a_pace_curriculum_without_a_pace_range_or_a_budget_is_refused():
    from jaxnav.core.config import load_config
    from jaxnav.core.errors import ConfigError

    with pytest.raises(ValueError, match="env.pace_curriculum moves env.motion_pace"):
        jaxnav.make("stage3", pace_curriculum=0.5)
    with pytest.raises(ConfigError, match="env.pace_curriculum needs total_steps"):
        load_config(None, ["env.maze=stage3", "env.motion_pace=[0,1]", "env.pace_curriculum=0.5"])
