"""A search in space and time: which goals the robot can reach from a pose at a time,
with which actions, in a world whose cylinders move.

Breadth first in time over the sequences of a discrete action set, from one pose at
one time, each step with the environment's own kinematics and collision test (the
step's exact path against the walls and against the moving cylinders over the step's
time, :func:`jaxnav.world.motion.step_clearance`). At each step it keeps one state per
cell of an (x, y, yaw) raster, the first found, so every state it keeps is reached by
a real sequence of actions; a goal is reached when a state ends a step within the goal
radius. A goal it does not reach is not proven unreachable: the raster merges states
that differ within a cell.

Two users: ``jaxnav probe search`` (:mod:`jaxnav.experiments.reachability`) proves a
moving stage's first goals reachable, and the oracle (:mod:`jaxnav.planners.oracle`)
drives the sequences it finds out of a start its reactive plans cannot leave
(:func:`opening`): stage 3's, where the robot starts inside the ring of turning
cylinders and a gap must be timed seconds ahead.
"""

from __future__ import annotations

import dataclasses
import math
import time

import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.core.settings import can_stop
from jaxnav.env import EnvParams, NavEnv
from jaxnav.world import motion
from jaxnav.world.geometry import displacement, wrap_angle
from jaxnav.world.maps import Maze


@dataclasses.dataclass
class Searched:
    """What a search found: per goal reached, the actions that reach it."""

    reached: dict[int, list[int]]  # goal index -> its actions, the last one reaching it
    largest: int  # states kept at one step, at most
    seconds: float


def search_problem(env: NavEnv, maze: Maze) -> str | None:
    """Why the search cannot run in ``env`` with ``maze`` (one line), or None."""
    if maze.motion is None:
        return "no moving obstacles"
    if env.continuous or env.action_delay or env.generates or env.scales_maze:
        return "the search needs a fixed maze, a discrete action set and no action delay"
    return None


def first_goals(env: NavEnv, params: EnvParams) -> np.ndarray:
    """f32[G, 2]: the goals an episode's reset can set from the start: ROBOTIS' fixed
    first goal, the maze file's own, or the points the free sampler draws from, at
    least ``goal_min_separation`` from the start."""
    maze = params.maze
    start = np.asarray(maze.start, np.float32)
    if maze.goal is not None or env.goal_sampler == "robotis":
        return np.asarray(env.first_goal(None, jnp.asarray(start[:2]), params, 1.0))[None]
    goals = np.asarray(maze.goal_points)[: int(maze.n_goal_points)]
    far = np.hypot(*(goals - start[:2]).T) >= float(params.goal_min_separation)
    return goals[far] if far.any() else goals[:1]


