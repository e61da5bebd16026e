"""The field's exploration methods beside EBE (strategies rnd, noisy, count), each
against an independent reference: RND's bonus is the predictor's squared error computed
by hand, NoisyNets' noise has the factorised covariance over many draws, the count bonus
is 1/sqrt(n) of a NumPy count; and each leaves the runs of other strategies in its
program as they were, and every program without it unchanged."""

from __future__ import annotations

import csv
import math
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav.agent import counts, explored, noisy, rnd
from jaxnav.agent.bonus import Moments, Steps
from jaxnav.agent.hyper import hyper
from jaxnav.agent.networks import QNetwork
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.env import from_config

# a PQN config on square4 small enough to compile and train in seconds
TINY = [
    "preset=modern",
    "env.maze=square4",
    "env.reward=sparse",
    "seeds=2",
    "total_steps=2048",
    "pqn.num_envs=4",
    "pqn.rollout=16",
    "pqn.minibatches=2",
    "pqn.epochs=2",
    "run.chunk_steps=1024",
    "run.test_mazes=[square4]",
    "run.test_episodes=1",
]


def tiny(*more):
    return load_config(None, [*TINY, *more])


# ----------------------------------------------------------------------------
# RND
# ----------------------------------------------------------------------------


def _mlp(params, x, hidden):
    """The RND features by hand: leaky ReLU (slope 0.01) between Dense layers."""
    p = params["params"]
    for i in range(hidden + 1):
        x = x @ np.asarray(p[f"Dense_{i}"]["kernel"], np.float64) + np.asarray(
            p[f"Dense_{i}"]["bias"], np.float64
        )
        if i < hidden:
            x = np.where(x > 0, x, 0.01 * x)
    return x


def test_rnd_bonus_is_the_predictors_squared_error_by_hand():
    cfg = tiny("strategies=[rnd]")
    env = from_config(cfg)[0]
    bonus = rnd.make(cfg, env)
    rng = np.random.default_rng(0)
    T, E, D = 5, 4, env.obs_size
    state = bonus.init(jax.random.PRNGKey(3), jnp.asarray(rng.normal(size=(E, D)), jnp.float32))
    scale = 0.3
    h = SimpleNamespace(rnd_scale=jnp.float32(scale))
    running = np.zeros(E)
    ret_count, ret_mean, ret_var = 1e-4, 0.0, 1.0
    obs_count, obs_mean, obs_var = 1e-4, np.zeros(D), np.ones(D)
    for _ in range(2):  # two rollouts: the running moments carry over
        x = rng.normal(2.0, 3.0, size=(T, E, D)).astype(np.float32)
        got, state = bonus.reward(state, Steps(jnp.asarray(x), jnp.zeros((T, E, 2))), h)
        # observation moments over every sample so far, by the parallel formula
        flat = x.reshape(-1, D).astype(np.float64)
        n, m, v = len(flat), flat.mean(0), flat.var(0)
        tot = obs_count + n
        d = m - obs_mean
        obs_mean, obs_var = (
            obs_mean + d * n / tot,
            (obs_var * obs_count + v * n + d**2 * obs_count * n / tot) / tot,
        )
        obs_count = tot
        z = np.clip((x - obs_mean) / np.sqrt(obs_var), -5, 5)
        err = np.mean(
            (_mlp(state.predictor, z, 3) - _mlp(state.target, z, 2)) ** 2, axis=-1
        )  # [T, E]
        sums = []
        for t in range(T):
            running = 0.99 * running + err[t]
            sums.append(running.copy())
        sums = np.asarray(sums).reshape(-1)
        n, m, v = len(sums), sums.mean(), sums.var()
        tot = ret_count + n
        d = m - ret_mean
        ret_mean, ret_var = (
            ret_mean + d * n / tot,
            (ret_var * ret_count + v * n + d**2 * ret_count * n / tot) / tot,
        )
        ret_count = tot
        np.testing.assert_allclose(np.asarray(got), scale * err / np.sqrt(ret_var), rtol=2e-4)


