"""Exploration strategies by name: the registry every part of jaxnav reads.

A strategy is one pure function (``act``, in :mod:`jaxnav.agent.exploration` for the
built-in ones) and one :func:`register` call naming it, the exploration settings it
reads and a line about it. Config validation, sweeps (a strategy's arms vary only the
settings it reads), the trainer, the test rollout, export and the results files all
take the list from here, so nothing else changes when a strategy is added::

    from jaxnav.core import strategies

    def greedy(key, q, episode, settings):  # (action i32[], exploration f32[])
        return jnp.argmax(q), jnp.float32(0.0)

    strategies.register("greedy", greedy, keys=(), about="always the greedy action")

``act`` is ``(key, q f32[A], episode i32[], settings) -> (action i32[], f32[])``,
where ``settings`` has the exploration settings as attributes (a run's
:class:`jaxnav.dqn.Hyper` inside the trainer). It may be given as a callable or as
``"module:function"``, imported when first used, so this module imports no JAX.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from jaxnav.core.errors import ConfigError
from jaxnav.core.refs import resolve


@dataclass(frozen=True)
class Strategy:
    name: str
    act: Callable[..., Any] | str  # a callable, or "module:function"
    keys: tuple[str, ...]  # the dotted exploration settings act reads
    about: str
    label: str  # how tables and figures name it
    actions: str = "discrete"  # the agents it serves: "discrete" (over Q-values) or "continuous"

    def function(self) -> Callable[..., Any]:
        """``act`` as a callable."""
        return resolve(self.act)


_REGISTRY: dict[str, Strategy] = {}


def register(
    name: str,
    act: Callable[..., Any] | str,
    keys: tuple[str, ...] = (),
    about: str = "",
    label: str | None = None,
    actions: str = "discrete",
) -> Strategy:
    """Add a strategy; its index (the trainer's strategy number) is its place here;
    ``label`` (default: the name) is how tables and figures name it."""
    if name in _REGISTRY:
        raise ConfigError(f"strategy {name!r} is registered already")
    if not name.isidentifier():
        raise ConfigError(f"strategy name {name!r} must be an identifier")
    bad = [k for k in keys if not k.startswith("exploration.")]
    if bad:
        raise ConfigError(f"strategy {name!r}: {bad[0]} is not an exploration setting")
    _REGISTRY[name] = Strategy(name, act, tuple(keys), about, label or name, actions)
    return _REGISTRY[name]


def unregister(name: str) -> None:
    """Remove a strategy added by :func:`register` (tests use it to tidy up)."""
    _REGISTRY.pop(name, None)


def names(actions: str | None = None) -> tuple[str, ...]:
    """Every strategy's name, in registration order (the built-in ones first);
    ``actions`` ("discrete" or "continuous"): only those serving such agents."""
    return tuple(n for n, s in _REGISTRY.items() if actions in (None, s.actions))


def get(name: str) -> Strategy:
    return _REGISTRY[name]


def label(name: str) -> str:
    """How tables and figures name a strategy (its own name if not registered)."""
    return _REGISTRY[name].label if name in _REGISTRY else name


def index(name: str) -> int:
    """The strategy's number in the trainer's carry."""
    return names().index(name)


_EXPLORE = "jaxnav.agent.exploration"
register(
    "ebe",
    f"{_EXPLORE}:act_ebe",
    ("exploration.ebe_temperature", "exploration.ebe_power"),
    "entropy-based exploration (the paper): random with probability H(s) of softmax(Q - max Q)",
    "EBE",
)
register(
    "epsilon_greedy",
    f"{_EXPLORE}:act_epsilon_greedy",
    ("exploration.eps_start", "exploration.eps_decay", "exploration.eps_min"),
    "random with probability eps, eps decaying by episode (the paper's baseline)",
    "epsilon-greedy",
)
register(
    "boltzmann",
    f"{_EXPLORE}:act_boltzmann",
    ("exploration.boltzmann_temperature",),
    "the action sampled from softmax(Q / T) (EBE's control)",
    "Boltzmann",
)
register(
    "policy",
    f"{_EXPLORE}:act_policy",
    (),
    "a continuous agent's own exploration: its action sampled from its stochastic policy "
    "(SAC; not a strategy over Q-values)",
    "own policy",
    actions="continuous",
)
