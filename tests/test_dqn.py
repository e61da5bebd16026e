"""The learner's pieces against hand-computed and NumPy references."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from jaxnav.agent.exploration import (
    boltzmann,
    ebe,
    epsilon_greedy,
    epsilon_schedule,
    explore_action,
    explore_or_greedy,
    normalised_entropy,
)
from jaxnav.agent.networks import QNetwork, dropout16, dueling_q
from jaxnav.agent.qlearning import optimizer_of, soft_update, td_loss, td_target
from jaxnav.agent.trainer import make_train, run_inputs, run_limits, still_training
from jaxnav.core import strategies as registry
from jaxnav.core.config import ExplorationConfig, load_config
from jaxnav.core.errors import ConfigError
from jaxnav.dqn import make_trainer, network_of

STRATEGIES = registry.names("discrete")

# -- TD target and loss -------------------------------------------------------


def test_td_target_bootstraps_through_truncation_not_collision():
    reward = jnp.array([1.0, -150.0, 2.0])
    terminated = jnp.array([False, True, False])  # the third is a truncation: not terminal
    next_q = jnp.array([[0.0, 3.0, 1.0], [10.0, 20.0, 30.0], [-1.0, -2.0, 5.0]])
    y = td_target(reward, terminated, next_q, 0.9)
    np.testing.assert_allclose(y, [1.0 + 0.9 * 3.0, -150.0, 2.0 + 0.9 * 5.0], rtol=1e-6)


def test_td_loss_is_mean_squared_error_of_taken_actions():
    q = jnp.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    action = jnp.array([2, 0])
    target = jnp.array([1.0, 10.0])
    # (3 - 1)^2 = 4, (4 - 10)^2 = 36 -> mean 20
    assert float(td_loss(q, action, target)) == pytest.approx(20.0)
    # the gradient reaches only the taken actions' Q-values
    g = jax.grad(lambda q: td_loss(q, action, target))(q)
    np.testing.assert_allclose(g, [[0, 0, 2.0], [-6.0, 0, 0]])


# -- EBE ----------------------------------------------------------------------


def _np_entropy(q, t=1.0):
    z = (q - q.max()) / t
    p = np.exp(z) / np.exp(z).sum()
    return float(-(p * np.log(p + 1e-300)).sum() / math.log(len(q)))


def test_uniform_q_has_entropy_one():
    assert float(normalised_entropy(jnp.full(5, 3.7))) == pytest.approx(1.0, abs=1e-6)


def test_one_dominant_action_has_entropy_near_zero():
    assert float(normalised_entropy(jnp.array([0.0, 0.0, 100.0, 0.0, 0.0]))) < 1e-3


def test_entropy_matches_numpy():
    rng = np.random.default_rng(0)
    for scale in (0.1, 1.0, 5.0, 50.0):
        for _ in range(20):
            q = rng.normal(size=5) * scale
            for t in (1.0, 10.0):
                got = float(normalised_entropy(jnp.asarray(q, jnp.float32), t))
                assert got == pytest.approx(_np_entropy(q, t), abs=1e-5)


def test_ebe_random_action_rate_matches_entropy():
    q = jnp.array([0.0, 0.5, 1.5, 0.2, -0.3])
    h = float(normalised_entropy(q))
    keys = jax.random.split(jax.random.PRNGKey(0), 40_000)
    actions, hs = jax.vmap(lambda k: ebe(k, q))(keys)
    assert np.allclose(hs, h)
    # a random action is non-greedy 4 times in 5
    non_greedy = float(np.mean(np.asarray(actions) != 2))
    assert non_greedy == pytest.approx(h * 4 / 5, abs=0.01)


def test_epsilon_greedy_rate_and_schedule():
    q = jnp.array([0.0, 1.0, 0.0, 0.0, 0.0])
    keys = jax.random.split(jax.random.PRNGKey(1), 40_000)
    actions, _ = jax.vmap(lambda k: epsilon_greedy(k, q, 0.3))(keys)
    assert float(np.mean(np.asarray(actions) != 1)) == pytest.approx(0.3 * 4 / 5, abs=0.01)
    eps = [1.0]
    for _ in range(400):
        eps.append(max(0.99 * eps[-1], 0.05))
    got = epsilon_schedule(jnp.arange(401))
    np.testing.assert_allclose(got, eps, rtol=1e-5)
    assert float(got[0]) == 1.0 and float(got[-1]) == pytest.approx(0.05)


def test_strategy_table_gives_each_strategy_its_tested_act():
    assert STRATEGIES[:3] == ("ebe", "epsilon_greedy", "boltzmann")  # the built-in ones
    x = ExplorationConfig(
        ebe_temperature=2.0, eps_start=0.8, eps_decay=0.9, eps_min=0.1, boltzmann_temperature=0.5
    )
    q = jnp.array([0.0, 0.5, 1.5, 0.2, -0.3])
    episode, key = jnp.int32(7), jax.random.PRNGKey(3)
    eps = epsilon_greedy(key, q, epsilon_schedule(episode, 0.8, 0.9, 0.1))
    want = {
        "ebe": ebe(key, q, 2.0),
        "epsilon_greedy": eps,
        "boltzmann": boltzmann(key, q, 0.5),
        # RND and the count bonus act epsilon-greedy on Q-values that learn their bonus;
        # NoisyNets greedy on Q-values that carry the network's noise
        "rnd": eps,
        "count": eps,
        "noisy": (jnp.argmax(q), jnp.float32(0.0)),
    }
    assert set(want) >= set(STRATEGIES) - {"policy"}, "a new strategy needs its act here"
    for name in STRATEGIES:
        action, prob = explore_action(jnp.int32(registry.index(name)), key, q, episode, x)
        assert int(action) == int(want[name][0]) and float(prob) == float(want[name][1]), name
    # vmapped over one strategy index per run, as in the trainer; a program that meets
    # only some strategies computes only theirs, and selects the same
    for strategies in (STRATEGIES, ("ebe", "epsilon_greedy"), ("boltzmann", "ebe")):
        index = jnp.asarray([registry.index(s) for s in strategies])
        acts = jax.vmap(lambda i, s=strategies: explore_action(i, key, q, episode, x, s))(index)
        np.testing.assert_array_equal(acts[0], [want[s][0] for s in strategies])
        np.testing.assert_array_equal(acts[1], [want[s][1] for s in strategies])


def test_boltzmann_samples_from_the_softmax_of_q_over_t():
    q = jnp.array([0.0, 0.5, 1.5, 0.2, -0.3])
    for t in (0.3, 1.0, 3.0):
        p = np.exp(np.asarray(q, np.float64) / t)
        p /= p.sum()
        keys = jax.random.split(jax.random.PRNGKey(0), 40_000)
        actions, not_greedy = jax.vmap(lambda k, t=t: boltzmann(k, q, t))(keys)
        freq = np.bincount(np.asarray(actions), minlength=5) / len(keys)
        # 40k draws: each frequency within 5 standard errors of its probability
        assert np.all(np.abs(freq - p) <= 5 * np.sqrt(p * (1 - p) / len(keys))), (t, freq, p)
        assert float(not_greedy[0]) == pytest.approx(1.0 - p.max(), rel=1e-5)


def test_ebe_power_raises_the_entropy_to_the_power():
    q = jnp.array([0.0, 0.5, 1.5, 0.2, -0.3])
    key = jax.random.PRNGKey(1)
    h = float(normalised_entropy(q))
    assert float(ebe(key, q, 1.0, 2.0)[1]) == pytest.approx(h**2, rel=1e-6)
    assert float(ebe(key, q, 1.0, 0.5)[1]) == pytest.approx(h**0.5, rel=1e-6)
    assert float(ebe(key, q)[1]) == h  # power 1 is the paper's H exactly


# -- Network ------------------------------------------------------------------


def test_q_network_is_paper_table_2_with_dropout_only_in_training():
    net = QNetwork()
    x = jnp.ones((3, 26))
    params = net.init(jax.random.PRNGKey(0), x)
    shapes = jax.tree.map(lambda a: a.shape, params)["params"]
    assert shapes == {
        "Dense_0": {"kernel": (26, 64), "bias": (64,)},
        "Dense_1": {"kernel": (64, 64), "bias": (64,)},
        "Dense_2": {"kernel": (64, 5), "bias": (5,)},
    }
    a = net.apply(params, x)
    np.testing.assert_array_equal(a, net.apply(params, x))  # acting is deterministic
    t1 = net.apply(params, x, train=True, rngs={"dropout": jax.random.PRNGKey(1)})
    t2 = net.apply(params, x, train=True, rngs={"dropout": jax.random.PRNGKey(2)})
    assert not np.allclose(t1, t2)


# -- Training step ------------------------------------------------------------


def _tiny(*overrides):
    return load_config(
        None,
        [
            "seeds=2",
            "episodes=3",
            "env.max_steps=40",
            "run.chunk_steps=50",
            "dqn.batch_size=8",
            *overrides,
        ],
    )


def _run(inputs, r: int):
    """Trainer.init's arguments of run r."""
    return jax.tree.map(lambda a: a[r], tuple(inputs))


