"""The real-robot adapter: a raw LaserScan and odometry give the trained observation."""

from __future__ import annotations

import functools
import json
import math
import py_compile
import shutil
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _nav_reference import turned_changes_by_hand
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxnav.agent.networks import QNetwork
from jaxnav.commands import export as export_command
from jaxnav.core import agents
from jaxnav.core.config import dump_config, load_config
from jaxnav.core.errors import ConfigError
from jaxnav.core.rundir import atomic_write_bytes, atomic_write_text, load_params, npz_bytes
from jaxnav.env import from_config
from jaxnav.robot import controller, deploy, export, scan
from jaxnav.robot.deploy import Policy
from jaxnav.robot.scan import nearest_rays
from jaxnav.run.checkpoint import params_arrays
from jaxnav.world.geometry import ray_distances_dir
from jaxnav.world.maps import ROBOT_RADIUS, clearance
from jaxnav.world.sensor import beam_angles, beam_directions

ROOT = Path(__file__).resolve().parent.parent
N_STATES = 150
LDS01 = (0.0, 2 * math.pi / 360)  # angle_min, angle_increment of the TurtleBot3's LDS-01


def _fake_run(root: Path, maze: str, extra: tuple[str, ...] = (), name: str | None = None) -> Path:
    """A run directory whose params.npz holds an initialised (untrained) network.

    The adapter only has to reproduce the network's input and output, so training is
    not needed; the weights are scaled up so the greedy action varies with the input.
    """
    cfg = load_config(None, ["seeds=1", "strategies=[ebe]", f"env.maze={maze}", *extra])
    env, _ = from_config(cfg)
    net = agents.get(cfg.agent).network_of(cfg, env)
    params = net.init(jax.random.key(7), jnp.zeros(env.obs_size))
    params = jax.tree.map(lambda x: x[None], params)  # leading axis: one run
    out = root / (name or maze)
    out.mkdir()
    atomic_write_text(out / "config.yaml", dump_config(cfg))
    atomic_write_bytes(out / "params.npz", npz_bytes(params_arrays(cfg, params)))
    return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("deploy")
    return {m: _fake_run(root, m) for m in ("square4", "square4_obstacles")}


class Setup:
    """The environment, flax network and exported policy of a fake run."""

    def __init__(self, run: Path):
        self.cfg = load_config(str(run / "config.yaml"))
        self.env, self.params = from_config(self.cfg)
        self.net = agents.get(self.cfg.agent).network_of(self.cfg, self.env)
        self.net_params = load_params(run / "params.npz", "ebe", 0)
        self.policy = Policy.from_arrays(export.export_policy(run, "ebe", 0))

    def flax_q(self, obs):
        return np.asarray(self.net.apply(self.net_params, jnp.asarray(obs)))


@pytest.fixture(scope="module")
def setups(runs):
    return {m: Setup(r) for m, r in runs.items()}


def _random_states(maze, n, seed):
    """Poses in free space (clear of every surface by the robot radius) and goals."""
    rng = np.random.default_rng(seed)
    walls, circles = maze.walls(), maze.obstacles()
    lo, hi = np.asarray(maze.bounds[:2]), np.asarray(maze.bounds[2:])
    pts = rng.uniform(lo, hi, size=(8 * n, 2))
    pts = pts[clearance(pts, walls, circles) >= ROBOT_RADIUS][:n]
    assert len(pts) == n
    yaw = rng.uniform(-math.pi, math.pi, n)
    goal_pool = np.asarray(maze.goal_points)[: int(maze.n_goal_points)]
    goals = goal_pool[rng.integers(0, len(goal_pool), n)]
    return pts.astype(np.float32), yaw.astype(np.float32), goals.astype(np.float32)


def _env_obs(env, params, pos, yaw, goal):
    key = jax.random.key(0)
    f = jax.jit(jax.vmap(lambda p, y, g: env.observe(key, p, y, g, params)))
    return np.asarray(f(pos, yaw, goal))


def _scan_angles(angle_min, increment, n_rays, n_beams=24):
    """f32 robot-frame angle of each scan ray, and the trained beam it points along
    (-1 if none)."""
    rel = angle_min + increment * np.arange(n_rays)
    out = rel.astype(np.float32)
    beams = np.asarray(beam_angles(n_beams))
    k = np.round((rel % (2 * np.pi)) / (2 * np.pi / n_beams)).astype(int) % n_beams
    on_beam = np.abs(((rel - beams[k] + np.pi) % (2 * np.pi)) - np.pi) < 1e-6
    out[on_beam] = beams[k[on_beam]]
    return out, np.where(on_beam, k, -1)


def _scans(maze, pos, yaw, angle_min, increment, n_rays, n_beams=24):
    """Exact synthetic LaserScans: ray i at yaw + angle_min + i * increment (inf: no hit).

    A ray that points along a trained beam gets exactly the environment's direction
    for that beam: two roundings of one direction differ by an ulp, which moves a ray
    that grazes a wall by more than 1e-5 m.
    """
    rel, beam = _scan_angles(angle_min, increment, n_rays, n_beams)
    rel, on_beam, k = jnp.asarray(rel), jnp.asarray(beam >= 0), jnp.asarray(np.maximum(beam, 0))
    return np.asarray(
        _scan_rays(maze, jnp.asarray(pos), jnp.asarray(yaw), rel, on_beam, k, n_beams)
    )


