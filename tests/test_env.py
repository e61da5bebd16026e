"""The navigation environment against the spec: motion, collisions, rewards, goals,
episodes, and the jit/vmap contract (gymnax 1.0 style API)."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import _nav_reference as ref
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import jaxnav
from jaxnav.core.config import build_config
from jaxnav.env import EnvParams, EnvState, NavEnv, from_config
from jaxnav.world.maps import BUILTIN_MAZES, GOAL_CLEARANCE, make_maze, stack_mazes
from jaxnav.world.reward import psi, reward_fn
from jaxnav.world.stages import STAGES

CORRIDOR = str(Path(__file__).resolve().parents[1] / "configs" / "mazes" / "corridor.yaml")
# The mazes that stand still (the stages' moving cylinders: tests/test_moving.py).
STILL = [n for n in BUILTIN_MAZES if n not in STAGES]
NAMES = (*STILL, "corridor")
MAZES = {n: make_maze(CORRIDOR if n == "corridor" else n) for n in NAMES}
# All mazes padded to one shape: one compiled step serves every maze.
STACK = stack_mazes([MAZES[n] for n in NAMES])
PI32 = float(np.float32(np.pi))  # float32's pi is a hair above the real one
HYP = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)


def padded(name: str):
    i = NAMES.index(name)
    return jax.tree.map(lambda x: x[i], STACK)


# Compiling a step costs seconds on a CPU, so the tests share a few compiled
# functions: one env (stage-2 observation) and padded mazes, params as arguments.
ENV = NavEnv(obstacle_obs=True)
N_BATCH = 1000


@functools.cache
def jitted(env: NavEnv):
    """Compiled reset/step/step_env for one env (static shapes), and vmapped ones."""
    return dict(
        reset=jax.jit(env.reset),
        step=jax.jit(env.step),
        step_env=jax.jit(env.step_env),
        vreset=jax.jit(jax.vmap(env.reset, in_axes=(0, None))),
        vstep=jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None))),
        observe=jax.jit(env.observe),
    )


def make(name: str, preset: str = "paper", **kw):
    """jaxnav.make on the padded maze, so every test shares the compiled step."""
    env, params = jaxnav.make(padded(name), preset, obstacle_obs=True, **kw)
    assert env == ENV or kw
    return env, params


@functools.cache
def _template() -> EnvState:
    """A real state from reset; tests replace the fields they set (so new fields keep
    their reset values)."""
    return jitted(ENV)["reset"](KEY, EnvParams(maze=padded("square4")))[1]


def state_at(pos, yaw, goal=(1.2, 1.2), t=0):
    pos = jnp.asarray(pos, jnp.float32)
    goal = jnp.asarray(goal, jnp.float32)
    return _template().replace(
        pos=pos,
        yaw=jnp.asarray(yaw, jnp.float32),
        goal=goal,
        t=jnp.asarray(t, jnp.int32),
        goal_distance0=jnp.linalg.norm(goal - pos),
    )


def batch_of_states(pos, yaw):
    """Stacked states at poses (N, 2), (N,)."""
    n = len(pos)
    batch = jax.tree.map(lambda x: jnp.broadcast_to(x, (n, *x.shape)), _template())
    return batch.replace(pos=jnp.asarray(pos, jnp.float32), yaw=jnp.asarray(yaw, jnp.float32))


def f32(x):
    """Round to float32 and back: the value jaxnav actually sees."""
    return np.asarray(np.asarray(x, np.float32), np.float64)


KEY = jax.random.PRNGKey(0)


# ----------------------------------------------------------------------------
# Motion
# ----------------------------------------------------------------------------


@settings(max_examples=60, **HYP)
@given(
    x=st.floats(-3.0, 3.0),
    y=st.floats(-3.0, 3.0),
    yaw=st.floats(-math.pi, math.pi),
    action=st.integers(0, 4),
)
def test_step_is_the_exact_unicycle_arc(x, y, yaw, action):
    # Spec: v = 0.15 m/s, omega from paper Table 1, dt = 0.2 s; closed form of the arc.
    params = EnvParams(maze=padded("square8"))
    step_env = jitted(ENV)["step_env"]
    _, s, *_ = step_env(KEY, state_at((x, y), yaw), action, params)
    x32, y32, yaw32 = (float(np.float32(v)) for v in (x, y, yaw))
    want_pos, want_yaw = ref.unicycle(np.array([x32, y32]), yaw32, ref.OMEGAS[action], ref.DT)
    np.testing.assert_allclose(np.asarray(s.pos), want_pos, atol=2e-6)
    assert abs(ref.wrap(float(s.yaw) - want_yaw)) < 2e-6


def test_fifty_steps_of_hard_left_trace_the_turning_circle():
    # omega = 1.5 rad/s at 0.15 m/s: a circle of radius 0.1 m around (0, 0.1).
    params = EnvParams(maze=padded("square4"))
    step_env = jitted(ENV)["step_env"]
    s = state_at((0.0, 0.0), 0.0)
    for _ in range(50):
        _, s, _, term, _, _ = step_env(KEY, s, 4, params)
        assert not term
    want, want_yaw = ref.unicycle(np.zeros(2), 0.0, 1.5, 50 * ref.DT)
    np.testing.assert_allclose(np.asarray(s.pos), want, atol=1e-5)
    assert abs(ref.wrap(float(s.yaw) - want_yaw)) < 1e-5
    assert abs(np.hypot(float(s.pos[0]), float(s.pos[1]) - 0.1) - 0.1) < 1e-5


@settings(max_examples=60, **HYP)
@given(yaw=st.floats(-4 * math.pi, 4 * math.pi), action=st.integers(0, 4))
def test_yaw_and_heading_stay_wrapped(yaw, action):
    params = EnvParams(maze=padded("square4"))
    step_env = jitted(ENV)["step_env"]
    obs, s, *_ = step_env(KEY, state_at((0.3, -0.2), yaw, goal=(-1.0, 0.7)), action, params)
    assert -PI32 <= float(s.yaw) < PI32
    assert -PI32 <= float(obs[ENV.n_beams]) < PI32  # heading to the goal


# ----------------------------------------------------------------------------
# Collisions: compare with a dense sampling of the true arc
# ----------------------------------------------------------------------------

BAND = 1e-4  # m: 400 samples of a 3 cm arc are 7.5e-5 m apart; float32 besides


def check_collision_flag(maze_name, pos, yaw, action, collided, end_pos):
    """Returns True when the case was decisive (outside the tolerance band)."""
    walls, circles = ref.maze_geometry(MAZES[maze_name])
    pos = np.asarray(np.float32(pos), np.float64)
    yaw = float(np.float32(yaw))
    d = ref.path_min_clearance(pos, yaw, ref.OMEGAS[action], walls, circles, n=400)
    if d < ref.ROBOT_R - BAND:
        assert collided, f"{maze_name}: path from {pos} yaw {yaw} a{action} comes {d:.5f} m close"
    elif d > ref.ROBOT_R + BAND:
        assert not collided, (
            f"{maze_name}: false collision from {pos} yaw {yaw} a{action}, {d:.5f} m"
        )
    else:
        return False
    if not collided:  # it did not go through a wall either
        end = np.asarray(end_pos, np.float64)[None]
        assert ref.in_free_space(end, walls, circles, ref.ROBOT_R - BAND)[0]
    return True


@st.composite
def pose_near_a_surface(draw):
    """A pose near a wall or cylinder, roughly facing it (or random), in free space."""
    name = draw(st.sampled_from(NAMES))
    walls, circles = ref.maze_geometry(MAZES[name])
    gap = draw(st.floats(0.10, 0.20))  # centre's distance to the surface
    turn = draw(st.floats(-1.6, 1.6))  # yaw relative to facing the surface
    if len(circles) and draw(st.booleans()):
        cx, cy, r = circles[draw(st.integers(0, len(circles) - 1))]
        ang = draw(st.floats(-math.pi, math.pi))
        pos = np.array([cx, cy]) + (r + gap) * np.array([math.cos(ang), math.sin(ang)])
        facing = ang + math.pi
    else:
        x1, y1, x2, y2 = walls[draw(st.integers(0, len(walls) - 1))]
        u = draw(st.floats(0.0, 1.0))
        foot = np.array([x1 + u * (x2 - x1), y1 + u * (y2 - y1)])
        n = np.array([-(y2 - y1), x2 - x1]) / math.hypot(x2 - x1, y2 - y1)
        side = 1.0 if draw(st.booleans()) else -1.0
        pos = foot + side * gap * n
        facing = math.atan2(-side * n[1], -side * n[0])
    assume(ref.inside_walls(pos[None], walls)[0])
    if len(circles):
        assume((np.hypot(*(pos[None] - circles[:, :2]).T) > circles[:, 2]).all())
    yaw = float(ref.wrap(facing + turn))
    return name, pos, yaw, draw(st.integers(0, 4))


@settings(max_examples=150, **HYP)
@given(case=pose_near_a_surface())
def test_robot_cannot_pass_through_a_wall_unnoticed(case):
    name, pos, yaw, action = case
    step_env = jitted(ENV)["step_env"]
    _, s, _, term, _, info = step_env(KEY, state_at(pos, yaw), action, EnvParams(maze=padded(name)))
    assert bool(term) == bool(info["collision"])
    check_collision_flag(name, pos, yaw, action, bool(info["collision"]), s.pos)


@pytest.mark.parametrize("name", NAMES)
def test_collision_flag_matches_dense_arc_sampling(name):
    """A thousand poses within a step's reach of a surface, random actions."""
    rng = np.random.default_rng(7)
    walls, circles = ref.maze_geometry(MAZES[name])
    pts = np.zeros((0, 2))
    while len(pts) < N_BATCH:
        cand = ref.sample_free(rng, MAZES[name], 4000, 0.08)
        pts = np.concatenate([pts, cand[ref.clearance(cand, walls, circles) < 0.2]])
    pts = f32(pts[:N_BATCH])
    yaw = f32(rng.uniform(-np.pi, np.pi, N_BATCH))
    actions = rng.integers(0, 5, N_BATCH)
    states = batch_of_states(pts, yaw)
    _, s, _, term, _, info = jitted(ENV)["vstep"](
        jax.random.split(KEY, N_BATCH), states, jnp.asarray(actions), EnvParams(maze=padded(name))
    )
    collided = np.asarray(info["collision"])
    assert (collided == np.asarray(term)).all()
    d = ref.path_min_clearance_batch(pts, yaw, ref.OMEGAS[actions], walls, circles)
    must, must_not = d < ref.ROBOT_R - BAND, d > ref.ROBOT_R + BAND
    missed = np.flatnonzero(must & ~collided)
    assert not len(missed), f"{name}: missed collisions at {pts[missed[:3]]}, {yaw[missed[:3]]}"
    false = np.flatnonzero(must_not & collided)
    assert not len(false), f"{name}: false collisions at {pts[false[:3]]}, {yaw[false[:3]]}"
    assert (must | must_not).mean() > 0.95  # few cases inside the tolerance band
    assert 0.05 < collided.mean() < 0.95  # both outcomes exercised
    end = np.asarray(s.pos, np.float64)[~collided]  # no reset there (t = 1)
    assert ref.in_free_space(end, walls, circles, ref.ROBOT_R - BAND).all()


