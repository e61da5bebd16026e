"""Across-seed statistics: rliable's metrics, bootstrap intervals that resample seeds.

The paper reports one training run per strategy. jaxnav trains many seeds and
summarises the per-seed scores as rliable (Agarwal et al., NeurIPS 2021)
recommends, with rliable's own functions for the point estimates (interquartile
mean, probability of improvement) and arch's bootstrap (the engine under rliable's
intervals) for percentile confidence intervals, seeded so a table is reproducible.

One seed is one trained network. When the same networks are tested on several
mazes, a bootstrap resample draws seeds, and each drawn seed brings its scores on
every maze (joint resampling, ``x`` as f[seeds, mazes]). rliable's
``StratifiedBootstrap`` draws seeds independently for each task, as if every maze
had been trained separately; with the same networks on every maze that interval is
too narrow. The seeds of two strategies are resampled independently of each other.

Intervals need at least two seeds; with fewer they come back as NaN.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from arch.bootstrap import IIDBootstrap, IndependentSamplesBootstrap
from rliable import metrics

CONFIDENCE = 0.95
N_RESAMPLES = 5000  # bootstrap resamples
BOOTSTRAP_SEED = 0  # fixed, so a table is reproducible


class Interval(NamedTuple):
    """A point estimate with a confidence interval [low, high]."""

    value: float
    low: float
    high: float


def mean_std(x: Sequence[float]) -> tuple[float, float]:
    """Mean and standard deviation (NumPy's ddof=0, as the paper's tables likely used)."""
    x = np.asarray(x, np.float64)
    return float(x.mean()), float(x.std())


def _as_tasks(x) -> np.ndarray:
    """Scores as f[seeds, tasks]; a 1-D array is one task."""
    x = np.asarray(x, np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise ValueError("scores must be [seeds] or [seeds, tasks]")
    return x


def _percentile_ci(bootstrap, statistic, confidence: float) -> tuple[float, float]:
    ci = bootstrap.conf_int(statistic, reps=N_RESAMPLES, method="percentile", size=confidence)
    return float(ci[0, 0]), float(ci[1, 0])


# arch's bootstrap computes the statistic of each resample in a Python loop: with 5000
# resamples, about 70 ms an interval here, most of a test's tables (94 intervals in a
# test of 16 seeds beside the reference drivers). For the statistics below, the same
# resamples (arch's own index draws, in its order) are gathered at once and the
# statistic computed over them in NumPy with the same reductions, then given to arch's
# own percentile interval: the same numbers, bit for bit (tests/test_stats.py compares
# them with arch's loop), in about 30 ms, most of it the 5000 draws themselves.
_CHUNK = 500  # resamples computed at once (bounds the gathered array's memory)


def _vectorised_ci(bootstrap, statistic, per_resample, confidence: float) -> tuple[float, float]:
    """:func:`_percentile_ci` with the resamples' statistics from ``per_resample``
    (index draws -> f[reps], the statistic of each resample) instead of arch's loop."""
    draws = [bootstrap.update_indices() for _ in range(N_RESAMPLES)]
    results = np.concatenate(
        [per_resample(draws[i : i + _CHUNK]) for i in range(0, N_RESAMPLES, _CHUNK)]
    )
    # what arch's _construct_bootstrap_estimates leaves for conf_int(reuse=True)
    bootstrap._base = np.asarray(statistic(*bootstrap._args))
    bootstrap._results = results[:, None]
    bootstrap._studentized_results = np.zeros_like(bootstrap._results)
    bootstrap._last_func = statistic
    ci = bootstrap.conf_int(
        statistic, reps=N_RESAMPLES, method="percentile", size=confidence, reuse=True
    )
    return float(ci[0, 0]), float(ci[1, 0])


def _mean_of_all(s: np.ndarray) -> float:
    return np.mean(s)


def iqm(x) -> float:
    """Interquartile mean over seeds (and tasks): rliable's ``aggregate_iqm``."""
    return float(metrics.aggregate_iqm(_as_tasks(x)))


def mean_ci(x, confidence: float = CONFIDENCE) -> Interval:
    """Mean over seeds (and tasks) with a percentile bootstrap CI over seeds."""
    x = _as_tasks(x)
    value = float(metrics.aggregate_mean(x))
    if len(x) < 2:
        return Interval(value, math.nan, math.nan)
    bs = IIDBootstrap(x, seed=BOOTSTRAP_SEED)

    def means(draws):  # each resample's mean over all its seeds' scores
        return x[np.stack(draws)].reshape(len(draws), -1).mean(axis=1)

    return Interval(value, *_vectorised_ci(bs, _mean_of_all, means, confidence))


def _iqm_resampled(x: np.ndarray) -> float:
    """rliable's ``aggregate_iqm`` (``scipy.stats.trim_mean(x, 0.25, axis=None)``) as
    scipy computes it, the same partition and the same mean, without the wrapper's
    cost per call, which dominated a bootstrap of 5000 resamples (bit for bit the
    same value: tests/test_stats.py)."""
    a = np.asarray(x).ravel()
    low = int(0.25 * a.size)
    high = a.size - low
    return np.mean(np.partition(a, (low, high - 1))[low:high])


def iqm_ci(x, confidence: float = CONFIDENCE) -> Interval:
    """Interquartile mean with a percentile bootstrap CI over seeds."""
    x = _as_tasks(x)
    if len(x) < 2:
        return Interval(iqm(x), math.nan, math.nan)
    bs = IIDBootstrap(x, seed=BOOTSTRAP_SEED)
    return Interval(iqm(x), *_percentile_ci(bs, _iqm_resampled, confidence))


