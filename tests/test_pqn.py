"""PQN against independent references: its lambda-returns, its network, its runs."""

import csv
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _cut_run import cut_after_one_chunk

from jaxnav import dqn, pqn
from jaxnav.agent.exploration import epsilon_schedule, normalised_entropy
from jaxnav.agent.qlearning import td_target
from jaxnav.agent.trainer import make_train, run_inputs
from jaxnav.commands.train import main
from jaxnav.core import agents, rundir
from jaxnav.core import strategies as registry
from jaxnav.core.config import load_config
from jaxnav.robot.deploy import FORMAT_VERSION, NORMS_VERSION, Policy
from jaxnav.robot.export import export_policy
from jaxnav.run import launch
from jaxnav.run.launch import train_new

STRATEGIES = registry.names("discrete")
TINY = [
    "agent=pqn",
    "seeds=2",
    "episodes=12",
    "env.max_steps=20",
    "pqn.num_envs=4",
    "pqn.rollout=8",
    "pqn.minibatches=2",
    "run.chunk_steps=64",
    "dqn.optimizer=radam",
    "dqn.lr=0.001",
    f"strategies=[{', '.join(STRATEGIES)}]",
]


def _np_lambda_returns(r, term, trunc, v, gamma, lam):
    """The lambda-return by a plain backwards loop, one environment at a time."""
    T, E = r.shape
    g = np.zeros((T, E))
    for e in range(E):
        for t in reversed(range(T)):
            if term[t, e]:  # a collision: no bootstrap
                g[t, e] = r[t, e]
            elif trunc[t, e] or t == T - 1:  # bootstrap from the observation after t
                g[t, e] = r[t, e] + gamma * v[t, e]
            else:
                g[t, e] = r[t, e] + gamma * ((1 - lam) * v[t, e] + lam * g[t + 1, e])
    return g


def _rollout_arrays(seed, T=12, E=5):
    rng = np.random.default_rng(seed)
    r = rng.normal(size=(T, E)).astype(np.float32)
    v = rng.normal(size=(T, E)).astype(np.float32)
    end = rng.uniform(size=(T, E))
    term, trunc = end < 0.15, (end >= 0.15) & (end < 0.3)
    term[-1, 0], trunc[-1, 1] = True, True  # ends on the rollout's last step too
    term[-1, 1] = False
    return r, term, trunc, v


# -- Lambda-returns ---------------------------------------------------------------


@pytest.mark.parametrize("lam", [0.0, 0.65, 1.0])
def test_lambda_returns_match_a_numpy_backwards_loop(lam):
    r, term, trunc, v = _rollout_arrays(0)
    assert term.any() and trunc.any() and (~(term | trunc)).any()
    got = pqn.lambda_returns(*map(jnp.asarray, (r, term, trunc, v)), 0.9, lam)
    np.testing.assert_allclose(got, _np_lambda_returns(r, term, trunc, v, 0.9, lam), rtol=1e-5)


def test_lambda_zero_is_the_one_step_td_target():
    r, term, trunc, v = _rollout_arrays(1)
    got = pqn.lambda_returns(*map(jnp.asarray, (r, term, trunc, v)), 0.9, 0.0)
    # td_target takes Q-values; a single action makes max_a Q the value itself
    want = td_target(jnp.asarray(r), jnp.asarray(term), jnp.asarray(v)[..., None], 0.9)
    np.testing.assert_allclose(got, want, rtol=1e-6)


def test_lambda_return_is_the_lambda_weighted_mix_of_n_step_returns():
    """Forward view, no episode end: G_t = (1 - lam) sum_n lam^(n-1) G_t^(n) up to the
    rollout's end, whose n-step return takes the remaining weight lam^(N-1)."""
    T, gamma, lam = 7, 0.9, 0.7
    rng = np.random.default_rng(2)
    r, v = rng.normal(size=(T, 1)), rng.normal(size=(T, 1))
    no = np.zeros((T, 1), bool)
    got = np.asarray(pqn.lambda_returns(jnp.asarray(r), no, no, jnp.asarray(v), gamma, lam))
    for t in range(T):
        N = T - t

        def n_step(n, t=t):
            return sum(gamma**k * r[t + k, 0] for k in range(n)) + gamma**n * v[t + n - 1, 0]

        want = (1 - lam) * sum(lam ** (n - 1) * n_step(n) for n in range(1, N))
        want += lam ** (N - 1) * n_step(N)
        assert got[t, 0] == pytest.approx(want, rel=1e-4)