@pytest.mark.parametrize("name", ["square2", "triangle", "square4_obstacles", "corridor"])
def test_a_glancing_arc_that_dips_within_the_radius_mid_step_collides(name):
    """The robot passes a wall or cylinder while turning away from it: the closest
    approach is mid-step, about 1 mm nearer than either end. 0.3 mm inside the
    radius is a collision, 0.3 mm outside is not."""
    walls, circles = ref.maze_geometry(MAZES[name])
    cases = []  # (pos, yaw, action, should collide)
    for x1, y1, x2, y2 in walls:
        foot = np.array([(x1 + x2) / 2, (y1 + y2) / 2])
        e = np.array([x2 - x1, y2 - y1]) / math.hypot(x2 - x1, y2 - y1)
        for n in (np.array([-e[1], e[0]]), np.array([e[1], -e[0]])):
            if ref.in_free_space((foot + 0.2 * n)[None], walls, circles, 0.15)[0]:
                cases += glancing(foot, n)
    for cx, cy, r in circles:
        for ang in np.linspace(0, 2 * np.pi, 8, endpoint=False):
            n = np.array([math.cos(ang), math.sin(ang)])
            c = np.array([cx, cy]) + r * n
            if ref.in_free_space((c + 0.2 * n)[None], walls, circles, 0.15)[0]:
                cases += glancing(c, n)
    assert len(cases) >= 16
    step_env = jitted(ENV)["step_env"]
    params = EnvParams(maze=padded(name))
    for pos, yaw, action, expect in cases:
        d = ref.path_min_clearance(
            f32(pos), float(np.float32(yaw)), ref.OMEGAS[action], walls, circles
        )
        assert (d < 0.13) == expect  # the construction is right
        _, _, _, term, _, _ = step_env(KEY, state_at(pos, yaw), action, params)
        assert bool(term) == expect, (name, pos, yaw, action, d)


