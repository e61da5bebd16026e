"""Training configuration: typed dataclasses with the paper's defaults.

A config is data. It is filled once, at the edge, from a YAML file and dotted
``key=value`` overrides (``dqn.gamma=0.99``), and validated field by field: an
unknown key or a value of the wrong type is a :class:`ConfigError` whose one-line
message names the field. Nothing deeper in jaxnav reads files.

``preset`` (``paper`` or ``robotis``) sets the defaults of every other field; the
YAML file and then the overrides are applied on top of it.

Replay capacity: ``dqn.buffer_size`` (10^6 as in the paper) is capped at the largest
number of transitions the run can produce (``episodes * env.max_steps`` or
``total_steps``), since a bigger buffer never fills; the cap changes no result.
"""

from __future__ import annotations

import dataclasses
import sys
import typing
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import yaml

from jaxnav.core import agents, robots
from jaxnav.core import strategies as registry
from jaxnav.core import sweep as sweeps
from jaxnav.core.agent_sections import DQNConfig, PQNConfig, SACConfig
from jaxnav.core.env_rules import (
    env_action_problem,
    env_bank_problem,
    env_broad_phase_problem,
    env_family_problem,
    env_reward_problem,
    env_scan_problem,
    env_unused_problem,
    env_waypoint_problem,
)
from jaxnav.core.errors import ConfigError
from jaxnav.core.sections import EnvConfig, ExplorationConfig, RunConfig
from jaxnav.core.settings import (
    AT_LEAST_1,
    CONTINUOUS,
    PRESETS,
    SEED,
    problem,
    setting,
    training_only_on,
)
from jaxnav.core.shipped import (
    CONFIG_DIR,
    builtin_configs,
    did_you_mean_config,
    resolve_config_path,
)
from jaxnav.core.values import coerce, flatten, parse_override, yaml_mark

# The strategies the paper compares; jaxnav.core.strategies has every registered one.
PAPER_STRATEGIES = ("ebe", "epsilon_greedy")