@pytest.mark.slow
def test_target_sync_every_n_steps():
    cfg = _tiny("dqn.target_update_every=5", "dqn.learning_starts=1")
    tr = make_trainer(cfg)
    ts = tr.init(*_run(run_inputs(cfg), 0))
    step = jax.jit(tr.step)
    for n in range(1, 12):
        ts, _ = step(ts, None)
        same = all(
            np.array_equal(a, b)
            for a, b in zip(jax.tree.leaves(ts.params), jax.tree.leaves(ts.target_params))
        )
        assert same == (n % 5 == 0), n


@pytest.mark.slow
def test_robotis_target_is_the_online_net_in_warm_up_then_last_episode_ends_copy():
    """ROBOTIS: targets from the online net while the step is at most N, then from the
    target net, which is copied at every episode end (warm-up included)."""
    warm = 30
    cfg = _tiny(
        "dqn.target_update=episode_end",
        f"dqn.target_update_every={warm}",
        "dqn.learning_starts=1",
        "env.max_steps=7",  # episodes end often: at least every 7 steps
        "episodes=100",
    )
    tr = make_trainer(cfg)
    ts = tr.init(*_run(run_inputs(cfg), 0))
    init_params = ts.target_params
    step = jax.jit(tr.step)
    copies = 0
    for n in range(1, 3 * warm):
        before = ts
        ts, _ = step(ts, None)
        ended = int(ts.episode) > int(before.episode)
        synced = all(
            np.array_equal(a, b)
            for a, b in zip(jax.tree.leaves(ts.params), jax.tree.leaves(ts.target_params))
        )
        kept = all(
            np.array_equal(a, b)
            for a, b in zip(
                jax.tree.leaves(before.target_params), jax.tree.leaves(ts.target_params)
            )
        )
        assert synced if ended else kept, n
        copies += ended
    assert copies >= 2 * warm // 7
    # after the warm-up the target is never the initial network
    assert not np.array_equal(
        ts.target_params["params"]["Dense_0"]["kernel"],
        init_params["params"]["Dense_0"]["kernel"],
    )