@functools.partial(jax.jit, static_argnames=("n_beams",))
def _scan_rays(maze, pos, yaw, rel, on_beam, k, n_beams):
    """_scans' rays, compiled once per shape (not once per call)."""

    def scan(p, y):
        plain = jnp.stack([jnp.cos(y + rel), jnp.sin(y + rel)], axis=-1)
        dirs = jnp.where(on_beam[:, None], beam_directions(n_beams, y)[k], plain)
        return ray_distances_dir(maze, p, dirs)

    return jax.vmap(scan)(pos, yaw)


def _compare(setup, maze, angle_min, increment, n_rays, seed):
    """Adapter observations and actions vs the environment's own, state by state."""
    pos, yaw, goal = _random_states(maze, N_STATES, seed)
    params = setup.params.replace(maze=maze)
    want = _env_obs(setup.env, params, pos, yaw, goal)
    scans = _scans(maze, pos, yaw, angle_min, increment, n_rays)
    got = np.stack(
        [
            setup.policy.observe(s, angle_min, increment, (p[0], p[1], y), g)
            for s, p, y, g in zip(scans, pos, yaw, goal)
        ]
    )
    nb = setup.env.n_beams
    heading_err = np.abs((got[:, nb] - want[:, nb] + math.pi) % (2 * math.pi) - math.pi)
    assert heading_err.max() < 1e-5
    others = np.delete(np.arange(got.shape[1]), nb)
    np.testing.assert_allclose(got[:, others], want[:, others], atol=1e-5, rtol=0)
    want_actions = np.argmax(setup.flax_q(want), axis=-1)
    got_actions = setup.policy.act(got)
    np.testing.assert_array_equal(got_actions, want_actions)
    return scans, got, want_actions


# ----------------------------------------------------------------------------
# Inference
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("maze", ["square4", "square4_obstacles"])
def test_numpy_inference_equals_the_flax_network(setups, maze):
    s = setups[maze]
    rng = np.random.default_rng(1)
    n, nb = 512, s.env.n_beams
    parts = [
        rng.uniform(0.12, 3.5, (n, nb)),  # ranges
        rng.uniform(-math.pi, math.pi, (n, 1)),  # heading
        rng.uniform(0.0, 5.0, (n, 1)),  # distance
    ]
    if s.env.obstacle_obs:
        parts += [rng.uniform(0.12, 3.5, (n, 1)), rng.integers(0, nb, (n, 1))]
    obs = np.concatenate(parts, axis=1).astype(np.float32)
    want = s.flax_q(obs)
    np.testing.assert_allclose(s.policy.q_values(obs), want, rtol=1e-5, atol=1e-5)
    np.testing.assert_array_equal(s.policy.act(obs), np.argmax(want, axis=-1))
    assert isinstance(s.policy.act(obs[0]), int)


# ----------------------------------------------------------------------------
# LaserScan -> observation
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("angle_min", [0.0, -math.pi], ids=["from_ahead", "from_behind"])
@pytest.mark.parametrize("maze", ["square4", "square4_obstacles"])
def test_scan_through_adapter_gives_the_env_observation_and_action(setups, maze, angle_min):
    s = setups[maze]
    increment = 2 * math.pi / 360  # 360 rays include every trained beam angle
    rays, _ = _scan_angles(angle_min, increment, 360)
    assert np.isin(np.asarray(beam_angles(24)), rays).all()
    scans, obs, actions = _compare(s, s.params.maze, angle_min, increment, 360, seed=2)
    assert len(set(actions.tolist())) > 1  # the check is not vacuous
    # command() is the greedy action's velocities.
    p0 = (0.0, 0.0, 0.0)
    lin, ang = s.policy.command(scans[0], angle_min, increment, p0, (1.0, 1.0))
    a = s.policy.act(s.policy.observe(scans[0], angle_min, increment, p0, (1.0, 1.0)))
    assert (lin, ang) == (0.15, [-1.5, -0.75, 0.0, 0.75, 1.5][a])


MODERN = (
    "env.observation=normalised",  # ranges and goal scaled, the last command in it
    "env.actions=vw",  # (v, omega) pairs with a stop
    "env.scan_beams=72",  # the least range of each 15-degree sector of 72 beams
    "env.wheel_limit=true",  # the last command is what the firmware lets the wheels drive
)


