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
import math
import os
import re
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from jaxnav.core import strategies as registry
from jaxnav.core import sweep as sweeps
from jaxnav.core.errors import ConfigError
from jaxnav.core.settings import PRESETS, env_setting_problem

# The strategies the paper compares; jaxnav.core.strategies has every registered one.
PAPER_STRATEGIES = ("ebe", "epsilon_greedy")
# The shipped configs and maze files: package data, so they work from an installed wheel.
CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"


@dataclass(frozen=True)
class EnvConfig:
    maze: str = "square4"  # built-in maze name or a maze YAML file
    n_beams: int = 24
    max_steps: int = 500  # an episode is truncated after this many steps
    lidar_noise_std: float = 0.0  # m; 0.01 reproduces Gazebo's range noise
    # Reward constants; null takes them from the preset (docs/paper.md, "Reward").
    R_plus: float | None = None
    R_minus: float | None = None
    reward_span: float | None = None
    reward_distance_exp: bool | None = None
    obstacle_obs: bool | None = None  # null: on for mazes with obstacles
    # Realism for a real robot, all off in the paper (see jaxnav.env.NavEnv):
    beam_dropout: float = 0.0  # probability a beam returns nothing (reads max range)
    odom_noise: tuple[float, ...] = (0.0, 0.0)  # std of (position m, yaw rad) odometry noise
    random_start: bool = False  # each episode starts at a random free pose
    maze_scale: tuple[float, ...] = (1.0, 1.0)  # per-episode maze scale drawn from [low, high]
    # ROBOTIS-faithful switches, all off by default (see jaxnav.env.NavEnv):
    collision: str = "disc"  # or "lidar": smallest observed beam below 0.13 m
    goal_sampler: str = "free"  # or "robotis": respawnGoal.py's grid, boxes and rules
    beam_layout: str = "even"  # or "gazebo": n beams over [0, 2 pi] inclusive
    action_delay: bool = False  # each action applied one step late


@dataclass(frozen=True)
class DQNConfig:
    gamma: float = PRESETS["paper"].gamma
    lr: float = 0.00025
    rms_decay: float = 0.9  # RMSprop rho
    rms_eps: float = 1e-6
    batch_size: int = 64
    buffer_size: int = 1_000_000  # capped at the run's largest possible step count
    learning_starts: int = 64  # stored transitions before the first gradient step
    hidden: tuple[int, ...] = (64, 64)
    dropout: float = 0.2
    # "periodic": hard copy every target_update_every env steps (paper).
    # "episode_end": online net gives the targets for the first target_update_every
    # steps, then the target net is synced at every episode end (ROBOTIS code).
    target_update: str = PRESETS["paper"].target_update
    target_update_every: int = 2000


@dataclass(frozen=True)
class ExplorationConfig:
    ebe_temperature: float = 1.0  # softmax temperature of EBE; 1 in the paper
    ebe_power: float = 1.0  # explore with probability H(s)^power; 1 in the paper
    boltzmann_temperature: float = 1.0  # Boltzmann samples from softmax(Q / T)
    eps_start: float = 1.0
    eps_decay: float = 0.99  # per episode
    eps_min: float = 0.05


@dataclass(frozen=True)
class RunConfig:
    chunk_steps: int = 10_000  # env steps per jitted chunk (progress, checkpoint)
    test_mazes: tuple[str, ...] = ("square4", "square8", "square2", "triangle", "pentagon")
    test_episodes: int = 10
    # A run whose loss, Q-values or parameters stop being finite: "stop" the command
    # with an error (the last good checkpoint kept), or "drop" that run (frozen and
    # listed in summary.json as diverged) and let the others finish.
    on_divergence: str = "stop"
    # Training curves for TensorBoard in RUN_DIR/tensorboard (jaxnav.run.tblog; needs the
    # optional extra "tensorboard").
    tensorboard: bool = False