def glancing(point, n):
    """Poses whose step's arc is tangent, mid-step, to the line through ``point``
    with free-side normal ``n``, 0.13 -+ 0.3 mm from it, for the four turning actions."""
    cases = []
    for action in (0, 1, 3, 4):
        w = ref.OMEGAS[action]
        # Mid-step heading along the surface, turning away from it.
        t = np.array([n[1], -n[0]]) if w > 0 else np.array([-n[1], n[0]])
        yaw_mid = math.atan2(t[1], t[0])
        for gap, expect in ((0.13 - 3e-4, True), (0.13 + 3e-4, False)):
            mid = point + gap * n
            pos, yaw = ref.unicycle(mid, yaw_mid, w, -ref.DT / 2)  # back up half a step
            cases.append((pos, float(ref.wrap(yaw)), action, expect))
    return cases


# ----------------------------------------------------------------------------
# Rewards (spec table: presets paper and robotis)
# ----------------------------------------------------------------------------


def test_presets_hold_the_spec_constants():
    for maze, preset, R_plus, R_minus, span, exp in (
        ("square4", "paper", 1000, -150, math.pi / 2, False),
        ("square4_obstacles", "paper", 1000, -150, math.pi / 2, False),
        ("square4", "robotis", 200, -200, math.pi / 4, True),  # stage 1
        ("square4_obstacles", "robotis", 200, -150, math.pi / 4, True),  # stage 2
    ):
        env, p = jaxnav.make(maze, preset)
        assert (p.R_plus, p.R_minus, p.reward_span, bool(p.reward_distance_exp)) == pytest.approx(
            (R_plus, R_minus, span, exp)
        ), (maze, preset)
        assert (p.v, p.dt, p.robot_radius, p.goal_radius, p.max_steps) == pytest.approx(
            (0.15, 0.2, 0.13, 0.2, 500)
        )
        assert (p.min_range, p.max_range) == pytest.approx((0.12, 3.5))
        np.testing.assert_allclose(np.asarray(p.omegas), ref.OMEGAS)
        assert env.n_beams == 24 and env.num_actions == 5
        assert env.obstacle_obs == (maze == "square4_obstacles")


