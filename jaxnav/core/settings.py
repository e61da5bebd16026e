"""The presets and the environment's settings: each constant declared once, each
setting checked by one rule.

A preset is the set of constants that differ between the paper's text and
ROBOTIS' code (docs/paper.md): training length, discount, target-network rule and the
reward. ``jaxnav.core.config`` applies a preset's training constants as config
defaults; ``jaxnav.env.make`` takes its reward constants. The environment's
settings are declared once each with :func:`setting` (in ``jaxnav.core.config``'s
dataclasses), with the rules below.

No JAX here: configs are read and checked before JAX starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Preset:
    """Constants of one preset (docs/paper.md, "Reward" and "DQN")."""

    episodes: int
    gamma: float
    target_update: str  # "periodic" (paper) or "episode_end" (ROBOTIS)
    R_plus: float
    R_minus: float  # mazes without obstacles (stage 1)
    R_minus_obstacles: float  # mazes with obstacles (stage 2)
    reward_span: float  # phi_a spans +-reward_span
    reward_distance_exp: bool  # D = 2^(d_c / d_0) (ROBOTIS) instead of d_c (paper)
    # more config defaults, as dotted keys (the modern preset's agent, sensor, reward)
    defaults: dict[str, Any] = field(default_factory=dict)

    def training(self) -> dict[str, Any]:
        """Config defaults, as dotted config keys."""
        return {
            "episodes": self.episodes,
            "dqn.gamma": self.gamma,
            "dqn.target_update": self.target_update,
            **self.defaults,
        }

    def reward(self, has_obstacles: bool) -> dict[str, Any]:
        """The environment's reward constants for a maze with or without obstacles."""
        return {
            "R_plus": self.R_plus,
            "R_minus": self.R_minus_obstacles if has_obstacles else self.R_minus,
            "reward_span": self.reward_span,
            "reward_distance_exp": self.reward_distance_exp,
        }


PRESETS: dict[str, Preset] = {
    "paper": Preset(
        episodes=500,
        gamma=0.9,
        target_update="periodic",
        R_plus=1000.0,
        R_minus=-150.0,
        R_minus_obstacles=-150.0,
        reward_span=math.pi / 2,
        reward_distance_exp=False,
    ),
    "robotis": Preset(
        episodes=3000,
        gamma=0.99,
        target_update="episode_end",
        R_plus=200.0,
        R_minus=-200.0,
        R_minus_obstacles=-150.0,
        reward_span=math.pi / 4,
        reward_distance_exp=True,
    ),
    # Not a paper's: what the field's navigation agents use (docs/driving.md), measured
    # here to drive. PQN with many environments, a discount of 0.99, the normalised
    # observation with the last command, three speeds (a stop among them), progress
    # towards the goal and a penalty near surfaces, the burger's wheel limits.
    "modern": Preset(
        episodes=None,
        gamma=0.99,
        target_update="periodic",
        R_plus=10.0,
        R_minus=-10.0,
        R_minus_obstacles=-10.0,
        reward_span=math.pi / 2,
        reward_distance_exp=False,
        defaults={
            "total_steps": 2_000_000,
            "env.observation": "normalised",
            "env.actions": "vw",
            "env.reward": "progress",
            "env.progress_scale": 5.0,
            "env.proximity_penalty": 0.2,
            "env.proximity_distance": 0.3,
            "agent": "pqn",
            "dqn.lr": 0.001,
            "dqn.optimizer": "radam",
            "dqn.dropout": 0.0,
            "pqn.num_envs": 128,
            "pqn.rollout": 32,
            "pqn.td_lambda": 0.65,
            "pqn.epochs": 4,
            "pqn.minibatches": 4,
            "run.chunk_steps": 409_600,
        },
    ),
}

# The sensor and start-pose settings for a real robot (all off in the paper): the
# robustness sweep perturbs them and its table shows them.
REALISM = ("lidar_noise_std", "beam_dropout", "odom_noise", "random_start", "maze_scale")


def setting(default: Any = None, help: str = "", *, rule=None, sweep: bool = False, factory=None):
    """One setting's declaration, as a config dataclass field: its default, a line of
    help, its rule ``(predicate, what it says when it fails)`` (what it says may be a
    function of nothing, called when the rule fails) and whether a sweep may
    vary it (it is then data in the compiled step: ``jaxnav.dqn.Hyper``). The type is
    the field's annotation. ``jaxnav.core.config`` derives validation, the sweep keys,
    ``jaxnav list`` and the settings table of the docs from these declarations."""
    meta = {"help": help, "rule": rule, "sweep": sweep}
    if factory is not None:
        return field(default_factory=factory, metadata=meta)
    return field(default=default, metadata=meta)


def _pair(x: Any) -> bool:
    return isinstance(x, (tuple, list)) and len(x) == 2