@dataclass(frozen=True)
class Config:
    preset: str = setting(
        "paper",
        "paper, robotis or modern (what the field's navigation agents use): the defaults of "
        "the other settings",
    )
    seed: int = setting(
        0,
        "first seed; a run uses seed, ..., seed + seeds - 1 (each below 2^32: a PRNG key's range)",
        rule=SEED,
    )
    seeds: int = setting(8, "seeds per arm", rule=AT_LEAST_1)
    strategies: tuple[str, ...] = setting(
        PAPER_STRATEGIES,
        "exploration strategies, one arm each (jaxnav list)",
        rule=(lambda v: len(v) > 0, "must name at least one strategy"),
    )
    episodes: int | None = setting(
        PRESETS["paper"].episodes,
        "episodes per run (null: only total_steps limits the run)",
        rule=(lambda v: v is None or v >= 1, "must be at least 1"),
    )
    total_steps: int | None = setting(
        None,
        "env steps per run (null: only episodes limits the run)",
        rule=(lambda v: v is None or v >= 1, "must be at least 1"),
    )
    agent: str = setting(
        "dqn",
        "the agent that learns (jaxnav list): dqn (the paper's: replay and a target "
        "network), pqn (parallel envs, lambda-returns, LayerNorm; pqn.*) or sac (continuous "
        "actions, twin critics, entropy temperature; sac.*)",
    )
    env: EnvConfig = setting(factory=EnvConfig)
    dqn: DQNConfig = setting(factory=DQNConfig)
    pqn: PQNConfig = setting(factory=PQNConfig)
    sac: SACConfig = setting(factory=SACConfig)
    exploration: ExplorationConfig = setting(factory=ExplorationConfig)
    run: RunConfig = setting(factory=RunConfig)
    # ((dotted key, (value, ...)), ...): the settings this run varies across its runs,
    # their grid trained in the same program (jaxnav.core.sweep); () for none.
    sweep: tuple[tuple[str, tuple[Any, ...]], ...] = ()

    @property
    def n_runs(self) -> int:
        return self.seeds * len(self.arms())

    def points(self, strategy: str | None = None) -> list[sweeps.Point]:
        """The sweep's grid (of the keys ``strategy`` reads), ``[()]`` without a sweep."""
        return sweeps.grid(self.sweep, strategy)

    def arms(self) -> list[tuple[str, sweeps.Point]]:
        """(strategy, sweep point) of each arm, strategy-major; a strategy's points
        vary only the swept keys it reads (jaxnav.core.strategies)."""
        return [(s, p) for s in self.strategies for p in self.points(s)]

    def arm_names(self) -> list[str]:
        """Each arm's name (the strategy's, without a sweep), in :meth:`arms` order."""
        return [sweeps.arm_name(s, p) for s, p in self.arms()]

    def run_arms(self) -> list[tuple[str, sweeps.Point, int]]:
        """(strategy, sweep point, seed) of each run: strategy, then point, then seed
        (the order of every run axis)."""
        return [(s, p, self.seed + i) for s, p in self.arms() for i in range(self.seeds)]

    def run_labels(self) -> list[tuple[str, int]]:
        """(arm name, seed) of each run, in :meth:`run_arms` order; the arm name is the
        strategy's without a sweep."""
        return [(sweeps.arm_name(s, p), seed) for s, p, seed in self.run_arms()]

    def run_fields(self) -> list[tuple]:
        """Each run's leading fields in its logs and results: (strategy, the value of
        each swept key, seed); a swept key the strategy does not read is empty."""
        keys = [k for k, _ in self.sweep]
        out = []
        for strategy, point, seed in self.run_arms():
            values = dict(point)
            swept = [sweeps.value_text(values[k]) if k in values else "" for k in keys]
            out.append((strategy, *swept, seed))
        return out

    def tested(self, overrides: Sequence[str] = ()) -> Config:
        """This config as a test plays its world: every training-only env setting off
        (:data:`jaxnav.core.settings.TRAINING_ONLY`: the moving cylinders at their own
        pace, real collisions), except those ``overrides`` (the test's ``key=value``
        settings, already applied) set."""
        off = {
            name: value
            for name, value in training_only_on(self.env).items()
            if not any(o.startswith(f"env.{name}=") for o in overrides)
        }
        if not off:
            return self
        return dataclasses.replace(self, env=dataclasses.replace(self.env, **off))

    def at(self, point: sweeps.Point) -> Config:
        """This config at one sweep point: the point's values set, no sweep."""
        sections: dict[str, dict[str, Any]] = {}
        top: dict[str, Any] = {"sweep": ()}
        for key, value in point:
            if "." in key:
                sec, name = key.split(".", 1)
                sections.setdefault(sec, {})[name] = value
            else:
                top[key] = value
        for sec, kv in sections.items():
            top[sec] = dataclasses.replace(getattr(self, sec), **kv)
        return dataclasses.replace(self, **top)

    @property
    def max_total_steps(self) -> int:
        """Most env steps one seed can take in this run."""
        limits = []
        if self.episodes is not None:
            limits.append(self.episodes * self.env.max_steps)
        if self.total_steps is not None:
            limits.append(self.total_steps)
        return min(limits)

    @property
    def buffer_capacity(self) -> int:
        return min(self.dqn.buffer_size, self.max_total_steps)

    def memory_estimate(self) -> int:
        """Bytes the runs' largest arrays will take, before anything is allocated: the
        agent's estimate (:func:`dqn_memory`, :func:`pqn_memory`)."""
        return agents.get(self.agent).memory_estimate(self)

    def env_kwargs(self) -> dict[str, Any]:
        """The environment's settings as ``jaxnav.env.make`` keywords (besides the maze
        and preset); the reward constants left null come from the preset there."""
        e = self.env
        out: dict[str, Any] = {
            f.name: getattr(e, f.name) for f in dataclasses.fields(e) if f.name != "maze"
        }
        return {k: v for k, v in out.items() if v is not None}


# ----------------------------------------------------------------------------
# Loading and validation
# ----------------------------------------------------------------------------


