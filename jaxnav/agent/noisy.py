"""NoisyNets (Fortunato et al. 2018, "Noisy Networks for Exploration"): a dense layer
whose weights carry learnt factorised Gaussian noise, the exploration of strategy
``noisy`` (:mod:`jaxnav.core.strategies`).

A noisy layer of p inputs and q outputs has the mean weights ``kernel`` f32[p, q] and
``bias`` f32[q] (a plain ``Dense``'s, under the same names, so the mean network is what a
greedy test, export and deployment read) and their scales ``kernel_sigma`` and
``bias_sigma``. Each forward pass with noise draws eps_in ~ N(0, 1)^p and eps_out ~
N(0, 1)^q and uses (paper, eq. 10-11)

    W = kernel + kernel_sigma * outer(f(eps_in), f(eps_out)),   b = bias + bias_sigma * f(eps_out),
    f(x) = sign(x) sqrt(|x|),

computed without forming W: x W = x kernel + ((x f(eps_in)) kernel_sigma) f(eps_out).
The mean weights start as the plain layer's (LeCun uniform, as every jaxnav Q-network),
the sigmas at sigma_0 / sqrt(p) (the paper's factorised initialisation; sigma_0 is
``exploration.noisy_sigma``).

A draw is a set of (f(eps_in), f(eps_out)) per layer, kept in the ``noise`` collection:
:func:`draw` makes one for a batch of observations (one per leading index: the
trainers draw one per environment for a whole rollout, as NoisyNet-A3C's actors hold
theirs, and one per minibatch of learning, as NoisyNet-DQN draws one per optimisation
step), :func:`with_draw` hands it to the network; a noisy layer called without one
draws its own from the ``noise`` PRNG stream.

``noise`` is a run's switch as data (f32[], 1 or 0): the runs of other strategies in the
same program pass 0 and their outputs are exactly the mean network's.
"""

from __future__ import annotations

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp

COLLECTION = "noise"  # the flax collection a draw of the layers' noise is kept in


def scaled(x: chex.Array) -> chex.Array:
    """f(x) = sign(x) sqrt(|x|), the factorised noise's scaling."""
    return jnp.sign(x) * jnp.sqrt(jnp.abs(x))


def factorised_noise(key: chex.PRNGKey, lead: tuple[int, ...], p: int, q: int):
    """(f(eps_in) f32[*lead, p], f(eps_out) f32[*lead, q]) of one draw per sample: the
    noise of the weights is their outer product, of the biases f(eps_out)."""
    k_in, k_out = jax.random.split(key)
    return (
        scaled(jax.random.normal(k_in, (*lead, p), jnp.float32)),
        scaled(jax.random.normal(k_out, (*lead, q), jnp.float32)),
    )


class NoisyDense(nn.Module):
    """A dense layer with factorised Gaussian noise (the module's docstring)."""

    features: int
    sigma0: float = 0.5

    @nn.compact
    def __call__(self, x: chex.Array, noise=None) -> chex.Array:
        """``x`` f32[..., p]; ``noise`` None (the mean layer) or f32[] (a run's switch:
        the noise times it), drawn from the ``noise`` PRNG stream."""
        p = x.shape[-1]
        kernel = self.param("kernel", nn.initializers.lecun_uniform(), (p, self.features))
        bias = self.param("bias", nn.initializers.zeros, (self.features,))
        start = nn.initializers.constant(self.sigma0 / jnp.sqrt(p))
        kernel_sigma = self.param("kernel_sigma", start, (p, self.features))
        bias_sigma = self.param("bias_sigma", start, (self.features,))
        y = x @ kernel + bias
        if noise is None:
            return y
        if self.has_variable(COLLECTION, "draw"):  # a draw handed in (with_draw)
            f_in, f_out = self.get_variable(COLLECTION, "draw")
        else:
            f_in, f_out = factorised_noise(self.make_rng("noise"), x.shape[:-1], p, self.features)
            if self.is_mutable_collection(COLLECTION):  # kept for later calls (draw)
                self.put_variable(COLLECTION, "draw", (f_in, f_out))
        return y + noise * (((x * f_in) @ kernel_sigma) * f_out + bias_sigma * f_out)


def draw(network: nn.Module, params, obs: chex.Array, switch, key: chex.PRNGKey):
    """A draw of every noisy layer of ``network`` for observations ``obs`` f32[..., D]:
    one per leading index (a single observation: one draw for any batch)."""
    _, drawn = network.apply(params, obs, noise=switch, rngs={"noise": key}, mutable=[COLLECTION])
    return drawn[COLLECTION]


def with_draw(params, drawn):
    """``params`` with a draw (:func:`draw`) for the network's noisy layers to use."""
    return {**params, COLLECTION: drawn}


__all__ = ["COLLECTION", "NoisyDense", "draw", "factorised_noise", "scaled", "with_draw"]