def test_rnd_predictor_learns_the_observations_it_sees_and_not_others():
    cfg = tiny("strategies=[rnd]", "pqn.rollout=64", "pqn.epochs=4")
    env = from_config(cfg)[0]
    bonus = rnd.make(cfg, env)
    rng = np.random.default_rng(1)
    D = env.obs_size
    seen = jnp.asarray(rng.normal(size=(64, 4, D)), jnp.float32)
    unseen = jnp.asarray(rng.normal(size=(64, 4, D)) + 1.5, jnp.float32)
    state = bonus.init(jax.random.PRNGKey(0), seen[0])
    h = SimpleNamespace(rnd_scale=jnp.float32(1.0))
    steps = Steps(seen, jnp.zeros((64, 4, 2)))
    _, state = bonus.reward(state, steps, h)

    def err(s, x):
        return float(jnp.mean(rnd.error(s.target, s.predictor, rnd.normalised(x, s.obs))))

    before = err(state, seen), err(state, unseen)
    learn = jax.jit(bonus.learn)
    for i in range(150):
        state = learn(state, steps, jax.random.PRNGKey(i))
    after = err(state, seen), err(state, unseen)
    assert after[0] < 0.5 * before[0]  # the seen observations are learnt
    assert after[1] > 2 * after[0]  # the unseen ones stay novel


# ----------------------------------------------------------------------------
# NoisyNets
# ----------------------------------------------------------------------------


def test_noisy_noise_has_the_factorised_covariance_over_many_draws():
    p, q, n = 3, 4, 200_000
    f_in, f_out = noisy.factorised_noise(jax.random.PRNGKey(0), (n,), p, q)
    eps = np.asarray(f_in)[:, :, None] * np.asarray(f_out)[:, None, :]  # [n, p, q]
    # each weight's noise: mean 0, variance E|x|^2 = 2/pi (f(x)^2 = |x|)
    np.testing.assert_allclose(eps.mean(0), 0.0, atol=0.01)
    np.testing.assert_allclose(eps.var(0), 2 / math.pi, rtol=0.02)
    # the factorised structure: weights that share an input (or an output) have
    # correlated squares, Cov = E[x^2] (2/pi) - (2/pi)^2; others none
    sq = eps.reshape(n, p * q) ** 2
    cov = np.cov(sq, rowvar=False)
    share = 2 / math.pi - (2 / math.pi) ** 2
    for a in range(p * q):
        for b in range(a + 1, p * q):
            (i, j), (k, m) = divmod(a, q), divmod(b, q)
            want = share if (i == k) != (j == m) else 0.0
            assert abs(cov[a, b] - want) < 0.02, (a, b, cov[a, b], want)
    # and every draw is exactly the outer product of the two noises (rank one)
    assert np.linalg.matrix_rank(eps[0]) == 1


def test_noisy_layer_output_is_the_mean_weights_plus_the_drawn_noise_by_hand():
    layer = noisy.NoisyDense(5, sigma0=0.5)
    x = jnp.asarray(np.random.default_rng(0).normal(size=(7, 3)), jnp.float32)
    params = layer.init(jax.random.PRNGKey(0), x)
    p = {k: np.asarray(v, np.float64) for k, v in params["params"].items()}
    np.testing.assert_allclose(p["kernel_sigma"], 0.5 / math.sqrt(3))  # sigma_0 / sqrt(p)
    on = jnp.float32(1.0)
    drawn = noisy.draw(layer, params, x, on, jax.random.PRNGKey(9))  # one per sample
    y = layer.apply(noisy.with_draw(params, drawn), x, noise=on)
    f_in, f_out = (np.asarray(a, np.float64) for a in drawn["draw"])
    assert f_in.shape == (7, 3) and f_out.shape == (7, 5)
    xs = np.asarray(x, np.float64)
    for b in range(len(xs)):  # each sample's own weights, formed whole
        w = p["kernel"] + p["kernel_sigma"] * np.outer(f_in[b], f_out[b])
        bias = p["bias"] + p["bias_sigma"] * f_out[b]
        np.testing.assert_allclose(np.asarray(y[b]), xs[b] @ w + bias, rtol=1e-5, atol=1e-6)
    # a draw for one observation is one set of weights for a whole batch
    one = noisy.draw(layer, params, x[0], on, jax.random.PRNGKey(9))
    f_in, f_out = (np.asarray(a, np.float64) for a in one["draw"])
    w = p["kernel"] + p["kernel_sigma"] * np.outer(f_in, f_out)
    np.testing.assert_allclose(
        np.asarray(layer.apply(noisy.with_draw(params, one), x, noise=on)),
        xs @ w + p["bias"] + p["bias_sigma"] * f_out,
        rtol=1e-5,
        atol=1e-6,
    )
    # switched off (0) or without noise: exactly the mean layer
    off = layer.apply(noisy.with_draw(params, drawn), x, noise=jnp.float32(0.0))
    np.testing.assert_array_equal(np.asarray(off), np.asarray(layer.apply(params, x)))