@dataclass(frozen=True)
class Config:
    preset: str = "paper"
    seed: int = 0  # first seed; a run uses seed, seed + 1, ..., seed + seeds - 1
    seeds: int = 8  # seeds per strategy
    strategies: tuple[str, ...] = PAPER_STRATEGIES
    episodes: int | None = PRESETS[
        "paper"
    ].episodes  # per seed (null: only total_steps limits the run)
    total_steps: int | None = None  # env steps per seed (null: only episodes limits)
    env: EnvConfig = field(default_factory=EnvConfig)
    dqn: DQNConfig = field(default_factory=DQNConfig)
    exploration: ExplorationConfig = field(default_factory=ExplorationConfig)
    run: RunConfig = field(default_factory=RunConfig)
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
        """Bytes the runs' replay memories will take, an upper bound within 10% (for
        24 beams), before anything is allocated: jaxnav.agent.replay keeps per slot
        an f32 observation of at most n_beams + 4 values and 11 bytes of action,
        reward, flags and ring index, and a ring of capacity // max_steps + 2 final
        observations; the networks and the environment are small beside it."""
        obs = 4 * (self.env.n_beams + 4)
        capacity = self.buffer_capacity
        ring = capacity // self.env.max_steps + 3  # the final-observation ring and tail
        return self.n_runs * (capacity * (obs + 11) + ring * obs + 12)  # + 3 i32 counters

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


def _flatten(d: dict, prefix: str = "") -> dict[str, Any]:
    out = {}
    for k, v in d.items():
        if not isinstance(k, str):
            raise ConfigError(f"config: key {k!r} must be a string")
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, name + "."))
        else:
            out[name] = v
    return out


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


def _type_name(t) -> str:
    args = typing.get_args(t)
    origin = typing.get_origin(t)
    if origin in (types.UnionType, typing.Union):
        inner = [a for a in args if a is not type(None)]
        return _type_name(inner[0]) + " or null"
    if origin is tuple:
        return f"list of {_type_name(args[0])}"
    return {int: "an integer", float: "a number", bool: "true or false", str: "a string"}[t]


# A number as people write one: 1e-4, 5E3, 1_000_000, -2.5. YAML 1.1 (PyYAML) reads
# "1e-4" (no dot) and "1_000" in a file as strings; they are numbers here.
_NUMBER = re.compile(r"[+-]?(\d[\d_]*(\.[\d_]*)?|\.\d[\d_]*)([eE][+-]?\d+)?")


