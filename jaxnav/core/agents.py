"""Agents by name: the registry the config, the host loop, evaluation and export read.

An agent is one module that builds a trainer (``make_trainer(config) -> Trainer``, the
shape of :class:`jaxnav.agent.trainer.Trainer`) and the network its policy acts with
(``network_of(config, env) -> flax module``), plus one :func:`register` call naming
them, the settings sections it reads and what it needs. Nothing else changes when an
agent is added::

    from jaxnav.core import agents

    agents.register(
        "toy",
        trainer="my_package.toy:make_trainer",
        network="my_package.toy:network_of",
        reads=("dqn",),
        about="a toy agent",
    )

after which ``agent=toy`` trains it, ``jaxnav evaluate`` tests it and ``jaxnav export``
writes its policy. ``trainer`` and ``network`` may be callables or ``"module:function"``
strings, imported when first used, so this module imports no JAX.

The policy a trained agent is tested and deployed with is its network's output: the
greedy action (``argmax``) of a discrete-action Q-learner (``actions="discrete"``), or
the command itself for a continuous agent (``actions="continuous"``: the network maps an
observation to its mean action in [-1, 1]^2, and ``network.sample(obs, key)`` draws
the exploring one), which needs ``env.actions continuous``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from jaxnav.core.errors import ConfigError
from jaxnav.core.refs import resolve

# The settings sections an agent may read (besides env, exploration and run, which
# every agent reads).
AGENT_SECTIONS = ("dqn", "pqn", "sac")
# What an agent's network gives: action values to take the argmax of, or a command.
ACTION_KINDS = ("discrete", "continuous")


@dataclass(frozen=True)
class Agent:
    name: str
    trainer: Callable[..., Any] | str  # make_trainer(config) -> Trainer
    network: Callable[..., Any] | str  # network_of(config, env=None) -> module
    reads: tuple[str, ...]  # the settings sections it reads (AGENT_SECTIONS)
    replay: bool  # keeps a replay memory (its slots go to checkpoints)
    target_network: bool
    actions: str  # "discrete" (argmax of the network's outputs) or "continuous"
    about: str
    # (config) -> str | None: what is wrong with its settings together, one line;
    # a callable or "module:function" (JAX-free: it runs when a config loads).
    problem: Callable[[Any], str | None] | str | None = None
    # (config) -> int: bytes its runs' largest arrays take (the memory check); None: 0.
    memory: Callable[[Any], int] | str | None = None

    def make_trainer(self, config: Any) -> Any:
        """The agent's trainer of ``config``."""
        return resolve(self.trainer)(config)

    def network_of(self, config: Any, env: Any = None) -> Any:
        """The network the agent's policy acts with (``env``: the config's, if made)."""
        return resolve(self.network)(config, env)

    def settings_problem(self, config: Any) -> str | None:
        """What is wrong with ``config``'s settings of this agent, or None."""
        return None if self.problem is None else resolve(self.problem)(config)

    def memory_estimate(self, config: Any) -> int:
        """Bytes the runs' largest arrays take, before anything is allocated."""
        return 0 if self.memory is None else int(resolve(self.memory)(config))


_REGISTRY: dict[str, Agent] = {}


def register(
    name: str,
    trainer: Callable[..., Any] | str,
    network: Callable[..., Any] | str,
    reads: tuple[str, ...] = ("dqn",),
    replay: bool = False,
    target_network: bool = False,
    actions: str = "discrete",
    about: str = "",
    problem: Callable[[Any], str | None] | str | None = None,
    memory: Callable[[Any], int] | str | None = None,
) -> Agent:
    """Add an agent (see the module's docstring); ``agent=NAME`` then trains it."""
    if name in _REGISTRY:
        raise ConfigError(f"agent {name!r} is registered already")
    if not name.isidentifier():
        raise ConfigError(f"agent name {name!r} must be an identifier")
    bad = [s for s in reads if s not in AGENT_SECTIONS]
    if bad:
        raise ConfigError(f"agent {name!r}: {bad[0]} is not an agent settings section")
    if actions not in ACTION_KINDS:
        raise ConfigError(
            f"agent {name!r}: actions must be {' or '.join(ACTION_KINDS)}, got {actions!r}"
        )
    _REGISTRY[name] = Agent(
        name,
        trainer,
        network,
        tuple(reads),
        replay,
        target_network,
        actions,
        about,
        problem,
        memory,
    )
    return _REGISTRY[name]


def unregister(name: str) -> None:
    """Remove an agent added by :func:`register` (tests use it to tidy up)."""
    _REGISTRY.pop(name, None)


def names() -> tuple[str, ...]:
    """Every agent's name, in registration order (the built-in ones first)."""
    return tuple(_REGISTRY)


def get(name: str) -> Agent:
    """The agent registered as ``name``; an unknown name is a one-line ConfigError."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise ConfigError(
            f"config: agent must be one of {', '.join(_REGISTRY)}, got {name!r}"
        ) from None


# The built-in agents. Their settings' checks and memory estimates are in
# jaxnav.core.agent_settings.
register(
    "dqn",
    trainer="jaxnav.dqn:make_trainer",
    network="jaxnav.dqn:network_of",
    reads=("dqn",),
    replay=True,
    target_network=True,
    about="the paper's DQN: replay and a target network (dqn.*)",
    problem="jaxnav.core.agent_settings:dqn_problem",
    memory="jaxnav.core.agent_settings:dqn_memory",
)
register(
    "pqn",
    trainer="jaxnav.pqn:make_trainer",
    network="jaxnav.pqn:network_of",
    reads=("dqn", "pqn"),
    problem="jaxnav.core.agent_settings:pqn_problem",
    memory="jaxnav.core.agent_settings:pqn_memory",
    about="PQN: parallel environments, lambda-returns, LayerNorm (pqn.*; shares dqn.gamma, "
    "lr, hidden, dropout, dueling, loss and optimizer)",
)

register(
    "sac",
    trainer="jaxnav.sac:make_trainer",
    network="jaxnav.sac:network_of",
    reads=("sac",),
    actions="continuous",
    target_network=True,
    problem="jaxnav.core.agent_settings:sac_problem",
    memory="jaxnav.core.agent_settings:sac_memory",
    about="SAC: continuous (speed, yaw rate), twin critics, replay, automatic entropy "
    "temperature (sac.*; env.actions continuous, strategies [policy])",
)


__all__ = ["ACTION_KINDS", "AGENT_SECTIONS", "Agent", "get", "names", "register", "unregister"]
