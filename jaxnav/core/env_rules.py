"""The environment's settings checked together: one line naming the setting where a
combination cannot make a valid world (a reward that follows shortest paths in mazes
that have none, a bank of layouts for a fixed maze, ...), or None.

A config applies them when it is built (:mod:`jaxnav.core.config`) and
``jaxnav.env.NavEnv`` applies them again to its own fields, so an environment made in
code is held to the same rules. Each takes anything with the environment's fields
(an ``EnvConfig`` or a ``NavEnv``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from jaxnav.core import families, robots
from jaxnav.core.settings import (
    ACTION_SETS,
    BURGER_MAX_OMEGA,
    BURGER_MAX_V,
    CONTINUOUS,
    MAX_LATTICE_CELLS,
    PRESETS,
    paces_motion,
)


def env_family_problem(env: Any) -> str | None:
    """What is wrong with a maze family's settings together (one line naming the
    setting), or None; ``env`` is an EnvConfig or a ``jaxnav.env.NavEnv`` whose
    ``generator`` names a family (:mod:`jaxnav.core.families`)."""
    if env.goal_sampler == "robotis":
        return "env.goal_sampler robotis needs a fixed maze (env.generator empty)"
    return families.get(env.generator).problem(env)


def env_reward_problem(env: Any) -> str | None:
    """What is wrong with the reward setting given the maze settings, or None."""
    paths = families.with_shortest_paths()
    which = families.listing(paths)
    if env.reward == "geodesic" and env.generator not in paths:
        return f"env.reward geodesic needs env.generator {which} (its shortest paths)"
    if env.progress_path == "geodesic" and (env.reward != "progress" or env.generator not in paths):
        return f"env.progress_path geodesic needs env.reward progress and env.generator {which}"
    if env.moving_proximity_penalty and (env.reward != "progress" or env.generator):
        return (
            "env.moving_proximity_penalty is a progress reward term for a fixed maze with "
            "moving cylinders: it needs env.reward progress and no env.generator"
        )
    return None


def env_bank_problem(env: Any) -> str | None:
    """What is wrong with the maze bank's setting given the maze settings, or None."""
    if paces_motion(env.motion_pace) and env.generator:
        return "env.motion_pace paces moving cylinders: drawn mazes have none (env.generator)"
    if env.pace_curriculum and not paces_motion(env.motion_pace):
        return (
            "env.pace_curriculum moves env.motion_pace's range to the cylinders' own pace: "
            "set env.motion_pace"
        )
    if env.restart_goal == "new" and env.generator and env.new_maze_every > 1:
        return (
            "env.restart_goal new draws a reset's goal: with drawn mazes it needs "
            "env.new_maze_every 1 (each restart a new layout and goal)"
        )
    if env.maze_bank and not env.generator:
        return "env.maze_bank draws layouts ahead: it needs drawn mazes (env.generator)"
    if env.maze_bank_refresh and not env.maze_bank:
        return "env.maze_bank_refresh draws new banks: it needs env.maze_bank"
    return None


def env_broad_phase_problem(env: Any) -> str | None:
    """What is wrong with the LiDAR's broad phase given the maze settings, or None."""
    return lattice_problem(env) if env.broad_phase == "lattice" else None


def lattice_problem(env: Any) -> str | None:
    """Why ``env``'s LiDAR cannot walk its mazes' lattice, or None where it can (drawn
    mazes of a family with a lattice, unscaled, at most MAX_LATTICE_CELLS a side)."""
    lattice = families.with_lattice()
    if env.generator not in lattice:
        which = families.listing(lattice)
        return f"env.broad_phase lattice walks a maze's lattice: it needs env.generator {which}"
    if tuple(env.maze_scale) != (1.0, 1.0):
        return "env.broad_phase lattice walks the lattice of unscaled mazes: env.maze_scale is on"
    if families.get(env.generator).lattice(env) > MAX_LATTICE_CELLS:
        return f"env.broad_phase lattice walks lattices of at most {MAX_LATTICE_CELLS} cells a side"
    return None


def env_waypoint_problem(env: Any) -> str | None:
    """What is wrong with the waypoint setting given the maze settings, or None (a
    config's check: a run's test on a fixed maze observes the goal as its waypoint)."""
    paths = families.with_shortest_paths()
    if env.waypoint and env.generator not in paths:
        which = families.listing(paths)
        return f"env.waypoint follows the maze's shortest paths: it needs env.generator {which}"
    return None