def _number(value: Any) -> int | float | None:
    """An int or float from a YAML scalar (int, float or numeric string), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return value
    if isinstance(value, str):
        text = value.strip()
        if text.lower() in (".inf", "+.inf", "-.inf", ".nan", "inf", "-inf", "nan"):
            return math.nan if "nan" in text.lower() else math.inf
        if _NUMBER.fullmatch(text) and "__" not in text and not text.endswith("_"):
            number = float(text.replace("_", ""))
            is_int = number.is_integer() and not any(c in text for c in ".eE")
            return int(text.replace("_", "")) if is_int else number
    return None


def _coerce(name: str, value: Any, t) -> Any:
    """Check ``value`` against type ``t``; return it in canonical form."""
    origin = typing.get_origin(t)
    args = typing.get_args(t)
    bad = ConfigError(f"config: {name} must be {_type_name(t)}, got {value!r}")
    if origin in (types.UnionType, typing.Union):
        if value is None:
            return None
        inner = [a for a in args if a is not type(None)][0]
        return _coerce(name, value, inner)
    if origin is tuple:
        if isinstance(value, str) or not isinstance(value, (list, tuple)):
            raise bad
        return tuple(_coerce(name, v, args[0]) for v in value)
    if t is bool:
        if not isinstance(value, bool):
            raise bad
        return value
    if t in (int, float):
        number = _number(value)
        if number is None:
            raise bad
        if not math.isfinite(number):
            raise ConfigError(f"config: {name} must be a finite number, got {value!r}")
        if t is float:
            return float(number)
        if number != int(number):
            raise bad
        return int(number)
    if t is str:
        if not isinstance(value, str):
            raise bad
        return value
    raise bad


def _parse_override(item: str) -> tuple[str, Any]:
    if "=" not in item:
        raise ConfigError(f"config: override '{item}' must look like key=value")
    key, raw = item.split("=", 1)
    key = key.strip()
    try:
        value = yaml.safe_load(raw) if raw.strip() else None
    except yaml.YAMLError:
        value = raw
    return key, value


_AT_LEAST_1 = (lambda v: v >= 1, "must be at least 1")
_POSITIVE = (lambda v: v > 0, "must be positive")
_UNIT = (lambda v: 0.0 <= v <= 1.0, "must be in [0, 1]")
_UNIT_OPEN = (lambda v: 0.0 <= v < 1.0, "must be in [0, 1)")

# field -> (rule, what it says when it fails); the environment's fields have their
# rules in jaxnav.core.settings (NavEnv applies the same ones).
_RULES: dict[str, tuple[Any, str]] = {
    "seeds": _AT_LEAST_1,
    "seed": (lambda v: v >= 0, "must be non-negative"),
    "strategies": (lambda v: len(v) > 0, "must name at least one strategy"),
    "episodes": (lambda v: v is None or v >= 1, "must be at least 1"),
    "total_steps": (lambda v: v is None or v >= 1, "must be at least 1"),
    "dqn.gamma": _UNIT,
    "dqn.lr": _POSITIVE,
    "dqn.rms_decay": _UNIT_OPEN,
    "dqn.rms_eps": _POSITIVE,
    "dqn.batch_size": _AT_LEAST_1,
    "dqn.buffer_size": _AT_LEAST_1,
    "dqn.learning_starts": _AT_LEAST_1,
    "dqn.hidden": (
        lambda v: len(v) > 0 and min(v) >= 1,
        "must be a non-empty list of positive layer widths",
    ),
    "dqn.dropout": _UNIT_OPEN,
    "dqn.target_update_every": _AT_LEAST_1,
    "exploration.ebe_temperature": _POSITIVE,
    "exploration.ebe_power": _POSITIVE,
    "exploration.boltzmann_temperature": _POSITIVE,
    "exploration.eps_start": _UNIT,
    "exploration.eps_decay": _UNIT,
    "exploration.eps_min": _UNIT,
    "run.chunk_steps": _AT_LEAST_1,
    "run.test_episodes": _AT_LEAST_1,
    "run.on_divergence": (lambda v: v in ("stop", "drop"), "must be stop or drop"),
}


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
    for name, (ok, says) in _RULES.items():
        if not ok(_get(cfg, name)):
            fail(name, says)
    for f in dataclasses.fields(cfg.env):
        problem = env_setting_problem(f.name, getattr(cfg.env, f.name))
        if problem:
            fail(f"env.{f.name}", problem)
    known = registry.names()
    for s in cfg.strategies:
        if s not in known:
            fail("strategies", f"has unknown strategy {s!r} (choose from {', '.join(known)})")
    if len(set(cfg.strategies)) != len(cfg.strategies):
        fail("strategies", "lists a strategy twice")
    if cfg.episodes is None and cfg.total_steps is None:
        fail("episodes", "and total_steps cannot both be null")
    capacity = cfg.buffer_capacity
    for name in ("batch_size", "learning_starts"):
        if getattr(cfg.dqn, name) > capacity:
            fail(
                f"dqn.{name}",
                f"({getattr(cfg.dqn, name)}) is larger than the replay memory, {capacity} "
                "transitions (the smaller of dqn.buffer_size and the most steps a run "
                "takes): it would never learn",
            )
    if cfg.dqn.target_update not in ("periodic", "episode_end"):
        fail(
            "dqn.target_update",
            f"must be periodic or episode_end, got {cfg.dqn.target_update!r}",
        )
    return cfg


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
            raise ConfigError(f"config: unknown key {key!r} in sweep")
        why = sweeps.refusal(key)
        if why:
            raise ConfigError(f"config: {why}")
        if raw is None:  # sweep.KEY=null (or an empty YAML entry) removes the key
            continue
        if isinstance(raw, str) or not isinstance(raw, (list, tuple)) or not raw:
            raise ConfigError(f"config: {name} must be a non-empty list of values, got {raw!r}")
        typed = tuple(_coerce(name, v, FIELD_TYPES[key]) for v in raw)
        if len(set(typed)) != len(typed):
            raise ConfigError(f"config: {name} lists a value twice")
        out.append((key, typed))
    return tuple(out)


def build_config(values: dict[str, Any]) -> Config:
    """A validated Config from flat dotted ``{"dqn.gamma": 0.9, ...}`` values; the
    ``sweep.KEY`` entries are the sweep's values of KEY."""
    values = dict(values)
    sweep = _sweep(values)
    preset = values.get("preset", "paper")
    merged: dict[str, Any] = {}
    if isinstance(preset, str) and preset in PRESETS:
        merged.update(PRESETS[preset].training())
    merged.update(values)
    for name in merged:
        if name not in FIELD_TYPES:
            if name in SECTIONS:
                raise ConfigError(f"config: {name} must be a mapping of its fields")
            raise ConfigError(f"config: unknown key {name!r}")
    typed = {name: _coerce(name, v, FIELD_TYPES[name]) for name, v in merged.items()}
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


