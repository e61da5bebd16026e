"""Can the burger reach a moving stage's goals at all? A search that answers yes with a
witness.

ROBOTIS' stage 3 spins four cylinders about the robot's start, inside the ring they
sweep, and every goal lies beyond it. From the start, a plan 2.8 s ahead (the oracle's
default where cylinders move, :mod:`jaxnav.planners.oracle`) finds no gap there;
``jaxnav probe reach`` (:mod:`jaxnav.world.reach`) shows that speed alone does not
rule the world out. This settles it for one action set (:mod:`jaxnav.planners.search`,
whose sequences the oracle now drives out of the ring): it searches, breadth first in
time, the sequences of the world's actions from the start pose at time 0, each step
with the environment's own kinematics and collision test (the step's exact path
against the walls and against the moving cylinders over the step's time,
:func:`jaxnav.world.motion.step_clearance`). At each step it keeps one state per cell
of an (x, y, yaw) raster, the first found, so every state it keeps is reached by a
real sequence of actions. A goal is reached when a state ends a step within the goal
radius (the goals: the points the environment draws an episode's first goal from, at
least ``goal_min_separation`` from the start, or ROBOTIS' fixed first goal); the
sequence that got there is then replayed through the environment itself
(``NavEnv.step_env`` from a reset with that goal), and the goal counts only if the
replay reaches it with no collision.

So every goal it counts is proven reachable from the start (the first goal of an
episode; later goals start elsewhere and later). A goal it does not reach within the
horizon is not proven unreachable: the raster merges states that differ within a cell.

    jaxnav probe search stage3 env.actions=vw
    jaxnav probe search stage3                  # the paper's five yaw rates
    jaxnav probe search stage4 env.actions=vw --replay 20
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from jaxnav.core.config import load_config
from jaxnav.core.errors import JaxnavError
from jaxnav.env import from_config
from jaxnav.planners import search as space_time


@dataclass
class Found:
    """What a search found in one world."""

    name: str  # the maze
    actions: str  # the action set
    dt: float
    horizon: int  # steps searched, at most
    goals: np.ndarray  # f32[G, 2] the first goals searched for
    reached: dict[int, list[int]] = field(default_factory=dict)  # goal -> its actions
    proven: list[int] = field(default_factory=list)  # goals whose replay reached them
    largest: int = 1  # states kept at one step, at most
    seconds: float = 0.0  # the search's


def search(
    config: str,
    overrides: Sequence[str] = (),
    cell: float = 0.04,
    headings: int = 24,
    horizon: int = 0,
    replay: int = 0,
) -> Found:
    """Search ``config``'s world (with ``overrides``) from its start pose at time 0 for
    every first goal, ``horizon`` steps at most (0: env.max_steps), on a raster of
    ``cell`` m and ``headings`` yaw bins (:func:`jaxnav.planners.search.search`); replay
    the sequences found (``replay``: the first so many, 0 all) through the environment.
    A bad config, or a world the search does not apply to, is a :class:`JaxnavError`."""
    cfg = load_config(config, list(overrides))
    env, params = from_config(cfg)
    why = space_time.search_problem(env, params.maze)
    if why:
        raise JaxnavError(f"{cfg.env.maze}: {why}" if params.maze.motion is None else why)
    horizon = horizon or int(params.max_steps)
    goals = space_time.first_goals(env, params)
    found = Found(cfg.env.maze, cfg.env.actions, float(params.dt), horizon, goals)
    searched = space_time.search(env, params, goals, cell=cell, headings=headings, horizon=horizon)
    found.reached, found.largest, found.seconds = (
        searched.reached,
        searched.largest,
        searched.seconds,
    )

    chosen = list(found.reached)[: replay or None]
    if chosen:
        ok, _ = space_time.replay_all(
            env, params, goals[chosen], [found.reached[g] for g in chosen]
        )
        found.proven = [g for g, good in zip(chosen, ok) if good]
    return found


def replays(env, params, goal, actions: list[int]) -> bool:
    """Whether ``actions``, driven through the environment from a reset with ``goal``,
    reach it at their last step and collide nowhere before
    (:func:`jaxnav.planners.search.replay_all` of the one sequence)."""
    ok, _ = space_time.replay_all(env, params, np.asarray(goal, np.float32)[None], [list(actions)])
    return bool(ok[0])


def found_line(f: Found, cell: float, headings: int, replay: int) -> str:
    """What a search found (its options ``cell``, ``headings``, ``replay`` named) as one
    line."""
    where = f"{f.name} ({f.actions} actions)"
    if f.proven:
        sec = np.asarray([len(f.reached[g]) for g in f.proven]) * f.dt
        told = (
            f"{where}: {len(f.proven)} of {len(f.goals)} first goals proven reachable from "
            f"the start (replayed in the environment, no collision), in "
            f"{np.min(sec):.1f}-{np.max(sec):.1f} s (median {np.median(sec):.1f} s)"
        )
    else:
        told = f"{where}: no first goal proven reachable within {f.horizon} steps"
    replayed = min(len(f.reached), replay or len(f.reached))
    return (
        f"{told}; the search reached {len(f.reached)}, {replayed} replayed "
        f"({cell} m x {headings} headings raster, at most {f.largest:,} states "
        f"a step, {f.seconds:.0f} s)"
    )