def test_a_noisy_q_network_starts_from_the_plain_networks_weights():
    obs = jnp.ones(28)
    plain = QNetwork(5, (64, 64), 0.0, layer_norm=True)
    noisy_net = QNetwork(5, (64, 64), 0.0, layer_norm=True, noisy=True)
    a = plain.init(jax.random.PRNGKey(4), obs)["params"]
    b = noisy_net.init(jax.random.PRNGKey(4), obs)["params"]
    for name, layer in a.items():
        for leaf, value in layer.items():
            np.testing.assert_array_equal(np.asarray(value), np.asarray(b[name][leaf]))
    assert set(b["Dense_0"]) == {"kernel", "bias", "kernel_sigma", "bias_sigma"}
    # the mean network (no noise asked) is the plain one
    np.testing.assert_array_equal(
        np.asarray(plain.apply({"params": a}, obs)), np.asarray(noisy_net.apply({"params": b}, obs))
    )


# ----------------------------------------------------------------------------
# The count bonus and the record of what a run explored
# ----------------------------------------------------------------------------


def test_count_bonus_is_scale_over_sqrt_of_a_numpy_count():
    cfg = tiny("strategies=[count]", "exploration.count_cell=0.5")
    bonus = counts.make(cfg, from_config(cfg)[0])
    rng = np.random.default_rng(0)
    state = bonus.init(jax.random.PRNGKey(0), jnp.zeros((4, 28)))
    h = SimpleNamespace(count_scale=jnp.float32(0.2))
    n = np.zeros((8, 8))  # square4: 3.7 m, cells of 0.5 m
    for _ in range(3):
        pos = rng.uniform(-1.85, 1.85, size=(6, 4, 2)).astype(np.float32)
        got, state = bonus.reward(state, Steps(jnp.zeros((6, 4, 28)), jnp.asarray(pos)), h)
        ix = np.floor((pos[..., 0] + 1.85) / 0.5).astype(int)
        iy = np.floor((pos[..., 1] + 1.85) / 0.5).astype(int)
        np.add.at(n, (iy.ravel(), ix.ravel()), 1)
        np.testing.assert_allclose(np.asarray(got), 0.2 / np.sqrt(n[iy, ix]), rtol=1e-6)
    np.testing.assert_array_equal(np.asarray(state.counts), n)


def test_explored_keeps_the_visited_cells_and_the_first_goal():
    e = explored.Explored.start(3, 4)
    iy = jnp.asarray([[0, 1], [2, 2]])
    ix = jnp.asarray([[0, 3], [1, 1]])
    none = jnp.zeros((2, 2), bool)
    e = explored.visited(e, iy, ix, none, jnp.int32(100), 2)
    assert int(e.first_goal) == -1
    reached = jnp.asarray([[False, False], [False, True]])
    e = explored.visited(e, iy, ix, reached, jnp.int32(104), 2)
    assert int(e.first_goal) == 104 + 2 * 2  # the second step of that rollout
    e = explored.visited(e, iy, ix, jnp.ones((2, 2), bool), jnp.int32(108), 2)
    assert int(e.first_goal) == 108 - 4 + 2 * 2  # kept: the first one
    want = np.zeros((3, 4), bool)
    want[[0, 1, 2], [0, 3, 1]] = True
    np.testing.assert_array_equal(np.asarray(e.visits), want)
    free = np.ones((3, 4), bool)
    free[0, 0] = False
    assert float(explored.coverage(e.visits, jnp.asarray(free))) == pytest.approx(2 / 11)


# ----------------------------------------------------------------------------
# The configs: off by default, refused where they cannot work
# ----------------------------------------------------------------------------