def shipped_path(path: str) -> str:
    """``path`` if it exists, else the shipped file it names: ``configs/smoke.yaml`` or
    ``configs/mazes/corridor.yaml`` resolve to the package's copy from any folder."""
    if os.path.exists(path):
        return path
    rel = Path(path)
    if rel.parts[:1] == ("configs",):
        cand = CONFIG_DIR.joinpath(*rel.parts[1:])
        if cand.is_file():
            return str(cand)
    return path


def resolve_config_path(name: str) -> str:
    """A config path, a built-in config's name (``smoke``: ``configs/smoke.yaml``), or
    a path under ``configs/`` from any folder; a missing one is returned unchanged."""
    if os.path.exists(name):
        return name
    for cand in (CONFIG_DIR / name, CONFIG_DIR / f"{name}.yaml"):
        if cand.is_file() and "/" not in name:
            return str(cand)
    return shipped_path(name)


def builtin_configs() -> dict[str, str]:
    """Each shipped config's name and the first line of its opening comment."""
    out = {}
    for path in sorted(CONFIG_DIR.glob("*.yaml")):
        first = next((ln for ln in path.read_text().splitlines() if ln.startswith("#")), "#")
        out[path.stem] = first.lstrip("# ").rstrip(" ,.:")
    return out


def load_config(path: str | None, overrides: list[str] = ()) -> Config:
    """Config from a YAML file (or the defaults if None) plus ``key=value`` overrides."""
    values: dict[str, Any] = {}
    if path is not None:
        path = resolve_config_path(path)
        try:
            with open(path) as f:
                doc = yaml.safe_load(f)
        except FileNotFoundError:
            raise ConfigError(f"config: no such file {path}") from None
        except IsADirectoryError:
            raise ConfigError(f"config: {path} is a directory, not a YAML file") from None
        except yaml.YAMLError as e:
            mark = getattr(e, "problem_mark", None)
            at = f" at line {mark.line + 1}" if mark is not None else ""
            raise ConfigError(f"config: {path} is not valid YAML{at}") from None
        except UnicodeDecodeError:
            raise ConfigError(f"config: {path} is not a text file (not UTF-8)") from None
        if doc is None:
            doc = {}
        if not isinstance(doc, dict):
            raise ConfigError(f"config: {path} must hold a mapping of keys")
        values.update(_flatten(doc))
    for item in overrides:
        key, value = _parse_override(item)
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