def search(
    env: NavEnv,
    params: EnvParams,
    goals: np.ndarray,
    pace: float | None = None,
    cell: float = 0.04,
    headings: int = 24,
    horizon: int = 0,
    stand: float = 0.0,
    stand_margin: float = 0.03,
    patience: int = 0,
) -> Searched:
    """Search from the maze's start pose at time 0 for ``goals`` (f32[G, 2]), at most
    ``horizon`` steps (0: the attempt limit), on a raster of ``cell`` m and ``headings``
    yaw bins, the cylinders at ``pace`` times their own (None: their own). With
    ``stand`` (s), a goal counts as reached only where the robot could then stand
    still that long with no moving cylinder within ``stand_margin`` of it: the next
    goal's drive starts there. With ``patience``, it stops that many steps after it last
    reached a new goal (0: it searches on to the horizon)."""
    maze = params.maze
    if pace is not None:
        maze = maze.replace(motion=motion.paced(maze.motion, jnp.float32(pace)))
    n_actions = env.num_actions
    dt, goal_radius = float(params.dt), float(params.goal_radius)
    radius = float(params.robot_radius) + float(env.collision_margin)
    horizon = horizon or env.attempt_steps(params)
    start = np.asarray(maze.start, np.float32)
    lo = np.asarray(maze.bounds, np.float64)[:2]
    span = np.asarray(maze.bounds, np.float64)[2:] - lo
    nx, ny = (np.ceil(span / cell).astype(int) + 1).tolist()
    actions = jnp.arange(n_actions)

    def one(pos, yaw, a, time0):
        v, omega = env.command(params, a)
        c = motion.step_clearance(maze, pos, yaw, omega, v, dt, time0)
        return pos + displacement(yaw, omega, v, dt), wrap_angle(yaw + omega * dt), c >= radius

    expand = jax.jit(jax.vmap(jax.vmap(one, (None, None, 0, None)), (0, 0, None, None)))
    # where the cylinders are over ``stand`` seconds from a time, 4 samples a step
    offsets = jnp.linspace(0.0, stand, max(1, int(round(4 * stand / dt))) + 1)
    cylinders = jax.jit(lambda t: jax.vmap(lambda s: motion.positions(maze.motion, t + s))(offsets))
    reach = float(params.robot_radius) + stand_margin + np.asarray(maze.motion.radius)

    def can_stand(points: np.ndarray, step: int) -> np.ndarray:
        """bool[N]: whether the robot could stand at each of ``points`` after ``step``."""
        if stand <= 0.0:
            return np.ones(len(points), bool)
        where = np.asarray(cylinders(jnp.float32((step + 1) * dt)))  # [S, M, 2]
        gap = np.linalg.norm(points[:, None, None] - where[None], axis=-1) - reach
        return np.all(gap >= 0.0, axis=(1, 2))

    pos, yaw = start[None, :2], start[None, 2]
    parents: list[tuple[np.ndarray, np.ndarray]] = []  # per step: (parent index, action)
    first: dict[int, tuple[int, int]] = {}  # goal -> (step, state index) first reached
    largest, t0 = 1, time.perf_counter()
    # with ``stand``: which goals' radius each state's way has entered (the first entry
    # ends the attempt, so a goal entered where the robot cannot stand is not reached)
    entered = np.zeros((1, len(goals)), bool) if stand > 0.0 else None
    for step in range(horizon):
        n = len(pos)
        size = 1 << max(4, (n - 1).bit_length())  # padded, so few shapes compile
        p = np.zeros((size, 2), np.float32)
        y = np.zeros(size, np.float32)
        p[:n], y[:n] = pos, yaw
        new_pos, new_yaw, ok = jax.device_get(expand(p, y, actions, jnp.float32(step * dt)))
        new_pos, new_yaw, ok = new_pos[:n], new_yaw[:n], ok[:n]
        parent, action = np.nonzero(ok)
        if len(parent) == 0:
            break
        cand_pos, cand_yaw = new_pos[parent, action], new_yaw[parent, action]
        ix = np.clip(((cand_pos[:, 0] - lo[0]) / cell).astype(int), 0, nx - 1)
        iy = np.clip(((cand_pos[:, 1] - lo[1]) / cell).astype(int), 0, ny - 1)
        ih = np.clip(np.floor((cand_yaw + math.pi) / (2 * math.pi) * headings), 0, headings - 1)
        keys = (ix * ny + iy) * headings + ih.astype(int)
        _, keep = np.unique(keys, return_index=True)
        keep.sort()
        pos, yaw = cand_pos[keep], cand_yaw[keep]
        parents.append((parent[keep], action[keep]))
        largest = max(largest, len(pos))
        open_goals = [g for g in range(len(goals)) if g not in first]
        if entered is None:  # a goal is reached where a state is within its radius
            inside = np.hypot(
                pos[:, None, 0] - goals[None, open_goals, 0],
                pos[:, None, 1] - goals[None, open_goals, 1],
            )
            fresh = inside < goal_radius
        else:  # only where a state enters its radius: the environment ends the attempt there
            entered = entered[parents[-1][0]]
            inside = np.hypot(
                pos[:, None, 0] - goals[None, :, 0], pos[:, None, 1] - goals[None, :, 1]
            )
            inside = inside < goal_radius
            fresh = (inside & ~entered)[:, open_goals]
            entered |= inside
        near = np.flatnonzero(np.any(fresh, axis=1))
        standing = np.zeros(len(pos), bool)
        standing[near] = can_stand(pos[near], step)
        for j, g in enumerate(open_goals):
            idx = np.flatnonzero(fresh[:, j] & standing)
            if len(idx):
                first[g] = (step, int(idx[0]))
        if len(first) == len(goals):
            break
        last = max((s for s, _ in first.values()), default=step)
        if patience and step - last >= patience:
            break
    seconds = time.perf_counter() - t0

    reached = {}
    for g, (step, index) in sorted(first.items(), key=lambda kv: kv[1][0]):
        seq = []
        for s in range(step, -1, -1):
            parent, action = parents[s]
            seq.append(int(action[index]))
            index = int(parent[index])
        reached[g] = seq[::-1]
    return Searched(reached, largest, seconds)