def _field_types(cls, prefix: str = "") -> dict[str, Any]:
    hints = typing.get_type_hints(cls)
    out = {}
    for f in dataclasses.fields(cls):
        if f.name == "sweep":  # a mapping of other fields' values (_sweep)
            continue
        t = hints[f.name]
        if dataclasses.is_dataclass(t):
            out.update(_field_types(t, f"{prefix}{f.name}."))
        else:
            out[f"{prefix}{f.name}"] = t
    return out


FIELD_TYPES = _field_types(Config)
SECTIONS = {k.split(".")[0] for k in FIELD_TYPES if "." in k}


@dataclass(frozen=True)
class Setting:
    """One setting as declared (:func:`jaxnav.core.settings.setting`)."""

    key: str  # dotted: "dqn.gamma"
    type: Any
    default: Any
    help: str
    rule: Any  # (predicate, message) or None
    sweep: bool


def _settings(cls, prefix: str = "") -> dict[str, Setting]:
    hints = typing.get_type_hints(cls)
    out = {}
    for f in dataclasses.fields(cls):
        if f.name == "sweep":
            continue
        t = hints[f.name]
        if dataclasses.is_dataclass(t):
            out.update(_settings(t, f"{prefix}{f.name}."))
            continue
        m = f.metadata
        out[f"{prefix}{f.name}"] = Setting(
            f"{prefix}{f.name}", t, f.default, m["help"], m["rule"], m["sweep"]
        )
    return out


# Every setting, from its one declaration in the dataclasses above.
SETTINGS: dict[str, Setting] = _settings(Config)
# The settings a sweep may vary: data in the compiled step (jaxnav.dqn.Hyper).
SWEEPABLE: tuple[str, ...] = tuple(k for k, s in SETTINGS.items() if s.sweep)
# Environment settings that are not config keys (jaxnav.env.NavEnv's own knobs).
_ENV_ONLY_RULES = {"goal_candidates": AT_LEAST_1}


def env_setting_problem(name: str, value: Any) -> str | None:
    """What is wrong with an environment setting's value ("must be ..."), or None: the
    rule a config applies to ``env.NAME``, applied by ``jaxnav.env.NavEnv`` too."""
    s = SETTINGS.get(f"env.{name}")
    return problem(s.rule if s else _ENV_ONLY_RULES.get(name), value)


def sweep_refusal(key: str) -> str | None:
    """Why ``key`` cannot be swept, or None if it can."""
    if key in SWEEPABLE:
        return None
    if key in ("seed", "seeds", "strategies", "preset"):
        return f"sweep.{key} is not a sweep key: set {key} itself"
    return (
        f"sweep.{key} cannot be swept: it changes array shapes or the compiled program "
        "(run one config per value; jaxnav list marks the keys that can be swept)"
    )


def _get(cfg: Config, name: str) -> Any:
    value = cfg
    for part in name.split("."):
        value = getattr(value, part)
    return value