@pytest.mark.parametrize("observed", [True, False], ids=["command", "no_command"])
def test_a_modern_policy_sees_on_the_robot_what_it_saw_in_training(tmp_path, observed):
    """The normalised observation, the pooled scan, the (v, omega) actions and the last
    command: the adapter's observation from raw 360-ray scans equals the environment's.
    Trained without the command (env.observe_command false): zeros in its place on both
    sides, format version 8."""
    extra = (*MODERN, f"env.observe_command={str(observed).lower()}")
    s = Setup(_fake_run(tmp_path, "square4_obstacles", extra, name="modern"))
    env, params, policy = s.env, s.params, s.policy
    version = deploy.DRIVE_VERSION if observed else deploy.COMMAND_VERSION
    assert policy.meta["version"] == version and policy.obs_size == env.obs_size
    n_actions = env.num_actions
    v, w = env.command(params, jnp.arange(n_actions))
    np.testing.assert_allclose(policy.driven, np.stack([v, w], -1), atol=1e-7)
    np.testing.assert_allclose(policy.omegas, np.asarray(params.omegas), atol=1e-7)
    np.testing.assert_allclose(policy.speeds, np.asarray(params.speeds), atol=1e-7)
    assert np.any(np.abs(policy.driven[:, 1] - policy.omegas) > 1e-3)  # the limit bites
    maze = params.maze
    pos, yaw, goal = _random_states(maze, 60, seed=4)
    before = np.random.default_rng(4).integers(0, n_actions, len(pos))
    last = np.asarray(jnp.stack(env.command(params, jnp.asarray(before)), -1), np.float32)
    key = jax.random.key(0)
    f = jax.jit(jax.vmap(lambda p, y, g, c: env.observe(key, p, y, g, params, 1.0, 0.0, c)))
    want = np.asarray(f(pos, yaw, goal, last))
    increment = 2 * math.pi / 360
    scans = _scans(maze, pos, yaw, 0.0, increment, 360, n_beams=72)
    got = []
    for sc, p, y, g, a in zip(scans, pos, yaw, goal, before):
        policy.take(int(a))  # the command driven last
        got.append(policy.observe(sc, 0.0, increment, (p[0], p[1], y), g))
    got = np.stack(got)
    nb = env.n_beams
    heading_err = np.abs((got[:, nb] - want[:, nb] + 1.0) % 2.0 - 1.0) * math.pi
    assert heading_err.max() < 1e-5
    np.testing.assert_allclose(np.delete(got, nb, 1), np.delete(want, nb, 1), atol=1e-5)
    np.testing.assert_array_equal(policy.act(got), np.argmax(s.flax_q(want), axis=-1))
    command = want[:, nb + 2 : nb + 4]
    assert np.any(command != 0.0) if observed else np.all(command == 0.0)
    # A stop (the controller's, or an episode's start) makes the last command (0, 0).
    policy.rest()
    obs = policy.observe(scans[0], 0.0, increment, (pos[0][0], pos[0][1], yaw[0]), goal[0])
    assert np.all(obs[-2:] == 0.0)
    linear, angular = policy.command(scans[0], 0.0, increment, (0.0, 0.0, 0.0), (1.0, 1.0))
    a = int(np.argmax(np.all(policy.driven == policy.last_command, axis=1)))
    assert (linear, angular) == (policy.speeds[a], policy.omegas[a])
    control = _fed(controller.Controller(policy))
    control.on_goal((1.0, 1.0), "odom")
    c = control.decide(10.0)
    chosen = np.flatnonzero((policy.speeds == c.linear) & (policy.omegas == c.angular))
    assert c.reason == "drive" and chosen.size == 1
    np.testing.assert_array_equal(policy.last_command, policy.driven[chosen[0]])
    control.on_goal((0.05, 0.0), "odom")  # within the goal radius: the robot stops
    assert control.decide(10.0).reason == "reached" and np.all(policy.last_command == 0.0)


@pytest.mark.slow  # 4 s on 2 cores
@pytest.mark.parametrize(
    "changes, turned, conv",
    [(False, False, False), (True, False, False), (True, True, False), (True, True, True)],
    ids=["scans", "changes", "turned", "turned_conv"],
)
def test_a_policy_with_a_scan_history_sees_on_the_robot_the_scans_it_saw_in_training(
    tmp_path, changes, turned, conv
):
    """Step by step along the environment's own episodes on stage 4 (a collision or the
    step limit restarts one), the adapter's observation from raw scans of the walls and
    the moving cylinders, with the history it keeps, equals the environment's, and so
    does the greedy action: the scans newest first, at an episode's start copies of its
    first scan; a stop starts the history again. With env.history_changes, each beam's
    change since each of those scans (against NumPy); with env.history_turned, since
    each seen from the heading now, by the odometry's yaw (against the rule by hand).
    With dqn.scan_conv (PQN's network, LayerNorm), the policy's circular convolutions over
    those scans give the flax network's greedy action at every step."""
    k = 3
    extra = (*MODERN, f"env.scan_history={k}", "env.max_steps=40")  # restarts every 40 steps
    extra += (f"env.history_changes={str(changes).lower()}",)
    extra += (f"env.history_turned={str(turned).lower()}",)
    if conv:
        extra += ("agent=pqn", "dqn.scan_conv=[8,8]", "episodes=null", "total_steps=1024")
    run = _fake_run(tmp_path, "stage4", extra, "hist")  # its cylinders move
    s = Setup(run)
    env, params, policy = s.env, s.params, s.policy
    version = deploy.TURNED_VERSION if turned else deploy.HISTORY_VERSION
    if conv:
        version = deploy.CONV_VERSION
        assert len(policy.convs) == 2 and len(policy.norms) == 2
    assert policy.meta["version"] == version and policy.scan_history == k
    assert policy.obs_size == env.obs_size == env.n_beams * (1 + k) + 4
    increment, nb = 2 * math.pi / 360, env.n_beams
    rng = np.random.default_rng(3)
    key = jax.random.key(5)
    want, state = env.reset(key, params)
    step = jax.jit(lambda kk, st, a: env.step_env(kk, st, a, params))
    restarts = steps = moved = 0
    turns = 0.0
    restarted = True  # the first observation is an episode's start
    while steps < 100:
        pose = np.asarray(state.pos), float(state.yaw)
        maze = env.maze_at(params, 1.0, state.t * params.dt)  # the cylinders where they are
        scan = _scans(maze, pose[0][None], np.float32([pose[1]]), 0.0, increment, 360, 72)
        first = _scans(params.maze, pose[0][None], np.float32([pose[1]]), 0.0, increment, 360, 72)
        moved += bool(np.any(np.abs(scan - first) > 0.01))  # the moving cylinders are seen
        got = policy.observe(scan[0], 0.0, increment, (*pose[0], pose[1]), np.asarray(state.goal))
        want = np.asarray(want)
        assert abs((got[nb] - want[nb] + 1.0) % 2.0 - 1.0) < 1e-5  # heading, wrapped
        np.testing.assert_allclose(
            np.delete(got, nb)[: nb + 3], np.delete(want, nb)[: nb + 3], atol=1e-5
        )
        past = got[nb + 4 :].reshape(k, nb)
        if restarted:  # an episode's start: copies of its first scan
            history = np.tile(got[:nb], (k, 1))
            yaws = np.full(k, pose[1])
        if turned:  # each earlier scan seen from the heading now, by hand
            turn = (pose[1] - yaws + np.pi) % (2 * np.pi) - np.pi
            np.testing.assert_allclose(
                past, turned_changes_by_hand(got[:nb], history, turn), atol=1e-4
            )
            np.testing.assert_allclose(past, want[nb + 4 :].reshape(k, nb), atol=1e-4)
            turns = max(turns, float(np.abs(turn).max()))
        elif changes:  # the scan less each earlier one, x10, in [-1, 1]
            np.testing.assert_allclose(past, np.clip((got[:nb] - history) * 10, -1, 1), atol=1e-4)
            np.testing.assert_allclose(past, want[nb + 4 :].reshape(k, nb), atol=1e-4)
        else:
            np.testing.assert_array_equal(past, history)
            np.testing.assert_allclose(past, want[nb + 4 :].reshape(k, nb), atol=1e-5)
        history = np.concatenate([got[None, :nb], history[:-1]])  # this scan joins
        yaws = np.concatenate([[pose[1]], yaws[:-1]])
        assert policy.act(got) == int(np.argmax(s.flax_q(want)))
        a = int(rng.integers(0, env.num_actions))
        policy.take(a)
        key, sub = jax.random.split(key)
        want, state, _, terminated, truncated, _ = step(sub, state, jnp.asarray(a))
        restarted = bool(terminated | truncated)
        if restarted:  # the environment restarts the episode; the controller stops
            want, state = env.restart(sub, state, params)
            policy.rest()
            restarts += 1
        steps += 1
    assert np.any(history[0] != history[-1])  # the robot moved: the scans differ
    if changes:
        assert np.any(np.abs(past) > 0.05)  # and the changes show it
    if turned:
        assert turns > 0.5  # the robot turned by more than a beam between scans
    assert restarts >= 2 and moved >= 10