@pytest.mark.slow
def test_a_finished_run_is_held_still_while_the_others_train_and_sync():
    """Vmapped as jaxnav train runs them: a finished run's whole state stays as it was
    (rings, running sums, buffer, target), and the run beside it steps, files episodes
    and syncs its target exactly as it does beside a run that still trains."""
    cfg = _tiny(
        "dqn.target_update_every=3",
        "dqn.learning_starts=1",
        "env.max_steps=4",
        "episodes=100",
        "run.chunk_steps=10",
    )
    tr = make_trainer(cfg)
    both = jax.jit(jax.vmap(tr.chunk))(jax.vmap(tr.init)(*run_inputs(cfg)))[0]
    ts = both.replace(episode=both.episode.at[0].set(cfg.episodes))  # run 0 has finished
    finished = jax.tree.map(lambda a: a[0], ts)
    step = jax.jit(jax.vmap(tr.step))
    episodes = int(ts.episode[1])
    for _ in range(7):
        ts, _ = step(ts, None)
        both, _ = step(both, None)
        for a, b, c in zip(*map(jax.tree.leaves, (finished, ts, both)), strict=True):
            np.testing.assert_array_equal(b[0], a)
            np.testing.assert_array_equal(b[1], c[1])
        params, target = (jax.tree.leaves(t) for t in (ts.params, ts.target_params))
        synced = all(np.array_equal(a[1], b[1]) for a, b in zip(params, target))
        assert synced == (int(ts.step[1]) % 3 == 0), int(ts.step[1])
    filed = np.asarray(ts.metrics.ep_length[1, episodes : int(ts.episode[1])])
    assert len(filed) and np.all((filed > 0) & (filed <= 4))  # the new episodes are filed


