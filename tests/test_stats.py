"""The across-seed statistics against inputs whose answer is known by hand."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import trim_mean

from jaxnav import stats

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