AT_LEAST_1 = (lambda v: v >= 1, "must be at least 1")
NON_NEGATIVE = (lambda v: v >= 0, "must be non-negative")
POSITIVE = (lambda v: v > 0, "must be positive")
UNIT = (lambda v: 0.0 <= v <= 1.0, "must be in [0, 1]")
UNIT_OPEN = (lambda v: 0.0 <= v < 1.0, "must be in [0, 1)")
WIDTHS = (lambda v: len(v) > 0 and min(v) >= 1, "must be a non-empty list of positive widths")
CHANNELS = (lambda v: all(c >= 1 for c in v), "must be a list of positive channel counts")
# every seed a user gives (config, study, --seed): a larger one would repeat a smaller one
SEED = (lambda v: 0 <= v < 2**32, "must be in [0, 2^32): a PRNG key holds 32 bits")
PAIR_NON_NEGATIVE = (
    lambda x: _pair(x) and min(x) >= 0,
    "must be [position std, yaw std], both non-negative",
)
# env.motion_pace at the cylinders' own pace: off, and what every test plays
OWN_PACE = (1.0, 1.0)


def paces_motion(motion_pace) -> bool:
    """Whether an env.motion_pace draws each episode's pace (is not :data:`OWN_PACE`)."""
    return tuple(motion_pace) != OWN_PACE


# The env settings that shape training only, each with its value when off: a run's test,
# its periodic evaluations and the reference drivers play the world with them off.
TRAINING_ONLY = {"motion_pace": OWN_PACE, "pace_curriculum": 0.0, "collision_margin": 0.0}


def training_only_on(env: Any) -> dict[str, Any]:
    """Each training-only setting ``env`` (an env config or a NavEnv) turns on, with its
    value when off: what a test of its runs sets back."""
    on = {}
    for name, off in TRAINING_ONLY.items():
        value = getattr(env, name)
        if (tuple(value) if isinstance(value, (list, tuple)) else value) != off:
            on[name] = off
    return on


MARGIN = (lambda v: 0.0 <= v <= 0.2, "must be in [0, 0.2] (metres)")
PACE_RANGE = (
    lambda x: _pair(x) and 0.0 <= x[0] <= x[1] <= 4.0,
    "must be [low, high] with 0 <= low <= high <= 4",
)
SCALE_RANGE = (
    lambda x: _pair(x) and 0.5 <= x[0] <= x[1] <= 2.0,
    "must be [low, high] with 0.5 <= low <= high <= 2",
)


# The burger's teleop limits (turtlebot3_teleop: BURGER_MAX_LIN_VEL, BURGER_MAX_ANG_VEL):
# every action set stays within them, and the normalised observation scales by them.
BURGER_MAX_V, BURGER_MAX_OMEGA = 0.22, 2.84
# The LiDAR's lattice walk (jaxnav.world.lattice, env.broad_phase): its int32 bit fields
# hold a lattice line's cell sides (bits 1 to 30), so at most this many cells a side.
MAX_LATTICE_CELLS = 30

# Action sets: name -> ((v m/s, omega rad/s), ...) per action, or None for the paper's
# (EnvParams.omegas at the constant EnvParams.v). Every command is within the burger's
# teleop limits (0.22 m/s, 2.84 rad/s); ``env.wheel_limit`` drives them as the firmware
# clips them.
PAPER_YAW_RATES = (-1.5, -0.75, 0.0, 0.75, 1.5)
ACTION_SETS: dict[str, tuple[tuple[float, float], ...] | None] = {
    "paper": None,
    # the paper's five turns at 0.15 m/s, and a stop: the robot can wait
    "paper_stop": tuple((0.15, w) for w in PAPER_YAW_RATES) + ((0.0, 0.0),),
    # three speeds (stopped, half and the burger's full 0.22 m/s) by the five turns
    "vw": tuple((v, w) for v in (0.0, 0.11, 0.22) for w in PAPER_YAW_RATES),
    # vw and backing up at half speed: the robot can give way to what comes at it
    "vw_reverse": tuple((v, w) for v in (-0.11, 0.0, 0.11, 0.22) for w in PAPER_YAW_RATES),
}


def can_stop(actions: str) -> bool:
    """Whether the action set ``actions`` holds a stop (the robot can wait where it is)."""
    table = ACTION_SETS[actions]
    return table is not None and (0.0, 0.0) in table


# Continuous commands (env.actions continuous): an action is f32[2] in [-1, 1]^2, the
# speed across env.speed_range and the yaw rate across +-env.max_yaw_rate. The
# reference drivers, which search a finite set, plan over this discrete twin.
CONTINUOUS = "continuous"
CONTINUOUS_TWIN = "vw"
ACTION_KINDS = (*ACTION_SETS, CONTINUOUS)


def one_of(*choices: str):
    """The rule of a setting that takes one of ``choices``."""
    return (lambda x: x in choices, "must be " + " or ".join(choices))


def problem(rule, value: Any) -> str | None:
    """What ``rule`` says of ``value`` ("must be ..."), or None if it holds."""
    if rule is None:
        return None
    ok, says = rule
    says = says() if callable(says) else says  # a message of what is known when checked
    try:
        return None if ok(value) else says
    except TypeError:
        return says