def test_learning_starts_after_enough_transitions():
    cfg = _tiny("dqn.learning_starts=4")
    tr = make_trainer(cfg)
    ts0 = tr.init(*_run(run_inputs(cfg), 0))
    step = jax.jit(tr.step)
    ts = ts0
    for n in range(1, 6):
        ts, _ = step(ts, None)
        changed = not np.array_equal(
            ts.params["params"]["Dense_0"]["kernel"], ts0.params["params"]["Dense_0"]["kernel"]
        )
        assert changed == (n >= 4), n


@pytest.mark.slow
def test_seeds_differ_and_strategies_share_the_seed_init():
    cfg = _tiny()
    tr = make_trainer(cfg)
    inputs = run_inputs(cfg)
    assert list(np.asarray(inputs.strategy)) == [0, 0, 1, 1]
    ts = jax.vmap(tr.init)(*inputs)
    k = ts.params["params"]["Dense_0"]["kernel"]
    assert not np.allclose(k[0], k[1])  # seed 0 vs seed 1
    np.testing.assert_array_equal(k[0], k[2])  # ebe and epsilon-greedy on seed 0


def test_dropout16_drops_the_rate_and_rescales_the_rest():
    x = jnp.ones((64, 64 * 64 + 1))  # odd size: the last 32-bit draw is half used
    y = np.asarray(jax.jit(dropout16)(jax.random.PRNGKey(0), x, 0.2))
    dropped = y == 0.0
    assert abs(dropped.mean() - 0.2) < 0.005  # 262k units: 4 standard deviations ~ 0.003
    np.testing.assert_allclose(y[~dropped], 1.0 / 0.8, rtol=1e-6)
    # Both 16-bit halves of a draw are used, independently.
    assert not np.array_equal(dropped[:, 0::2], dropped[:, 1::2])
    y2 = np.asarray(dropout16(jax.random.PRNGKey(1), x, 0.2))
    assert not np.array_equal(y, y2)


@pytest.mark.parametrize("strategy", STRATEGIES[:3])  # the field's methods: their own tests
def test_trainer_acts_with_the_tested_exploration_functions(strategy):
    cfg = _tiny("strategies=[ebe, epsilon_greedy, boltzmann]")  # one program, three strategies
    tr = make_trainer(cfg)
    r = [s for s, _ in cfg.run_labels()].index(strategy)
    ts = tr.init(*_run(run_inputs(cfg), r))
    ts = ts.replace(episode=jnp.int32(2))  # eps below eps_start
    new, log = jax.jit(tr.step)(ts, None)
    explore = log.explore
    # The trainer's own key for acting, and its network's Q-values at the observation.
    _, k_act, _, _, _ = jax.random.split(ts.key, 5)
    q = network_of(cfg).apply(ts.params, ts.obs)
    x = cfg.exploration
    if strategy == "ebe":
        action, prob = ebe(k_act, q, x.ebe_temperature)
    elif strategy == "epsilon_greedy":
        eps = epsilon_schedule(ts.episode, x.eps_start, x.eps_decay, x.eps_min)
        action, prob = epsilon_greedy(k_act, q, eps)
    else:
        action, prob = boltzmann(k_act, q, x.boltzmann_temperature)
    assert float(explore) == pytest.approx(float(prob), rel=1e-6)
    assert int(new.buffer.action[0]) == int(action)
    if strategy != "boltzmann":
        # One draw serves EBE and epsilon-greedy: the same coin and random action.
        np.testing.assert_array_equal(action, explore_or_greedy(k_act, q, prob))


def test_still_training_is_one_rule_for_numpy_and_jax():
    episode, step = np.array([0, 2, 3, 1]), np.array([5, 5, 5, 10])
    want = [True, True, False, False]  # limits: 3 episodes, 10 steps
    np.testing.assert_array_equal(still_training(episode, step, 3, 10), want)
    got = still_training(jnp.asarray(episode), jnp.asarray(step), 3, 10)
    np.testing.assert_array_equal(got, want)
    never = int(jnp.iinfo(jnp.int32).max)
    assert run_limits(_tiny()) == (3, never)
    assert run_limits(_tiny("episodes=null", "total_steps=100")) == (never, 100)
    cfg = _tiny()
    tr = make_trainer(cfg)
    ts = tr.init(*_run(run_inputs(cfg), 0)).replace(episode=jnp.int32(3))
    assert not bool(tr.active(ts))


