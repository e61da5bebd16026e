"""A run's settings as data: what a sweep varies between the runs of one program.

:class:`Hyper` carries, per run, every setting the compiled step reads as a number
(the swept environment settings and agent switches only where swept), so the runs
of a sweep and a run without one are the same program. :func:`arm_hypers` gives each
arm's values (jaxnav.core.config.Config.arms).
"""

from __future__ import annotations

import chex
import jax
import numpy as np
from flax import struct

from jaxnav.core import strategies as registry
from jaxnav.core.config import Config
from jaxnav.env import EnvParams, from_config


@struct.dataclass
class Hyper:
    """A run's settings that are data in the compiled step, one field per key of
    :data:`jaxnav.core.config.SWEEPABLE` (its last component), each a scalar per run.

    Every run carries them, with or without a sweep, so the runs of a sweep and a run
    without one are the same program (PureJaxRL's hyperparameters-as-data). The
    environment's settings are None (not carried, so range noise 0 draws no noise)
    unless swept, and so are the agent switches ``double``, ``tau`` and ``loss``: the
    config's value is compiled in unless they are swept; then both paths are
    compiled side by side and the run's value picks one (:func:`_loss`,
    :func:`_target`).
    """

    gamma: chex.Array
    lr: chex.Array
    rms_decay: chex.Array
    rms_eps: chex.Array
    dropout: chex.Array
    target_update_every: chex.Array  # i32
    learning_starts: chex.Array  # i32
    ebe_temperature: chex.Array
    ebe_power: chex.Array
    boltzmann_temperature: chex.Array
    eps_start: chex.Array
    eps_decay: chex.Array
    eps_min: chex.Array
    lidar_noise_std: chex.Array | None = None
    R_plus: chex.Array | None = None
    R_minus: chex.Array | None = None
    reward_span: chex.Array | None = None
    double: chex.Array | None = None  # bool
    tau: chex.Array | None = None
    loss: chex.Array | None = None  # bool: True for huber, False for mse
    # the field's exploration methods' weights: None unless a listed strategy reads them
    rnd_scale: chex.Array | None = None
    count_scale: chex.Array | None = None

    def env_params(self, params: EnvParams, bank=None) -> EnvParams:
        """``params`` with the run's swept environment settings and, given one, its bank
        of drawn layouts (``bank``: the run state's, ``env.maze_bank``)."""
        new = {k: getattr(self, k) for k in ENV_HYPER if getattr(self, k) is not None}
        if bank is not None:
            new["bank"] = bank
        return params.replace(**new) if new else params


ENV_HYPER = ("lidar_noise_std", "R_plus", "R_minus", "reward_span")
AGENT_HYPER = ("double", "tau", "loss")
# exploration settings carried only where a strategy of the config reads them
# (jaxnav.core.strategies), so a program without that strategy is unchanged
BONUS_HYPER = ("rnd_scale", "count_scale")


def bonus_keys(config: Config) -> tuple[str, ...]:
    """The weights of BONUS_HYPER that a strategy of the config reads."""
    read = {k for s in config.strategies for k in registry.get(s).keys}
    return tuple(k for k in BONUS_HYPER if f"exploration.{k}" in read)


def hyper(
    config: Config,
    env_params: EnvParams | None = None,
    env_keys: tuple[str, ...] = (),
    agent_keys: tuple[str, ...] = (),
) -> Hyper:
    """A run's :class:`Hyper` (NumPy scalars) from its config; ``env_keys``: the
    environment settings to carry (the swept ones), read from ``env_params``;
    ``agent_keys``: the agent switches to carry (the swept ones of AGENT_HYPER)."""
    d, x = config.dqn, config.exploration
    f32 = np.float32
    agent = {"double": np.bool_(d.double), "tau": f32(d.tau), "loss": np.bool_(d.loss == "huber")}
    return Hyper(
        gamma=f32(d.gamma),
        lr=f32(d.lr),
        rms_decay=f32(d.rms_decay),
        rms_eps=f32(d.rms_eps),
        dropout=f32(d.dropout),
        target_update_every=np.int32(d.target_update_every),
        learning_starts=np.int32(d.learning_starts),
        ebe_temperature=f32(x.ebe_temperature),
        ebe_power=f32(x.ebe_power),
        boltzmann_temperature=f32(x.boltzmann_temperature),
        eps_start=f32(x.eps_start),
        eps_decay=f32(x.eps_decay),
        eps_min=f32(x.eps_min),
        **{k: f32(getattr(env_params, k)) for k in env_keys},
        **{k: agent[k] for k in agent_keys},
        **{k: f32(getattr(x, k)) for k in bonus_keys(config)},
    )


def swept_env_keys(config: Config) -> tuple[str, ...]:
    """The environment settings a config sweeps (carried in its runs' Hyper)."""
    swept = {key.split(".", 1)[1] for key, _ in config.sweep if key.startswith("env.")}
    return tuple(k for k in ENV_HYPER if k in swept)


def swept_agent_keys(config: Config) -> tuple[str, ...]:
    """The agent switches a config sweeps (carried in its runs' Hyper)."""
    swept = {key.split(".", 1)[1] for key, _ in config.sweep if key.startswith("dqn.")}
    return tuple(k for k in AGENT_HYPER if k in swept)


def arm_hypers(config: Config) -> list[Hyper]:
    """The :class:`Hyper` of each arm of a config (jaxnav.core.config.Config.arms)."""
    env_keys, agent_keys = swept_env_keys(config), swept_agent_keys(config)
    out = []
    for _, point in config.arms():
        at = config.at(point)
        env_params = from_config(at, prepare=False)[1] if env_keys else None
        out.append(hyper(at, env_params, env_keys, agent_keys))
    return out


def stack(trees: list) -> chex.ArrayTree:
    """NumPy pytrees of equal structure stacked along a new leading axis."""
    return jax.tree.map(lambda *xs: np.stack(xs), *trees)
