"""The navigation task: TurtleBot3 maze navigation as a pure, jit-able JAX environment
(gymnax 1.0 style).

``env, params = jaxnav.make("square4")`` then ``env.reset(key, params)`` and
``env.step(key, state, action, params)``. ``EnvParams`` and ``EnvState`` are immutable
pytrees, so everything jits and vmaps, over keys and over params.

* :mod:`jaxnav.env.navenv`: :class:`NavEnv`, its settings, ``reset`` and ``step``;
* :mod:`jaxnav.env.build`: :func:`make`, :func:`from_config` and :func:`prepared`.
"""

from __future__ import annotations

from jaxnav.env.build import ENV_FIELDS, PARAM_FIELDS, from_config, make, prepared
from jaxnav.env.navenv import RESTARTS, ROBOTIS_SWITCHES, NavEnv
from jaxnav.world.layouts import BANK_BATCH, bank_key
from jaxnav.world.state import PAPER_OMEGAS, STRAIGHT, EnvParams, EnvState, scale_maze

__all__ = [
    "BANK_BATCH",
    "ENV_FIELDS",
    "PARAM_FIELDS",
    "PAPER_OMEGAS",
    "RESTARTS",
    "ROBOTIS_SWITCHES",
    "STRAIGHT",
    "EnvParams",
    "EnvState",
    "NavEnv",
    "bank_key",
    "from_config",
    "make",
    "prepared",
    "scale_maze",
]