@pytest.mark.slow
def test_make_train_gives_the_state_of_repeated_chunks():
    cfg = _tiny("seeds=1", "episodes=2", "env.max_steps=20", "run.chunk_steps=16")
    tr = make_trainer(cfg)
    inputs = run_inputs(cfg)
    final = jax.jit(jax.vmap(make_train(cfg)))(*inputs)
    ts = jax.jit(jax.vmap(tr.init))(*inputs)
    chunk, chunks = jax.jit(jax.vmap(tr.chunk)), 0
    while np.asarray(jax.vmap(tr.active)(ts)).any():
        ts, _ = chunk(ts)
        chunks += 1
    assert chunks >= 2 and np.all(np.asarray(final.episode) == 2)
    for a, b in zip(jax.tree.leaves(final), jax.tree.leaves(ts), strict=True):
        np.testing.assert_array_equal(a, b)


# -- Agent variants beyond the paper (dqn.double, dueling, tau, loss, optimizer) ----


def test_double_target_differs_from_the_plain_one_exactly_where_the_argmaxes_disagree():
    reward = jnp.array([1.0, 2.0, 0.0, -150.0])
    terminated = jnp.array([False, False, False, True])
    next_q_target = jnp.array([[0.0, 3.0, 1.0], [4.0, 1.0, 2.0], [1.0, 1.5, 0.5], [9.0, 0.0, 0.0]])
    next_q_online = jnp.array([[0.0, 5.0, 1.0], [0.0, 1.0, 7.0], [2.0, 0.0, 0.0], [0.0, 9.0, 0.0]])
    plain = td_target(reward, terminated, next_q_target, 0.9)
    double = td_target(reward, terminated, next_q_target, 0.9, next_q_online)
    # row 0: both pick action 1 -> 1 + 0.9 * 3; row 1: online picks 2 -> 2 + 0.9 * 2;
    # row 2: online picks 0 -> 0.9 * 1; row 3: terminal, no bootstrap
    np.testing.assert_allclose(double, [1.0 + 2.7, 2.0 + 1.8, 0.9, -150.0], rtol=1e-6)
    disagree = np.argmax(next_q_online, -1) != np.argmax(next_q_target, -1)
    np.testing.assert_array_equal(np.asarray(double) != np.asarray(plain), disagree & ~terminated)


def test_dueling_head_is_value_plus_mean_subtracted_advantage():
    value = jnp.array([[2.0], [-1.0]])
    advantage = jnp.array([[1.0, 2.0, 6.0], [0.0, 0.0, 3.0]])
    # means 3 and 1: [2 - 2, 2 - 1, 2 + 3], [-1 - 1, -1 - 1, -1 + 2]
    np.testing.assert_allclose(dueling_q(value, advantage), [[0.0, 1.0, 5.0], [-2.0, -2.0, 1.0]])
    net = QNetwork(num_actions=3, hidden=(4,), dropout=0.0, dueling=True)
    x = jax.random.normal(jax.random.PRNGKey(0), (5, 6))
    params = net.init(jax.random.PRNGKey(1), x)
    p = jax.tree.map(np.asarray, params["params"])
    assert set(p) == {"Dense_0", "value", "advantage"}
    h = np.maximum(np.asarray(x) @ p["Dense_0"]["kernel"] + p["Dense_0"]["bias"], 0.0)
    v = h @ p["value"]["kernel"] + p["value"]["bias"]
    a = h @ p["advantage"]["kernel"] + p["advantage"]["bias"]
    np.testing.assert_allclose(net.apply(params, x), v + a - a.mean(-1, keepdims=True), atol=1e-5)


def test_soft_update_tau_one_is_a_copy_and_one_half_the_average():
    params = {"w": jnp.array([1.0, 2.0, -3.0]), "b": jnp.array(0.25)}
    target = {"w": jnp.array([3.0, 0.0, 1.0]), "b": jnp.array(-0.75)}
    copy = soft_update(params, target, 1.0)
    for k in params:
        np.testing.assert_array_equal(copy[k], params[k])
    half = soft_update(params, target, 0.5)
    np.testing.assert_array_equal(half["w"], [2.0, 1.0, -1.0])
    assert float(half["b"]) == -0.25