@pytest.mark.parametrize("preset", ["paper", "robotis"])
@pytest.mark.parametrize("maze", ["square4", "square4_obstacles"])
def test_reaching_the_goal_pays_R_plus_and_draws_a_new_goal(preset, maze):
    env, params = make(maze, preset)
    goal = np.asarray(params.maze.goal_points[5])
    s0 = state_at(goal - np.array([0.1, 0.0]), 0.0, goal=goal)
    _, s, r, term, trunc, info = jitted(env)["step"](KEY, s0, 2, params)  # 3 cm on
    assert float(r) == params.R_plus and bool(info["goal_reached"])
    assert not term and not trunc  # the episode goes on (spec)
    assert not np.allclose(np.asarray(s.goal), goal)
    assert np.linalg.norm(np.asarray(s.goal) - goal) >= 1.0  # away from the last goal
    assert float(s.goal_distance0) == pytest.approx(
        float(jnp.linalg.norm(s.goal - s.pos)), abs=1e-5
    )
    assert int(s.t) == 1


@pytest.mark.parametrize("preset", ["paper", "robotis"])
@pytest.mark.parametrize("maze", ["square4", "square4_obstacles"])
def test_collision_pays_R_minus_and_ends_the_episode(preset, maze):
    env, params = make(maze, preset)
    _, s, r, term, trunc, info = jitted(env)["step"](KEY, state_at((1.70, 0.3), 0.0), 2, params)
    want = {"paper": -150.0, "robotis": -200.0 if maze == "square4" else -150.0}[preset]
    assert float(r) == want == params.R_minus
    assert bool(term) and not bool(trunc) and bool(info["collision"])


def test_collision_outranks_reaching_the_goal():
    _, params = make("square4")
    r = reward_fn(params, 2, 0.0, 0.1, 1.0, jnp.bool_(True), jnp.bool_(True))
    assert float(r) == -150.0


@settings(max_examples=60, **HYP)
@given(
    preset=st.sampled_from(["paper", "robotis"]),
    pos=st.tuples(st.floats(-1.3, 1.3), st.floats(-1.3, 1.3)),
    goal_i=st.integers(0, 800),
    yaw=st.floats(-math.pi, math.pi),
    action=st.integers(0, 4),
    d0=st.floats(0.5, 4.0),
)
def test_shaping_reward_is_5_psi_times_D(preset, pos, goal_i, yaw, action, d0):
    # Spec: R = 5 psi(delta - phi_a) D, phi_a = omega_a / omega_max * span,
    # D = d_c (paper) or 2^(d_c / d_0) (ROBOTIS), delta and d_c after the step.
    env, params = make("square4", preset)
    goal = np.asarray(params.maze.goal_points[goal_i], np.float64)
    assume(np.linalg.norm(goal - np.array(pos)) > 0.3)
    s0 = state_at(pos, yaw, goal=goal).replace(goal_distance0=jnp.float32(d0))
    _, s, r, term, _, info = jitted(env)["step_env"](KEY, s0, action, params)
    assert not term and not info["goal_reached"]
    pos1, yaw1 = ref.unicycle(f32(pos), float(np.float32(yaw)), ref.OMEGAS[action], ref.DT)
    rel = goal - pos1
    delta = ref.wrap(math.atan2(rel[1], rel[0]) - yaw1)
    dc = float(np.hypot(*rel))
    span = math.pi / 2 if preset == "paper" else math.pi / 4
    D = dc if preset == "paper" else 2 ** (dc / float(np.float32(d0)))
    want = 5 * ref.psi(delta - ref.OMEGAS[action] / 1.5 * span) * D
    assert float(r) == pytest.approx(want, abs=1e-4 * max(1.0, abs(want)))