@pytest.mark.slow
def test_rollout_targets_bootstrap_a_truncation_from_its_final_observation():
    # a 3-step limit: every environment truncates twice inside an 8-step rollout
    cfg = load_config(None, [*TINY, "env.max_steps=3", "seeds=1", "strategies=[ebe]"])
    parts = pqn.make_rollouts(cfg)
    tr = pqn.make_trainer(cfg)
    ts = tr.init(*jax.tree.map(lambda a: a[0], tuple(run_inputs(cfg))))
    _, ro = jax.jit(parts.play)(ts, jnp.bool_(True), jax.random.PRNGKey(3))
    trunc = np.asarray(ro.truncated)
    assert trunc.sum() == 2 * cfg.pqn.num_envs and not np.asarray(ro.terminated).any()
    obs, nxt = np.asarray(ro.obs), np.asarray(ro.next_obs)
    within = ~trunc[:-1]  # steps whose next row continues the episode
    np.testing.assert_array_equal(nxt[:-1][within], obs[1:][within])
    assert not np.allclose(nxt[:-1][trunc[:-1]], obs[1:][trunc[:-1]])  # the reset start
    q = lambda x: np.asarray(parts.network.apply(ts.params, x)).max(-1)  # noqa: E731
    gamma, lam = cfg.dqn.gamma, cfg.pqn.td_lambda
    r, term = np.asarray(ro.reward), np.asarray(ro.terminated)
    want = _np_lambda_returns(r, term, trunc, q(nxt), gamma, lam)
    got = np.asarray(parts.targets(ts.params, ro, gamma))
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)
    # bootstrapping from the next row (the next episode's start) would differ
    v_next_row = np.concatenate([q(obs[1:]), q(nxt[-1:])])
    wrong = _np_lambda_returns(r, term, trunc, v_next_row, gamma, lam)
    assert not np.allclose(got[trunc], wrong[trunc], rtol=1e-4)


@pytest.mark.slow  # 3 s on 2 cores
def test_pqn_draws_restarted_episodes_paces_from_the_curriculum_at_its_progress():
    """env.pace_curriculum in training: at the start of the budget every restart draws
    from motion_pace's range; past the curriculum's share every restart runs the
    cylinders at their own pace."""
    over = ["env.maze=stage3", "env.max_steps=3", "seeds=1", "strategies=[ebe]"]
    over += ["episodes=null", "total_steps=1000", "env.motion_pace=[0,0.5]"]
    cfg = load_config(None, [*TINY, *over, "env.pace_curriculum=0.5"])
    parts, tr = pqn.make_rollouts(cfg), pqn.make_trainer(cfg)
    ts = tr.init(*jax.tree.map(lambda a: a[0], tuple(run_inputs(cfg))))
    play = jax.jit(parts.play)
    for step, low, high in ((0, 0.0, 0.5), (500, 1.0, 1.0)):
        (_, env_state, _, _), ro = play(
            ts.replace(step=jnp.int32(step)), True, jax.random.PRNGKey(3)
        )
        assert np.asarray(ro.truncated).any(0).all()  # every environment restarted
        pace = np.asarray(env_state.pace)
        assert np.all((pace >= low) & (pace <= high)), (step, pace)


# -- Network and acting -----------------------------------------------------------


def test_pqn_network_normalises_each_hidden_layer_before_its_relu():
    cfg = load_config(None, ["agent=pqn", "dqn.hidden=[8, 6]"])
    net = agents.get(cfg.agent).network_of(cfg)
    x = jax.random.normal(jax.random.PRNGKey(0), (4, 26))
    params = net.init(jax.random.PRNGKey(1), x)
    # a scale and bias that are not the identity's, so a missing one would show
    params = jax.tree.map(
        lambda a: a + 0.3 * jax.random.normal(jax.random.PRNGKey(2), a.shape), params
    )
    p = jax.tree.map(lambda a: np.asarray(a, np.float64), params["params"])
    assert sorted(p) == ["Dense_0", "Dense_1", "Dense_2", "LayerNorm_0", "LayerNorm_1"]
    h = np.asarray(x, np.float64)
    for i in range(2):
        h = h @ p[f"Dense_{i}"]["kernel"] + p[f"Dense_{i}"]["bias"]
        h = (h - h.mean(-1, keepdims=True)) / np.sqrt(h.var(-1, keepdims=True) + 1e-6)
        h = np.maximum(h * p[f"LayerNorm_{i}"]["scale"] + p[f"LayerNorm_{i}"]["bias"], 0.0)
    h = h @ p["Dense_2"]["kernel"] + p["Dense_2"]["bias"]
    np.testing.assert_allclose(net.apply(params, x), h, rtol=1e-4, atol=1e-5)
    dqn_params = dqn.network_of(load_config(None, ["dqn.hidden=[8, 6]"])).init(
        jax.random.PRNGKey(1), x
    )
    assert sorted(dqn_params["params"]) == ["Dense_0", "Dense_1", "Dense_2"]


