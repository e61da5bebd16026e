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

A strategy may explore by more than its act over the Q-values, each part named in its
entry and built by the trainer for the runs of that strategy:

* ``bonus``: an intrinsic reward added to the environment's in the runs of the
  strategy, ``make(config, env) -> jaxnav.agent.bonus.Bonus`` (RND, the count bonus);
* ``noisy``: its runs act and learn with noise in the Q-network's layers
  (:mod:`jaxnav.agent.noisy`, NoisyNets); every run of a program that has such a
  strategy carries the noisy layers' parameters, the noise on in its runs only;
* ``problem``: ``(config) -> str | None``, what the strategy cannot do with a
  config's agent or world, one line (JAX-free: it runs when a config loads).

Every part is built only where a config lists the strategy, so a program without it
is the program it was.
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
    bonus: Callable[..., Any] | str | None = None  # make(config, env) -> agent.bonus.Bonus
    noisy: bool = False  # acts and learns with a noisy Q-network (jaxnav.agent.noisy)
    problem: Callable[[Any], str | None] | str | None = None  # (config) -> one line or None

    def function(self) -> Callable[..., Any]:
        """``act`` as a callable."""
        return resolve(self.act)

    def settings_problem(self, config: Any) -> str | None:
        """What the strategy cannot do with ``config`` (its agent, its world), or None."""
        return None if self.problem is None else resolve(self.problem)(config)


_REGISTRY: dict[str, Strategy] = {}


def register(
    name: str,
    act: Callable[..., Any] | str,
    keys: tuple[str, ...] = (),
    about: str = "",
    label: str | None = None,
    actions: str = "discrete",
    bonus: Callable[..., Any] | str | None = None,
    noisy: bool = False,
    problem: Callable[[Any], str | None] | str | None = None,
) -> Strategy:
    """Add a strategy; its index (the trainer's strategy number) is its place here;
    ``label`` (default: the name) is how tables and figures name it; ``bonus``,
    ``noisy`` and ``problem``: the module's docstring."""
    if name in _REGISTRY:
        raise ConfigError(f"strategy {name!r} is registered already")
    if not name.isidentifier():
        raise ConfigError(f"strategy name {name!r} must be an identifier")
    bad = [k for k in keys if not k.startswith("exploration.")]
    if bad:
        raise ConfigError(f"strategy {name!r}: {bad[0]} is not an exploration setting")
    _REGISTRY[name] = Strategy(
        name, act, tuple(keys), about, label or name, actions, bonus, noisy, problem
    )
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


def with_bonus(listed: tuple[str, ...]) -> tuple[str, ...]:
    """The strategies of ``listed`` (a config's) that add an intrinsic reward."""
    return tuple(s for s in listed if _REGISTRY[s].bonus is not None)


def noisy_of(listed: tuple[str, ...]) -> tuple[str, ...]:
    """The strategies of ``listed`` (a config's) that act with a noisy Q-network."""
    return tuple(s for s in listed if _REGISTRY[s].noisy)


def exploring_problem(config: Any) -> str | None:
    """What is wrong with a config's exploration, one line naming the setting, or None:
    each listed strategy's own check, and the measures of exploring (``run.coverage``)
    need greedy evaluations of PQN's runs in one fixed world."""
    for name in config.strategies:
        says = _REGISTRY[name].settings_problem(config) if name in _REGISTRY else None
        if says:
            return f"strategies {says}"
    run = config.run
    if run.coverage and (not run.eval_every or config.agent != "pqn" or config.env.generator):
        return (
            "run.coverage is written with the greedy evaluations of PQN's runs in one fixed "
            "world: it needs run.eval_every > 0, agent pqn and a fixed maze (no env.generator)"
        )
    return None


def only_pqn(name: str) -> Callable[[Any], str | None]:
    """A ``problem`` check: the strategy's part trains on PQN's rollouts only."""

    def problem(config: Any) -> str | None:
        if config.agent != "pqn":
            return (
                f"has {name}, whose intrinsic reward learns from PQN's rollouts: it needs "
                f"agent pqn (agent is {config.agent})"
            )
        return None

    return problem


def _count_problem(config: Any) -> str | None:
    """The count bonus counts places of one fixed world with PQN's rollouts."""
    if says := only_pqn("count")(config):
        return says
    if config.env.generator:
        return (
            "has count, which counts visits to the places of one fixed world: it needs "
            f"a fixed maze (env.generator is {config.env.generator!r})"
        )
    return None


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
# The field's exploration methods beside EBE (after the built-in ones above, so their
# numbers stay as they were).
register(
    "rnd",
    f"{_EXPLORE}:act_epsilon_greedy",
    (
        "exploration.eps_start",
        "exploration.eps_decay",
        "exploration.eps_min",
        "exploration.rnd_scale",
    ),
    "epsilon-greedy plus random network distillation's intrinsic reward (Burda et al. 2018): "
    "the predictor's error on a fixed random network's features of the observation",
    "RND",
    bonus="jaxnav.agent.rnd:make",
    problem=only_pqn("rnd"),
)
register(
    "noisy",
    f"{_EXPLORE}:act_noisy",
    ("exploration.noisy_sigma",),
    "NoisyNets (Fortunato et al. 2018): greedy on a Q-network whose layers carry "
    "factorised Gaussian noise, learnt with it",
    "NoisyNets",
    noisy=True,
)
register(
    "count",
    f"{_EXPLORE}:act_epsilon_greedy",
    (
        "exploration.eps_start",
        "exploration.eps_decay",
        "exploration.eps_min",
        "exploration.count_scale",
        "exploration.count_cell",
    ),
    "epsilon-greedy plus a count bonus, scale / sqrt(visits) of the cell of a coarse "
    "position grid the robot reaches (Tang et al. 2017; in navigation, Zhelo et al. 2018)",
    "count bonus",
    bonus="jaxnav.agent.counts:make",
    problem=_count_problem,
)
