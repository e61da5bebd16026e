"""The across-seed statistics against inputs whose answer is known by hand."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import trim_mean

from jaxnav.report import stats

scores = st.lists(st.integers(-5, 5).map(float), min_size=2, max_size=8)


def test_identical_samples_have_probability_of_improvement_one_half():
    x = np.array([1.0, 5.0, 3.0, 3.0])
    p = stats.probability_of_improvement_ci(x, x.copy())
    assert p.value == 0.5
    assert p.low <= 0.5 <= p.high


def test_a_dominating_sample_has_probability_of_improvement_one():
    p = stats.probability_of_improvement_ci([10.0, 11.0, 12.0], [1.0, 2.0, 3.0])
    assert p == (1.0, 1.0, 1.0)
    assert stats.probability_of_improvement([1.0, 2.0], [10.0, 11.0]) == 0.0


def test_probability_of_improvement_counts_pairs_and_half_ties():
    # pairs of (3, 1) against (2, 2, 0): 3 beats all three, 1 beats only 0 -> 4 / 6
    assert stats.probability_of_improvement([3.0, 1.0], [2.0, 2.0, 0.0]) == pytest.approx(4 / 6)
    # (1, 2, 3) against (2): 0 + 0.5 + 1 over 3 pairs
    assert stats.probability_of_improvement([1.0, 2.0, 3.0], [2.0]) == pytest.approx(0.5)


def test_probability_of_improvement_averages_over_tasks():
    x = np.array([[1.0, 10.0], [2.0, 11.0]])  # task 0: X loses, task 1: X wins
    y = np.array([[5.0, 0.0], [6.0, 1.0]])
    assert stats.probability_of_improvement(x, y) == 0.5
    p = stats.probability_of_improvement_ci(x, y)
    assert p.low == p.high == 0.5  # every resample keeps the order inside each task


@settings(max_examples=30, deadline=None)
@given(scores, scores)
def test_probability_of_improvement_is_complementary(x, y):
    assert stats.probability_of_improvement(x, y) + stats.probability_of_improvement(
        y, x
    ) == pytest.approx(1.0)


def test_iqm_of_a_known_array():
    assert stats.iqm(np.arange(1, 9)) == 4.5  # mean of 3, 4, 5, 6
    x = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 1000.0]
    assert stats.iqm(x) == 3.5  # the outlier is trimmed away
    assert stats.iqm(x) == pytest.approx(trim_mean(x, 0.25))


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-1e4, 1e4), min_size=2, max_size=12))
def test_bootstrap_intervals_contain_their_estimate(x):
    m = stats.mean_ci(x)
    assert m.value == pytest.approx(np.mean(x))
    assert m.low - 1e-9 * (1 + abs(m.value)) <= m.value <= m.high + 1e-9 * (1 + abs(m.value))
    q = stats.iqm_ci(x)
    assert q.low - 1e-6 * (1 + abs(q.value)) <= q.value <= q.high + 1e-6 * (1 + abs(q.value))


def test_bootstrap_interval_is_reproducible_and_narrows_with_more_seeds():
    rng = np.random.default_rng(1)
    few, many = rng.normal(0, 1, 4), rng.normal(0, 1, 64)
    assert stats.mean_ci(few) == stats.mean_ci(few)
    width = lambda iv: iv.high - iv.low  # noqa: E731
    assert width(stats.mean_ci(many)) < width(stats.mean_ci(few))


def test_one_seed_has_no_interval():
    m = stats.mean_ci([3.0])
    assert m.value == 3.0 and np.isnan(m.low) and np.isnan(m.high)
    assert np.isnan(stats.probability_of_improvement_ci([1.0], [0.0]).low)


def test_constant_scores_have_a_zero_width_interval():
    assert stats.mean_ci([2.0, 2.0, 2.0]) == (2.0, 2.0, 2.0)


def test_mean_std_is_the_papers_population_std():
    assert stats.mean_std([1.0, 3.0]) == (2.0, 1.0)


def test_moving_average_is_trailing_and_keeps_length():
    np.testing.assert_allclose(stats.moving_average([1, 2, 3, 4, 5], 2), [1, 1.5, 2.5, 3.5, 4.5])
    np.testing.assert_allclose(stats.moving_average([[2, 4, 6]], 10), [[2, 3, 4]])


def test_bootstrap_band_brackets_the_mean_curve():
    x = np.random.default_rng(0).normal(size=(6, 20))
    mean, low, high = stats.bootstrap_band(x)
    np.testing.assert_allclose(mean, x.mean(0))
    assert np.all(low <= mean) and np.all(mean <= high) and np.all(high > low)
    m1, l1, h1 = stats.bootstrap_band(x[:1])
    np.testing.assert_array_equal(l1, m1)


# ----------------------------------------------------------------------------
# Against rliable, and the joint resampling of seeds over mazes
# ----------------------------------------------------------------------------

# Per-seed mean test returns of an earlier 8-seed reproduction (trained on square4,
# tested on five mazes): rows are seeds 0-7, columns square4, square8, square2,
# triangle, pentagon.
EBE_8 = np.array(
    [
        [9674.26, 7155.14, 12425.16, 9464.89, 9823.02],
        [-411.23, 999.50, -138.33, 1479.38, 1613.80],
        [7356.40, 7830.63, 7142.72, 7064.16, 7538.72],
        [10084.77, 6325.00, 15002.35, 9850.84, 9941.76],
        [9773.42, 3827.77, 2469.92, 8554.08, 9891.03],
        [9442.42, 7598.66, 7442.32, 8831.84, 9802.55],
        [10309.27, 8223.10, 15747.15, 9791.52, 10195.42],
        [9397.17, 6003.05, -137.69, 9322.34, 9188.01],
    ]
)
EPS_8 = np.array(
    [
        [7743.80, 4107.61, -219.28, 6003.53, 8210.13],
        [6508.21, 4213.80, -71.60, 6354.71, 7518.49],
        [7780.26, 4586.76, 2017.67, 7111.72, 9115.85],
        [1370.26, 7645.00, -172.99, 1406.67, 5093.55],
        [9743.71, 6754.29, -253.07, 9119.45, 9635.80],
        [9190.06, 3893.23, 2877.70, 7099.67, 7684.42],
        [9717.97, 6796.74, 280.04, 8353.33, 9862.05],
        [986.61, 1442.55, -137.69, -214.94, 1180.99],
    ]
)


def test_point_estimates_are_rlibables():
    from rliable import metrics

    rng = np.random.default_rng(3)
    x, y = rng.normal(size=(7, 3)), rng.normal(0.5, 1, size=(9, 3))
    x[0, 0] = y[0, 0]  # a tie
    assert stats.probability_of_improvement(x, y) == pytest.approx(
        metrics.probability_of_improvement(x, y)
    )
    assert stats._p_greater(x, y) == pytest.approx(metrics.probability_of_improvement(x, y))
    assert stats.iqm(x) == pytest.approx(metrics.aggregate_iqm(x))
    assert stats.mean_ci(x).value == pytest.approx(metrics.aggregate_mean(x))


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.integers(-3, 3).map(float) | st.floats(-1e4, 1e4), min_size=1, max_size=60),
    st.integers(1, 5),
)
def test_the_bootstraps_iqm_is_rlibables_bit_for_bit(values, tasks):
    from rliable import metrics

    n = len(values) // tasks * tasks or len(values)
    x = np.asarray(values[:n]).reshape(-1, tasks if n % tasks == 0 else 1)
    assert stats._iqm_resampled(x) == metrics.aggregate_iqm(x)  # ties, odd sizes, one seed


def test_iqm_interval_equals_the_one_with_rlibables_statistic():
    from arch.bootstrap import IIDBootstrap
    from rliable import metrics

    x = np.random.default_rng(5).normal(size=(12, 5))
    bs = IIDBootstrap(x, seed=stats.BOOTSTRAP_SEED)
    ci = bs.conf_int(metrics.aggregate_iqm, reps=stats.N_RESAMPLES, method="percentile")
    assert stats.iqm_ci(x)[1:] == (ci[0, 0], ci[1, 0])


@pytest.mark.parametrize("shape", [(2,), (16,), (7, 3), (32, 5)])
def test_the_intervals_are_archs_own_loop_bit_for_bit(shape):
    """The mean's and P(X > Y)'s intervals gather arch's resamples at once: the same
    numbers as arch's own loop over them, ties and one task included."""
    from arch.bootstrap import IIDBootstrap, IndependentSamplesBootstrap

    rng = np.random.default_rng(sum(shape))
    for x in (rng.normal(size=shape), rng.integers(0, 3, size=shape).astype(float)):
        bs = IIDBootstrap(stats._as_tasks(x), seed=stats.BOOTSTRAP_SEED)
        ci = bs.conf_int(lambda s: np.mean(s), reps=stats.N_RESAMPLES, method="percentile")
        assert stats.mean_ci(x)[1:] == (ci[0, 0], ci[1, 0])
        y = rng.integers(0, 3, size=(shape[0] + 3, *shape[1:])).astype(float)
        xt, yt = stats._as_tasks(x), stats._as_tasks(y)
        bs = IndependentSamplesBootstrap(xt, yt, seed=stats.BOOTSTRAP_SEED)
        ci = bs.conf_int(stats._p_greater, reps=stats.N_RESAMPLES, method="percentile")
        assert stats.probability_of_improvement_ci(x, y)[1:] == (ci[0, 0], ci[1, 0])


