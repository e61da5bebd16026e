"""SAC and continuous actions against independent references: the squashed Gaussian's
log-probability (NumPy, tanh correction included), the soft target by hand, the
temperature's direction, Polyak averaging, the command against the wheel model, the
refusals, and a tiny run."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav import sac
from jaxnav.agent.trainer import make_train, run_inputs
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.env import from_config, make
from jaxnav.world.kinematics import firmware_limit

TINY = [
    "preset=modern",
    "agent=sac",
    "strategies=[policy]",
    "seeds=2",
    "episodes=null",
    "total_steps=256",
    "env.maze=square4",
    "env.actions=continuous",
    "env.max_steps=40",
    "sac.num_envs=4",
    "sac.batch_size=16",
    "sac.learning_starts=64",
    "sac.hidden=[16, 16]",
    "run.chunk_steps=128",
]


def test_squashed_log_probability_matches_numpy_with_the_tanh_correction():
    key = jax.random.PRNGKey(4)
    mean = jnp.asarray([[0.3, -1.2], [2.5, 0.0], [-4.0, 3.0]], jnp.float32)
    log_std = jnp.asarray([[-0.5, 0.2], [-2.0, 0.7], [0.1, -1.0]], jnp.float32)
    a, logp = sac.squashed_sample(key, mean, log_std)
    eps = np.asarray(jax.random.normal(key, mean.shape), np.float64)
    mu, ls = np.asarray(mean, np.float64), np.asarray(log_std, np.float64)
    u = mu + np.exp(ls) * eps
    gauss = -0.5 * ((u - mu) / np.exp(ls)) ** 2 - ls - 0.5 * math.log(2 * math.pi)
    want = np.sum(gauss - np.log(1.0 - np.tanh(u) ** 2), axis=-1)
    np.testing.assert_allclose(np.asarray(a), np.tanh(u), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(np.asarray(logp), want, rtol=1e-4, atol=1e-3)
    # far in the tail, where tanh(u) rounds to 1 in f32, the log-probability stays finite
    _, far = sac.squashed_sample(key, jnp.full((1, 2), 30.0), jnp.full((1, 2), -5.0))
    assert np.all(np.isfinite(np.asarray(far)))


def test_soft_target_by_hand():
    reward = jnp.asarray([1.0, -10.0, 0.5])
    terminated = jnp.asarray([False, True, False])
    next_q = jnp.asarray([[2.0, 5.0, -1.0], [3.0, 4.0, -2.0]])  # twin critics
    next_logp = jnp.asarray([-1.0, 0.5, 2.0])
    got = sac.soft_target(reward, terminated, next_q, next_logp, alpha=0.2, gamma=0.9)
    want = [
        1.0 + 0.9 * (2.0 - 0.2 * -1.0),  # min(2, 3) = 2
        -10.0,  # a collision: no bootstrap
        0.5 + 0.9 * (-2.0 - 0.2 * 2.0),  # min(-1, -2) = -2
    ]
    np.testing.assert_allclose(np.asarray(got), want, rtol=1e-6)


def test_temperature_rises_below_the_entropy_target_and_falls_above():
    target = -2.0  # H_target = -1 x 2 actions
    grad = jax.grad(sac.temperature_loss)
    # log pi = 3: entropy about -3, below the target -> gradient descent raises log alpha
    assert float(grad(jnp.float32(0.0), jnp.asarray([3.0, 3.0]), target)) < 0.0
    # log pi = 0: entropy about 0, above the target -> log alpha falls
    assert float(grad(jnp.float32(0.0), jnp.asarray([0.0, 0.0]), target)) > 0.0


@pytest.mark.slow  # 5 s on 2 cores
@pytest.mark.parametrize("average", [0.0, 0.1])
def test_one_gradient_step_moves_the_targets_by_polyak_averaging(average):
    cfg = load_config("smoke", TINY + ["sac.tau=0.25", f"sac.actor_average={average}"])
    env, params = make(
        "square4", "modern", actions="continuous", reward="progress", observation="normalised"
    )
    obs, _ = env.reset(jax.random.PRNGKey(0), params)
    actor, critic = sac.network_of(cfg), sac.critic_of(cfg)
    a_p = actor.init(jax.random.PRNGKey(1), obs)
    c_p = critic.init(jax.random.PRNGKey(2), obs, jnp.zeros(2))
    t_p = critic.init(jax.random.PRNGKey(3), obs, jnp.zeros(2))  # a target unlike the critic
    opt = __import__("optax").adam(cfg.sac.lr)
    n, d = 32, obs.shape[0]
    rng = np.random.default_rng(0)
    memory = sac.Memory(
        obs=jnp.asarray(rng.normal(size=(n, d)), jnp.float32),
        action=jnp.asarray(rng.uniform(-1, 1, size=(n, 2)), jnp.float32),
        reward=jnp.asarray(rng.normal(size=n), jnp.float32),
        next_obs=jnp.asarray(rng.normal(size=(n, d)), jnp.float32),
        terminated=jnp.asarray(rng.uniform(size=n) < 0.2),
        filled=jnp.int32(n),
        cursor=jnp.int32(0),
    )
    # a tested actor unlike the actor, so the average's step is seen
    avg_p = actor.init(jax.random.PRNGKey(4), obs)
    learner = sac.Learner(
        a_p,
        avg_p,
        c_p,
        t_p,
        jnp.log(jnp.float32(0.1)),
        opt.init(a_p),
        opt.init(c_p),
        opt.init(0.0),
    )
    new, loss, finite = sac.make_learner(cfg)(learner, memory, jax.random.PRNGKey(5))
    assert bool(finite) and float(loss) > 0.0
    want = jax.tree.map(lambda c, t: 0.25 * c + 0.75 * t, new.critic, t_p)
    for g, w in zip(jax.tree.leaves(new.target), jax.tree.leaves(want)):
        np.testing.assert_allclose(np.asarray(g), np.asarray(w), rtol=1e-6, atol=1e-7)
    # the critic moved and the target sits a quarter of the way towards it
    moved = jax.tree.leaves(jax.tree.map(lambda a, b: jnp.max(jnp.abs(a - b)), new.critic, c_p))
    assert max(float(x) for x in moved) > 0.0
    # the tested actor: the new actor itself, or a tenth of the way from its last value
    if average:
        want = jax.tree.map(lambda a, t: 0.1 * a + 0.9 * t, new.actor, avg_p)
    else:
        want = new.actor
    for g, w in zip(jax.tree.leaves(new.average), jax.tree.leaves(want)):
        np.testing.assert_allclose(np.asarray(g), np.asarray(w), rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("wheel_limit", [False, True])
def test_continuous_command_spans_the_limits_as_the_wheel_model_drives_it(wheel_limit):
    env, params = make(
        "square4",
        "modern",
        actions="continuous",
        reward="progress",
        speed_range=(0.05, 0.2),
        max_yaw_rate=2.0,
        wheel_limit=wheel_limit,
    )
    a = np.asarray([[-1, -1], [1, 1], [0, 0], [0.5, -0.25], [3.0, -7.0]], np.float32)
    v, omega = env.command(params, jnp.asarray(a))
    clipped = np.clip(a.astype(np.float64), -1, 1)
    want_v = 0.05 + (clipped[:, 0] + 1) / 2 * 0.15
    want_w = clipped[:, 1] * 2.0
    if wheel_limit:
        want_v, want_w = firmware_limit(want_v, want_w)
    np.testing.assert_allclose(np.asarray(v), want_v, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(np.asarray(omega), want_w, rtol=1e-5, atol=1e-6)
    # a step drives that arc: straight ahead at full speed for one period
    obs, state = env.reset(jax.random.PRNGKey(0), params)
    _, after, *_ = env.step(jax.random.PRNGKey(1), state, jnp.asarray([1.0, 0.0]), params)
    v_full, _ = firmware_limit(np.float64(0.2), np.float64(0.0)) if wheel_limit else (0.2, 0)
    travelled = np.linalg.norm(np.asarray(after.pos) - np.asarray(state.pos))
    assert travelled == pytest.approx(float(v_full) * float(params.dt), rel=1e-5)


def test_discrete_twin_plans_over_the_vw_set_in_the_same_world():
    env, params = make("square4", "modern", actions="continuous", reward="progress")
    twin, twin_params = env.discrete_twin(params)
    assert twin.actions == "vw" and twin.num_actions == 15
    key = jax.random.PRNGKey(3)
    np.testing.assert_array_equal(env.reset(key, params)[0], twin.reset(key, twin_params)[0])
    with pytest.raises(ValueError, match="continuous"):
        env.num_actions  # noqa: B018


@pytest.mark.parametrize(
    "overrides, says",
    [
        (["env.actions=vw"], "agent sac drives continuous commands: it needs env.actions"),
        (["strategies=[ebe]"], "strategies must be \\[policy\\]"),
        (["env.max_yaw_rate=3.0"], "burger's limits"),
        (["env.speed_range=[0, 0.3]"], "beyond_limits"),
        (["env.speed_range=[0.2, 0.1]"], "low <= high"),
        (["sac.entropy_scale=0"], "entropy_scale must be positive"),
        (["env.reward=dense"], "progress or sparse"),
        (["sac.batch_size=100000"], "larger than the replay"),
        (["env.action_delay=true"], "action_delay holds a discrete action"),
        (["sac.shared_torso=true"], "shared_torso shares the scan convolutions"),
        (["sac.updates=3", "sac.actor_every=2"], "actor_every \\(2\\) must divide"),
        (["sac.lr_decay=true", "total_steps=null", "episodes=5"], "lr_decay needs total_steps"),
    ],
)
def test_bad_continuous_settings_are_one_line_refusals(overrides, says):
    with pytest.raises(ConfigError, match=says) as err:
        load_config("smoke", TINY + overrides)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "overrides, says",
    [
        (["env.actions=continuous", "env.reward=progress"], "needs an agent with continuous"),
        (["env.actions=vw", "strategies=[policy]"], "policy is a continuous agent's own"),
        (["sac.num_envs=4"], "sac.num_envs is a SAC setting: it needs agent sac"),
    ],
)
@pytest.mark.parametrize("agent", ["dqn", "pqn"])
def test_a_q_learner_is_refused_continuous_actions_and_the_policy_strategy(agent, overrides, says):
    with pytest.raises(ConfigError, match=says):
        load_config("smoke", [f"agent={agent}", *overrides])


def test_beyond_limits_lets_faster_commands_through():
    cfg = load_config("smoke", TINY + ["env.speed_range=[0, 0.3]", "env.beyond_limits=true"])
    assert cfg.env.speed_range == (0.0, 0.3)


@pytest.mark.slow  # 3 s on 2 cores
def test_a_tiny_run_is_deterministic_and_acts_within_the_limits():
    cfg = load_config("smoke", TINY)
    train = jax.jit(jax.vmap(make_train(cfg)))
    inputs = run_inputs(cfg)
    a = train(*inputs)
    b = train(*inputs)
    assert np.asarray(a.step).tolist() == [256, 256]
    assert np.all(np.asarray(a.diverged_at) == -1)
    for x, y in zip(jax.tree.leaves(a.params), jax.tree.leaves(b.params)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    # the two seeds learned different policies; their mean commands lie in [-1, 1]^2
    obs = np.asarray(a.obs)[:, 0]
    actor = sac.network_of(cfg)
    acts = [
        np.asarray(actor.apply(jax.tree.map(lambda x, i=i: x[i], a.params), obs[i])) for i in (0, 1)
    ]
    assert all(np.all(np.abs(x) <= 1.0) for x in acts)
    assert int(a.memory.filled[0]) == 256 and np.asarray(a.memory.action).max() <= 1.0


@pytest.mark.slow  # 5 s on 2 cores
def test_the_tested_actor_is_the_actor_or_its_average():
    def run(extra):
        cfg = load_config("smoke", TINY + extra)
        return jax.jit(jax.vmap(make_train(cfg)))(*run_inputs(cfg))

    plain, averaged = run([]), run(["sac.actor_average=0.05"])
    leaves = jax.tree.leaves
    assert plain.actor is None  # off: the tested actor is the actor itself
    # the same actor learns (the average is not fed back), and the tested one lags it
    for x, y in zip(leaves(averaged.actor), leaves(plain.params)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    gap = [
        np.max(np.abs(np.asarray(x) - np.asarray(y)))
        for x, y in zip(leaves(averaged.params), leaves(averaged.actor))
    ]
    assert max(gap) > 0.0


@pytest.fixture(scope="module")
def tiny_sac_run(tmp_path_factory):
    from jaxnav.run.launch import train_new

    cfg = load_config("smoke", TINY + ["env.wheel_limit=true"])
    out = tmp_path_factory.mktemp("sac") / "run"
    train_new(cfg, out, quiet=True)
    return cfg, out


@pytest.mark.slow  # 3 s on 2 cores
def test_the_exported_policy_drives_the_trained_mean_command(tiny_sac_run):
    from jaxnav.core import rundir
    from jaxnav.robot.deploy import CONTINUOUS_VERSION, Policy
    from jaxnav.robot.export import export_policy

    cfg, out = tiny_sac_run
    policy = Policy.from_arrays(export_policy(out, "policy", 1))
    assert policy.meta["version"] == CONTINUOUS_VERSION and policy.continuous
    x = np.random.default_rng(5).uniform(-1, 1, (9, policy.obs_size)).astype(np.float32)
    params = rundir.load_params(out / rundir.PARAMS, "policy", 1)
    want = np.asarray(sac.network_of(cfg).apply(params, jnp.asarray(x)))
    np.testing.assert_allclose(policy.act(x), want, rtol=1e-4, atol=1e-5)
    # the command over the limits, the last command as the firmware drives it
    env, env_params = make(
        "square4",
        "modern",
        actions="continuous",
        reward="progress",
        observation="normalised",
        wheel_limit=True,
    )
    for a in want[:4]:
        v, omega = policy.take(a)
        assert (v, omega) == pytest.approx((0.11 * (a[0] + 1), 2.84 * a[1]), rel=1e-5)
        driven = env.command(env_params, jnp.asarray(a))
        np.testing.assert_allclose(policy.last_command, np.asarray(driven), rtol=1e-5, atol=1e-6)


@pytest.mark.slow
def test_a_sac_run_is_evaluated_beside_planners_of_its_discrete_twin(tiny_sac_run):
    import csv

    from jaxnav.commands import evaluate

    cfg, out = tiny_sac_run
    assert evaluate.main([str(out), "--episodes", "2"]) == 0
    with open(out / "eval" / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["strategy"] for r in rows} >= {"policy", "oracle", "dwa"}


def test_the_change_penalty_takes_the_command_change_by_hand():
    kw = dict(actions="continuous", reward="progress", observation="normalised")
    env, params = make("square4", "modern", step_penalty=0.02, change_penalty=0.3, **kw)
    plain_env, plain = make("square4", "modern", step_penalty=0.02, **kw)
    obs, state = env.reset(jax.random.PRNGKey(0), params)
    a1, a2 = jnp.asarray([1.0, 0.5]), jnp.asarray([0.0, -0.5])
    k = jax.random.PRNGKey(1)
    _, s1, r1, *_ = env.step(k, state, a1, params)
    _, p1, q1, *_ = plain_env.step(k, state, a1, plain)
    # from rest to (0.22, 1.42): the change is 0.22 / 0.22 + 1.42 / 2.84 = 1.5
    assert float(q1 - r1) == pytest.approx(0.3 * 1.5, rel=1e-5)
    _, _, r2, *_ = env.step(k, s1, a2, params)
    _, _, q2, *_ = plain_env.step(k, p1, a2, plain)
    # then to (0.11, -1.42): 0.11 / 0.22 + 2.84 / 2.84 = 1.5 again
    assert float(q2 - r2) == pytest.approx(0.3 * 1.5, rel=1e-5)


def test_the_change_penalty_needs_the_progress_reward_and_the_normalised_observation():
    with pytest.raises(ConfigError, match="env.change_penalty needs env.reward progress"):
        load_config("smoke", TINY + ["env.change_penalty=0.3", "env.observation=robotis"])
    assert load_config("smoke", TINY + ["env.change_penalty=0.3"]).env.change_penalty == 0.3


@pytest.mark.slow
def test_resume_after_sigkill_gives_identical_results(tmp_path):
    """The replay ring travels in the checkpoint with the rest of SAC's state."""
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    tiny = [o for o in TINY if not o.startswith(("total_steps", "run.chunk_steps"))]
    tiny += ["total_steps=8192", "run.chunk_steps=512", "run.chunk_s=0", "run.checkpoint_s=0"]
    ref, killed = tmp_path / "ref", tmp_path / "killed"
    cmd = [sys.executable, "-m", "jaxnav.commands.train", "smoke", *tiny, "--quiet"]
    subprocess.run(cmd + ["--out", str(ref)], check=True, cwd=root)
    proc = subprocess.Popen(cmd + ["--out", str(killed)], cwd=root)
    ckpt = killed / "checkpoints" / "last.npz"
    deadline = time.time() + 120
    while not ckpt.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not (killed / "params.npz").exists(), "the run finished before it could be killed"
    resume = [sys.executable, "-m", "jaxnav.commands.train", "--resume", str(killed), "--quiet"]
    subprocess.run(resume, check=True, cwd=root)
    assert (killed / "metrics.csv").read_bytes() == (ref / "metrics.csv").read_bytes()
    a, b = np.load(ref / "params.npz"), np.load(killed / "params.npz")
    assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files)