def replay_all(
    env: NavEnv, params: EnvParams, goals: np.ndarray, sequences: list[list[int]], pace=None
) -> tuple[np.ndarray, np.ndarray]:
    """Drive each of ``sequences`` through the environment (``NavEnv.step_env``, all at
    once) from a reset with its goal: (bool[G] whether it reaches its goal at its last
    step and collides nowhere before, f32[G, T, 2] the position before each step)."""
    n, T = len(sequences), max(len(s) for s in sequences)
    acts = np.zeros((n, T), np.int32)
    for i, s in enumerate(sequences):
        acts[i, : len(s)] = s
    length = np.asarray([len(s) for s in sequences], np.int32)
    goal = jnp.asarray(goals, jnp.float32)
    key = jax.random.PRNGKey(0)

    def drive(goal, actions, length):
        _, state = env.reset(key, params)
        if pace is not None:
            state = state.replace(pace=jnp.float32(pace))
        state = state.replace(goal=goal, goal_distance0=jnp.linalg.norm(goal - state.pos))

        def body(carry, i):
            state, done, ok = carry
            _, new, _, _, _, info = env.step_env(key, state, actions[i], params)
            live = ~done & (i < length)
            last = i == length - 1
            good = ~info["collision"] & (info["goal_reached"] == last)
            ok = jnp.where(live, ok & good, ok)
            pos = state.pos
            state = jax.tree.map(lambda a, b: jnp.where(live, a, b), new, state)
            return (state, done | ~live | info["goal_reached"], ok), pos

        (_, _, ok), poses = jax.lax.scan(body, (state, False, True), jnp.arange(T))
        return ok, poses

    ok, poses = jax.jit(jax.vmap(drive))(goal, jnp.asarray(acts), jnp.asarray(length))
    return np.asarray(ok), np.asarray(poses)


@dataclasses.dataclass(frozen=True, eq=False)
class Opening:
    """The oracle's way out of a start: per goal an episode's reset can set, the actions
    that reach it from the start pose at time 0 (replayed clean in the environment) and
    the positions they pass, which the oracle checks it is on before each step.

    Attributes:
      goals: f32[G, 2] the goals.
      actions: i32[G, T] the actions, padded.
      poses: f32[G, T, 2] the robot's position before each of them.
      length: i32[G] the number of actions.
      marker: f32[2] the first moving cylinder's centre at time 0: which world it is of.
      seconds: the search's and replay's.
    """

    goals: np.ndarray
    actions: np.ndarray
    poses: np.ndarray
    length: np.ndarray
    marker: np.ndarray
    seconds: float


def encircled(maze: Maze) -> bool:
    """Whether the maze's start lies inside the orbit of a turning cylinder (host
    side): then every way out crosses its sweep, at a time a plan must find."""
    m = maze.motion
    if m is None:
        return False
    start = np.asarray(maze.start, np.float64)[:2]
    for i in range(m.n):
        spin, centre = float(m.spin[i]), np.asarray(m.centre[i], np.float64)
        if spin == 0.0:
            continue
        orbit = np.min(np.linalg.norm(np.asarray(m.points[i], np.float64) - centre, axis=1))
        if np.linalg.norm(start - centre) < orbit - float(m.radius[i]):
            return True
    return False


def needs_opening(env: NavEnv, params: EnvParams) -> bool:
    """Whether the oracle searches its way out of the start in this world: a start
    encircled by turning cylinders (:func:`encircled`), a searchable world
    (:func:`search_problem`), an action set that can stop (the robot must wait for its
    gap), a fixed start and cylinders at one pace."""
    maze = params.maze
    return (
        search_problem(env, maze) is None
        and encircled(maze)
        and can_stop(env.actions)
        and not env.random_start
        and env.motion_pace[0] == env.motion_pace[1]
    )


def opening(
    env: NavEnv, params: EnvParams, stand: float = 3.2, patience: int = 50, **kw
) -> Opening | None:
    """The :class:`Opening` of ``env``'s world, or None where it needs none
    (:func:`needs_opening`) or the search reaches no goal. Its sequences end only where
    the robot could stand ``stand`` seconds clear of the cylinders (the oracle's own
    rule for where a plan may end), and it stops ``patience`` steps after its last new
    goal, since goals no stand can be found at keep it searching to the attempt limit;
    ``kw``: :func:`search`'s."""
    if not needs_opening(env, params):
        return None
    t0 = time.perf_counter()
    pace = env.motion_pace[0] if env.paces_motion else None
    goals = first_goals(env, params)
    found = search(env, params, goals, pace=pace, stand=stand, patience=patience, **kw)
    if not found.reached:
        return None
    index = list(found.reached)
    ok, poses = replay_all(env, params, goals[index], [found.reached[g] for g in index], pace)
    keep = [i for i, good in enumerate(ok) if good]
    if not keep:
        return None
    seqs = [found.reached[index[i]] for i in keep]
    T = max(len(s) for s in seqs)
    actions = np.zeros((len(seqs), T), np.int32)
    for i, s in enumerate(seqs):
        actions[i, : len(s)] = s
    marker = np.asarray(motion.positions(params.maze.motion, 0.0))[0]
    return Opening(
        goals=goals[[index[i] for i in keep]].astype(np.float32),
        actions=actions,
        poses=poses[keep][:, :T].astype(np.float32),
        length=np.asarray([len(s) for s in seqs], np.int32),
        marker=marker.astype(np.float32),
        seconds=time.perf_counter() - t0,
    )


__all__ = [
    "Opening",
    "Searched",
    "encircled",
    "first_goals",
    "needs_opening",
    "opening",
    "replay_all",
    "search",
    "search_problem",
]