def test_pooled_interval_resamples_each_seed_jointly_over_mazes():
    """All mazes test the same networks: a resample draws seeds, not (seed, maze) cells.

    rliable's StratifiedBootstrap draws seeds per maze and gives a narrower interval
    on these numbers ([0.63, 0.85]); drawing each seed's row gives [0.54, 0.92].
    """
    from rliable import library

    p = stats.probability_of_improvement_ci(EBE_8, EPS_8)
    assert p.value == pytest.approx(0.7484375)
    assert p.low == pytest.approx(0.54, abs=0.02) and p.high == pytest.approx(0.92, abs=0.02)
    np.random.seed(0)  # rliable's bootstrap draws from NumPy's global generator
    _, cis = library.get_interval_estimates(
        {"p": [EBE_8, EPS_8]},
        lambda x, y: np.array([stats._p_greater(x, y)]),
        reps=2000,
    )
    low, high = cis["p"][:, 0]
    assert (p.high - p.low) > (high - low) + 0.1  # per-maze resampling is too narrow


def test_joint_resampling_keeps_a_seeds_mazes_together_by_hand():
    """Two seeds per strategy, two mazes, X wins on one maze and loses on the other in
    every seed: each resample keeps that, so P stays 0.5 exactly. Independent
    per-maze resampling would mix rows and move it."""
    x = np.array([[1.0, 10.0], [2.0, 11.0]])
    y = np.array([[5.0, 0.0], [6.0, 1.0]])
    assert stats.probability_of_improvement_ci(x, y) == (0.5, 0.5, 0.5)
    # seed 0 of X beats Y on maze 0 only when drawn; the interval spans the draws
    x2 = np.array([[9.0, 0.0], [1.0, 0.0]])
    y2 = np.array([[5.0, 0.0], [5.0, 0.0]])
    p = stats.probability_of_improvement_ci(x2, y2)
    assert p.value == 0.5 and p.low == pytest.approx(0.25) and p.high == pytest.approx(0.75)


def test_seeds_to_resolve_extrapolates_the_half_width():
    p = stats.Interval(0.625, 0.5, 0.875)  # half-width 0.1875, effect 0.125, at 8 seeds
    assert stats.seeds_to_resolve(p, 8) == math.ceil(8 * 1.5**2)
    assert stats.seeds_to_resolve(stats.Interval(0.5, 0.4, 0.6), 8) == math.inf
    assert math.isnan(stats.seeds_to_resolve(stats.Interval(0.7, math.nan, math.nan), 1))