@pytest.mark.slow  # 3 s on 2 cores
def test_a_sac_policy_with_scan_convolutions_trains_and_exports_its_mean_command(tmp_path):
    """sac.scan_conv: the actor and each critic start with their own circular
    convolutions over the scan and its history; a tiny run trains, and the exported
    policy (format version 7) drives the trained actor's mean command on the same
    observations."""
    from jaxnav.core import rundir
    from jaxnav.robot.deploy import CONV_VERSION, Policy
    from jaxnav.robot.export import export_policy
    from jaxnav.run.launch import train_new

    extra = ["sac.scan_conv=[4,4]", "env.scan_history=2", "env.history_changes=true"]
    cfg = load_config("smoke", TINY + extra)
    out = tmp_path / "run"
    train_new(cfg, out, quiet=True)
    params = rundir.load_params(out / rundir.PARAMS, "policy", 0)
    assert set(params["params"]["ScanTorso"]) == {"Conv_0", "Conv_1"}
    critic = sac.critic_of(cfg).init(
        jax.random.key(0), jnp.zeros((1, 24 * 3 + 4)), jnp.zeros((1, 2))
    )
    twin = critic["params"]["VmapCritic_0"]["ScanTorso"]["Conv_0"]["kernel"]
    assert twin.shape == (2, 5, 3, 4)  # each critic its own kernel over 3 channels
    policy = Policy.from_arrays(export_policy(out, "policy", 0))
    assert policy.meta["version"] == CONV_VERSION and policy.continuous
    x = np.random.default_rng(6).uniform(-1, 1, (9, policy.obs_size)).astype(np.float32)
    want = np.asarray(sac.network_of(cfg).apply(params, jnp.asarray(x)))
    np.testing.assert_allclose(policy.act(x), want, rtol=1e-4, atol=1e-5)


