"""A sweep's verdicts need enough seeds: below stats.MIN_SEEDS they say so instead."""

from __future__ import annotations

import math

import pytest

from jaxnav.core.rundir import csv_text
from jaxnav.report import stats
from jaxnav.report.results import RESULT_COLUMNS
from jaxnav.report.tables import sweep_markdown

KEY = "exploration.ebe_temperature"


def _results(n_seeds: int) -> str:
    """A swept run's results.csv: every EBE seed far above every epsilon-greedy seed."""
    rows = []
    for strategy, temperature, base in (("ebe", "0.1", 1000.0), ("ebe", "1", 900.0)) + (
        ("epsilon_greedy", "", 0.0),
    ):
        for seed in range(n_seeds):
            for episode in range(2):
                ret = base + 10 * seed + episode
                rows.append([strategy, temperature, seed, "greedy", "square4", episode, ret])
                rows[-1] += [1, 0, 500]
    return csv_text((RESULT_COLUMNS[0], KEY, *RESULT_COLUMNS[1:]), rows)


def test_the_minimum_is_the_fewest_seeds_a_rank_test_could_separate():
    n = stats.MIN_SEEDS
    assert n == 4 and stats.CONFIDENCE == 0.95
    assert 2 / math.comb(2 * n, n) <= 0.05 < 2 / math.comb(2 * (n - 1), n - 1)
    assert stats.enough_seeds(4, 5) and not stats.enough_seeds(3, 8)


@pytest.mark.parametrize("n_seeds", [2, 3])
def test_too_few_seeds_give_no_verdict(n_seeds):
    text = "\n".join(sweep_markdown(_results(n_seeds), 0))
    # the interval still excludes 0.5 (P = 1 in every resample) ...
    assert "| 1.00 [1.00, 1.00] |" in text
    # ... but no arm is called better
    assert "better |" not in text and "beats" not in text
    assert f"| {stats.TOO_FEW_SEEDS} |" in text
    assert (
        f"EBE against epsilon-greedy: too few seeds for a verdict ({n_seeds} per arm; "
        f"it needs {stats.MIN_SEEDS})." in text
    )
    assert f"with fewer than {stats.MIN_SEEDS} seeds per arm it says too few seeds" in text


def test_enough_seeds_give_the_verdict():
    text = "\n".join(sweep_markdown(_results(stats.MIN_SEEDS), 0))
    assert "| EBE ebe_temperature=0.1 better |" in text
    assert "EBE beats epsilon-greedy at ebe_temperature=0.1, ebe_temperature=1." in text
    assert stats.TOO_FEW_SEEDS not in text
