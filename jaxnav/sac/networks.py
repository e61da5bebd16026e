"""SAC's networks: the squashed Gaussian actor, the critics and the scan torso they
may share (sac.shared_torso)."""

from __future__ import annotations

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp

from jaxnav.agent.networks import ScanTorso
from jaxnav.core.config import Config
from jaxnav.env import NavEnv, from_config

# The actor's log standard deviation, squashed into this range (CleanRL's, SB3's).
LOG_STD_MIN, LOG_STD_MAX = -5.0, 2.0
ACTION_SIZE = 2  # (speed, yaw rate)


# ----------------------------------------------------------------------------
# The squashed Gaussian
# ----------------------------------------------------------------------------


def squashed_sample(key: chex.PRNGKey, mean: chex.Array, log_std: chex.Array):
    """(a, log pi(a)) of a = tanh(u), u ~ N(mean, exp(log_std)) element-wise:
    log pi(a) = sum_j [log N(u_j; mean_j, std_j) - log(1 - tanh(u_j)^2)] over the last
    axis (Haarnoja et al. 2018, appendix C), the correction computed as
    2 (log 2 - u - softplus(-2u)), which stays finite where tanh(u) rounds to +-1."""
    std = jnp.exp(log_std)
    eps = jax.random.normal(key, mean.shape, mean.dtype)
    u = mean + std * eps
    gauss = -0.5 * eps**2 - log_std - 0.5 * jnp.log(2.0 * jnp.pi)
    correction = 2.0 * (jnp.log(2.0) - u - jax.nn.softplus(-2.0 * u))
    return jnp.tanh(u), jnp.sum(gauss - correction, axis=-1)


class Actor(nn.Module):
    """The policy: ReLU layers of ``hidden`` widths, then one linear layer giving the
    mean and the (squashed) log standard deviation of each of the action's numbers.

    ``actor(obs)`` is the mean action tanh(mean) (tested, exported, deployed);
    ``actor(obs, key)`` samples: (a, log pi(a)). Its layers are ``Dense_0``, ... with
    the last giving [mean, raw log std], so a NumPy reader runs it as a plain MLP (after
    the scan's convolutions with ``scan_conv``, :class:`jaxnav.agent.networks.ScanTorso`)."""

    hidden: tuple[int, ...] = (128, 128)
    action_size: int = ACTION_SIZE
    scan_conv: tuple[int, ...] = ()
    scan_layout: tuple[int, int, int] = (0, 0, 0)

    @nn.compact
    def __call__(self, obs: chex.Array, key: chex.PRNGKey | None = None):
        x = obs
        if self.scan_conv:  # the circular convolutions over the scan first
            x = ScanTorso(self.scan_conv, self.scan_layout, name="ScanTorso")(x)
        for width in self.hidden:
            x = nn.relu(nn.Dense(width)(x))
        mean, raw = jnp.split(nn.Dense(2 * self.action_size)(x), 2, axis=-1)
        if key is None:
            return jnp.tanh(mean)
        log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (jnp.tanh(raw) + 1.0)
        return squashed_sample(key, mean, log_std)


class Critic(nn.Module):
    """Q(s, a): ReLU layers of ``hidden`` widths on [s, a] (LayerNorm before each ReLU
    with ``layer_norm``), one linear output; with ``scan_conv`` s is first what the
    scan's convolutions make of it (its own, not the actor's)."""

    hidden: tuple[int, ...] = (128, 128)
    layer_norm: bool = True
    scan_conv: tuple[int, ...] = ()
    scan_layout: tuple[int, int, int] = (0, 0, 0)

    @nn.compact
    def __call__(self, obs: chex.Array, action: chex.Array) -> chex.Array:
        if self.scan_conv:
            obs = ScanTorso(self.scan_conv, self.scan_layout, name="ScanTorso")(obs)
        x = jnp.concatenate([obs, action], axis=-1)
        for width in self.hidden:
            x = nn.Dense(width)(x)
            if self.layer_norm:
                x = nn.LayerNorm()(x)
            x = nn.relu(x)
        return nn.Dense(1)(x)[..., 0]


class TwinCritic(nn.Module):
    """Two :class:`Critic` s with their own parameters: Q f32[2, ...]. With ``shared``
    the scan's convolutions (``ScanTorso``) are one, before both (sac.shared_torso)."""

    hidden: tuple[int, ...] = (128, 128)
    layer_norm: bool = True
    scan_conv: tuple[int, ...] = ()
    scan_layout: tuple[int, int, int] = (0, 0, 0)
    shared: bool = False

    @nn.compact
    def __call__(self, obs: chex.Array, action: chex.Array) -> chex.Array:
        conv = self.scan_conv
        if self.shared and conv:
            obs = ScanTorso(conv, self.scan_layout, name="ScanTorso")(obs)
            conv = ()
        twins = nn.vmap(
            Critic,
            variable_axes={"params": 0},
            split_rngs={"params": True},
            in_axes=None,
            out_axes=0,
            axis_size=2,
        )
        return twins(self.hidden, self.layer_norm, conv, self.scan_layout)(obs, action)


def _conv(config: Config, env: NavEnv | None) -> dict:
    """The scan convolutions' settings of SAC's networks (``env``: the config's
    environment, made here if needed for the observation's layout)."""
    if not config.sac.scan_conv:
        return {}
    env = from_config(config, prepare=False)[0] if env is None else env
    return {"scan_conv": tuple(config.sac.scan_conv), "scan_layout": env.scan_layout}


def network_of(config: Config, env: NavEnv | None = None) -> Actor:
    """The network SAC's policy acts with: the actor (``env``: the config's
    environment, if already made)."""
    return Actor(tuple(config.sac.hidden), **_conv(config, env))


def critic_of(config: Config, env: NavEnv | None = None) -> TwinCritic:
    s = config.sac
    return TwinCritic(tuple(s.hidden), s.layer_norm, shared=s.shared_torso, **_conv(config, env))


# With sac.shared_torso the actor's and the critics' parameters each hold the one torso
# under "ScanTorso", beside their own layers: split off, it runs alone, and the rest
# runs as the same network without convolutions.
TORSO = "ScanTorso"


def split_torso(variables: dict) -> tuple[dict, dict]:
    """(the torso's variables, the rest's) of a network with a ``ScanTorso``."""
    p = variables["params"]
    return {"params": p[TORSO]}, {"params": {k: v for k, v in p.items() if k != TORSO}}


def with_torso(head: dict, torso: dict) -> dict:
    """The network's variables: ``head``'s layers after ``torso``'s convolutions."""
    return {"params": {**head["params"], TORSO: torso["params"]}}


def trained_part(config: Config, actor_params: dict) -> dict:
    """The part of the actor's parameters its optimiser steps: all of them, or with
    sac.shared_torso all but the torso (the critics train that)."""
    return split_torso(actor_params)[1] if config.sac.shared_torso else actor_params