SHARED = [
    "sac.scan_conv=[4,4]",
    "env.scan_history=2",
    "env.history_changes=true",
    "sac.shared_torso=true",
]


def uniform_memory(n: int, d: int, seed: int) -> sac.Memory:
    """A full replay memory of ``n`` random transitions of ``d``-value observations in
    [-1, 1] (the normalised observation's range), a fifth of them collisions."""
    rng = np.random.default_rng(seed)
    return sac.Memory(
        obs=jnp.asarray(rng.uniform(-1, 1, size=(n, d)), jnp.float32),
        action=jnp.asarray(rng.uniform(-1, 1, size=(n, 2)), jnp.float32),
        reward=jnp.asarray(rng.normal(size=n), jnp.float32),
        next_obs=jnp.asarray(rng.uniform(-1, 1, size=(n, d)), jnp.float32),
        terminated=jnp.asarray(rng.uniform(size=n) < 0.2),
        filled=jnp.int32(n),
        cursor=jnp.int32(0),
    )


def test_a_shared_torso_is_trained_by_the_critics_loss_alone_and_read_by_the_actor():
    """sac.shared_torso: one gradient step moves the critics (torso included) by one
    Adam step of the critics' loss alone, recomputed here on the same batch; the actor's
    own layers move, its torso becomes the critics' new one, the targets take their
    Polyak step, and the actor's optimiser holds only the actor's own layers."""
    import optax

    cfg = load_config("smoke", TINY + SHARED + ["sac.tau=0.25"])
    env, _ = from_config(cfg)
    d = 24 * 3 + 4
    actor, critic = sac.network_of(cfg, env), sac.critic_of(cfg, env)
    assert critic.shared and env.scan_layout == (24, 4, 2)
    x0, a0 = jnp.zeros(d), jnp.zeros(2)
    c_p = critic.init(jax.random.PRNGKey(2), x0, a0)
    assert c_p["params"]["ScanTorso"]["Conv_0"]["kernel"].shape == (5, 3, 4)  # one, not two
    t_p = critic.init(jax.random.PRNGKey(3), x0, a0)
    a_p = sac.with_torso(
        sac.split_torso(actor.init(jax.random.PRNGKey(1), x0))[1], sac.split_torso(c_p)[0]
    )
    opt = optax.adam(cfg.sac.lr)
    n = 32
    memory = uniform_memory(n, d, seed=0)
    head0 = sac.trained_part(cfg, a_p)
    assert "ScanTorso" not in head0["params"]
    learner = sac.Learner(
        a_p, a_p, c_p, t_p, jnp.log(jnp.float32(0.1)), opt.init(head0), opt.init(c_p), opt.init(0.0)
    )
    key = jax.random.PRNGKey(5)
    new, loss, finite = sac.make_learner(cfg, env)(learner, memory, key)
    assert bool(finite) and float(loss) > 0.0

    # the reference: the same batch and next actions, through the full (unsplit) networks
    k_idx, k_next, _ = jax.random.split(key, 3)
    idx = jax.random.randint(k_idx, (cfg.sac.batch_size,), 0, n)
    obs, next_obs = memory.obs[idx], memory.next_obs[idx]
    next_a, next_logp = actor.apply(a_p, next_obs, k_next)
    next_q = critic.apply(t_p, next_obs, next_a)
    y = sac.soft_target(memory.reward[idx], memory.terminated[idx], next_q, next_logp, 0.1, 0.99)

    def critic_loss(p):
        return jnp.sum(jnp.mean((critic.apply(p, obs, memory.action[idx]) - y) ** 2, axis=-1))

    grads = jax.grad(critic_loss)(c_p)
    updates, _ = opt.update(grads, opt.init(c_p), c_p)
    want = optax.apply_updates(c_p, updates)
    for g, w in zip(jax.tree.leaves(new.critic), jax.tree.leaves(want)):
        np.testing.assert_allclose(np.asarray(g), np.asarray(w), rtol=1e-5, atol=1e-6)

    torso, head = sac.split_torso(new.actor)
    for g, w in zip(jax.tree.leaves(torso), jax.tree.leaves(sac.split_torso(new.critic)[0])):
        np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
    moved = jax.tree.map(lambda a, b: float(jnp.max(jnp.abs(a - b))), head, head0)
    assert min(jax.tree.leaves(moved)) > 0.0  # every layer of the actor's own moved
    target = jax.tree.map(lambda c, t: 0.25 * c + 0.75 * t, new.critic, t_p)
    for g, w in zip(jax.tree.leaves(new.target), jax.tree.leaves(target)):
        np.testing.assert_allclose(np.asarray(g), np.asarray(w), rtol=1e-6, atol=1e-7)


