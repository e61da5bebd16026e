"""The Q-network both Q-learning agents act and learn with (paper Table 2), its
dueling head, the circular convolutions over the scan it may start with, and the
dropout mask it trains with."""

from __future__ import annotations

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.agent.noisy import NoisyDense

# The scan convolutions' kernel (beams) and stride: each output looks at 5 neighbouring
# beams, every second beam, so each layer halves the beams (rounded up).
CONV_KERNEL = 5
CONV_STRIDE = 2


class QNetwork(nn.Module):
    """Paper Table 2: Dense 64 ReLU, Dense 64 ReLU, Dropout 0.2, Dense |A| linear.

    ``dueling`` (Wang et al. 2016) replaces the last layer by two linear streams on
    the same hidden features, a value ``value`` (1 output) and an advantage
    ``advantage`` (|A| outputs), joined by :func:`dueling_q`. ``layer_norm`` (PQN,
    Gallici et al. 2024) normalises each hidden layer before its ReLU. ``noisy``
    (NoisyNets, strategy ``noisy``) makes every dense layer a
    :class:`jaxnav.agent.noisy.NoisyDense` of ``noisy_sigma`` under the plain layer's
    name: called with ``noise`` (a run's switch, f32[]) it draws the ``noise`` PRNG
    stream, without it it is the mean network.

    ``scan_conv`` (channels per layer; empty: none, the paper's network) puts circular
    convolutions over the scan before the hidden layers (:class:`ScanTorso`):
    ``scan_layout`` (beams, gap, history) says where the normalised observation holds
    the scan and its history (:attr:`jaxnav.world.observer.Observer.scan_layout`).
    """

    num_actions: int = 5
    hidden: tuple[int, ...] = (64, 64)
    dropout: float = 0.2
    dueling: bool = False
    layer_norm: bool = False
    scan_conv: tuple[int, ...] = ()
    scan_layout: tuple[int, int, int] = (0, 0, 0)
    noisy: bool = False
    noisy_sigma: float = 0.5

    @nn.compact
    def __call__(
        self, obs: chex.Array, train: bool = False, dropout=None, noise=None
    ) -> chex.Array:
        """``dropout``: the rate as data (f32[]); None takes ``self.dropout``. ``noise``:
        a noisy network's switch (f32[]); None: its mean network."""
        x = obs
        init = nn.initializers.lecun_uniform()  # ROBOTIS' Keras initialiser
        dense_count = iter(range(len(self.hidden) + 1))

        def dense(width, name=None):
            if not self.noisy:
                return lambda h: nn.Dense(width, kernel_init=init, name=name)(h)
            name = name or f"Dense_{next(dense_count)}"  # the plain layer's name
            return lambda h: NoisyDense(width, self.noisy_sigma, name=name)(h, noise)

        if self.scan_conv:
            x = ScanTorso(self.scan_conv, self.scan_layout, name="ScanTorso")(x)
        for width in self.hidden:
            x = dense(width)(x)
            if self.layer_norm:
                x = nn.LayerNorm()(x)
            x = nn.relu(x)
        if train and (dropout is not None or self.dropout > 0.0):
            rate = self.dropout if dropout is None else dropout
            x = dropout16(self.make_rng("dropout"), x, rate)
        if not self.dueling:
            return dense(self.num_actions)(x)
        value = dense(1, "value")(x)
        advantage = dense(self.num_actions, "advantage")(x)
        return dueling_q(value, advantage)


def split_scans(obs: chex.Array, layout: tuple[int, int, int]):
    """(scans f[..., beams, 1 + history], rest f[..., m]) of normalised observations
    f[..., obs_size] laid out as (beams, gap, history) says: the scan, ``gap`` values
    (heading, distance, last command, waypoint), ``history`` blocks of ``beams`` (the
    earlier scans or their changes, newest first), then anything after them. The scan
    and each history block become one channel, the rest keeps its order."""
    beams, gap, history = layout
    start = beams + gap
    end = start + history * beams
    blocks = [obs[..., :beams]]
    blocks += [obs[..., start + k * beams : start + (k + 1) * beams] for k in range(history)]
    rest = jnp.concatenate([obs[..., beams:start], obs[..., end:]], axis=-1)
    return jnp.stack(blocks, axis=-1), rest


def circular_taps(width: int) -> np.ndarray:
    """f32[CONV_KERNEL, width, out]: tap t of output o reads beam (CONV_STRIDE o + t -
    CONV_KERNEL // 2) mod ``width``, out = ceil(width / CONV_STRIDE). A 1 where it does
    (summed where two taps wrap onto one beam of a narrow layer)."""
    out = -(-width // CONV_STRIDE)
    taps = np.zeros((CONV_KERNEL, width, out), np.float32)
    for t in range(CONV_KERNEL):
        for o in range(out):
            taps[t, (CONV_STRIDE * o + t - CONV_KERNEL // 2) % width, o] += 1.0
    return taps


class CircularConv(nn.Module):
    """One circular convolution over the beams, ReLU after it: f[..., width, C] ->
    f[..., ceil(width / 2), features]. The scan wraps round the robot, so the first beam
    neighbours the last. Parameters as ``nn.Conv``'s (kernel f[5, C, features], tap t
    of output o on beam 2 o + t - 2), computed as one matrix product, which a small
    network runs faster so on a CPU than as a convolution (the same numbers up to
    rounding): on an even width, the beams in pairs, each output's five taps are its
    pair's, the pair before's and the next pair's first beam; on an odd one, the kernel
    laid out over every (beam, output) pair (:func:`circular_taps`)."""

    features: int

    @nn.compact
    def __call__(self, x: chex.Array) -> chex.Array:
        width, channels = x.shape[-2], x.shape[-1]
        init = nn.initializers.lecun_uniform()  # fan-in: kernel x channels, as nn.Conv
        kernel = self.param("kernel", init, (CONV_KERNEL, channels, self.features))
        bias = self.param("bias", nn.initializers.zeros, (self.features,))
        lead = x.shape[:-2]
        if width % 2 == 0:
            pairs = x.reshape(lead + (width // 2, 2 * channels))
            ring = jnp.concatenate([pairs[..., -1:, :], pairs, pairs[..., :1, :]], axis=-2)
            cols = [ring[..., :-2, :], ring[..., 1:-1, :], ring[..., 2:, :channels]]
            y = jnp.concatenate(cols, axis=-1) @ kernel.reshape(CONV_KERNEL * channels, -1)
        else:
            taps = circular_taps(width)
            full = jnp.einsum("tio,tcf->icof", taps, kernel)
            y = x.reshape(lead + (width * channels,)) @ full.reshape(width * channels, -1)
            y = y.reshape(lead + (taps.shape[-1], self.features))
        return nn.relu(y + bias)


class ScanTorso(nn.Module):
    """The scan and its history through :class:`CircularConv` layers of ``channels``,
    flattened, then the observation's other values after them."""

    channels: tuple[int, ...]
    layout: tuple[int, int, int]

    @nn.compact
    def __call__(self, obs: chex.Array) -> chex.Array:
        y, rest = split_scans(obs, self.layout)
        for i, c in enumerate(self.channels):
            y = CircularConv(c, name=f"Conv_{i}")(y)
        y = y.reshape(y.shape[:-2] + (-1,))
        return jnp.concatenate([y, rest], axis=-1)


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


__all__ = [
    "CONV_KERNEL",
    "CONV_STRIDE",
    "CircularConv",
    "QNetwork",
    "ScanTorso",
    "circular_taps",
    "dropout16",
    "dueling_q",
    "split_scans",
]