def env_scan_problem(env: Any) -> str | None:
    """What is wrong with the pooled scan's setting given the beams, or None."""
    if env.scan_beams and (env.scan_beams % env.n_beams or env.scan_beams < env.n_beams):
        return (
            f"env.scan_beams ({env.scan_beams}) must be 0 or a multiple of env.n_beams "
            f"({env.n_beams})"
        )
    if env.scan_beams and env.beam_layout != "even":
        return "env.scan_beams pools an even scan: it needs env.beam_layout even"
    for part in ("waypoint", "observe_moving", "scan_history"):
        if getattr(env, part) and env.observation != "normalised":
            return (
                f"env.{part} is part of the normalised observation: it needs "
                "env.observation normalised"
            )
    if not env.observe_command and env.observation != "normalised":
        return (
            "env.observe_command false hides the normalised observation's last command: it "
            "needs env.observation normalised"
        )
    if env.history_changes and not env.scan_history:
        return "env.history_changes observes the scan history: it needs env.scan_history > 0"
    if env.history_turned and not env.history_changes:
        return (
            "env.history_turned turns the scan history's changes: it needs env.history_changes true"
        )
    if env.history_turned and env.beam_layout != "even":
        return "env.history_turned turns an even scan: it needs env.beam_layout even"
    return None


def env_action_problem(env: Any) -> str | None:
    """What is wrong with the commands and the robot given the other settings, or None:
    the robot's own (:func:`env_robot_problem`); with continuous actions, the paper's and
    the geodesic reward score a discrete action's turn, a delayed action is held as a
    number, and the limits stay within the robot's unless overridden."""
    robot_problem = env_robot_problem(env)
    if robot_problem:
        return robot_problem
    top_problem = _top_speed_problem(env)
    if top_problem:
        return top_problem
    if env.actions != CONTINUOUS:
        return _continuous_only_problem(env)
    if env.reward not in ("progress", "sparse"):
        return (
            f"env.actions continuous needs env.reward progress or sparse (env.reward "
            f"{env.reward} scores the turn of a discrete action)"
        )
    if env.action_delay:
        return "env.action_delay holds a discrete action: it needs discrete env.actions"
    robot = _robot(env)
    if not env.beyond_limits and (
        env.speed_range[1] > robot.max_v or env.max_yaw_rate > robot.max_omega
    ):
        return (
            f"env.speed_range and env.max_yaw_rate must stay within the {robot.name}'s limits "
            f"({robot.max_v} m/s, {robot.max_omega} rad/s); set env.beyond_limits true to "
            "go beyond them"
        )
    return None


def _robot(env: Any) -> robots.Robot:
    """``env``'s robot profile (the burger's for a name the config's own check refuses)."""
    return robots.get(env.robot) if env.robot in robots.names() else robots.get("burger")


def _top_speed_problem(env: Any) -> str | None:
    """``top_speed`` scales an action set's speeds: the paper's actions (one speed, the
    preset's) and continuous ones (``speed_range``) have none, and it stays within the
    robot's top speed."""
    if env.top_speed is None:
        return None
    sets = [name for name, table in ACTION_SETS.items() if table is not None]
    if env.actions not in sets:
        return (
            f"env.top_speed scales an action set's speeds: env.actions {env.actions} has no "
            f"set ({', '.join(sets)} have one)"
        )
    robot = _robot(env)
    if env.top_speed > robot.max_v:
        return (
            f"env.top_speed ({env.top_speed:g} m/s) is beyond the {robot.name}'s top speed "
            f"({robot.max_v:g} m/s)"
        )
    return None


def _continuous_only_problem(env: Any) -> str | None:
    """With discrete actions, the continuous commands' limits keep their defaults (the
    burger's, or the robot's): the action sets' speeds are fixed, scaled by the robot's
    top speed and yaw rate, so a range set here would change nothing."""
    robot = _robot(env)
    speeds = {(0.0, BURGER_MAX_V), tuple(robot.defaults.get("env.speed_range", ()))}
    yaws = {BURGER_MAX_OMEGA, robot.defaults.get("env.max_yaw_rate")}
    given = tuple(float(x) for x in env.speed_range)
    if given not in speeds or float(env.max_yaw_rate) not in yaws or env.beyond_limits:
        return (
            "env.speed_range, env.max_yaw_rate and env.beyond_limits set continuous "
            f"commands: with env.actions {env.actions} the speeds and yaw rates are the "
            "action set's, scaled by the robot's limits (env.robot); leave them unset"
        )
    return None


