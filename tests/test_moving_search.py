"""jaxnav.experiments.reachability and ``jaxnav probe search``: the search that proves a
moving stage's goals reachable.

Its witnesses are held against an independent NumPy replay of stage 3: the unicycle's
exact arc and the cylinders turned about the origin, sampled 400 times a step, walls
and cylinders measured by brute force. A witness must keep the robot's disc clear of
both all the way and end within the goal radius; a sequence that drives into the wall
must be refused by the environment's replay and collide in the NumPy one too."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jaxnav.commands.probe import main as probe
from jaxnav.experiments import reachability as search
from jaxnav.world import reach
from jaxnav.world.maps import make_maze

VW = ["env.actions=vw"]
ROBOT = 0.13  # m, the burger's disc
GOAL_RADIUS = 0.2


def _segment_distance(p: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Distance of each point p[N, 2] to its nearest wall segment (walls[S, 4])."""
    a, b = walls[None, :, :2], walls[None, :, 2:]
    ab = b - a
    t = np.clip(np.sum((p[:, None] - a) * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    return np.min(np.linalg.norm(p[:, None] - (a + t[..., None] * ab), axis=-1), axis=1)


def stage3_spinning() -> reach.Spinning:
    return reach.spinning(make_maze("stage3"), "stage3")


def numpy_replay(actions: list[int], goal: np.ndarray, substeps: int = 400, played=None):
    """(smallest clearance beyond the robot's radius over the whole drive, distance to
    the goal at the end) of ``actions`` of the vw set from stage 3's start at time 0,
    which stops where the robot first comes within the goal radius; ``played``, a list,
    gets the steps driven and the end position."""
    from jaxnav.core.settings import ACTION_SETS

    centres, radii, spin, _, start = stage3_spinning()
    walls = make_maze("stage3").walls().astype(np.float64)
    table = ACTION_SETS["vw"]
    x, y, yaw, time, dt = float(start[0]), float(start[1]), 0.0, 0.0, 0.2
    clearance = math.inf
    for a in actions:
        v, w = table[a]
        s = np.linspace(0.0, dt, substeps + 1)
        if abs(w) < 1e-9:
            px, py = x + v * s * math.cos(yaw), y + v * s * math.sin(yaw)
        else:
            px = x + v / w * (np.sin(yaw + w * s) - math.sin(yaw))
            py = y - v / w * (np.cos(yaw + w * s) - math.cos(yaw))
        path = np.stack([px, py], 1)
        ang = spin * (time + s)  # the body turns about the origin
        c, sn = np.cos(ang)[:, None], np.sin(ang)[:, None]
        cx = c * centres[None, :, 0] - sn * centres[None, :, 1]
        cy = sn * centres[None, :, 0] + c * centres[None, :, 1]
        d_cyl = np.hypot(px[:, None] - cx, py[:, None] - cy) - radii[None]
        d = min(float(d_cyl.min()), float(_segment_distance(path, walls).min()))
        clearance = min(clearance, d - ROBOT)
        x, y, yaw, time = float(px[-1]), float(py[-1]), yaw + w * dt, time + dt
        if math.hypot(x - goal[0], y - goal[1]) < GOAL_RADIUS:
            break
    if played is not None:
        played += [round(time / dt), np.array([x, y])]
    return clearance, math.hypot(x - goal[0], y - goal[1])


@pytest.fixture(scope="module")
def found():
    return search.search("stage3", VW, cell=0.05, headings=16, horizon=40)


@pytest.mark.slow  # 18 s on 2 cores
def test_stage3_goals_beyond_the_ring_are_reachable_with_a_stop_capable_set(found):
    centres, radii, *_ = stage3_spinning()
    hi = float(np.max(np.hypot(*centres.T) + radii)) + ROBOT  # the ring's outer edge
    assert len(found.goals) > 100
    assert np.all(np.hypot(*found.goals.T) >= 1.0)  # first goals: 1 m from the start
    assert len(found.reached) > 20
    assert found.proven == list(found.reached)  # every witness replays clean in the env
    beyond = [g for g in found.proven if np.hypot(*found.goals[g]) > hi]
    assert beyond, "a witness should reach past the cylinders' ring"


@pytest.mark.slow  # its fixture is a slow test's
def test_each_witness_stays_clear_in_an_independent_numpy_replay(found):
    for g in found.proven[::4]:
        clearance, distance = numpy_replay(found.reached[g], found.goals[g])
        assert clearance > -1e-4, (g, clearance)  # float32 in the env against float64 here
        assert distance < GOAL_RADIUS


def test_a_drive_into_the_wall_is_refused_by_both_replays():
    from jaxnav.core.config import load_config
    from jaxnav.env import from_config

    env, params = from_config(load_config("stage3", VW))
    straight = [12] * 40  # 0.22 m/s straight ahead for 8 s: 1.76 m east of the start
    goal = np.array([1.5, -1.5], np.float32)
    assert not search.replays(env, params, goal, straight)
    clearance, _ = numpy_replay(straight, goal)
    assert clearance < 0.0


def test_a_world_that_stands_still_is_one_line(capsys):
    assert probe(["search", "paper_no_obstacles", "--horizon", "2"]) == 2
    assert capsys.readouterr().err == "jaxnav probe search: error: square4: no moving obstacles\n"


@pytest.mark.parametrize(
    "argv, message",
    [
        (["stage3", "env.nope=1"], "unknown key 'env.nope'"),
        (["stage3", "--cell", "0"], "--cell must be positive"),
        (["nowhere.yaml"], "nowhere.yaml"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, message, capsys):
    assert probe(["search", *argv]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("jaxnav probe search: error: ")
    assert err.count("\n") == 1 and message in err, err


@pytest.mark.slow  # its fixture is a slow test's
def test_what_the_search_found_in_one_line(found, capsys):
    sec = np.asarray([len(found.reached[g]) for g in found.proven]) * 0.2
    assert search.found_line(found, 0.05, 16, 0) == (
        f"stage3 (vw actions): {len(found.proven)} of {len(found.goals)} first goals proven "
        f"reachable from the start (replayed in the environment, no collision), in "
        f"{sec.min():.1f}-{sec.max():.1f} s (median {np.median(sec):.1f} s); the search "
        f"reached {len(found.reached)}, {len(found.reached)} replayed (0.05 m x 16 headings "
        f"raster, at most {found.largest:,} states a step, {found.seconds:.0f} s)"
    )
    # the command, over a horizon too short to reach any goal: 1 m takes 5 steps at least
    argv = ["stage3", *VW, "--cell", "0.05", "--headings", "16", "--horizon", "2"]
    assert probe(["search", *argv]) == 0
    out = capsys.readouterr().out
    assert out.startswith(
        "stage3 (vw actions): no first goal proven reachable within 2 steps; the search "
        "reached 0, 0 replayed (0.05 m x 16 headings raster, at most "
    )
    assert out.endswith(" s)\n") and out.count("\n") == 1


# -- the oracle's way out of stage 3's ring (jaxnav.planners.search.opening) ---------


@pytest.fixture(scope="module")
def stage3_vw():
    from jaxnav.core.config import load_config
    from jaxnav.env import from_config

    return from_config(load_config("stage3", VW))


@pytest.fixture(scope="module")
def opening(stage3_vw):
    from jaxnav.planners.search import opening

    env, params = stage3_vw
    return opening(env, params, cell=0.05, headings=16, horizon=55)


def test_only_a_start_inside_turning_cylinders_needs_an_opening(stage3_vw):
    from jaxnav.core.config import load_config
    from jaxnav.env import from_config
    from jaxnav.planners.search import encircled, needs_opening

    assert encircled(make_maze("stage3")) and encircled(make_maze("stage3_humble"))
    assert not encircled(make_maze("stage4"))  # waypoint loops beside the start
    assert not encircled(make_maze("square4"))  # nothing moves
    assert needs_opening(*stage3_vw)
    paper = from_config(load_config("stage3"))  # five yaw rates at 0.15 m/s: no stop
    assert not needs_opening(*paper)
    drawn_pace = from_config(load_config("stage3", [*VW, "env.motion_pace=[0,1]"]))
    assert not needs_opening(*drawn_pace)


@pytest.mark.slow
def test_each_opening_enters_its_goal_once_at_its_end_where_the_robot_can_stand(opening):
    """In the NumPy replay: clear all the way, the goal radius first entered at the last
    action, and the cylinders, turned on for 3.2 s more, keep clear of the robot standing
    there (the search samples them 4 times a step, this 100 times)."""
    centres, radii, spin, _, _ = stage3_spinning()
    assert opening is not None and len(opening.goals) > 30
    for g in range(0, len(opening.goals), 7):
        actions = opening.actions[g, : opening.length[g]].tolist()
        played = []
        clearance, distance = numpy_replay(actions, opening.goals[g], played=played)
        steps, end = played
        assert clearance > -1e-4 and distance < GOAL_RADIUS
        assert steps == len(actions)  # not inside the goal radius before the last step
        times = steps * 0.2 + np.linspace(0.0, 3.2, 1601)
        c, s = np.cos(spin * times)[:, None], np.sin(spin * times)[:, None]
        cx = c * centres[None, :, 0] - s * centres[None, :, 1]
        cy = s * centres[None, :, 0] + c * centres[None, :, 1]
        gap = np.hypot(end[0] - cx, end[1] - cy) - radii[None] - ROBOT
        assert gap.min() > 0.02, (g, gap.min())  # the 0.03 m margin, less the sampling's


@pytest.mark.slow
def test_the_oracle_leaves_the_ring_on_an_opening_and_not_without(stage3_vw, opening):
    """From the start at ROBOTIS' pace the plain oracle finds no gap in the time the
    opening takes; with the opening it reaches the goal at the opening's last step."""
    import jax
    import jax.numpy as jnp

    from jaxnav.planners.oracle import Oracle
    from jaxnav.planners.raster import raster_for

    env, params = stage3_vw
    raster = raster_for([params.maze], 0.05)
    g = int(np.argmax(opening.length))  # the longest: its gap is the hardest to time
    goal = jnp.asarray(opening.goals[g])
    _, state0 = env.reset(jax.random.PRNGKey(3), params)
    state0 = state0.replace(goal=goal, goal_distance0=jnp.linalg.norm(goal - state0.pos))
    n = int(opening.length[g])

    def drive(oracle):
        plan, step = jax.jit(oracle.plan), jax.jit(env.step_env)
        state, memory, key = state0, oracle.start(params, state0), jax.random.PRNGKey(0)
        for i in range(n):
            action, memory = plan(memory, None, state, params)
            _, state, _, _, _, info = step(key, state, action, params)
            if bool(info["goal_reached"]) or bool(info["collision"]):
                return i + 1, bool(info["goal_reached"])
        return n, False

    assert drive(Oracle(env, raster, openings=(opening,))) == (n, True)
    assert drive(Oracle(env, raster)) == (n, False)


@pytest.mark.slow
def test_where_cylinders_outrun_the_robot_the_oracle_plans_a_whole_crossing(stage3_vw):
    """Stage 3's cylinders (0.5 rad/s on a 0.6 * sqrt(2) m orbit: 0.42 m/s) outrun the
    burger (0.22 m/s), stage 4's (at most 0.21 m/s) do not: only stage 3 gets the 4.2 s
    tree. With it the oracle crosses the ring mid-episode, inwards and outwards; with
    the 2.8 s tree it waits at the sweep's edge and reaches neither goal."""
    import jax
    import jax.numpy as jnp

    from jaxnav.core.config import load_config
    from jaxnav.env import from_config
    from jaxnav.planners.oracle import Oracle, holds_for
    from jaxnav.planners.raster import raster_for
    from jaxnav.world.motion import top_speed

    env, params = stage3_vw
    # by hand: 0.5 rad/s on stage 3's orbit; stage 4's fastest leg (docs: 0.07-0.21 m/s)
    assert top_speed(params.maze.motion) == pytest.approx(0.5 * 0.6 * math.sqrt(2), rel=1e-3)
    assert top_speed(make_maze("stage4").motion) == pytest.approx(0.21, abs=0.005)
    assert holds_for(env, params, [params.maze]) == (1, 20)
    for name, actions in (("stage4", "vw"), ("stage3", "paper"), ("square4", "vw")):
        other_env, other = from_config(
            load_config(None, [f"env.maze={name}", f"env.actions={actions}"])
        )
        assert holds_for(other_env, other, [other.maze]) is None, name

    raster = raster_for([params.maze], 0.05)
    _, state0 = env.reset(jax.random.PRNGKey(3), params)
    polar = lambda r, a: (r * math.cos(a), r * math.sin(a))  # noqa: E731
    crossings = [  # (start, heading, goal): into the ring from outside, and out of it
        (polar(1.25, 0.0), math.pi, polar(0.45, 2.0)),
        (polar(0.45, 2.0), 2.0, polar(1.4, 1.0)),
    ]

    def drive(oracle, start, heading, goal, n=60):
        plan, step = jax.jit(oracle.plan), jax.jit(env.step_env)
        goal = jnp.asarray(goal, jnp.float32)
        pos = jnp.asarray(start, jnp.float32)
        state = state0.replace(
            pos=pos, yaw=jnp.float32(heading), goal=goal, goal_distance0=jnp.linalg.norm(goal - pos)
        )
        memory, key = oracle.start(params, state), jax.random.PRNGKey(0)
        for _ in range(n):
            action, memory = plan(memory, None, state, params)
            _, state, _, _, _, info = step(key, state, action, params)
            if bool(info["collision"]):
                return "collision"
            if bool(info["goal_reached"]):
                return "goal"
        return "waiting"

    long_tree = Oracle(env, raster, holds=holds_for(env, params, [params.maze]))
    assert [drive(long_tree, *c) for c in crossings] == ["goal", "goal"]
    assert [drive(Oracle(env, raster), *c) for c in crossings] == ["waiting", "waiting"]
