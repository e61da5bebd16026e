"""What the robot drives: an action's (speed, yaw rate), from the paper's five yaw rates,
a discrete (v, w) set or a continuous command, as the burger's firmware clips them
where ``wheel_limit`` asks, and the action space. A mixin of :class:`jaxnav.env.NavEnv`:
the fields it reads (``actions``, ``speed_range``, ...) are the environment's."""

from __future__ import annotations

import dataclasses
from typing import Any

import chex
import jax.numpy as jnp

from jaxnav.core import robots
from jaxnav.core.settings import (
    ACTION_SETS,
    BURGER_MAX_OMEGA,
    BURGER_MAX_V,
    CONTINUOUS,
    CONTINUOUS_TWIN,
)
from jaxnav.world.kinematics import firmware_limit
from jaxnav.world.spaces import Box, Discrete
from jaxnav.world.state import PAPER_OMEGAS, EnvParams, EnvState


class Commands:
    """The action side of :class:`jaxnav.env.NavEnv`."""

    actions: str
    wheel_limit: bool
    action_delay: bool
    speed_range: tuple[float, float]
    max_yaw_rate: float
    normalised: bool
    robot: str

    def command(self, params: EnvParams, action: chex.Array) -> tuple[chex.Array, chex.Array]:
        """(v m/s, omega rad/s) the robot drives for ``action`` (any shape): the action's
        yaw rate at its speed (the forward speed ``v`` for the paper's actions), as the
        firmware clips them if ``wheel_limit``. A continuous action (f32[..., 2] in
        [-1, 1], clipped there) sets the speed across ``speed_range`` and the yaw rate
        across +-``max_yaw_rate``."""
        if self.continuous:
            a = jnp.clip(jnp.asarray(action, jnp.float32), -1.0, 1.0)
            low, high = self.speed_range
            v = low + (a[..., 0] + 1.0) * (0.5 * (high - low))
            omega = a[..., 1] * self.max_yaw_rate
        else:
            omega = jnp.asarray(params.omegas)[action]
            v = params.v if params.speeds is None else jnp.asarray(params.speeds)[action]
        if self.wheel_limit:  # the arc the robot drives, not the one commanded
            v, omega = firmware_limit(jnp.asarray(v, jnp.float32), omega)
        return v, omega

    def driven(self, params: EnvParams, state: EnvState, action: chex.Array):
        """(v, omega), f32[] each: the command the step from ``state`` drives for the
        action chosen (or, with ``action_delay``, the one pending)."""
        applied = state.pending_action if self.action_delay else action
        v, omega = self.command(params, applied)
        v = jnp.broadcast_to(jnp.asarray(v, jnp.float32), jnp.shape(omega))
        return v, jnp.asarray(omega, jnp.float32)

    def _change(self, state: EnvState, v: chex.Array, omega: chex.Array) -> chex.Array | None:
        """The step's change of the driven command from the last step's, each over the
        burger's limits (for ``change_penalty``); None without the normalised
        observation, which is what keeps the last command."""
        if not self.normalised:
            return None
        last = state.last_command
        sv, sw = command_scale(self.robot)
        return jnp.abs(jnp.asarray(v, jnp.float32) - last[0]) / sv + jnp.abs(omega - last[1]) / sw

    def travel(self, params: EnvParams, state: EnvState, action: chex.Array) -> chex.Array:
        """f32[]: the length of the path the step from ``state`` drives (|v| dt along its
        arc), for the action chosen (or, with ``action_delay``, the one pending)."""
        v, _ = self.driven(params, state, action)
        return jnp.abs(v) * params.dt

    @property
    def continuous(self) -> bool:
        """Whether an action is a continuous command (``actions`` continuous)."""
        return self.actions == CONTINUOUS

    @property
    def num_actions(self) -> int:
        """The discrete actions' count (continuous actions have none: ``action_size``)."""
        if self.continuous:
            raise ValueError("continuous actions are not counted: see NavEnv.action_size")
        table = ACTION_SETS[self.actions]
        return len(PAPER_OMEGAS) if table is None else len(table)

    @property
    def action_size(self) -> int:
        """Numbers per action: 2 for a continuous command (speed, yaw rate), else 1."""
        return 2 if self.continuous else 1

    def discrete_twin(self, params: EnvParams) -> tuple[Any, EnvParams]:
        """This environment and ``params`` with the discrete commands the reference
        drivers plan over: the ``vw`` set (:data:`jaxnav.core.settings.CONTINUOUS_TWIN`)
        for continuous actions, unchanged otherwise. The world, its goals and its keys
        are the same, so a planner's test meets the goals a continuous policy meets."""
        if not self.continuous:
            return self, params
        table = ACTION_SETS[CONTINUOUS_TWIN]
        twin = dataclasses.replace(self, actions=CONTINUOUS_TWIN)
        speeds = jnp.asarray([v for v, _ in table], jnp.float32)
        omegas = jnp.asarray([w for _, w in table], jnp.float32)
        return twin, params.replace(speeds=speeds, omegas=omegas)

    def action_space(self, params: EnvParams | None = None) -> Discrete | Box:
        if self.continuous:
            return Box(-1.0, 1.0, (2,))
        return Discrete(self.num_actions)


def set_commands(actions: str, robot: str, top_speed: float | None = None) -> dict[str, Any]:
    """``EnvParams``' speeds and yaw rates (f32[A] each) of the action set ``actions``,
    the burger's commands scaled by ``robot``'s limits over the burger's
    (:attr:`jaxnav.core.robots.Robot.command_scale`), the speeds instead by
    ``top_speed`` over the burger's 0.22 m/s where it is given; {} for the paper's
    actions and continuous ones, which hold no set."""
    table = ACTION_SETS.get(actions)
    if table is None:
        return {}
    sv, sw = robots.get(robot).command_scale if robot != "burger" else (1.0, 1.0)
    if top_speed is not None:
        sv = top_speed / BURGER_MAX_V
    return {
        "speeds": jnp.asarray([v * sv for v, _ in table], jnp.float32),
        "omegas": jnp.asarray([w * sw for _, w in table], jnp.float32),
    }


def command_scale(robot: str) -> tuple[float, float]:
    """(v m/s, omega rad/s): the robot's top speeds, which the normalised observation
    and the change penalty divide the driven command by (the burger's teleop limits)."""
    if robot == "burger":
        return BURGER_MAX_V, BURGER_MAX_OMEGA
    r = robots.get(robot)
    return r.max_v, r.max_omega