def test_the_weights_are_carried_only_where_a_listed_strategy_reads_them():
    plain = hyper(tiny())
    assert plain.rnd_scale is None and plain.count_scale is None
    both = hyper(tiny("strategies=[ebe,rnd,count]", "exploration.rnd_scale=0.5"))
    assert both.rnd_scale == np.float32(0.5) and both.count_scale == np.float32(0.1)


@pytest.mark.parametrize(
    "overrides, says",
    [
        (["agent=dqn", "strategies=[rnd]"], "strategies has rnd, whose intrinsic reward"),
        (["env.generator=grid", "strategies=[count]"], "counts visits to the places of one"),
        (["run.coverage=true"], "run.coverage is written with the greedy evaluations"),
    ],
)
def test_a_method_where_it_cannot_work_is_one_line(overrides, says):
    with pytest.raises(ConfigError, match=says):
        tiny(*overrides)


@pytest.mark.slow
def test_a_bonus_or_noise_changes_its_own_runs_only(tmp_path):
    """Every arm of a program with rnd, noisy and count; the epsilon-greedy runs in it
    learn exactly as they do in a program without them."""
    from jaxnav.run.launch import train_new

    alone = tiny("strategies=[epsilon_greedy]", "run.eval_every=1024")
    mixed = tiny(
        "strategies=[epsilon_greedy,rnd,noisy,count]", "run.eval_every=1024", "run.coverage=true"
    )
    train_new(alone, tmp_path / "alone", quiet=True)
    train_new(mixed, tmp_path / "mixed", quiet=True)
    a = np.load(tmp_path / "alone" / "params.npz")
    m = np.load(tmp_path / "mixed" / "params.npz")
    assert a.files and all(k.startswith("epsilon_greedy/") for k in a.files)
    for k in a.files:  # the epsilon-greedy runs' layers (a noisy one's mean weights)
        np.testing.assert_allclose(a[k], m[k], rtol=1e-6, atol=1e-7, err_msg=k)
    for other in ("rnd", "noisy", "count"):  # the others learn apart from them
        assert any(not np.allclose(m[k], m[k.replace("epsilon_greedy", other)]) for k in a.files)
    with open(tmp_path / "mixed" / "eval.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["strategy"] for r in rows} == {"epsilon_greedy", "rnd", "noisy", "count"}
    assert all(0.0 < float(r["coverage"]) <= 1.0 for r in rows)
    assert all(r["first_goal"] == "" or int(r["first_goal"]) > 0 for r in rows)


def test_moments_match_numpy_over_batches():
    rng = np.random.default_rng(2)
    m = Moments.start((3,))
    xs = [rng.normal(1.0, 2.0, size=(50, 3)) for _ in range(4)]
    for x in xs:
        m = m.update(jnp.asarray(x, jnp.float32))
    allx = np.concatenate(xs)
    np.testing.assert_allclose(np.asarray(m.mean), allx.mean(0), rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(np.asarray(m.var), allx.var(0), rtol=1e-3)


def test_dqn_learns_a_noisy_network_with_its_own_noise_and_the_others_without():
    from jaxnav.agent.replay import Batch
    from jaxnav.dqn import batch_loss, network_of

    cfg = load_config("smoke", ["strategies=[ebe,noisy]"])
    net = network_of(cfg)
    assert net.noisy and net.noisy_sigma == 0.5
    rng = np.random.default_rng(0)
    batch = Batch(
        jnp.asarray(rng.normal(size=(8, 26)), jnp.float32),
        jnp.asarray(rng.integers(0, 5, 8)),
        jnp.asarray(rng.normal(size=8), jnp.float32),
        jnp.asarray(rng.normal(size=(8, 26)), jnp.float32),
        jnp.zeros(8, bool),
    )
    params = net.init(jax.random.PRNGKey(0), batch.obs[0])
    h = hyper(cfg)
    key = jax.random.PRNGKey(1)

    def loss(noise):
        return float(batch_loss(net, h, params, params, batch, key, noise=noise))

    plain = loss(None)
    assert loss(jnp.float32(0.0)) == plain  # an EBE run of the program: no noise at all
    assert loss(jnp.float32(1.0)) != plain  # a NoisyNets run: its own noise
    assert network_of(load_config("smoke")).noisy is False  # off unless listed
