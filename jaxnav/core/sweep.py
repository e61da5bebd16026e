"""Sweeps: which settings a run may vary across its runs, the grid of their values,
and the name of each arm (a strategy at one sweep point).

A config's ``sweep`` maps dotted config keys to lists of values; several keys form
their product (the first key varies slowest). A strategy's arms vary only the swept
keys it reads: sweeping ``exploration.ebe_temperature`` gives EBE one arm per value
and epsilon-greedy one arm, since the two would otherwise train identical runs
(each strategy's ``keys`` in :mod:`jaxnav.core.strategies`). Every run of the grid trains in the
same compiled program: a swept setting is carried as data in the training state
(:class:`jaxnav.dqn.Hyper`), so a point costs what a seed costs. A key whose value
changes an array shape or the compiled program (batch size, hidden sizes, beams,
the maze, a switch that adds computation) is refused: run one config per value.

The files of a swept run carry one column per swept key, named by the key, beside
``strategy``; readers name a row's arm with :func:`row_arm` (no JAX here).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import Any

from jaxnav.core import strategies as registry

# A sweep point: ((dotted key, value), ...) in the sweep's key order; () without a sweep.
Point = tuple[tuple[str, Any], ...]


def applies(key: str, strategy: str | None) -> bool:
    """Whether ``strategy``'s runs read ``key`` (every key applies to None)."""
    if strategy is None or not key.startswith("exploration."):
        return True
    return strategy in registry.names() and key in registry.get(strategy).keys


def grid(sweep: Sequence[tuple[str, Sequence[Any]]], strategy: str | None = None) -> list[Point]:
    """Every point of the sweep's grid (the product of its keys' values, only the
    keys ``strategy`` reads), the first key varying slowest; ``[()]`` without one."""
    sweep = [(k, v) for k, v in sweep if applies(k, strategy)]
    keys = [k for k, _ in sweep]
    return [tuple(zip(keys, values)) for values in itertools.product(*(v for _, v in sweep))]


def value_text(value: Any) -> str:
    """A swept value as the files and arm names write it (``0.1``, ``1``, ``2000``)."""
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def short_names(keys: Sequence[str]) -> dict[str, str]:
    """Each key's last component, or the whole key where two would clash."""
    last = [k.rsplit(".", 1)[-1] for k in keys]
    return {k: (s if last.count(s) == 1 else k) for k, s in zip(keys, last)}


def arm_name(strategy: str, point: Point) -> str:
    """``ebe`` without a sweep, ``ebe ebe_temperature=0.1`` at a sweep point."""
    short = short_names([k for k, _ in point])
    return " ".join([strategy] + [f"{short[k]}={value_text(v)}" for k, v in point])


def with_swept(columns: Sequence[str], sweep: Sequence[tuple[str, Any]]) -> tuple[str, ...]:
    """A file's header ``columns`` (its first "strategy") with the swept keys after it."""
    return (columns[0], *(k for k, _ in sweep), *columns[1:])


def swept_columns(header: Sequence[str]) -> list[str]:
    """The swept keys among a results file's columns (the dotted ones)."""
    return [c for c in header if "." in c]


def row_arm(row: Mapping[str, str]) -> str:
    """The arm of a metrics, explore or results row: its strategy and its swept
    columns' values (empty where the strategy does not read the key), named as
    :func:`arm_name` names them."""
    keys = [k for k in swept_columns(list(row)) if row[k] != ""]
    short = short_names(keys)
    return " ".join([row["strategy"]] + [f"{short[k]}={row[k]}" for k in keys])