def test_psi_is_the_triangle_wave():
    x = jnp.asarray([0.0, math.pi / 2, -math.pi / 2, math.pi, -math.pi, math.pi / 4, 2 * math.pi])
    np.testing.assert_allclose(np.asarray(psi(x)), [1, 0, 0, -1, -1, 0.5, 1], atol=1e-6)


@settings(max_examples=100, **HYP)
@given(
    preset=st.sampled_from(["paper", "robotis"]),
    delta=st.floats(-math.pi, math.pi),
    dc=st.floats(0.05, 5.0),
    d0=st.floats(0.3, 5.0),
)
def test_turning_towards_the_goal_earns_the_largest_shaping_reward(preset, delta, dc, d0):
    _, params = make("square4", preset)
    phi = ref.OMEGAS / 1.5 * params.reward_span  # direction each action turns towards
    gap = np.abs(ref.wrap(delta - phi))
    assume(np.sort(gap)[1] - np.sort(gap)[0] > 1e-4)  # no tie between two actions
    no = jnp.bool_(False)
    rewards = jax.vmap(lambda a: reward_fn(params, a, jnp.float32(delta), dc, d0, no, no))
    r = np.asarray(rewards(jnp.arange(5)))
    assert int(np.argmax(r)) == int(np.argmin(gap))