@pytest.mark.slow
def test_trainer_with_tau_moves_the_target_by_polyak_every_step():
    cfg = _tiny("dqn.tau=0.5", "dqn.learning_starts=1", "dqn.target_update_every=1000")
    tr = make_trainer(cfg)
    ts = tr.init(*_run(run_inputs(cfg), 0))
    step = jax.jit(tr.step)
    for _ in range(3):
        new, _ = step(ts, None)
        want = jax.tree.map(lambda p, t: 0.5 * p + 0.5 * t, new.params, ts.target_params)
        for a, b in zip(jax.tree.leaves(new.target_params), jax.tree.leaves(want), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-6)
        ts = new
    assert not np.array_equal(
        ts.params["params"]["Dense_0"]["kernel"], ts.target_params["params"]["Dense_0"]["kernel"]
    )


def test_huber_loss_against_a_hand_computed_value():
    q = jnp.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    action = jnp.array([2, 0])
    target = jnp.array([2.5, 7.0])
    # errors 0.5 and -3: 0.5 * 0.5^2 = 0.125 and 3 - 0.5 = 2.5 -> mean 1.3125
    assert float(td_loss(q, action, target, "huber")) == pytest.approx(1.3125)
    g = jax.grad(lambda q: td_loss(q, action, target, "huber"))(q)
    np.testing.assert_allclose(g, [[0, 0, 0.25], [-0.5, 0, 0]])  # clipped at 1, over 2
    assert float(td_loss(q, action, target)) == pytest.approx((0.25 + 9.0) / 2)


def test_adam_first_update_is_optax_adam():
    d = _tiny("dqn.optimizer=adam", "dqn.lr=0.01").dqn
    params = {"w": jnp.array([0.5, -1.0, 2.0]), "b": jnp.array([0.1])}
    grads = {"w": jnp.array([0.3, -2.0, 1e-3]), "b": jnp.array([-0.7])}
    ours = optimizer_of(d, d.optimizer)
    updates, _ = ours.update(grads, ours.init(params), params)
    ref = optax.adam(0.01)
    want, _ = ref.update(grads, ref.init(params), params)
    for k in params:
        np.testing.assert_array_equal(updates[k], want[k])
    # Adam's first step: m / sqrt(v) = g / |g| after bias correction, so -lr * sign(g)
    np.testing.assert_allclose(updates["w"], [-0.01, 0.01, -0.01], rtol=1e-4)


@pytest.mark.parametrize(
    "switch",
    [
        "dqn.double=true",
        "dqn.dueling=true",
        "dqn.loss=huber",
        "dqn.optimizer=adam",
        "dqn.tau=0.5",
        "dqn.n_step=3",
        "dqn.prioritised=true",
    ],
)
@pytest.mark.slow
def test_each_switch_trains_and_changes_the_updates(switch):
    # a large learning rate, so the online and target networks' argmax part early
    common = ("seeds=1", "strategies=[ebe]", "dqn.learning_starts=2", "dqn.lr=0.01")
    base, cfg = _tiny(*common), _tiny(*common, switch)
    out = []
    for c in (base, cfg):
        tr = make_trainer(c)
        ts = tr.init(*_run(run_inputs(c), 0))
        ts, _ = jax.lax.scan(tr.step, ts, None, length=30)  # 29 gradient steps
        assert all(np.all(np.isfinite(x)) for x in jax.tree.leaves(ts.params))
        out.append(ts)
    if switch != "dqn.dueling=true":  # the same network: the switch changed the update
        k0, k1 = (t.params["params"]["Dense_2"]["kernel"] for t in out)
        assert not np.array_equal(k0, k1)


@pytest.mark.parametrize(
    "override, key",
    [
        ("dqn.tau=0", "dqn.tau"),
        ("dqn.tau=1.5", "dqn.tau"),
        ("dqn.loss=l1", "dqn.loss"),
        ("dqn.optimizer=sgd", "dqn.optimizer"),
        ("dqn.n_step=0", "dqn.n_step"),
    ],
)
def test_bad_agent_switches_are_one_line_naming_the_setting(override, key):
    with pytest.raises(ConfigError) as e:
        load_config(None, [override])
    msg = str(e.value)
    assert key in msg and "\n" not in msg
