"""Can the burger reach a moving stage's goals at all? A search that answers yes with a
witness.

ROBOTIS' stage 3 spins four cylinders about the robot's start, inside the ring they
sweep, and every goal lies beyond it. From the start, a plan 2.8 s ahead (the oracle's
default where cylinders move, ``jaxnav/planners/oracle.py``) finds no gap there;
``scripts/moving_reach.py`` shows that speed alone does not rule the world out. This
script settles it for one action set
(:mod:`jaxnav.planners.search`, whose sequences the oracle now drives out of the ring):
it searches, breadth first in time,
the sequences of the world's actions from the start pose at time 0, each step with the
environment's own kinematics and collision test (the step's exact path against the
walls and against the moving cylinders over the step's time,
:func:`jaxnav.world.motion.step_clearance`). At each step it
keeps one state per cell of an (x, y, yaw) raster, the first found, so every state it
keeps is reached by a real sequence of actions. A goal is reached when a state ends a step
within the goal radius (the goals: the points the environment draws an episode's first
goal from, at least ``goal_min_separation`` from the start, or ROBOTIS' fixed first
goal); the sequence that got there is then replayed
through the environment itself (``NavEnv.step_env`` from a reset with that goal), and
the goal counts only if the replay reaches it with no collision.

So every goal it counts is proven reachable from the start (the first goal of an
episode; later goals start elsewhere and later). A goal it does not reach within the
horizon is not proven unreachable: the raster merges states that differ within a cell.

    python scripts/moving_search.py stage3 env.actions=vw
    python scripts/moving_search.py stage3                  # the paper's five yaw rates
    python scripts/moving_search.py stage4 env.actions=vw --replay 20
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field

import numpy as np


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
    overrides: list[str] = (),
    cell: float = 0.04,
    headings: int = 24,
    horizon: int = 0,
    replay: int = 0,
) -> Found:
    """Search ``config``'s world (with ``overrides``) from its start pose at time 0 for
    every first goal, ``horizon`` steps at most (0: env.max_steps), on a raster of
    ``cell`` m and ``headings`` yaw bins (:func:`jaxnav.planners.search.search`); replay
    the sequences found (``replay``: the first so many, 0 all) through the environment.
    ValueError names a world the search does not apply to."""
    from jaxnav.core.config import load_config
    from jaxnav.core.errors import JaxnavError
    from jaxnav.env import from_config
    from jaxnav.planners import search as space_time

    try:
        cfg = load_config(config, list(overrides))
        env, params = from_config(cfg)
    except JaxnavError as e:
        raise ValueError(str(e)) from None
    why = space_time.search_problem(env, params.maze)
    if why:
        raise ValueError(f"{cfg.env.maze}: {why}" if params.maze.motion is None else why)
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
    from jaxnav.planners.search import replay_all

    ok, _ = replay_all(env, params, np.asarray(goal, np.float32)[None], [list(actions)])
    return bool(ok[0])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config", help="a shipped config or config file whose maze moves")
    ap.add_argument("overrides", nargs="*", help="key=value settings (env.actions=vw)")
    ap.add_argument("--cell", type=float, default=0.04, help="raster cell, m")
    ap.add_argument("--headings", type=int, default=24, help="yaw bins of the raster")
    ap.add_argument("--horizon", type=int, default=0, help="steps (0: env.max_steps)")
    ap.add_argument("--replay", type=int, default=0, help="replay at most this many (0: all)")
    args = ap.parse_args(argv)
    try:
        f = search(args.config, args.overrides, args.cell, args.headings, args.horizon, args.replay)
    except ValueError as e:  # a bad config or a world the search does not apply to
        print(f"moving_search: {e}", file=sys.stderr)
        return 2
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
    replayed = min(len(f.reached), args.replay or len(f.reached))
    print(
        f"{told}; the search reached {len(f.reached)}, {replayed} replayed "
        f"({args.cell} m x {args.headings} headings raster, at most {f.largest:,} states "
        f"a step, {f.seconds:.0f} s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