def _check(cfg: Config) -> Config:
    """Value checks that types alone do not catch; the first failure is a ConfigError."""

    def fail(name, msg):
        raise ConfigError(f"config: {name} {msg}")

    if cfg.preset not in PRESETS:
        fail("preset", f"must be one of {', '.join(PRESETS)}, got {cfg.preset!r}")
    for name, s in SETTINGS.items():
        says = problem(s.rule, _get(cfg, name))
        if says:
            fail(name, says)
    says = agent_switch_problem(cfg)  # before the settings it names are checked one by one
    if says:
        raise ConfigError(f"config: {says}")
    if cfg.env.generator:
        says = env_family_problem(cfg.env)
        if says:
            raise ConfigError(f"config: {says}")
    says = (
        env_reward_problem(cfg.env)
        or env_scan_problem(cfg.env)
        or env_bank_problem(cfg.env)
        or env_broad_phase_problem(cfg.env)
        or env_waypoint_problem(cfg.env)
        or env_action_problem(cfg.env)
        or env_unused_problem(cfg.env, {n: x.default for n, x in SETTINGS.items()}, cfg.preset)
    )
    if says:
        raise ConfigError(f"config: {says}")
    if cfg.env.change_penalty and (
        cfg.env.reward != "progress" or cfg.env.observation != "normalised"
    ):
        fail(
            "env.change_penalty",
            "needs env.reward progress and env.observation normalised (which keeps the last "
            "command)",
        )
    if cfg.env.attempt_limit > cfg.env.max_steps:
        fail(
            "env.attempt_limit",
            f"({cfg.env.attempt_limit}) must not exceed env.max_steps ({cfg.env.max_steps}): "
            "an attempt never lasts longer than its episode",
        )
    known = registry.names()
    for s in cfg.strategies:
        if s not in known:
            fail("strategies", f"has unknown strategy {s!r} (choose from {', '.join(known)})")
    if len(set(cfg.strategies)) != len(cfg.strategies):
        fail("strategies", "lists a strategy twice")
    if cfg.episodes is None and cfg.total_steps is None:
        fail("episodes", "and total_steps cannot both be null")
    if cfg.seed + cfg.seeds > 2**32:
        last = cfg.seed + cfg.seeds - 1
        fail("seeds", f"would go up to seed {last}, past 2^32 - 1: a PRNG key holds 32 bits")

    if cfg.run.keep_best and not cfg.run.eval_every:
        fail("run.keep_best", "chooses among the greedy evaluations: it needs run.eval_every > 0")
    if says := registry.exploring_problem(cfg):  # each strategy's own check, run.coverage
        raise ConfigError(f"config: {says}")
    if cfg.dqn.lr_decay and cfg.total_steps is None:
        fail("dqn.lr_decay", "needs total_steps: the decay spans the run's budget of env steps")
    if cfg.env.pace_curriculum and cfg.total_steps is None:
        fail("env.pace_curriculum", "needs total_steps: it spans the run's budget of env steps")
    says = agent_problem(cfg)
    if says:
        raise ConfigError(f"config: {says}")
    return cfg


def agent_problem(cfg: Config) -> str | None:
    """What is wrong with a config's agent settings, one line naming the setting, or
    None: the agent must be registered (:mod:`jaxnav.core.agents`), the settings
    sections it does not read keep their defaults (the preset's), and the agent's own
    check passes (:mod:`jaxnav.core.agent_settings`)."""
    if cfg.agent not in agents.names():
        return f"agent must be one of {', '.join(agents.names())}, got {cfg.agent!r}"
    agent = agents.get(cfg.agent)
    defaults = PRESETS[cfg.preset].training()
    for section in (s for s in agents.AGENT_SECTIONS if s not in agent.reads):
        for name in (f.name for f in dataclasses.fields(getattr(cfg, section))):
            key = f"{section}.{name}"
            if getattr(getattr(cfg, section), name) != defaults.get(key, SETTINGS[key].default):
                readers = [a for a in agents.names() if section in agents.get(a).reads]
                return (
                    f"{key} is a {section.upper()} setting: it needs agent {' or '.join(readers)}"
                )
    return action_problem(cfg, agent) or agent.settings_problem(cfg)


def agent_switch_problem(cfg: Config) -> str | None:
    """Every setting a config's agent needs changed, in one line, or None: an agent of
    the other kind of actions (``agent=sac`` on a discrete config, ``agent=dqn`` on a
    continuous one) needs its actions, the reward that scores them and its own
    exploration, and these would otherwise be refused one at a time."""
    if cfg.agent not in agents.names():
        return None  # agent_problem names the choices
    agent = agents.get(cfg.agent)
    continuous = cfg.env.actions == CONTINUOUS
    own = registry.names("continuous")
    need = []
    if agent.actions == "continuous":
        if not continuous:
            need.append(f"env.actions={CONTINUOUS}")
        if cfg.env.reward not in ("progress", "sparse"):
            need.append("env.reward=progress")
        if cfg.env.action_delay:
            need.append("env.action_delay=false")
        if list(cfg.strategies) != list(own[:1]) and not (
            len(cfg.strategies) == 1 and cfg.strategies[0] in own
        ):
            need.append(f"strategies=[{own[0]}]")
        kind = "drives continuous commands and explores by sampling its own policy"
    else:
        if continuous:
            actions = PRESETS[cfg.preset].training().get("env.actions", "paper")
            need.append(f"env.actions={actions if actions != CONTINUOUS else 'paper'}")
        if any(s in own for s in cfg.strategies):
            need.append(f"strategies=[{', '.join(PAPER_STRATEGIES)}]")
        kind = "picks one of a set of discrete actions"
    if len(need) < 2:  # one setting: the checks below name it in their own words
        return None
    shipped = [
        name
        for name in builtin_configs()
        if f"agent: {agent.name}" in (CONFIG_DIR / f"{name}.yaml").read_text()
    ]
    start = f", or start from {' or '.join(shipped[:2])}" if shipped else ""
    return f"agent {agent.name} {kind}: add {' '.join(need)}{start}"


