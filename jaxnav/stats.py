"""Across-seed statistics for the test tables: small pure NumPy/SciPy functions.

The paper reports one training run per strategy as mean ± std over 10 test
episodes. jaxnav trains many seeds, so it also summarises the per-seed scores the
way rliable (Agarwal et al., NeurIPS 2021) recommends, without depending on it:

* :func:`mean_ci`: mean of the per-seed scores with a percentile bootstrap CI;
* :func:`iqm` / :func:`iqm_ci`: interquartile mean (25 % trimmed mean) and its CI;
* :func:`probability_of_improvement` / :func:`probability_of_improvement_ci`:
  P(X > Y) + 0.5 P(X = Y) for a run of X against a run of Y, averaged over tasks
  (mazes), with rliable's stratified independent bootstrap: the seeds of X and the
  seeds of Y are resampled independently, within each task.

Every function takes plain arrays and returns floats, so it can be checked by hand.
Intervals of fewer than two samples are undefined and come back as NaN.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy import stats as _st

CONFIDENCE = 0.95
N_RESAMPLES = 5000  # bootstrap resamples; plenty for 2-16 seeds
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


def iqm(x: Sequence[float]) -> float:
    """Interquartile mean: the mean of the middle 50 % (scipy ``trim_mean(x, 0.25)``)."""
    return float(_st.trim_mean(np.asarray(x, np.float64).ravel(), 0.25))


def _bootstrap(
    samples: tuple[np.ndarray, ...], statistic, confidence: float
) -> tuple[float, float]:
    """Percentile bootstrap CI (each sample resampled independently), NaN if undefined."""
    if any(len(s) < 2 for s in samples):
        return float("nan"), float("nan")
    res = _st.bootstrap(
        samples,
        statistic,
        n_resamples=N_RESAMPLES,
        confidence_level=confidence,
        method="percentile",  # as rliable; BCa is unstable for a handful of seeds
        vectorized=True,
        paired=False,
        random_state=np.random.default_rng(BOOTSTRAP_SEED),
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def mean_ci(x: Sequence[float], confidence: float = CONFIDENCE) -> Interval:
    """Mean of ``x`` (one score per seed) with a percentile bootstrap CI."""
    x = np.asarray(x, np.float64).ravel()
    low, high = _bootstrap((x,), lambda s, axis=-1: np.mean(s, axis=axis), confidence)
    return Interval(float(x.mean()), low, high)


def iqm_ci(x: Sequence[float], confidence: float = CONFIDENCE) -> Interval:
    """Interquartile mean of ``x`` with a percentile bootstrap CI."""
    x = np.asarray(x, np.float64).ravel()
    low, high = _bootstrap((x,), lambda s, axis=-1: _st.trim_mean(s, 0.25, axis=axis), confidence)
    return Interval(iqm(x), low, high)


def _p_greater(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """P(X > Y) + 0.5 P(X = Y) over all pairs; x [..., n], y [..., m] -> [...]."""
    xx, yy = x[..., :, None], y[..., None, :]
    return np.mean((xx > yy) + 0.5 * (xx == yy), axis=(-2, -1))


def _as_tasks(x) -> np.ndarray:
    """Scores as [runs, tasks]; a 1-D array is one task."""
    x = np.asarray(x, np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise ValueError("scores must be [runs] or [runs, tasks]")
    return x


def probability_of_improvement(x, y) -> float:
    """rliable's P(X > Y): for each task, the chance a run of X scores more than a
    run of Y (ties count half), averaged over tasks.

    Args:
      x: f[n] or f[n, tasks] scores of algorithm X (one row per seed).
      y: f[m] or f[m, tasks] scores of algorithm Y (same tasks).
    """
    x, y = _as_tasks(x), _as_tasks(y)
    if x.shape[1] != y.shape[1]:
        raise ValueError("x and y must have the same tasks")
    return float(np.mean([_p_greater(x[:, t], y[:, t]) for t in range(x.shape[1])]))


def probability_of_improvement_ci(x, y, confidence: float = CONFIDENCE) -> Interval:
    """P(X > Y) with a stratified independent bootstrap CI (seeds of X and of Y
    resampled independently within every task, as rliable's
    ``StratifiedIndependentBootstrap``)."""
    x, y = _as_tasks(x), _as_tasks(y)
    if x.shape[1] != y.shape[1]:
        raise ValueError("x and y must have the same tasks")
    n_tasks = x.shape[1]
    # One bootstrap sample per (algorithm, task): scipy resamples each independently.
    samples = tuple(a[:, t] for t in range(n_tasks) for a in (x, y))

    def stat(*s, axis=-1):
        per_task = [
            _p_greater(np.moveaxis(s[2 * t], axis, -1), np.moveaxis(s[2 * t + 1], axis, -1))
            for t in range(n_tasks)
        ]
        return np.mean(per_task, axis=0)

    low, high = _bootstrap(samples, stat, confidence)
    return Interval(probability_of_improvement(x, y), low, high)


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
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    n_boot = 2000
    idx = rng.integers(0, x.shape[0], size=(n_boot, x.shape[0]))
    boot = x[idx].mean(axis=1)  # [n_boot, T]
    alpha = (1.0 - confidence) / 2
    low, high = np.quantile(boot, [alpha, 1.0 - alpha], axis=0)
    return mean, low, high
