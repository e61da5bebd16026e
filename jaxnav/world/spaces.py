"""Action and observation spaces (gymnax style): a description of valid values, with
``sample`` and ``contains``."""

from __future__ import annotations

import dataclasses
from typing import Any

import chex
import jax
import jax.numpy as jnp
import numpy as np


@dataclasses.dataclass(frozen=True)
class Discrete:
    """The integers 0, ..., n - 1."""

    n: int
    shape: tuple = ()
    dtype: Any = jnp.int32

    def sample(self, key: chex.PRNGKey) -> chex.Array:
        return jax.random.randint(key, (), 0, self.n, dtype=self.dtype)

    def contains(self, x) -> bool:
        x = np.asarray(x)
        return bool(x.shape == () and 0 <= int(x) < self.n)


@dataclasses.dataclass(frozen=True)
class Box:
    """Arrays of ``shape`` between ``low`` and ``high`` (inclusive, element-wise)."""

    low: Any
    high: Any
    shape: tuple
    dtype: Any = jnp.float32

    def sample(self, key: chex.PRNGKey) -> chex.Array:
        return jax.random.uniform(key, self.shape, self.dtype, self.low, self.high)

    def contains(self, x) -> bool:
        x = np.asarray(x)
        return bool(x.shape == self.shape and np.all(x >= self.low) and np.all(x <= self.high))
