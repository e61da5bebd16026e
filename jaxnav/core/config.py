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
import os
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from jaxnav.core import strategies as registry
from jaxnav.core import sweep as sweeps
from jaxnav.core.errors import ConfigError
from jaxnav.core.settings import (
    AT_LEAST_1,
    GENERATORS,
    NON_NEGATIVE,
    PAIR_NON_NEGATIVE,
    POSITIVE,
    PRESETS,
    ROBOT_DIAMETER,
    SCALE_RANGE,
    UNIT,
    UNIT_OPEN,
    grid_problem,
    one_of,
    problem,
    setting,
)
from jaxnav.core.values import coerce, flatten, parse_override

# The strategies the paper compares; jaxnav.core.strategies has every registered one.
PAPER_STRATEGIES = ("ebe", "epsilon_greedy")
# The shipped configs and maze files: package data, so they work from an installed wheel.
CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"


@dataclass(frozen=True)
class EnvConfig:
    maze: str = setting("square4", "built-in maze name or a maze YAML file")
    n_beams: int = setting(24, "LiDAR beams (360 on the robot)", rule=AT_LEAST_1)
    max_steps: int = setting(500, "an episode is truncated after this many steps", rule=AT_LEAST_1)
    lidar_noise_std: float = setting(
        0.0, "std of Gaussian range noise, m (0.01: Gazebo's)", rule=NON_NEGATIVE, sweep=True
    )
    R_plus: float | None = setting(None, "reward for a goal (null: the preset's)", sweep=True)
    R_minus: float | None = setting(None, "reward for a collision (null: the preset's)", sweep=True)
    reward_span: float | None = setting(
        None, "the heading term's phi_a spans +-this, rad (null: the preset's)", sweep=True
    )
    reward_distance_exp: bool | None = setting(
        None, "D = 2^(d_c / d_0) (ROBOTIS) instead of d_c (null: the preset's)"
    )
    obstacle_obs: bool | None = setting(
        None, "observe the smallest range and its beam (null: on for mazes with obstacles)"
    )
    # Realism for a real robot, all off in the paper (see jaxnav.env.NavEnv):
    beam_dropout: float = setting(
        0.0, "probability a beam returns nothing (reads max range)", rule=UNIT_OPEN
    )
    odom_noise: tuple[float, ...] = setting(
        (0.0, 0.0), "std of (position m, yaw rad) odometry noise", rule=PAIR_NON_NEGATIVE
    )
    random_start: bool = setting(False, "each episode starts at a random free pose")
    maze_scale: tuple[float, ...] = setting(
        (1.0, 1.0), "per-episode maze scale drawn from [low, high]", rule=SCALE_RANGE
    )
    # ROBOTIS-faithful switches, all off by default (see jaxnav.env.NavEnv):
    collision: str = setting(
        "disc",
        "disc (exact) or lidar (ROBOTIS: smallest beam below 0.13 m)",
        rule=one_of("disc", "lidar"),
    )
    goal_sampler: str = setting(
        "free",
        "free, or robotis (respawnGoal.py's grid, boxes and rules)",
        rule=one_of("free", "robotis"),
    )
    beam_layout: str = setting(
        "even",
        "even, or gazebo (n beams over [0, 2 pi] inclusive)",
        rule=one_of("even", "gazebo"),
    )
    action_delay: bool = setting(False, "each action applied one step late (ROBOTIS' loop)")
    # Procedural mazes (jaxnav.world.generators), off by default: env.maze is the maze.
    generator: str = setting(
        "",
        "empty: the fixed maze env.maze; grid: a random grid maze, new every new_maze_every "
        "episodes",
        rule=(lambda v: v in GENERATORS, 'must be "" (the fixed env.maze) or grid'),
    )
    grid_rows: int = setting(4, "grid: rows of cells", rule=AT_LEAST_1)
    grid_cols: int = setting(4, "grid: columns of cells", rule=AT_LEAST_1)
    grid_cell: float = setting(
        1.0,
        "grid: a cell's side, m",
        rule=(lambda v: v > ROBOT_DIAMETER, f"must be more than {ROBOT_DIAMETER} m"),
    )
    grid_loops: float = setting(
        0.0, "grid: fraction of the perfect maze's closed walls opened (loops)", rule=UNIT
    )
    min_path_cells: int = setting(
        1,
        "grid: cells between the start and the first goal along the maze, at least",
        rule=AT_LEAST_1,
    )
    new_maze_every: int = setting(1, "grid: episodes in each maze", rule=AT_LEAST_1)
    split: str = setting(
        "train",
        "grid: train or test mazes (a layout is in one split only)",
        rule=one_of("train", "test"),
    )