# NoisyNets acts greedily on Q-values with its noise (tests/test_exploration_methods.py)
@pytest.mark.parametrize("strategy", [s for s in STRATEGIES if s != "noisy"])
def test_every_environment_explores_by_its_own_q_values(strategy):
    cfg = load_config(None, TINY)
    parts, tr = pqn.make_rollouts(cfg), pqn.make_trainer(cfg)
    r = [s for s, _ in cfg.run_labels()].index(strategy)
    ts = tr.init(*jax.tree.map(lambda a: a[r], tuple(run_inputs(cfg))))
    ts = ts.replace(episode=jnp.int32(7))  # epsilon below its start
    _, ro = jax.jit(parts.play)(ts, jnp.bool_(True), jax.random.PRNGKey(4))
    q = np.asarray(parts.network.apply(ts.params, ro.obs[0]), np.float64)  # first step
    np.testing.assert_allclose(ro.max_q[0], q.max(-1), rtol=1e-6)
    x = cfg.exploration
    if strategy == "ebe":
        want = np.asarray(normalised_entropy(jnp.asarray(q), x.ebe_temperature))
    elif strategy in ("epsilon_greedy", "rnd", "count"):  # the bonuses act epsilon-greedy
        want = np.full(len(q), float(epsilon_schedule(jnp.int32(7), x.eps_start, x.eps_decay)))
    else:
        z = (q - q.max(-1, keepdims=True)) / x.boltzmann_temperature
        want = 1.0 - (np.exp(z) / np.exp(z).sum(-1, keepdims=True)).max(-1)
    np.testing.assert_allclose(ro.explore[0], want, rtol=1e-4, atol=1e-6)
    assert len(set(np.asarray(ro.explore[0]).round(6))) > 1 or strategy in (
        "epsilon_greedy",
        "rnd",
        "count",
    )


# -- Runs -------------------------------------------------------------------------


def _files(out):
    return {f: (out / f).read_bytes() for f in ("metrics.csv", "explore.csv", "params.npz")}


@pytest.fixture(scope="module")
def tiny_pqn_run(tmp_path_factory):
    cfg = load_config(None, TINY)
    out = tmp_path_factory.mktemp("pqn") / "run"
    train_new(cfg, out, quiet=True)
    return cfg, out


@pytest.mark.slow
def test_a_tiny_pqn_run_is_deterministic_and_every_strategy_learns(tiny_pqn_run, tmp_path):
    cfg, out = tiny_pqn_run
    train_new(cfg, tmp_path / "again", quiet=True)
    assert _files(tmp_path / "again") == _files(out)
    tr = pqn.make_trainer(cfg)
    inputs = run_inputs(cfg)
    for r, (strategy, seed) in enumerate(cfg.run_labels()):
        init = tr.init(*jax.tree.map(lambda a, r=r: a[r], tuple(inputs))).params["params"]
        trained = rundir.load_params(out / rundir.PARAMS, strategy, seed)["params"]
        assert "LayerNorm_0" in trained
        # a program with NoisyNets carries the noise's scales in every run: they learn in
        # the noisy runs only
        names = [jax.tree_util.keystr(p) for p, _ in jax.tree_util.tree_flatten_with_path(init)[0]]
        moved = [
            not np.array_equal(a, b)
            for name, a, b in zip(names, *map(jax.tree.leaves, (init, trained)), strict=True)
            if strategy == "noisy" or "sigma" not in name
        ]
        assert moved and all(moved), f"{strategy} seed {seed} did not train"
    with open(out / rundir.METRICS) as f:
        rows = list(csv.DictReader(f))
    for strategy, seed in cfg.run_labels():
        numbers = [
            int(x["episode"]) for x in rows if (x["strategy"], int(x["seed"])) == (strategy, seed)
        ]
        assert numbers == list(range(len(numbers))) and len(numbers) >= cfg.pqn.num_envs


@pytest.mark.slow  # 4 s on 2 cores
def test_the_episode_budget_counts_the_episodes_of_all_environments(tiny_pqn_run):
    cfg, out = tiny_pqn_run
    with open(out / rundir.METRICS) as f:
        rows = list(csv.DictReader(f))
    for label in cfg.run_labels():
        mine = [x for x in rows if (x["strategy"], int(x["seed"])) == label]
        assert [int(x["episode"]) for x in mine] == list(range(cfg.episodes))
        assert all(1 <= int(x["length"]) <= cfg.env.max_steps for x in mine)
    # 4 environments play the 12 episodes: 3 rounds of at most 20 steps, whole updates
    steps = json.loads((out / rundir.SUMMARY).read_text())["env_steps"] / cfg.n_runs
    assert steps % (cfg.pqn.num_envs * cfg.pqn.rollout) == 0 and steps <= 3 * 20 * 4 + 32


