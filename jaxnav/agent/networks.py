"""The Q-network both Q-learning agents act and learn with (paper Table 2), its
dueling head and the dropout mask it trains with."""

from __future__ import annotations

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp


class QNetwork(nn.Module):
    """Paper Table 2: Dense 64 ReLU, Dense 64 ReLU, Dropout 0.2, Dense |A| linear.

    ``dueling`` (Wang et al. 2016) replaces the last layer by two linear streams on
    the same hidden features, a value ``value`` (1 output) and an advantage
    ``advantage`` (|A| outputs), joined by :func:`dueling_q`. ``layer_norm`` (PQN,
    Gallici et al. 2024) normalises each hidden layer before its ReLU.
    """

    num_actions: int = 5
    hidden: tuple[int, ...] = (64, 64)
    dropout: float = 0.2
    dueling: bool = False
    layer_norm: bool = False

    @nn.compact
    def __call__(self, obs: chex.Array, train: bool = False, dropout=None) -> chex.Array:
        """``dropout``: the rate as data (f32[]); None takes ``self.dropout``."""
        x = obs
        init = nn.initializers.lecun_uniform()  # ROBOTIS' Keras initialiser
        for width in self.hidden:
            x = nn.Dense(width, kernel_init=init)(x)
            if self.layer_norm:
                x = nn.LayerNorm()(x)
            x = nn.relu(x)
        if train and (dropout is not None or self.dropout > 0.0):
            rate = self.dropout if dropout is None else dropout
            x = dropout16(self.make_rng("dropout"), x, rate)
        if not self.dueling:
            return nn.Dense(self.num_actions, kernel_init=init)(x)
        value = nn.Dense(1, kernel_init=init, name="value")(x)
        advantage = nn.Dense(self.num_actions, kernel_init=init, name="advantage")(x)
        return dueling_q(value, advantage)


def dueling_q(value: chex.Array, advantage: chex.Array) -> chex.Array:
    """Q = V + A - mean_a A (Wang et al. 2016, eq. 9): ``value`` f32[..., 1],
    ``advantage`` f32[..., A] -> f32[..., A]."""
    return value + advantage - jnp.mean(advantage, axis=-1, keepdims=True)


def dropout16(key: chex.PRNGKey, x: chex.Array, rate) -> chex.Array:
    """Inverted dropout whose mask takes 16 random bits per unit, two per 32-bit draw.

    A unit is dropped when its 16 bits fall below round(rate * 2^16), so the rate is
    quantised to 1/65536 (0.2 -> 0.199997). Half the random bits of
    ``flax.linen.Dropout``: the mask is a large share of a small network's step.
    ``rate`` may be data; rate 0 keeps every unit unchanged.
    """
    n = x.size
    words = jax.random.bits(key, ((n + 1) // 2,), jnp.uint32)
    halves = jnp.stack([words & 0xFFFF, words >> 16], axis=-1).reshape(-1)[:n]
    rate = jnp.asarray(rate, jnp.float32)
    threshold = jnp.round(rate * 65536).astype(jnp.uint32)
    keep = halves.reshape(x.shape) >= threshold
    return jnp.where(keep, x / (1.0 - rate), 0.0)


__all__ = ["QNetwork", "dropout16", "dueling_q"]