def action_problem(cfg: Config, agent: agents.Agent) -> str | None:
    """What is wrong with the agent's actions against the environment's and the
    strategies, or None: a continuous agent drives continuous commands and explores by
    sampling its own policy (strategy ``policy``); a discrete agent neither."""
    continuous = cfg.env.actions == CONTINUOUS
    own = [s for s in cfg.strategies if s in registry.names("continuous")]
    if agent.actions == "continuous":
        if not continuous:
            return f"agent {agent.name} drives continuous commands: it needs env.actions continuous"
        if len(cfg.strategies) != 1 or not own:
            return (
                f"strategies: agent {agent.name} explores by sampling its own policy, so "
                f"strategies must be [{', '.join(registry.names('continuous'))}]"
            )
        return None
    if continuous:
        which = " or ".join(a for a in agents.names() if agents.get(a).actions == "continuous")
        return f"env.actions continuous needs an agent with continuous actions ({which})"
    if own:
        return f"strategies: {own[0]} is a continuous agent's own exploration (agent sac)"
    return None


def _sweep(values: dict[str, Any]) -> tuple[tuple[str, tuple[Any, ...]], ...]:
    """Take the ``sweep.KEY`` entries out of ``values``: ((KEY, values), ...), each
    value typed as KEY's field; a key that cannot be swept is a ConfigError."""
    out = []
    bare = values.pop("sweep", None)
    if bare is not None:
        raise ConfigError("config: sweep must be a mapping of dotted keys to lists of values")
    for name in [n for n in values if n.startswith("sweep.")]:
        key, raw = name[len("sweep.") :], values.pop(name)
        if key not in FIELD_TYPES:
            raise ConfigError(f"config: unknown key {key!r} in sweep{_did_you_mean(key)}")
        why = sweep_refusal(key)
        if why:
            raise ConfigError(f"config: {why}")
        if raw is None:  # sweep.KEY=null (or an empty YAML entry) removes the key
            continue
        if isinstance(raw, str) or not isinstance(raw, (list, tuple)) or not raw:
            raise ConfigError(f"config: {name} must be a non-empty list of values, got {raw!r}")
        typed = tuple(coerce(name, v, FIELD_TYPES[key]) for v in raw)
        if len(set(typed)) != len(typed):
            raise ConfigError(f"config: {name} lists a value twice")
        out.append((key, typed))
    return tuple(out)


# The names other code bases give the settings jaxnav names short, for did-you-mean.
SPELLED_OUT = {"learning_rate": "dqn.lr", "discount": "dqn.gamma"}


def _did_you_mean(name: str) -> str:
    """`` (did you mean 'env.max_steps'?)`` for a misspelt key, or nothing: the key
    nearest to ``name``, or whose last part (or spelled-out name) is nearest to the
    last part of ``name``, in any section (``run.sed``: ``seed``;
    ``dqn.lerning_rate``: ``dqn.lr``), whichever is nearer."""
    from difflib import SequenceMatcher

    leaf = name.rsplit(".", 1)[-1]
    pairs = [(name, key, key) for key in FIELD_TYPES]  # (typed, compared with, suggested)
    pairs += [(leaf, key.rsplit(".", 1)[-1], key) for key in FIELD_TYPES]
    pairs += [(leaf, spelled, key) for spelled, key in SPELLED_OUT.items()]
    score, key = max((SequenceMatcher(None, a, b).ratio(), key) for a, b, key in pairs)
    return f" (did you mean {key!r}?)" if score >= 0.75 else ""