@dataclass(frozen=True)
class DQNConfig:
    gamma: float = setting(PRESETS["paper"].gamma, "discount", rule=UNIT, sweep=True)
    lr: float = setting(0.00025, "learning rate (RMSprop or Adam)", rule=POSITIVE, sweep=True)
    rms_decay: float = setting(0.9, "RMSprop rho", rule=UNIT_OPEN, sweep=True)
    rms_eps: float = setting(1e-6, "RMSprop epsilon", rule=POSITIVE, sweep=True)
    batch_size: int = setting(64, "transitions per gradient step", rule=AT_LEAST_1)
    buffer_size: int = setting(
        1_000_000, "replay capacity, capped at the run's largest step count", rule=AT_LEAST_1
    )
    learning_starts: int = setting(
        64, "stored transitions before the first gradient step", rule=AT_LEAST_1, sweep=True
    )
    hidden: tuple[int, ...] = setting(
        (64, 64),
        "hidden layer widths",
        rule=(lambda v: len(v) > 0 and min(v) >= 1, "must be a non-empty list of positive widths"),
    )
    dropout: float = setting(0.2, "dropout after the hidden layers", rule=UNIT_OPEN, sweep=True)
    # "periodic": hard copy every target_update_every env steps (paper).
    # "episode_end": online net gives the targets for the first target_update_every
    # steps, then the target net is synced at every episode end (ROBOTIS code).
    target_update: str = setting(
        PRESETS["paper"].target_update,
        "periodic (paper) or episode_end (ROBOTIS)",
        rule=one_of("periodic", "episode_end"),
    )
    target_update_every: int = setting(
        2000,
        "env steps between target syncs (warm-up for episode_end)",
        rule=AT_LEAST_1,
        sweep=True,
    )
    # Agent variants beyond the paper, all off by default (the paper's agent):
    double: bool = setting(
        False,
        "double DQN: the online net picks the next action, the target net values it",
        sweep=True,
    )
    dueling: bool = setting(False, "dueling head: Q = V + A - mean(A)")
    tau: float = setting(
        1.0,
        "Polyak target rate per step; 1: a copy every target_update_every steps (paper)",
        rule=(lambda v: 0.0 < v <= 1.0, "must be in (0, 1]"),
        sweep=True,
    )
    loss: str = setting(
        "mse", "TD loss: mse (paper) or huber (delta 1)", rule=one_of("mse", "huber"), sweep=True
    )
    optimizer: str = setting(
        "rmsprop",
        "rmsprop (paper, rms_decay and rms_eps) or adam (optax defaults)",
        rule=one_of("rmsprop", "adam"),
    )
    n_step: int = setting(
        1, "n-step returns: up to n rewards, then gamma^k bootstrap (1: paper)", rule=AT_LEAST_1
    )


@dataclass(frozen=True)
class ExplorationConfig:
    ebe_temperature: float = setting(
        1.0, "softmax temperature of EBE (1 in the paper)", rule=POSITIVE, sweep=True
    )
    ebe_power: float = setting(
        1.0,
        "EBE explores with probability H(s)^power (1 in the paper)",
        rule=POSITIVE,
        sweep=True,
    )
    boltzmann_temperature: float = setting(
        1.0, "Boltzmann samples from softmax(Q / T)", rule=POSITIVE, sweep=True
    )
    eps_start: float = setting(1.0, "epsilon of the first episode", rule=UNIT, sweep=True)
    eps_decay: float = setting(0.99, "epsilon's factor per episode", rule=UNIT, sweep=True)
    eps_min: float = setting(0.05, "epsilon's floor", rule=UNIT, sweep=True)


@dataclass(frozen=True)
class RunConfig:
    chunk_steps: int = setting(
        10_000, "env steps per compiled chunk (progress, checkpoint)", rule=AT_LEAST_1
    )
    test_mazes: tuple[str, ...] = setting(
        ("square4", "square8", "square2", "triangle", "pentagon"), "mazes of the test"
    )
    test_episodes: int = setting(10, "consecutive test episodes per maze", rule=AT_LEAST_1)
    on_divergence: str = setting(
        "stop",
        "a run whose numbers stop being finite: stop the command, or drop that run",
        rule=one_of("stop", "drop"),
    )
    tensorboard: bool = setting(
        False, "training curves for TensorBoard in RUN_DIR/tensorboard (extra 'tensorboard')"
    )


@dataclass(frozen=True)
class Config:
    preset: str = setting("paper", "paper or robotis: the defaults of the other settings")
    seed: int = setting(0, "first seed; a run uses seed, ..., seed + seeds - 1", rule=NON_NEGATIVE)
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
    env: EnvConfig = setting(factory=EnvConfig)
    dqn: DQNConfig = setting(factory=DQNConfig)
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


def env_family_problem(env: Any) -> str | None:
    """What is wrong with a maze generator's settings together (one line naming the
    setting), or None; ``env`` is an EnvConfig or a ``jaxnav.env.NavEnv``."""
    if env.goal_sampler == "robotis":
        return "env.goal_sampler robotis needs a fixed maze (env.generator empty)"
    return grid_problem(
        env.grid_rows, env.grid_cols, env.grid_cell, env.grid_loops, env.min_path_cells
    )


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
    if cfg.env.generator:
        says = env_family_problem(cfg.env)
        if says:
            raise ConfigError(f"config: {says}")
    known = registry.names()
    for s in cfg.strategies:
        if s not in known:
            fail("strategies", f"has unknown strategy {s!r} (choose from {', '.join(known)})")
    if len(set(cfg.strategies)) != len(cfg.strategies):
        fail("strategies", "lists a strategy twice")
    if cfg.episodes is None and cfg.total_steps is None:
        fail("episodes", "and total_steps cannot both be null")
    capacity = cfg.buffer_capacity
    if cfg.dqn.batch_size > capacity:
        fail(
            "dqn.batch_size",
            f"({cfg.dqn.batch_size}) is larger than the replay memory, {capacity} "
            "transitions (the smaller of dqn.buffer_size and the most steps a run takes)",
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