@pytest.mark.parametrize(
    "change", [{"history_change_gain": 0.0}, {"scan_history": 0}], ids=["no gain", "no history"]
)
def test_metadata_with_history_changes_but_no_gain_or_history_is_refused(tmp_path, change):
    """A history of changes without its gain would observe zeros; without a history,
    nothing: the reader refuses the file instead of driving on either."""
    extra = (*MODERN, "env.scan_history=2", "env.history_changes=true")
    arrays = export.export_policy(_fake_run(tmp_path, "square4", extra, "hist"), "ebe", 0)
    Policy.from_arrays(arrays)  # as written, it loads
    meta = {**json.loads(str(arrays["meta"])), **change}
    with pytest.raises(deploy.PolicyError, match="history_changes needs"):
        Policy.from_arrays({**arrays, "meta": np.asarray(json.dumps(meta))})


def test_metadata_with_turned_changes_but_no_changes_is_refused(tmp_path):
    """A turned history without its changes says nothing the reader could compute."""
    extra = (*MODERN, "env.scan_history=2", "env.history_changes=true")
    extra += ("env.history_turned=true",)
    arrays = export.export_policy(_fake_run(tmp_path, "square4", extra, "turn"), "ebe", 0)
    assert Policy.from_arrays(arrays).history_turned  # as written, it loads
    meta = {**json.loads(str(arrays["meta"])), "history_changes": False}
    with pytest.raises(deploy.PolicyError, match="history_turned needs history_changes"):
        Policy.from_arrays({**arrays, "meta": np.asarray(json.dumps(meta))})


@pytest.mark.parametrize("broken", ["layout", "kernel", "missing", "not_a_mapping"])
def test_a_policy_file_with_broken_scan_convolutions_is_refused_in_one_line(tmp_path, broken):
    """A version-7 file whose convolutions do not fit its observation, or lack an
    array, or whose metadata is not a mapping: a PolicyError naming the problem."""
    extra = (*MODERN, "env.scan_history=2", "env.history_changes=true", "dqn.scan_conv=[4,4]")
    arrays = export.export_policy(_fake_run(tmp_path, "square4", extra, "conv"), "ebe", 0)
    assert Policy.from_arrays(arrays).meta["version"] == deploy.CONV_VERSION
    meta = json.loads(str(arrays["meta"]))
    if broken == "layout":
        meta["scan_conv"]["layout"] = [24, 4, 3]
        says = "scan_conv layout"
    elif broken == "kernel":
        arrays = {**arrays, "ScanTorso/Conv_1/kernel": np.zeros((5, 3, 4), np.float32)}
        says = "scan convolution 1 has shape"
    elif broken == "missing":
        arrays = {k: v for k, v in arrays.items() if k != "ScanTorso/Conv_0/bias"}
        says = "lacks array"
    else:
        meta["scan_conv"] = [1, 2]
        says = "not a mapping"
    with pytest.raises(deploy.PolicyError, match=says) as e:
        Policy.from_arrays({**arrays, "meta": np.asarray(json.dumps(meta))})
    assert "\n" not in str(e.value)


def test_rays_with_no_return_become_max_range_as_in_the_env(setups):
    """Two walls removed: many rays hit nothing (inf), both paths read 3.5 m there."""
    s = setups["square4"]
    maze = s.params.maze
    mask = np.asarray(maze.segment_mask).copy()
    mask[:2] = False
    open_maze = maze.replace(segment_mask=jnp.asarray(mask))
    scans, obs, _ = _compare(s, open_maze, 0.0, 2 * math.pi / 360, 360, seed=3)
    assert np.isinf(scans).mean() > 0.2
    assert (obs[:, :24] == 3.5).mean() > 0.2


