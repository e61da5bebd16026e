"""scripts/moving_search.py: the search that proves a moving stage's goals reachable.

Its witnesses are held against an independent NumPy replay of stage 3: the unicycle's
exact arc and the cylinders turned about the origin, sampled 400 times a step, walls
and cylinders measured by brute force. A witness must keep the robot's disc clear of
both all the way and end within the goal radius; a sequence that drives into the wall
must be refused by the environment's replay and collide in the NumPy one too."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPTS = Path(__file__).resolve().parent.parent / "scripts"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


search = _load("moving_search")
reach = _load("moving_reach")

VW = ["env.actions=vw"]
ROBOT = 0.13  # m, the burger's disc
GOAL_RADIUS = 0.2


def _segment_distance(p: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Distance of each point p[N, 2] to its nearest wall segment (walls[S, 4])."""
    a, b = walls[None, :, :2], walls[None, :, 2:]
    ab = b - a
    t = np.clip(np.sum((p[:, None] - a) * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    return np.min(np.linalg.norm(p[:, None] - (a + t[..., None] * ab), axis=-1), axis=1)


def numpy_replay(actions: list[int], goal: np.ndarray, substeps: int = 400):
    """(smallest clearance beyond the robot's radius over the whole drive, distance to
    the goal at the end) of ``actions`` of the vw set from stage 3's start at time 0."""
    from jaxnav.core.settings import ACTION_SETS
    from jaxnav.world.maps import make_maze

    centres, radii, spin, _, start = reach.spinning("stage3")
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
    return clearance, math.hypot(x - goal[0], y - goal[1])


@pytest.fixture(scope="module")
def found():
    return search.search("stage3", VW, cell=0.05, headings=16, horizon=40)


def test_stage3_goals_beyond_the_ring_are_reachable_with_a_stop_capable_set(found):
    centres, radii, *_ = reach.spinning("stage3")
    hi = float(np.max(np.hypot(*centres.T) + radii)) + ROBOT  # the ring's outer edge
    assert len(found.goals) > 100
    assert np.all(np.hypot(*found.goals.T) >= 1.0)  # first goals: 1 m from the start
    assert len(found.reached) > 20
    assert found.proven == list(found.reached)  # every witness replays clean in the env
    beyond = [g for g in found.proven if np.hypot(*found.goals[g]) > hi]
    assert beyond, "a witness should reach past the cylinders' ring"


def test_each_witness_stays_clear_in_an_independent_numpy_replay(found):
    for g in found.proven[::4]:
        clearance, distance = numpy_replay(found.reached[g], found.goals[g])
        assert clearance > -1e-4, (g, clearance)  # float32 in the env against float64 here
        assert distance < GOAL_RADIUS


def test_a_drive_into_the_wall_is_refused_by_both_replays():
    import jax

    from jaxnav.core.config import load_config
    from jaxnav.env import from_config

    env, params = from_config(load_config("stage3", VW))
    straight = [12] * 40  # 0.22 m/s straight ahead for 8 s: 1.76 m east of the start
    goal = np.array([1.5, -1.5], np.float32)
    step_env = jax.jit(env.step_env)
    assert not search.replays(env, params, step_env, jax.random.PRNGKey(0), goal, straight)
    clearance, _ = numpy_replay(straight, goal)
    assert clearance < 0.0


def test_a_world_that_stands_still_is_one_line(capsys):
    assert search.main(["paper_no_obstacles", "--horizon", "2"]) == 2
    assert capsys.readouterr().err == "moving_search: square4: no moving obstacles\n"
