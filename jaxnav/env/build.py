"""Building the environment: :func:`make` from a maze and settings, :func:`from_config`
from a run's config, and :func:`prepared`, what the settings ask to be prepared outside
``reset`` and ``step`` (the bank of drawn layouts, the pace curriculum's point)."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import chex
import jax
import jax.numpy as jnp

from jaxnav.core.errors import ConfigError
from jaxnav.core.settings import PRESETS
from jaxnav.env.navenv import NavEnv
from jaxnav.world.commands import set_commands
from jaxnav.world.episode import fitted
from jaxnav.world.layouts import bank_key
from jaxnav.world.maps import Maze, make_maze
from jaxnav.world.state import EnvParams

if TYPE_CHECKING:
    from jaxnav.core.config import Config


# The environment's settings: data in EnvParams (vmappable, no recompile), or static
# in NavEnv (they fix array shapes or the program).
PARAM_FIELDS = frozenset(f.name for f in dataclasses.fields(EnvParams)) - {"maze", "bank"}
ENV_FIELDS = frozenset(f.name for f in dataclasses.fields(NavEnv))


def make(
    maze: str | Maze = "square4",
    preset: str = "paper",
    *,
    key: chex.PRNGKey | None = None,
    progress: float | None = None,
    prepare: bool = True,
    **overrides: Any,
) -> tuple[NavEnv, EnvParams]:
    """Build the environment and its params, ready for ``reset`` and ``step``.

    Args:
      maze: a built-in maze name, a path to a maze YAML file, or a ``Maze``; unused
        with a ``generator`` (the mazes are drawn, ``EnvParams.maze`` is one of
        them as a template of their shapes).
      preset: ``"paper"`` (default) or ``"robotis"`` reward constants
        (:data:`jaxnav.core.settings.PRESETS`; ROBOTIS' R- depends on obstacles).
      key: with drawn mazes and ``maze_bank`` N, the params hold a bank of N layouts
        drawn from ``bank_key(key)`` (default ``jax.random.PRNGKey(0)``), so every
        reset and restart picks its layout from it, as a training run's do.
      progress: with ``pace_curriculum``, the share of the training budget done
        (0 to 1): the params hold the pace range of that point of the curriculum
        (move it with ``env.at_progress(params, progress)``). Required then.
      prepare: False leaves out what the settings ask to be prepared outside
        ``reset``/``step`` (the bank, the curriculum's point) and their checks: for
        the trainers, which prepare them per run.
      **overrides: any ``EnvParams`` field (``R_plus=200``, ``lidar_noise_std=0.01``)
        or ``NavEnv`` field (``n_beams=360``, ``obstacle_obs=True``).

    Raises:
      ConfigError: a setting that only a training run applies (``maze_bank_refresh``)
        or ``pace_curriculum`` without ``progress``: one line naming the call to make.
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset '{preset}' (choose from {', '.join(PRESETS)})")
    if overrides.get("generator"):  # drawn mazes: params hold a template of their shapes
        family = NavEnv(**{k: v for k, v in overrides.items() if k in ENV_FIELDS})
        maze_obj = family.draw_maze(jax.random.PRNGKey(0))[0]
    else:
        maze_obj = make_maze(maze) if isinstance(maze, str) else maze
    has_obstacles = maze_obj.has_obstacles
    unknown = set(overrides) - PARAM_FIELDS - ENV_FIELDS
    if unknown:
        raise ValueError(f"unknown environment parameter '{sorted(unknown)[0]}'")
    values = PRESETS[preset].reward(has_obstacles)
    env_kwargs = {"obstacle_obs": has_obstacles}
    for k, v in overrides.items():
        (env_kwargs if k in ENV_FIELDS else values)[k] = v
    if "omegas" in values:
        values["omegas"] = jnp.asarray(values["omegas"], jnp.float32)
    env = NavEnv(**env_kwargs)
    values.update(set_commands(env.actions, env.robot, env.top_speed))  # a set's speeds, yaw rates
    env, params = fitted(env, EnvParams(maze=maze_obj, **values), maze)
    if env.paces_motion and maze_obj.motion is None:
        raise ConfigError(f"env.motion_pace paces moving cylinders: maze {maze!r} has none")
    if env.moving_proximity_penalty and maze_obj.motion is None:
        raise ConfigError(
            f"env.moving_proximity_penalty keeps clear of moving cylinders: maze {maze!r} has none"
        )
    if env.attempt_limit > int(params.max_steps):
        raise ValueError(
            f"attempt_limit ({env.attempt_limit}) must not exceed max_steps ({params.max_steps})"
        )
    if prepare:
        params = prepared(env, params, key, progress)
    return env, params


def prepared(
    env: NavEnv, params: EnvParams, key: chex.PRNGKey | None = None, progress: float | None = None
) -> EnvParams:
    """``params`` holding what ``env``'s settings ask to be prepared outside ``reset``
    and ``step``, as a training run prepares them: the bank of drawn layouts
    (``maze_bank``, from ``bank_key(key)``, default ``PRNGKey(0)``) and the pace
    curriculum's point (``pace_curriculum``, at ``progress``). A setting that only a
    training run can apply is refused with one line naming the call to make instead;
    nothing is ever silently left without effect."""
    if env.maze_bank_refresh:
        raise ConfigError(
            "env.maze_bank_refresh renews the bank as a training run's env steps pass its "
            "multiples, which reset and step cannot see: leave it 0 and draw a new bank "
            "when you want one with params = env.with_bank(params, key)"
        )
    if env.pace_curriculum:
        if progress is None:
            raise ConfigError(
                "env.pace_curriculum moves the cylinders' pace as training goes: give "
                "progress= (the share of training done, 0 to 1) and move it with "
                "params = env.at_progress(params, progress)"
            )
        params = env.at_progress(params, progress)
    if env.generates and env.maze_bank:
        params = env.with_bank(params, bank_key(jax.random.PRNGKey(0) if key is None else key))
    return params


def from_config(
    config: Config,
    key: chex.PRNGKey | None = None,
    *,
    progress: float | None = None,
    prepare: bool = True,
) -> tuple[NavEnv, EnvParams]:
    """The environment of a run's config (its maze, preset and env settings), with
    params ready for ``reset`` and ``step`` as :func:`make` gives them (``key``: the
    bank's; ``progress``: the pace curriculum's point). A config that sweeps an
    environment setting is refused: each sweep point is its own environment,
    ``from_config(config.at(point))``."""
    if prepare:
        swept = [k for k, _ in config.sweep if k.startswith("env.")]
        if swept:
            raise ConfigError(
                f"the config sweeps {swept[0]}: build one point's environment with "
                "from_config(config.at(point)) (config.points() lists them)"
            )
    return make(
        config.env.maze,
        config.preset,
        key=key,
        progress=progress,
        prepare=prepare,
        **config.env_kwargs(),
    )