def _p_greater(x: np.ndarray, y: np.ndarray) -> float:
    """rliable's probability of improvement, without a Mann-Whitney call per task:
    per task P(X > Y) + 0.5 P(X = Y) over all pairs, averaged over tasks."""
    xx, yy = x[:, None, :], y[None, :, :]
    return float(np.mean((xx > yy) + 0.5 * (xx == yy)))


def probability_of_improvement(x, y) -> float:
    """rliable's P(X > Y): for each task, the chance that a seed of X scores more than
    a seed of Y (ties count half), averaged over tasks.

    Args:
      x: f[n] or f[n, tasks] scores of X, one row per seed.
      y: f[m] or f[m, tasks] scores of Y on the same tasks.
    """
    x, y = _as_tasks(x), _as_tasks(y)
    if x.shape[1] != y.shape[1]:
        raise ValueError("x and y must have the same tasks")
    return float(metrics.probability_of_improvement(x, y))


def probability_of_improvement_ci(x, y, confidence: float = CONFIDENCE) -> Interval:
    """P(X > Y) with a percentile bootstrap CI: the seeds of X and of Y resampled
    independently, each seed jointly over all tasks (its row)."""
    x, y = _as_tasks(x), _as_tasks(y)
    value = probability_of_improvement(x, y)
    if len(x) < 2 or len(y) < 2:
        return Interval(value, math.nan, math.nan)
    bs = IndependentSamplesBootstrap(x, y, seed=BOOTSTRAP_SEED)

    def p_greater(draws):  # _p_greater of each resample
        xx = x[np.stack([d[0][0] for d in draws])][:, :, None, :]
        yy = y[np.stack([d[0][1] for d in draws])][:, None, :, :]
        wins = (xx > yy) + 0.5 * (xx == yy)
        return wins.reshape(len(draws), -1).mean(axis=1)

    return Interval(value, *_vectorised_ci(bs, _p_greater, p_greater, confidence))


# The fewest seeds per arm with which the rule of side() may name a better arm. With n
# seeds each, every seed of X scoring above every seed of Y happens by chance alone (no
# difference at all) with probability 2 / C(2n, n), either way round: 1/3 at 2 seeds,
# 1/10 at 3, 1/35 at 4. The bootstrap interval of that outcome is [1, 1] however few the
# seeds, so below this count an interval that excludes 0.5 is no evidence of a difference.
MIN_SEEDS = next(n for n in range(2, 64) if 2 / math.comb(2 * n, n) <= 1 - CONFIDENCE)
TOO_FEW_SEEDS = "too few seeds"  # what a verdict says instead below MIN_SEEDS


def side(p: Interval) -> int:
    """Where the interval of P(X > Y) lies: 1 above 0.5 (X better), -1 below (Y
    better), 0 across it or without an interval (no detectable difference). A
    verdict needs :data:`MIN_SEEDS` seeds per arm (:func:`enough_seeds`)."""
    if math.isnan(p.low):
        return 0
    return 1 if p.low > 0.5 else -1 if p.high < 0.5 else 0


def enough_seeds(*n_seeds: int) -> bool:
    """Whether every arm has the :data:`MIN_SEEDS` seeds that a verdict by :func:`side` needs."""
    return min(n_seeds) >= MIN_SEEDS


def seeds_to_resolve(p: Interval, n_seeds: int) -> float:
    """Seeds per strategy at which an interval like ``p`` would exclude 0.5.

    A rough extrapolation from the observed effect: the interval's half-width
    shrinks as 1 / sqrt(seeds), and its centre stays at the observed value. Infinite
    when the observed value is 0.5 (no effect to resolve), NaN without an interval.
    """
    half = (p.high - p.low) / 2
    effect = abs(p.value - 0.5)
    if math.isnan(half) or half == 0:
        return math.nan
    if effect == 0:
        return math.inf
    return float(math.ceil(n_seeds * (half / effect) ** 2 - 1e-9))


def moving_average(x: Sequence[float], window: int) -> np.ndarray:
    """Trailing moving average along the last axis; the first points average what
    there is so far (no shortening, no lag-free look-ahead)."""
    x = np.asarray(x, np.float64)
    window = max(int(window), 1)
    c = np.cumsum(x, axis=-1)
    out = c.copy()
    out[..., window:] = c[..., window:] - c[..., :-window]
    n = np.minimum(np.arange(1, x.shape[-1] + 1), window)
    return out / n


def bootstrap_band(
    x: np.ndarray, confidence: float = CONFIDENCE
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean over seeds and a percentile bootstrap CI of it, for every column.

    Args:
      x: f[seeds, T] a curve per seed.
    Returns:
      (mean f[T], low f[T], high f[T]); low = high = mean with fewer than 2 seeds.
    """
    x = np.asarray(x, np.float64)
    mean = x.mean(axis=0)
    if x.shape[0] < 2:
        return mean, mean.copy(), mean.copy()
    bs = IIDBootstrap(x, seed=BOOTSTRAP_SEED)
    boot = bs.apply(lambda s: s.mean(axis=0), reps=2000)  # [reps, T]
    alpha = (1.0 - confidence) / 2
    low, high = np.quantile(boot, [alpha, 1.0 - alpha], axis=0)
    return mean, low, high