_NOTED: set[str] = set()


def _note_once(text: str) -> None:
    """One line on stderr, once per process (a deprecated key's note)."""
    if text not in _NOTED:
        _NOTED.add(text)
        print(text, file=sys.stderr)


def build_config(values: dict[str, Any]) -> Config:
    """A validated Config from flat dotted ``{"dqn.gamma": 0.9, ...}`` values; the
    ``sweep.KEY`` entries are the sweep's values of KEY."""
    values = dict(values)
    if "dqn.agent" in values:  # the agent's key before agents had their own setting
        if "agent" in values:
            raise ConfigError("config: dqn.agent is the old name of agent: set agent alone")
        values["agent"] = values.pop("dqn.agent")
        _note_once(f"note: dqn.agent is now agent (read as agent={values['agent']})")
    sweep = _sweep(values)
    preset = values.get("preset", "paper")
    merged: dict[str, Any] = {}
    if isinstance(preset, str) and preset in PRESETS:
        merged.update(PRESETS[preset].training())
    merged.update(robots.config_defaults(values))  # the robot's (reads robot: as env.robot)
    merged.update(values)
    for name in merged:
        if name not in FIELD_TYPES:
            if name in SECTIONS:
                raise ConfigError(f"config: {name} must be a mapping of its fields")
            raise ConfigError(f"config: unknown key {name!r}{_did_you_mean(name)}")
    typed = {name: coerce(name, v, FIELD_TYPES[name]) for name, v in merged.items()}
    sections: dict[str, dict[str, Any]] = {}
    top: dict[str, Any] = {}
    for name, v in typed.items():
        if "." in name:
            sec, key = name.split(".", 1)
            sections.setdefault(sec, {})[key] = v
        else:
            top[name] = v
    hints = typing.get_type_hints(Config)
    for sec, kv in sections.items():
        top[sec] = hints[sec](**kv)
    cfg = _check(Config(**top, sweep=sweep))
    for point in cfg.points() if sweep else ():  # every point obeys the field rules
        try:
            _check(cfg.at(point))
        except ConfigError as e:
            raise ConfigError(str(e).replace("config: ", "config: sweep.", 1)) from None
    return cfg


def load_config(path: str | None, overrides: list[str] = ()) -> Config:
    """Config from a YAML file (or the defaults if None) plus ``key=value`` overrides."""
    values: dict[str, Any] = {}
    if path is not None:
        path = resolve_config_path(path)
        try:
            with open(path) as f:
                doc = yaml.safe_load(f)
        except FileNotFoundError:
            raise ConfigError(f"config: no such file {path}{did_you_mean_config(path)}") from None
        except IsADirectoryError:
            raise ConfigError(f"config: {path} is a directory, not a YAML file") from None
        except yaml.YAMLError as e:
            mark = yaml_mark(e)
            at = f" at line {mark.line + 1}" if mark is not None else ""
            raise ConfigError(f"config: {path} is not valid YAML{at}") from None
        except UnicodeDecodeError:
            raise ConfigError(f"config: {path} is not a text file (not UTF-8)") from None
        if doc is None:
            doc = {}
        if not isinstance(doc, dict):
            raise ConfigError(f"config: {path} must hold a mapping of keys")
        values.update(flatten(doc))
    for item in overrides:
        key, value = parse_override(item)
        values[key] = value
    return build_config(values)


def config_to_dict(cfg: Config) -> dict[str, Any]:
    """Nested plain dict (lists, not tuples) for writing YAML."""

    def conv(x):
        if dataclasses.is_dataclass(x):
            out = {f.name: conv(getattr(x, f.name)) for f in dataclasses.fields(x)}
            if "sweep" in out:  # written as a mapping, key -> list of values, when set
                out["sweep"] = {k: conv(v) for k, v in x.sweep}
                if not out["sweep"]:
                    del out["sweep"]
            return out
        if isinstance(x, tuple):
            return [conv(v) for v in x]
        return x

    return conv(cfg)


def dump_config(cfg: Config) -> str:
    return yaml.safe_dump(config_to_dict(cfg), sort_keys=False)