def test_nearest_ray_when_the_increment_does_not_divide_the_beam_spacing(setups):
    s = setups["square4_obstacles"]
    maze = s.params.maze
    pos, yaw, goal = _random_states(maze, 40, seed=4)
    for angle_min, increment in [(0.3, 2 * math.pi / 400), (0.3, -2 * math.pi / 400)]:
        n = 400  # 0.9 degree rays, 15 degree beams: 16.67 rays per beam
        # Direct: the ray index nearest beam k is round((theta_k - angle_min) / inc) mod n.
        theta = 2 * math.pi * np.arange(24) / 24
        frac = ((theta - angle_min) / increment) % n
        assert np.all(np.abs(frac % 1 - 0.5) > 1e-3)  # no ties in this layout
        idx = np.round(frac).astype(int) % n
        np.testing.assert_array_equal(nearest_rays(n, angle_min, increment, 24), idx)
        scans = _scans(maze, pos, yaw, angle_min, increment, n)
        for sc, p, y, g in zip(scans, pos, yaw, goal):
            obs = s.policy.observe(sc, angle_min, increment, (p[0], p[1], y), g)
            direct = np.clip(sc[idx], 0.12, 3.5)
            np.testing.assert_allclose(obs[:24], direct, atol=1e-5, rtol=0)
            assert obs[24 + 2] == pytest.approx(direct.min(), abs=1e-6)
            assert obs[24 + 3] == np.argmin(direct)


@settings(max_examples=200, deadline=None)
@given(
    n_rays=st.integers(24, 1500),
    angle_min=st.floats(-2 * math.pi, 2 * math.pi),
    clockwise=st.booleans(),
    n_beams=st.sampled_from([24, 360, 7]),
)
def test_every_beam_reads_a_ray_within_half_an_increment(n_rays, angle_min, clockwise, n_beams):
    inc = (-1 if clockwise else 1) * 2 * math.pi / n_rays
    idx = nearest_rays(n_rays, angle_min, inc, n_beams)
    ray = angle_min + inc * idx
    beam = 2 * math.pi * np.arange(n_beams) / n_beams
    gap = np.abs((ray - beam + math.pi) % (2 * math.pi) - math.pi)
    assert np.all(gap <= abs(inc) / 2 + 1e-9)
    assert np.all((0 <= idx) & (idx < n_rays))


def test_a_scan_that_does_not_cover_every_beam_is_an_error(setups):
    policy = setups["square4"].policy
    half = np.full(180, 2.0)  # 180 degrees in front only
    with pytest.raises(ValueError, match="does not cover"):
        policy.observe(half, -math.pi / 2, math.pi / 180, (0, 0, 0), (1, 0))


def test_invalid_readings_are_handled_as_documented(setups):
    policy = setups["square4_obstacles"].policy
    ranges = np.full(360, 2.0)
    # Trained beams 0..6 read rays 0, 15, ..., 90 of the LDS-01 layout.
    ranges[[0, 15, 30, 45, 60, 75, 90]] = [np.inf, 0.0, np.nan, -1.0, -np.inf, 0.05, 10.0]
    obs = policy.observe(ranges, *LDS01, (0, 0, 0), (1, 0))
    np.testing.assert_allclose(obs[:7], [3.5, 3.5, 3.5, 3.5, 0.12, 0.12, 3.5], atol=1e-6)
    assert np.all(obs[7:24] == 2.0)
    assert obs[26] == pytest.approx(0.12) and obs[27] == 4.0  # -inf: too close to measure
    # Invalid readings never look like a near obstacle (they are the LDS-01's no-return).
    ranges = np.full(360, 2.0)
    ranges[[15, 30, 45]] = [0.0, np.nan, -0.5]
    obs = policy.observe(ranges, *LDS01, (0, 0, 0), (1, 0))
    assert obs[26] == 2.0 and obs[27] == 0.0
    # ...unless the caller asks for another value.
    obs = policy.observe(ranges, *LDS01, (0, 0, 0), (1, 0), invalid=0.0)
    np.testing.assert_allclose(obs[1:4], [0.12, 0.12, 0.12], atol=1e-6)
    # A reading between the rays the beams use changes nothing.
    ranges = np.full(360, 2.0)
    ranges[7] = np.nan
    assert np.all(policy.observe(ranges, *LDS01, (0, 0, 0), (1, 0))[:24] == 2.0)


def test_heading_and_distance_come_from_odometry_and_goal(setups):
    policy = setups["square4"].policy
    scan = np.full(360, 1.0)
    obs = policy.observe(scan, *LDS01, (1.0, 1.0, math.pi / 2), (0.0, 1.0))  # goal to the left
    assert obs[24] == pytest.approx(math.pi / 2) and obs[25] == pytest.approx(1.0)
    obs = policy.observe(scan, *LDS01, (0.0, 0.0, 0.0), (0.0, -2.0))  # goal to the right
    assert obs[24] == pytest.approx(-math.pi / 2) and obs[25] == pytest.approx(2.0)
    with pytest.raises(ValueError, match="finite"):
        policy.command(scan, *LDS01, (np.nan, 0.0, 0.0), (1.0, 0.0))


def test_yaw_from_an_odometry_quaternion():
    for yaw in np.linspace(-3.1, 3.1, 13):
        q = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
        assert scan.yaw_from_quaternion(*q) == pytest.approx(yaw)