def env_robot_problem(env: Any) -> str | None:
    """What is wrong with the robot and its LiDAR given the other settings, or None:
    the firmware wheel limit is the burger's, a scan narrower than 360 degrees is spread
    from edge to edge (no pooled sectors, no turned history), and an acceleration limit
    that would bind within one control period is not simulated."""
    if env.wheel_limit and env.robot != "burger":
        return f"env.wheel_limit is the burger's firmware: env.robot is {env.robot}"
    if env.lidar_fov < 360.0:
        if env.scan_beams or env.history_turned or env.beam_layout != "even":
            return (
                "env.lidar_fov below 360 spreads the beams from edge to edge: it needs "
                "env.scan_beams 0, env.history_turned false and env.beam_layout even"
            )
        if env.n_beams < 2:
            return "env.lidar_fov below 360 needs at least 2 beams (one at each edge)"
    return None


# Settings that only a progress reward reads, and the one each waits on beside it
_PROGRESS_ONLY = ("progress_scale", "step_penalty", "proximity_penalty", "proximity_distance")
_NEEDS_BESIDE = {
    "proximity_distance": "proximity_penalty",
    "moving_proximity_distance": "moving_proximity_penalty",
}
# drawn mazes' own settings that a fixed maze never reads
_DRAWN_ONLY = ("new_maze_every", "split")
# a family's setting that another family reads too (rooms are a grid's cells)
_ALSO_READ = {"min_path_cells": ("rooms",)}


def _given(env: Any, name: str, defaults: dict[str, Any]) -> bool:
    """Whether the setting ``env.NAME`` differs from its default (the preset's and the
    robot's, in ``defaults``, dotted keys, else the setting's own)."""
    value = getattr(env, name)
    default = defaults.get(f"env.{name}")
    if isinstance(value, list | tuple):
        return default is None or tuple(value) != tuple(default)
    return value != default


def _shown(value: Any) -> str:
    """A setting's value as a config writes it."""
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_shown(v) for v in value) + "]"
    return f"{value:g}" if isinstance(value, float) else str(value)


def env_unused_problem(env: Any, own: dict[str, Any], preset: str) -> str | None:
    """A setting given a value that nothing reads with the other settings (one line
    naming it), or None: a maze family's settings without that family in use
    (env.generator, or one of env.mix_worlds), a drawn maze's without env.generator, a
    progress reward's without env.reward progress, a distance without its penalty.
    Given means other than its default as the config takes it unset: ``own`` (each
    setting's own, dotted keys), then ``preset``'s, then the robot's."""
    defaults = {**own, **PRESETS[preset].defaults, **robots.defaults(env.robot)}
    in_use = {env.generator} | (set(env.mix_worlds) if env.generator == "mix" else set())
    for family in families.names():
        settings = families.get(family).settings
        if settings is None:
            continue
        for f in dataclasses.fields(settings):
            readers = (family, *_ALSO_READ.get(f.name, ()))
            if not in_use & set(readers) and _given(env, f.name, defaults):
                where = " or ".join(readers)
                drawn = env.generator or "empty"
                if env.generator == "mix":
                    drawn = f"mix of {', '.join(env.mix_worlds)}"
                return (
                    f"env.{f.name} ({_shown(getattr(env, f.name))}) is a setting of {where} "
                    f"mazes, which this config does not draw (env.generator {drawn}): leave "
                    f"it at its default ({_shown(defaults.get(f'env.{f.name}'))})"
                )
    if not env.generator:
        for name in _DRAWN_ONLY:
            if _given(env, name, defaults):
                return f"env.{name} is a drawn mazes' setting: it needs env.generator"
    if env.reward != "progress":
        for name in _PROGRESS_ONLY:
            if _given(env, name, defaults):
                return (
                    f"env.{name} is a term of the progress reward: with env.reward "
                    f"{env.reward} it does nothing (set env.reward progress, or leave it unset)"
                )
    for name, penalty in _NEEDS_BESIDE.items():
        if _given(env, name, defaults) and not getattr(env, penalty):
            return f"env.{name} is where env.{penalty} applies: it needs env.{penalty} > 0"
    return None
