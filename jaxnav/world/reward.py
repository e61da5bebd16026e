"""The paper's reward: R+ on reaching the goal, R- on a collision, else orientation
shaping 5 psi(delta - phi_a) D (spec, "Reward"); and its sparse form, R+ and R- only.
The geodesic form is :func:`reward_fn` given the heading to the next opening on the
shortest path and the distance along it (:func:`jaxnav.world.generators.geodesic_target`).

Both presets' constants (paper and ROBOTIS) are data in ``EnvParams``; they come
from :data:`jaxnav.core.settings.PRESETS`.
"""

from __future__ import annotations

from typing import Any

import chex
import jax.numpy as jnp

from jaxnav.world.geometry import wrap_angle


def psi(x: chex.Array) -> chex.Array:
    """Orientation shaping wave: 1 facing the goal, 0 at 90 degrees, -1 behind."""
    return 1.0 - (2.0 / jnp.pi) * jnp.abs(wrap_angle(x))


def reward_fn(
    params: Any,
    action: chex.Array,
    heading: chex.Array,
    distance: chex.Array,
    goal_distance0: chex.Array,
    reached: chex.Array,
    collided: chex.Array,
) -> chex.Array:
    """R+ on reaching the goal, R- on collision, else 5 psi(delta - phi_a) D.

    phi_a = (omega_a / omega_max) * span is the direction action a turns towards, so
    the action that turns towards the goal earns the largest shaping reward.
    D is the current distance d_c (paper) or 2^(d_c / d_0) (ROBOTIS).

    Args:
      params: ``jaxnav.env.EnvParams``, or anything with its fields omegas, R_plus,
        R_minus, reward_span and reward_distance_exp.
      action: i32[] the action taken.
      heading: f32[] delta, the goal's direction relative to the yaw after the step.
      distance: f32[] d_c, the distance to the goal after the step.
      goal_distance0: f32[] d_0, the distance to the goal when it was drawn.
      reached, collided: bool[] what the step did.
    Returns:
      f32[] the reward.
    """
    omegas = jnp.asarray(params.omegas)
    phi = omegas[action] / jnp.max(jnp.abs(omegas)) * params.reward_span
    d_paper = distance
    d_robotis = jnp.exp2(distance / jnp.maximum(goal_distance0, 1e-6))
    D = jnp.where(params.reward_distance_exp, d_robotis, d_paper)
    shaping = 5.0 * psi(heading - phi) * D
    return jnp.where(collided, params.R_minus, jnp.where(reached, params.R_plus, shaping))


def sparse_reward(params: Any, reached: chex.Array, collided: chex.Array) -> chex.Array:
    """R+ on reaching the goal, R- on collision, else 0 (the time limit still applies)."""
    return jnp.where(collided, params.R_minus, jnp.where(reached, params.R_plus, 0.0))


def nearness(clearance: chex.Array, distance) -> chex.Array:
    """1 - c / ``distance`` clipped to [0, 1]: 1 at contact, 0 from ``distance`` (m) on,
    for a clearance c beyond the robot's radius."""
    return jnp.clip(1.0 - clearance / distance, 0.0, 1.0)


def progress_reward(
    params: Any,
    before: chex.Array,
    after: chex.Array,
    clearance: chex.Array,
    reached: chex.Array,
    collided: chex.Array,
    change: chex.Array | None = None,
) -> chex.Array:
    """R+ on reaching the goal, R- on collision, else the step's progress and penalties:
    ``progress_scale`` (before - after), the metres the step brought the robot closer
    to its goal (negative when it moved away), minus ``step_penalty`` and minus
    ``proximity_penalty`` (1 - c / ``proximity_distance``) where the step's path came
    within ``proximity_distance`` of a surface, c its clearance beyond the robot's
    radius (``clearance``: the path's least distance to any surface, as the collision
    test measures it). The field's shaping: progress towards the goal (turtlebot3_drlnav,
    JaxMARL's JaxNav), a penalty near obstacles (ROBOTIS' stage code). ``change`` (given
    with the normalised observation): the step's change of command, |dv| / 0.22 +
    |d omega| / 2.84, taken times ``change_penalty``."""
    near = nearness(clearance - params.robot_radius, params.proximity_distance)
    shaping = (
        params.progress_scale * (before - after)
        - params.step_penalty
        - params.proximity_penalty * near
    )
    if change is not None:  # a smoother command (the field's action-rate penalty)
        shaping = shaping - params.change_penalty * change
    return jnp.where(collided, params.R_minus, jnp.where(reached, params.R_plus, shaping))