# ----------------------------------------------------------------------------
# Export and files
# ----------------------------------------------------------------------------


def test_export_writes_a_file_that_policy_load_reads(runs, tmp_path):
    out = tmp_path / "policy.npz"
    assert (
        export_command.main(
            [str(runs["square4_obstacles"]), "--strategy", "ebe", "--seed", "0", "--out", str(out)]
        )
        == 0
    )
    with np.load(out, allow_pickle=False) as data:  # plain arrays only, no pickle
        arrays = {k: data[k] for k in data.files}
    assert all(a.dtype != object for a in arrays.values())
    policy = Policy.load(out)
    meta = policy.meta
    assert (meta["strategy"], meta["seed"], meta["maze"], meta["preset"]) == (
        "ebe",
        0,
        "square4_obstacles",
        "paper",
    )
    assert (policy.n_beams, policy.obstacle_obs, policy.min_range, policy.max_range) == (
        24,
        True,
        0.12,
        3.5,
    )
    assert policy.omegas.tolist() == [-1.5, -0.75, 0.0, 0.75, 1.5]
    assert policy.linear_velocity == 0.15 and policy.obs_size == 28
    assert arrays["maze/obstacles"].shape == (4, 3) and arrays["maze/walls"].shape == (4, 4)
    trained = load_params(runs["square4_obstacles"] / "params.npz", "ebe", 0)["params"]
    for i, (k, b) in enumerate(policy.layers):
        np.testing.assert_array_equal(k, trained[f"Dense_{i}"]["kernel"])
        np.testing.assert_array_equal(b, trained[f"Dense_{i}"]["bias"])
    assert [p.name for p in tmp_path.iterdir()] == ["policy.npz"]  # no temporary left


@pytest.mark.parametrize("case", ["missing_dir", "no_params", "strategy", "seed", "out_dir"])
def test_export_with_bad_input_fails_with_exit_2_and_one_line(runs, tmp_path, capsys, case):
    run = runs["square4"]
    out = tmp_path / "policy.npz"
    out.write_bytes(b"old")
    argv = {
        "missing_dir": [str(tmp_path / "nope")],
        "no_params": [str(tmp_path)],
        "strategy": [str(run), "--strategy", "greedy"],
        "seed": [str(run), "--seed", "5"],
        "out_dir": [str(run), "--out", str(tmp_path / "no" / "p.npz")],
    }[case]
    if case == "no_params":
        (tmp_path / "config.yaml").write_text((run / "config.yaml").read_text())
    if case != "out_dir":
        argv += ["--out", str(out), "--overwrite"]  # the error is the input's, not the file's
    assert export_command.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("jaxnav export: error: ")
    assert out.read_bytes() == b"old"  # the old file is untouched