def test_a_sac_policy_with_a_shared_torso_trains_and_exports_its_mean_command(tmp_path):
    """A tiny run with sac.shared_torso: the tested actor's torso is the critics', and
    the export (the same format as separate torsos) drives its mean command."""
    from jaxnav.core import rundir
    from jaxnav.robot.deploy import Policy
    from jaxnav.robot.export import export_policy
    from jaxnav.run.launch import train_new

    cfg = load_config("smoke", TINY + SHARED)
    out = tmp_path / "run"
    train_new(cfg, out, quiet=True)
    params = rundir.load_params(out / rundir.PARAMS, "policy", 0)
    assert set(params["params"]["ScanTorso"]) == {"Conv_0", "Conv_1"}
    policy = Policy.from_arrays(export_policy(out, "policy", 0))
    x = np.random.default_rng(7).uniform(-1, 1, (9, policy.obs_size)).astype(np.float32)
    want = np.asarray(sac.network_of(cfg).apply(params, jnp.asarray(x)))
    np.testing.assert_allclose(policy.act(x), want, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("shared", [False, True])
def test_a_critics_only_step_is_the_full_steps_critic_step_and_leaves_the_actor(shared):
    """sac.actor_every's critics-only step: the critics and targets move exactly as in
    the full step on the same key (the critics' step comes first in both); the actor's
    own layers, its optimiser, the temperature and its optimiser stay; with a shared
    torso the actor reads the critics' new one."""
    import optax

    cfg = load_config("smoke", TINY + (SHARED if shared else []) + ["sac.actor_average=0.1"])
    env, _ = from_config(cfg)
    d = env.obs_size
    actor, critic = sac.network_of(cfg, env), sac.critic_of(cfg, env)
    x0 = jnp.zeros(d)
    c_p = critic.init(jax.random.PRNGKey(2), x0, jnp.zeros(2))
    t_p = critic.init(jax.random.PRNGKey(3), x0, jnp.zeros(2))
    a_p = actor.init(jax.random.PRNGKey(1), x0)
    if shared:
        a_p = sac.with_torso(sac.split_torso(a_p)[1], sac.split_torso(c_p)[0])
    opt = optax.adam(cfg.sac.lr)
    n = 32
    memory = uniform_memory(n, d, seed=1)
    head0 = sac.trained_part(cfg, a_p)
    learner = sac.Learner(
        a_p, a_p, c_p, t_p, jnp.log(jnp.float32(0.1)), opt.init(head0), opt.init(c_p), opt.init(0.0)
    )
    learn = sac.make_learner(cfg, env)
    key = jax.random.PRNGKey(7)
    full, full_loss, _ = learn(learner, memory, key)
    critics, loss, finite = learn(learner, memory, key, actor_step=False)
    assert bool(finite) and float(loss) == float(full_loss)
    leaves = jax.tree.leaves
    for name in ("critic", "target", "critic_opt"):
        for g, w in zip(leaves(getattr(critics, name)), leaves(getattr(full, name))):
            np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
    for name in ("log_alpha", "actor_opt", "alpha_opt"):
        for g, w in zip(leaves(getattr(critics, name)), leaves(getattr(learner, name))):
            np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
    assert float(full.log_alpha) != float(learner.log_alpha)  # the full step moved it
    for g, w in zip(leaves(sac.trained_part(cfg, critics.actor)), leaves(head0)):
        np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
    if shared:  # the actor reads the critics' new torso
        torso = sac.split_torso(critics.actor)[0]
        for g, w in zip(leaves(torso), leaves(sac.split_torso(critics.critic)[0])):
            np.testing.assert_array_equal(np.asarray(g), np.asarray(w))


@pytest.mark.slow  # 3 s on 2 cores
def test_the_actor_steps_once_per_actor_every_critic_steps_in_a_run():
    """Adam counts its steps: after a tiny run with sac.updates 2 and sac.actor_every 2
    the actor's optimiser has taken half the critics' steps, the temperature's as many
    as the actor's."""
    cfg = load_config("smoke", TINY + ["sac.updates=2", "sac.actor_every=2"])
    out = jax.jit(jax.vmap(make_train(cfg)))(*run_inputs(cfg))
    assert np.all(np.asarray(out.diverged_at) == -1)

    def count(state):
        return int(np.asarray(jax.tree.leaves(state[0].count)[0]).reshape(-1)[0])

    critic_steps = count(out.critic_opt)
    # learning starts with the env step that reaches 64 env steps: 49 of the run's 64
    # steps of its 4 environments, 2 critic steps each
    assert critic_steps == ((256 - 64) // 4 + 1) * 2
    assert count(out.actor_opt) == critic_steps // 2 == count(out.alpha_opt)


@pytest.mark.slow  # 3 s on 2 cores
def test_the_learning_rates_fall_linearly_to_zero_at_the_runs_last_gradient_step():
    """sac.lr_decay: under a constant gradient Adam's direction is exactly 1, so step c
    moves a parameter by -lr (1 - c / N); N by hand is the run's gradient steps (49 env
    steps that learn x 2 critic steps; the actor every 2nd of them), and a tiny run's
    optimisers end at exactly that count."""
    import optax

    cfg = load_config(
        "smoke", TINY + ["sac.lr_decay=true", "sac.updates=2", "sac.actor_every=2", "sac.lr=0.01"]
    )
    for opt, n in zip(sac.optimizers(cfg), (49, 98)):
        x = jnp.zeros(())
        state = opt.init(x)
        for c in range(n + 1):
            updates, state = opt.update(jnp.ones(()), state, x)
            want = 0.0 if c == n else -0.01 * (1.0 - c / n)
            np.testing.assert_allclose(float(updates), want, rtol=1e-5, atol=1e-9)
            x = optax.apply_updates(x, updates)
    out = jax.jit(jax.vmap(make_train(cfg)))(*run_inputs(cfg))

    def count(state):
        return {int(c) for c in np.asarray(jax.tree.leaves(state[0].count)[0]).reshape(-1)}

    assert count(out.critic_opt) == {98} and count(out.actor_opt) == {49}


def test_n_step_returns_match_a_walk_through_each_environments_stream():
    """sac.n_step: every slot's return, last slot and discount against a plain Python
    walk of the ring (written in steps of ``envs`` slots, one per environment, wrapped
    round past the capacity) that follows each transition's environment forward while
    its episode goes on and the next step was written, n steps at most."""
    envs, capacity, n, gamma = 3, 20, 4, 0.9
    rng = np.random.default_rng(3)
    steps = 9  # 27 transitions into 20 slots: the ring wrapped
    reward = np.zeros(capacity, np.float32)
    done = np.zeros(capacity, bool)
    written = {}  # slot -> (env step t, env e)
    for t in range(steps):
        for e in range(envs):
            slot = (t * envs + e) % capacity
            reward[slot], done[slot] = rng.normal(), rng.uniform() < 0.25
            written[slot] = (t, e)
    cursor = steps * envs % capacity
    memory = sac.Memory(
        obs=jnp.zeros((capacity, 1)),
        action=jnp.zeros((capacity, 2)),
        reward=jnp.asarray(reward),
        next_obs=jnp.zeros((capacity, 1)),
        terminated=jnp.zeros(capacity, bool),
        filled=jnp.int32(capacity),
        cursor=jnp.int32(cursor),
        done=jnp.asarray(done),
    )
    slot_of = {v: k for k, v in written.items()}
    idx = np.arange(capacity)
    g, last, disc = sac.n_step_returns(memory, jnp.asarray(idx), n, envs, gamma)
    for i in idx:
        t, e = written[i]
        total, at, k = 0.0, i, 0
        while True:
            total += gamma**k * reward[at]
            k += 1
            nxt = slot_of.get((t + k, e))
            if k == n or done[at] or nxt is None:
                break
            at = nxt
        np.testing.assert_allclose(float(g[i]), total, rtol=1e-5, atol=1e-6)
        assert int(last[i]) == at and abs(float(disc[i]) - gamma**k) < 1e-6
    assert set(np.asarray(last).tolist()) != set(idx.tolist())  # some walks went on


@pytest.mark.slow  # 5 s on 2 cores
def test_a_tiny_n_step_run_learns_finite_and_one_step_is_unchanged():
    cfg = load_config("smoke", TINY + ["sac.n_step=3"])
    out = jax.jit(jax.vmap(make_train(cfg)))(*run_inputs(cfg))
    assert np.all(np.asarray(out.diverged_at) == -1)
    assert int(np.asarray(out.memory.done).sum()) > 0  # episodes of 40 steps ended
    plain = jax.jit(jax.vmap(make_train(load_config("smoke", TINY))))(*run_inputs(cfg))
    assert plain.memory.done is None