# ----------------------------------------------------------------------------
# Goals
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("name", NAMES)
def test_goals_are_drawn_in_free_space_with_clearance(name):
    params = EnvParams(maze=padded(name))  # padding rows of goal_points must never be drawn
    walls, circles = ref.maze_geometry(MAZES[name])
    n = 3000
    prev = ref.sample_free(np.random.default_rng(3), MAZES[name], n, 0.3)
    draw = jax.jit(jax.vmap(ENV.draw_goal, in_axes=(0, 0, None)))
    goals = np.asarray(draw(jax.random.split(KEY, n), jnp.asarray(prev, jnp.float32), params))
    assert ref.in_free_space(goals, walls, circles).all()
    assert ref.clearance(goals, walls, circles).min() >= GOAL_CLEARANCE - 1e-5
    assert GOAL_CLEARANCE > ref.ROBOT_R  # the robot can stand on any goal
    start = np.asarray(MAZES[name].start[:2])
    assert np.linalg.norm(goals - start, axis=1).min() >= 0.4 - 1e-5
    far = np.linalg.norm(goals - prev, axis=1) >= 1.0
    if name != "square2":  # square2's goal area is too small to always manage 1 m
        assert far.mean() > 0.99
    assert len(np.unique(goals, axis=0)) > min(50, int(MAZES[name].n_goal_points) // 2)


def goal_sequence(key, n=25):
    """Teleport onto each goal and step: every step reaches it and draws the next."""
    _, params = make("square4")
    fns = jitted(ENV)
    _, s = fns["reset"](key, params)
    goals = [np.asarray(s.goal)]
    for k in jax.random.split(key, n):
        _, s, _, _, _, info = fns["step"](k, s.replace(pos=s.goal), 2, params)
        assert bool(info["goal_reached"])
        goals.append(np.asarray(s.goal))
    return np.array(goals)


def test_same_key_same_goals_different_key_different_goals():
    a = goal_sequence(jax.random.PRNGKey(1))
    b = goal_sequence(jax.random.PRNGKey(1))
    c = goal_sequence(jax.random.PRNGKey(2))
    np.testing.assert_array_equal(a, b)
    assert (np.abs(a - c).sum(axis=1) > 0).mean() > 0.9
    assert len(np.unique(a, axis=0)) > 15
    assert (np.linalg.norm(np.diff(a, axis=0), axis=1) >= 1.0).all()


# ----------------------------------------------------------------------------
# Episodes: auto-reset and truncation
# ----------------------------------------------------------------------------


def test_after_a_collision_the_robot_restarts_at_the_start_with_its_goal():
    env, params = make("square4_obstacles")
    fns = jitted(env)
    goal = (-1.2, 1.0)
    s0 = state_at((1.70, 0.3), 0.0, goal=goal, t=17)
    obs, s, r, term, trunc, info = fns["step"](KEY, s0, 2, params)
    assert bool(term) and not bool(trunc) and float(r) == -150.0
    np.testing.assert_array_equal(np.asarray(s.pos), [0.0, 0.0])
    assert float(s.yaw) == 0.0 and int(s.t) == 0
    np.testing.assert_allclose(np.asarray(s.goal), goal)
    assert float(s.goal_distance0) == pytest.approx(math.hypot(*goal))
    # The returned observation is the start pose's; final_obs is the crash pose's.
    want_obs = fns["observe"](KEY, jnp.zeros(2), jnp.float32(0.0), jnp.asarray(goal), params)
    np.testing.assert_allclose(np.asarray(obs), np.asarray(want_obs), atol=1e-5)
    pre_obs, pre_s, *_ = fns["step_env"](jax.random.split(KEY)[0], s0, 2, params)
    np.testing.assert_allclose(np.asarray(info["final_obs"]), np.asarray(pre_obs), atol=1e-6)
    assert float(pre_s.pos[0]) > 1.72  # it did move into the wall's margin
    assert not np.allclose(np.asarray(info["final_obs"]), np.asarray(obs))


def _restart_goals(restart_goal: str, episodes: int = 4) -> list[tuple[float, float]]:
    """The goal of each episode when a policy drives straight on from square4's start
    until it hits the east wall, again and again (a deterministic failure)."""
    env, params = make("square4", restart_goal=restart_goal)
    fns = jitted(env)
    _, s = fns["reset"](KEY, params)
    goals, key = [tuple(np.asarray(s.goal).tolist())], KEY
    while len(goals) < episodes:
        key, sub = jax.random.split(key)
        _, s, _, term, trunc, _ = fns["step"](sub, s, 2, params)
        assert not bool(trunc)
        if bool(term):  # crashed: restarted at the start
            np.testing.assert_array_equal(np.asarray(s.pos), [0.0, 0.0])
            goals.append(tuple(np.asarray(s.goal).tolist()))
    return goals


def test_restart_goal_keep_retries_the_missed_goal_and_new_draws_a_fresh_one():
    # keep (ROBOTIS'): every restart retries the goal the crash missed.
    kept = _restart_goals("keep")
    assert len(set(kept)) == 1
    # new: each restart draws a goal as a reset does: one of the maze's admissible
    # points, at least goal_min_separation from the start, a different one each time.
    fresh = _restart_goals("new")
    assert fresh[0] == kept[0]  # the reset's goal is the same draw either way
    assert len(set(fresh)) == len(fresh)
    _, params = make("square4")
    points = np.asarray(params.maze.goal_points)[: int(params.maze.n_goal_points)]
    for goal in fresh:
        assert np.min(np.linalg.norm(points - np.asarray(goal), axis=1)) < 1e-6
        assert math.hypot(*goal) >= params.goal_min_separation


def test_restart_goal_new_with_drawn_mazes_needs_a_new_layout_at_every_restart():
    with pytest.raises(ValueError, match="env.restart_goal new .* env.new_maze_every 1"):
        NavEnv(generator="grid", new_maze_every=2, restart_goal="new")
    NavEnv(generator="grid", restart_goal="new")  # every restart draws a layout anyway


def test_episode_truncates_after_500_steps_with_the_pre_reset_observation():
    env, params = make("square4_obstacles")
    fns = jitted(env)
    # Hard left forever: a 0.1 m circle around (0, 0.1); never collides or reaches.
    s = state_at((0.0, 0.0), 0.0, goal=(1.2, -1.2))
    for t in range(499):
        obs, s, _, term, trunc, info = fns["step"](jax.random.PRNGKey(t), s, 4, params)
        assert not bool(term) and not bool(trunc), t
        # The same observation, though the compiler may round it in two fused kernels.
        np.testing.assert_allclose(np.asarray(info["final_obs"]), np.asarray(obs), rtol=1e-6)
    assert int(s.t) == 499
    obs, s500, r, term, trunc, info = fns["step"](KEY, s, 4, params)
    assert bool(trunc) and not bool(term)  # truncated, so a learner must bootstrap
    assert float(r) not in (params.R_plus, params.R_minus)
    assert int(s500.t) == 0 and np.allclose(np.asarray(s500.pos), 0.0)
    # final_obs is the observation at the pose the 500th step reached, before reset.
    pos, yaw = ref.unicycle(np.asarray(s.pos, np.float64), float(s.yaw), 1.5, ref.DT)
    pre = fns["observe"](
        KEY, jnp.asarray(pos, jnp.float32), jnp.float32(ref.wrap(yaw)), s.goal, params
    )
    np.testing.assert_allclose(np.asarray(info["final_obs"]), np.asarray(pre), atol=1e-4)
    assert not np.allclose(np.asarray(info["final_obs"]), np.asarray(obs))


# ----------------------------------------------------------------------------
# Observation and the jit/vmap contract
# ----------------------------------------------------------------------------


def test_observation_is_the_robotis_state():
    # [24 ranges, heading, distance, min range, argmin beam] for stage 2.
    env, params = make("square4_obstacles")
    pos, yaw, goal = np.array([0.9, -0.3]), 0.4, np.array([-1.0, 1.1])
    obs = np.asarray(
        jitted(env)["observe"](
            KEY,
            jnp.asarray(pos, jnp.float32),
            jnp.float32(yaw),
            jnp.asarray(goal, jnp.float32),
            params,
        )
    )
    walls, circles = ref.maze_geometry(MAZES["square4_obstacles"])
    ranges = ref.lidar(f32(pos)[None], f32([yaw]), walls, circles, 24)[0]
    np.testing.assert_allclose(obs[:24], ranges, atol=1e-4)
    rel = goal - pos
    assert obs[24] == pytest.approx(ref.wrap(math.atan2(rel[1], rel[0]) - yaw), abs=1e-5)
    assert obs[24] > 0  # the goal is to the robot's left: positive (spec)
    assert obs[25] == pytest.approx(np.hypot(*rel), abs=1e-5)
    assert obs[26] == pytest.approx(ranges.min(), abs=1e-4) and obs[27] == np.argmin(ranges)


@pytest.mark.parametrize("maze, obs_size", [("square4", 26), ("square4_obstacles", 28)])
def test_jit_and_vmap_over_1000_environments(maze, obs_size):
    env, params = jaxnav.make(padded(maze))  # obstacle features from the maze itself
    assert env.obs_size == obs_size
    n = N_BATCH
    fns = jitted(env)
    keys = jax.random.split(KEY, n)
    actions = jax.random.randint(KEY, (n,), 0, 5)

    def check(obs, s, r, term, trunc, info):
        assert obs.shape == (n, obs_size) and obs.dtype == jnp.float32
        for field, shape, dtype in (
            ("pos", (n, 2), jnp.float32),
            ("yaw", (n,), jnp.float32),
            ("goal", (n, 2), jnp.float32),
            ("t", (n,), jnp.int32),
        ):
            assert getattr(s, field).shape == shape and getattr(s, field).dtype == dtype, field
        assert r.shape == (n,) and r.dtype == jnp.float32
        assert term.shape == trunc.shape == (n,) and term.dtype == trunc.dtype == jnp.bool_
        assert info["final_obs"].shape == (n, obs_size)

    if obs_size == 26:  # shapes and dtypes through jit's tracing, without compiling twice
        obs, s = jax.eval_shape(fns["vreset"], keys, params)
        assert obs.shape == (n, obs_size) and obs.dtype == jnp.float32
        check(*jax.eval_shape(fns["vstep"], keys, s, actions, params))
        return
    obs, s = fns["vreset"](keys, params)
    assert obs.shape == (n, obs_size) and obs.dtype == jnp.float32
    assert len(np.unique(np.asarray(s.goal), axis=0)) > 100  # each env its own goal
    out = fns["vstep"](jax.random.split(KEY, n), s, actions, params)
    check(*out)
    obs, s2, r = out[:3]
    assert (np.asarray(s2.t) == 1).all()
    assert np.isfinite(np.asarray(obs)).all() and np.isfinite(np.asarray(r)).all()
    assert env.observation_space(params).contains(obs[0])
    assert env.action_space(params).contains(int(actions[0]))


@pytest.mark.slow
def test_vmap_over_a_batch_of_different_mazes():
    names = ["square4", "triangle", "square4_obstacles", "corridor"]
    stacked = jax.tree.map(lambda x: x[np.array([NAMES.index(n) for n in names])], STACK)
    params = EnvParams(maze=stacked)
    axes = jax.tree.map(lambda _: None, EnvParams(maze=MAZES["square4"]))
    axes = axes.replace(maze=jax.tree.map(lambda _: 0, stacked))
    actions = jnp.asarray([4, 4, 2, 0, 1, 3])

    def rollout(key, params):
        obs0, s = ENV.reset(key, params)

        def body(s, a):
            obs, s, *_ = ENV.step(key, s, a, params)
            return s, obs

        s, obs = jax.lax.scan(body, s, actions)
        return jnp.concatenate([obs0[None], obs]), s.pos

    obs_b, pos_b = jax.jit(jax.vmap(rollout, in_axes=(None, axes)))(KEY, params)
    fns = jitted(ENV)
    for i, n in enumerate(names):  # each maze alone, through the shared compiled step
        p = EnvParams(maze=padded(n))
        obs, s = fns["reset"](KEY, p)
        want = [obs]
        for a in actions:
            obs, s, *_ = fns["step"](KEY, s, a, p)
            want.append(obs)
        np.testing.assert_allclose(np.asarray(obs_b[i]), np.stack(want), atol=1e-5, err_msg=n)
        np.testing.assert_allclose(np.asarray(pos_b[i]), np.asarray(s.pos), atol=1e-6)
    assert not np.allclose(obs_b[0], obs_b[1])  # different mazes, different scans


def test_360_beams_work():
    env, params = jaxnav.make(padded("square4_obstacles"), n_beams=360)
    assert env.obs_size == 364
    obs, s = jax.eval_shape(env.reset, KEY, params)
    assert obs.shape == (364,) and obs.dtype == jnp.float32
    obs, s, r, *_ = jax.jit(env.step_env)(KEY, state_at((0.2, -0.5), 0.3), 2, params)
    assert obs.shape == (364,) and obs.dtype == jnp.float32
    walls, circles = ref.maze_geometry(MAZES["square4_obstacles"])
    pos, yaw = np.asarray(s.pos, np.float64)[None], np.asarray([s.yaw], np.float64)
    want = ref.lidar(pos, yaw, walls, circles, 360)[0]
    np.testing.assert_allclose(np.asarray(obs[:360]), want, atol=1e-4)
    assert obs[362] == pytest.approx(want.min(), abs=1e-4) and obs[363] == np.argmin(obs[:360])


def test_lidar_noise_has_the_requested_spread_and_stays_clipped():
    env, params = make("square4", lidar_noise_std=0.01)
    obs_fn = jax.jit(jax.vmap(env.observe, in_axes=(0, None, None, None, None)))
    pos, yaw, goal = jnp.asarray([1.0, 0.0]), jnp.float32(0.0), jnp.asarray([1.0, 1.0])
    keys = jax.random.split(KEY, 2000)
    obs = np.asarray(obs_fn(keys, pos, yaw, goal, params))[:, :24]
    clean = np.asarray(obs_fn(keys, pos, yaw, goal, params.replace(lidar_noise_std=0.0)))[0, :24]
    walls, circles = ref.maze_geometry(MAZES["square4"])
    np.testing.assert_allclose(
        clean, ref.lidar(np.array([[1.0, 0.0]]), np.zeros(1), walls, circles, 24)[0], atol=1e-4
    )
    noise = (obs - clean)[:, clean < 3.4]  # unclipped beams
    assert abs(noise.mean()) < 1e-3 and noise.std() == pytest.approx(0.01, rel=0.05)
    assert obs.min() >= 0.12 and obs.max() <= 3.5
    assert (obs[:, clean >= 3.5] == np.float32(3.5)).all()  # noise never exceeds max range


def test_make_rejects_an_unknown_keyword_by_name():
    with pytest.raises(ValueError, match="lidar_beams"):
        jaxnav.make("square4", lidar_beams=360)
    with pytest.raises(ValueError, match="nonsense"):
        jaxnav.make("square4", preset="nonsense")


def test_make_takes_the_reward_constants_from_the_one_preset_table():
    from jaxnav.core.settings import PRESETS

    for preset in PRESETS:
        for maze in ("square4", "square4_obstacles"):
            _, p = jaxnav.make(maze, preset)
            want = PRESETS[preset].reward(maze == "square4_obstacles")
            assert {k: getattr(p, k) for k in want} == want, (preset, maze)


@pytest.mark.parametrize(
    "setting, value, says",
    [
        ("n_beams", 0, "n_beams must be at least 1"),
        ("goal_candidates", 0, "goal_candidates must be at least 1"),
        ("beam_dropout", 1.0, "beam_dropout must be in [0, 1)"),
        ("odom_noise", (0.1, -0.1), "odom_noise must be [position std, yaw std]"),
        ("odom_noise", (0.1,), "odom_noise must be [position std, yaw std]"),
        ("maze_scale", (0.4, 1.0), "maze_scale must be [low, high] with 0.5 <= low"),
    ],
)
def test_env_settings_are_checked_by_the_shared_rule(setting, value, says):
    with pytest.raises(ValueError) as err:
        NavEnv(**{setting: value})
    assert str(err.value).startswith(says)


def test_from_config_builds_what_make_builds():
    cfg = build_config(
        {
            "preset": "robotis",
            "env.maze": "square4_obstacles",
            "env.n_beams": 36,
            "env.beam_dropout": 0.1,
            "env.R_plus": 300.0,
        }
    )
    env, params = from_config(cfg)
    want_env, want_params = jaxnav.make(
        "square4_obstacles", "robotis", n_beams=36, beam_dropout=0.1, R_plus=300.0
    )
    assert env == want_env and env.obstacle_obs
    for got, want in zip(jax.tree.leaves(params), jax.tree.leaves(want_params)):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    assert params.R_plus == 300.0 and params.R_minus == -150.0  # robotis stage 2