def test_export_refuses_an_existing_file_before_exporting(runs, tmp_path, capsys, monkeypatch):
    """An existing --out (or default file) needs --overwrite, checked before any work."""

    def no_export(*a, **k):
        raise AssertionError("exported before the output was checked")

    run = runs["square4"]
    out = tmp_path / "policy.npz"
    out.write_bytes(b"old")
    with monkeypatch.context() as m:
        m.setattr(export_command, "export_policy", no_export)
        assert export_command.main([str(run), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err == f"jaxnav export: error: {out} exists already (--overwrite replaces it)\n"
        m.chdir(tmp_path)  # the default name, policy-ebe-seed0.npz, in the working directory
        (tmp_path / "policy-ebe-seed0.npz").write_bytes(b"old")
        assert export_command.main([str(run)]) == 2
        assert "policy-ebe-seed0.npz exists already" in capsys.readouterr().err
        assert export_command.main([str(run), "--out", str(tmp_path)]) == 2
        assert "is not a file" in capsys.readouterr().err
    assert out.read_bytes() == b"old"
    assert export_command.main([str(run), "--out", str(out), "--overwrite"]) == 0
    assert Policy.load(out).meta["strategy"] == "ebe"


def test_command_line_error_is_one_line_without_traceback(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "jaxnav.commands.export", str(tmp_path / "missing")],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "does not exist" in r.stderr


def test_policy_inference_needs_only_numpy(runs, tmp_path):
    """The robot side's files copied onto a robot without JAX or jaxnav (deploy.py and
    the scan's pieces, scan.py; controller.py for a node's decisions) load a policy and
    act, with nothing else of jaxnav to import."""
    out = tmp_path / "p.npz"
    export.save_policy(export.export_policy(runs["square4"]), out)
    robot = tmp_path / "robot"
    robot.mkdir()
    for name in ("deploy.py", "scan.py", "controller.py"):
        shutil.copy(ROOT / "jaxnav" / "robot" / name, robot / name)
    code = (
        "import importlib.util, math, sys\n"
        "sys.modules['jax'] = None  # any 'import jax' now fails, and so does jaxnav\n"
        "sys.modules['jaxnav'] = None\n"
        "def load(name):\n"
        f"    path = {str(robot)!r} + '/' + name + '.py'\n"
        "    spec = importlib.util.spec_from_file_location(name, path)\n"
        "    m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m)\n"
        "    return m\n"
        "m, c = load('deploy'), load('controller')\n"
        f"p = m.Policy.load({str(out)!r})\n"
        "print(p.command([1.0] * 360, 0.0, 2 * math.pi / 360, (0, 0, 0), (1, 1)))\n"
        "control = c.Controller(p)\n"
        "control.on_goal((1, 1), 'odom'); control.on_odom((0, 0, 0), 'odom', 1.0)\n"
        "control.on_scan([1.0] * 360, 0.0, 2 * math.pi / 360, 1.0)\n"
        "print(control.decide(1.0).reason)\n"
    )
    r = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, cwd=tmp_path
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("(0.15, ") and r.stdout.splitlines()[1] == "drive"


def test_load_rejects_a_file_that_is_not_a_policy(tmp_path):
    bad = tmp_path / "x.npz"
    np.savez(bad, a=np.zeros(3))
    with pytest.raises(deploy.PolicyError, match="not a jaxnav policy"):
        Policy.load(bad)
    bad.write_bytes(b"garbage")
    with pytest.raises(deploy.PolicyError, match="cannot be read"):
        Policy.load(bad)


def test_info_prints_the_metadata(runs, tmp_path, capsys):
    out = tmp_path / "p.npz"
    export.save_policy(export.export_policy(runs["square4"]), out)
    assert export_command.main(["--info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "n_beams: 24" in text and "strategy: ebe" in text
    assert json.loads(str(np.load(out)["meta"]))["format"] == "jaxnav-policy"


@pytest.mark.parametrize("node", ["ros1_policy_node.py", "ros2_policy_node.py"])
def test_ros_node_examples_compile(node):
    py_compile.compile(str(ROOT / "examples" / node), doraise=True)


# ----------------------------------------------------------------------------
# A node's decisions (Controller)
# ----------------------------------------------------------------------------


def _steering_policy() -> Policy:
    """A one-layer policy that turns towards the goal: left (1.5 rad/s) when the goal
    is to the left, right when to the right, straight when ahead."""
    kernel = np.zeros((26, 5))
    kernel[24] = [-2.0, -1.0, 0.0, 1.0, 2.0]  # heading
    bias = np.asarray([0.0, 0.0, 0.1, 0.0, 0.0])
    meta = {
        "n_beams": 24,
        "obstacle_obs": False,
        "min_range": 0.12,
        "max_range": 3.5,
        "omegas": [-1.5, -0.75, 0.0, 0.75, 1.5],
        "linear_velocity": 0.15,
    }
    return Policy([(kernel, bias)], meta)


def _fed(control: controller.Controller, now: float = 10.0, pose=(0.0, 0.0, 0.0)):
    control.on_scan(np.full(360, 2.0), *LDS01, now)
    control.on_odom(pose, "odom", now)
    return control


def test_controller_drives_only_with_a_goal_a_scan_and_odometry():
    control = controller.Controller(_steering_policy())
    assert control.decide(0.0) == (0.0, 0.0, "no goal", "")
    control.on_goal((1.0, 1.0), "odom")  # ahead and to the left
    cmd = control.decide(0.0)
    assert (cmd.linear, cmd.angular, cmd.reason, cmd.level) == (0.0, 0.0, "waiting", "warn")
    control.on_scan(np.full(360, 2.0), *LDS01, 0.0)
    assert control.decide(0.0).reason == "waiting"  # a scan but no odometry
    control.on_odom((0.0, 0.0, 0.0), "odom", 0.0)
    assert control.decide(0.1) == (0.15, 1.5, "drive", "")
    control.on_goal((1.0, -1.0), "odom")  # a new goal replaces the old one
    assert control.decide(0.1)[:2] == (0.15, -1.5)
    assert control.decide(0.1).level == ""


def test_controller_gives_what_the_policy_commands(setups):
    policy = setups["square4_obstacles"].policy
    control = controller.Controller(policy)
    rng = np.random.default_rng(5)
    for _ in range(20):
        ranges, pose = rng.uniform(0.2, 3.0, 360), (*rng.uniform(-1, 1, 2), rng.uniform(-3, 3))
        goal = tuple(rng.uniform(-1.5, 1.5, 2))
        control.on_goal(goal, "odom")
        control.on_scan(ranges, *LDS01, 1.0)
        control.on_odom(pose, "odom", 1.0)
        cmd = control.decide(1.2)
        assert cmd[:3] == (*policy.command(ranges, *LDS01, pose, goal), "drive")


@pytest.mark.parametrize("stale", ["scan", "odometry"])
def test_controller_stops_on_stale_data(stale):
    control = controller.Controller(_steering_policy(), stale_after=0.5)
    control.on_goal((1.0, 0.0), "odom")

    def feed(t_old):
        control.on_scan(np.full(360, 2.0), *LDS01, t_old if stale == "scan" else 10.0)
        control.on_odom((0.0, 0.0, 0.0), "odom", t_old if stale == "odometry" else 10.0)

    feed(9.4)
    cmd = control.decide(10.0)
    assert cmd[:3] == (0.0, 0.0, "stale") and cmd.message.startswith(f"{stale} older than 0.5 s")
    feed(9.5)
    assert control.decide(10.0).reason == "drive"  # exactly stale_after old is fresh
    assert control.decide(9.9).reason == "stale"  # the clock went back: not trusted


def test_controller_stops_at_the_goal_and_forgets_it():
    control = _fed(controller.Controller(_steering_policy(), goal_tolerance=0.3))
    control.on_goal((0.25, 0.1), "odom")
    cmd = control.decide(10.0)
    assert cmd[:3] == (0.0, 0.0, "reached") and cmd.level == "info"
    assert "(0.25, 0.10) reached" in cmd.message
    assert control.goal is None and control.decide(10.0).reason == "no goal"
    control.on_goal((0.35, 0.0), "odom")  # outside the tolerance
    assert control.decide(10.0).reason == "drive"
    # The default tolerance is the policy's goal radius.
    assert controller.Controller(_steering_policy()).goal_tolerance == 0.2


def test_controller_refuses_a_goal_in_another_frame():
    control = _fed(controller.Controller(_steering_policy()))
    control.on_goal((1.0, 0.0), "map")
    cmd = control.decide(10.0)
    assert cmd[:3] == (0.0, 0.0, "frame") and "'map'" in cmd.message and "'odom'" in cmd.message
    for frame in ("odom", "/odom", ""):  # ROS 1's leading slash; no frame: trusted
        control.on_goal((1.0, 0.0), frame)
        assert control.decide(10.0).reason == "drive"


def test_controller_stops_on_a_scan_or_pose_it_cannot_use():
    control = _fed(controller.Controller(_steering_policy()))
    control.on_goal((1.0, 0.0), "odom")
    control.on_scan(np.full(180, 2.0), -math.pi / 2, math.pi / 180, 10.0)  # front half
    cmd = control.decide(10.0)
    assert cmd[:3] == (0.0, 0.0, "bad input") and cmd.level == "error"
    assert "does not cover" in cmd.message
    _fed(control, pose=(math.nan, 0.0, 0.0))
    assert control.decide(10.0).reason == "bad input"
    with pytest.raises(ValueError, match="not finite"):
        control.on_goal((math.inf, 0.0), "odom")


def test_controller_watchdog_stops_only_when_scans_stop():
    control = controller.Controller(_steering_policy(), stale_after=0.5)
    assert control.watchdog(0.0).reason == "no goal"  # no scan yet: a stop
    _fed(control, now=10.0)
    control.on_goal((1.0, 0.0), "odom")
    assert control.watchdog(10.4) is None  # scans drive the robot
    cmd = control.watchdog(10.6)
    assert cmd[:3] == (0.0, 0.0, "stale") and cmd.message.startswith("scan and odometry")


def test_controller_passes_the_invalid_reading_value_on():
    kernel = np.zeros((26, 5))
    kernel[0] = [1.0, 0.0, 0.0, 0.0, 0.0]  # beam 0 far: turn right; near: straight
    bias = np.asarray([0.0, 0.0, 1.0, 0.0, 0.0])
    policy = Policy([(kernel, bias)], _steering_policy().meta)
    for invalid, omega in ((None, -1.5), (0.0, 0.0)):
        control = controller.Controller(policy, invalid=invalid)
        control.on_goal((1.0, 0.0), "odom")
        ranges = np.full(360, 2.0)
        ranges[0] = 0.0  # the LDS-01's "no return"
        control.on_scan(ranges, *LDS01, 10.0)
        control.on_odom((0.0, 0.0, 0.0), "odom", 10.0)
        assert control.decide(10.0)[:2] == (0.15, omega)


def test_a_dueling_network_exports_as_the_plain_network_it_equals():
    net = QNetwork(num_actions=5, hidden=(8, 8), dropout=0.2, dueling=True)
    x = jax.random.normal(jax.random.PRNGKey(0), (7, 26))
    params = net.init(jax.random.PRNGKey(1), x)
    folded = export.fold_dueling(jax.tree.map(np.asarray, params["params"]))
    assert sorted(folded) == ["Dense_0", "Dense_1", "Dense_2"]
    h = np.asarray(x)
    for i in range(3):
        h = h @ folded[f"Dense_{i}"]["kernel"] + folded[f"Dense_{i}"]["bias"]
        h = np.maximum(h, 0.0) if i < 2 else h
    np.testing.assert_allclose(h, net.apply(params, x), rtol=1e-5, atol=1e-5)


def test_export_best_picks_the_seed_with_the_best_greedy_success(tmp_path):
    cfg = load_config(None, ["seeds=3", "strategies=[epsilon_greedy]"])
    run = tmp_path / "run"
    run.mkdir()
    atomic_write_text(run / "config.yaml", dump_config(cfg))
    with pytest.raises(deploy.PolicyError, match="jaxnav evaluate"):
        export.best_seed(run, "epsilon_greedy")
    head = "strategy,seed,env_step,success\n"
    rows = [  # the last evaluation decides: seed 2 there, though seed 0 led before
        "epsilon_greedy,0,100,1.0",
        "epsilon_greedy,1,100,0.2",
        "epsilon_greedy,2,100,0.5",
        "epsilon_greedy,0,200,0.6",
        "epsilon_greedy,1,200,0.7",
        "epsilon_greedy,2,200,0.9",
    ]
    (run / "eval.csv").write_text(head + "\n".join(rows) + "\n")
    seed, line = export.best_seed(run, "epsilon_greedy")
    assert seed == 2
    assert (
        "success 0.900" in line
        and "next seed 1: 0.700" in line
        and "median over 3 seeds 0.700" in line
    )
    assert export.default_strategy(run) == "epsilon_greedy"


def test_a_policy_with_a_waypoint_is_refused_by_export(tmp_path):
    overrides = ("preset=modern", "env.generator=rooms", "env.waypoint=true")
    run = _fake_run(tmp_path, "square4", overrides)
    with pytest.raises(deploy.PolicyError, match="env.waypoint"):
        export.export_policy(run, "ebe", 0)


def test_a_policy_that_observes_the_moving_cylinders_is_refused_by_export(tmp_path):
    overrides = ("preset=modern", "env.observe_moving=2")
    run = _fake_run(tmp_path, "stage4", overrides)
    with pytest.raises(deploy.PolicyError, match="env.observe_moving"):
        export.export_policy(run, "ebe", 0)


def test_hiding_the_last_command_needs_the_observation_that_holds_it():
    with pytest.raises(ConfigError, match="env.observe_command false hides"):
        from_config(load_config(None, ["env.observe_command=false"]))