@pytest.mark.slow
def test_a_resumed_pqn_run_ends_as_an_uninterrupted_one(tiny_pqn_run, tmp_path):
    cfg, ref = tiny_pqn_run
    out = tmp_path / "run"
    cut_after_one_chunk(cfg, out)  # one chunk, then "killed"
    assert not list(out.glob("checkpoints/rows-*.npz"))  # no replay rows to save
    launch.resume(out, quiet=True)
    assert _files(out) == _files(ref)


@pytest.mark.slow
def test_make_train_gives_the_host_loops_parameters(tiny_pqn_run, tmp_path):
    cfg, out = tiny_pqn_run
    final = jax.jit(jax.vmap(make_train(cfg, pqn.make_trainer(cfg))))(*run_inputs(cfg))
    k = np.asarray(final.params["params"]["Dense_2"]["kernel"])
    for r, (strategy, seed) in enumerate(cfg.run_labels()):
        want = rundir.load_params(out / rundir.PARAMS, strategy, seed)["params"]["Dense_2"]
        np.testing.assert_array_equal(k[r], want["kernel"])


@pytest.mark.slow
def test_a_step_budget_counts_the_steps_of_all_environments_in_whole_updates():
    cfg = load_config(None, [*TINY, "episodes=null", "total_steps=100"])
    final = jax.jit(jax.vmap(make_train(cfg, pqn.make_trainer(cfg))))(*run_inputs(cfg))
    np.testing.assert_array_equal(final.step, 128)  # 4 updates of 4 x 8 steps


@pytest.mark.slow  # its fixture is a slow test's
def test_a_pqn_policy_exports_with_its_layer_norms(tiny_pqn_run):
    cfg, out = tiny_pqn_run
    policy = Policy.from_arrays(export_policy(out, "ebe", 0))
    assert policy.meta["version"] == NORMS_VERSION != FORMAT_VERSION  # older readers refuse it
    assert len(policy.norms) == 2
    x = np.random.default_rng(5).uniform(0.1, 3.5, (9, policy.obs_size)).astype(np.float32)
    params = rundir.load_params(out / rundir.PARAMS, "ebe", 0)
    want = agents.get(cfg.agent).network_of(cfg).apply(params, jnp.asarray(x))
    np.testing.assert_allclose(policy.q_values(x), want, rtol=1e-4, atol=1e-4)


# -- Bad input --------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, message",
    [
        (["dqn.tau=0.5"], "dqn.tau is a replay or target-network setting"),
        (["dqn.double=true"], "dqn.double is a replay or target-network setting"),
        (["dqn.n_step=3"], "dqn.n_step is a replay or target-network setting"),
        (["dqn.buffer_size=1000"], "dqn.buffer_size is a replay or target-network setting"),
        (["dqn.batch_size=32"], "dqn.batch_size is a replay or target-network setting"),
        (["dqn.learning_starts=9"], "dqn.learning_starts is a replay or target-network"),
        (["dqn.target_update_every=9"], "dqn.target_update_every is a replay or target"),
        (["sweep.dqn.tau=[0.5, 1.0]"], "sweep.dqn.tau is a replay or target-network setting"),
        (["pqn.minibatches=3"], "pqn.minibatches (3) must divide pqn.num_envs x pqn.rollout"),
        (["pqn.td_lambda=1.5"], "pqn.td_lambda must be in [0, 1]"),
        (["pqn.num_envs=0"], "pqn.num_envs must be at least 1"),
        (
            ["agent=dqn", "pqn.rollout=8"],
            "pqn.rollout is a PQN setting: it needs agent pqn",
        ),
        (["agent=ppo"], "agent must be one of dqn, pqn, sac, got 'ppo'"),
    ],
)
def test_bad_pqn_input_is_one_line_and_exit_2(argv, message, capsys, tmp_path):
    assert main(["agent=pqn", *argv, "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "run").exists()


def test_pqn_takes_the_presets_target_rule_as_its_default():
    cfg = load_config(None, ["preset=robotis", "agent=pqn"])  # episode_end: robotis' default
    assert cfg.dqn.target_update == "episode_end" and cfg.agent == "pqn"
    assert load_config("pqn").agent == "pqn"
