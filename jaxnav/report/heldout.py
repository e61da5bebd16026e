"""A study's result on the kinds of world its policies never trained on (the fixed worlds
of ``generalise_to``), in one sentence: EBE against each other strategy there by the
claims' rule, and each strategy's mean success beside the reference drivers' on the same
tests. The paper's question of unseen mazes, asked of a ladder study's data."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from jaxnav.report.ladder import (
    BOLTZMANN,
    DRIVERS,
    EPS,
    NAMES,
    ORACLE,
    TEST_NAMES,
    Data,
    compare,
)

HELD_OUT_SKIP = ("own", "test", "larger")  # the tests of the worlds a rung trains on
NO_HELD_OUT = "No policy of this study was tested on a kind of world it did not train on."


def test_name(test: str) -> str:
    """A test's short name: a maze file by its stem (``office`` for its path)."""
    if test.endswith((".yaml", ".yml")):
        return Path(test).stem
    return TEST_NAMES.get(test, test)


def held_out_tests(data: Data) -> list[tuple[str, str, str]]:
    """(rung, agent, test) of every test on a kind of world no rung trained on."""
    return [
        (rung, agent, t)
        for rung in data.rungs
        for agent in data.agents
        if data.has(rung, agent)
        for t in data.tests(rung)
        if t not in HELD_OUT_SKIP
    ]


def reference(data: Data, rung: str, test: str, who: str, measure: str = "success"):
    """A reference driver's per-seed ``measure`` (f[seeds]) on a rung's test, or None: it
    drives a world's tests once, beside the rung's first agent
    (jaxnav.experiments.ladder.run_cell)."""
    for agent in data.agents:
        x = data.per_seed(rung, agent, test, who, measure)
        if len(x):
            return x
    return None


def reference_means(data: Data, tests: list[tuple[str, str]]) -> list[str]:
    """Each reference driver's mean success over the (rung, test) pairs, as a sentence
    names it (``the oracle 1.00``, ``DWA 0.77``), where every test drove it."""
    out = []
    for who, label in DRIVERS.items():
        got = [reference(data, r, t, who) for r, t in tests]
        if all(x is not None for x in got):
            the = "the " if who == ORACLE else ""
            out.append(f"{the}{label} {np.mean([x.mean() for x in got]):.2f}")
    return out


def held_out_sentence(data: Data) -> str:
    """EBE against each other strategy on the fixed worlds of kinds no rung trained on
    (``generalise_to``), success by the claims' rule, and each strategy's mean success
    over them: the paper's question of unseen mazes, in one sentence."""
    parts, means = [], []
    tests = held_out_tests(data)
    if not tests:
        return NO_HELD_OUT
    for other in (o for o in (EPS, BOLTZMANN) if o in data.strategies):
        c = Counter(compare(data, r, a, t, other, "success")[1] for r, a, t in tests)
        parts.append(
            f"than {NAMES[other]}'s in {c['EBE better']}, a lower one in {c['EBE worse']} "
            f"and no detectable difference in "
            f"{len(tests) - c['EBE better'] - c['EBE worse']}"
        )
    for s in data.strategies:
        x = np.mean([data.per_seed(r, a, t, s, "success").mean() for r, a, t in tests])
        means.append(f"{NAMES[s]} {x:.2f}")
    means += reference_means(data, [(r, t) for r, _, t in tests])
    names = ", ".join(dict.fromkeys(test_name(t) for _, _, t in tests))
    cells = "test" if len(tests) == 1 else "tests"
    return (
        f"Tested on kinds of world they never trained on ({names}; {len(tests)} {cells}, "
        f"one per world and agent trained), with {data.n_seeds()} seeds per strategy, "
        "EBE's policies reach a detectably higher success "
        + "; ".join(parts)
        + f"; mean success over those tests: {', '.join(means)}."
    )


__all__ = [
    "HELD_OUT_SKIP",
    "NO_HELD_OUT",
    "held_out_sentence",
    "held_out_tests",
    "reference",
    "reference_means",
    "test_name",
]
