"""jaxnav.experiments.collisions and ``jaxnav probe collisions``: what a policy's test
collisions hit, by hand-built cases and against the test's own count of collisions."""

from __future__ import annotations

import numpy as np
import pytest
from _tiny_run import tiny_run

from jaxnav.commands.probe import main as probe
from jaxnav.experiments import collisions as causes

WALL = np.array([[0.2, -1.0, 0.2, 1.0]])  # x = 0.2, 0.2 m ahead of a robot at the origin
NONE = np.zeros((0, 3))
DT = 0.2


def test_the_nearest_surface_is_what_the_robot_hit():
    far = np.array([[0.0, 0.4, 0.12]])  # 0.28 m from the robot's centre: the wall is nearer
    c = causes.cause(np.zeros(2), 0.0, 0.0, WALL, NONE, far, far, DT)
    assert c.surface == "wall" and c.gap == pytest.approx(0.2)
    standing = np.array([[-0.25, 0.0, 0.1]])  # a standing cylinder counts as a wall
    c = causes.cause(np.zeros(2), 0.0, 0.0, WALL, standing, far, far, DT)
    assert c.surface == "wall" and c.gap == pytest.approx(0.15)


def test_a_cylinder_that_comes_at_a_still_robot_from_the_side_closed_the_gap():
    now, before = np.array([[0.0, 0.25, 0.12]]), np.array([[0.0, 0.29, 0.12]])
    c = causes.cause(np.zeros(2), 0.0, 0.0, WALL, NONE, now, before, DT)
    assert c.surface == "moving" and c.gap == pytest.approx(0.13)
    assert c.bearing == pytest.approx(90.0) and c.stopped
    assert c.cylinder_closing == pytest.approx(0.2) and c.robot_closing == 0.0


def test_a_robot_driving_into_a_cylinder_ahead_closed_the_gap():
    now = np.array([[0.0, 0.0, 0.12]])
    pos, yaw = np.array([-0.25, 0.0]), 0.0  # heading +x, the cylinder 0.25 m ahead
    c = causes.cause(pos, yaw, 0.22, NONE.reshape(0, 4), NONE, now, now, DT)
    assert c.bearing == pytest.approx(0.0) and not c.stopped
    assert c.robot_closing == pytest.approx(0.22) and c.cylinder_closing == pytest.approx(0.0)
    # the same cylinder behind a robot turned round, catching it up at 0.1 m/s
    before = np.array([[0.02, 0.0, 0.12]])
    c = causes.cause(pos, np.pi, 0.05, NONE.reshape(0, 4), NONE, now, before, DT)
    assert c.bearing == pytest.approx(180.0)
    assert c.robot_closing == pytest.approx(-0.05) and c.cylinder_closing == pytest.approx(0.1)
    # at an episode's first step there is no step before: no velocity
    c = causes.cause(pos, yaw, 0.22, NONE.reshape(0, 4), NONE, now, None, DT)
    assert c.cylinder_closing == 0.0


def test_the_summary_counts_and_shares():
    found = [
        causes.Cause("wall", 0.1),
        causes.Cause("moving", 0.1, 0.0, 0.2, 90.0, True),
        causes.Cause("moving", 0.1, 0.2, 0.0, 10.0, False),
        causes.Cause("moving", 0.1, 0.0, 0.1, 170.0, True),
    ]
    s = causes.summary(found)
    assert (s["collisions"], s["wall"], s["moving"]) == (4, 1, 3)
    assert s["cylinder closed faster"] == pytest.approx(2 / 3)
    assert (s["ahead"], s["beside"], s["behind"]) == pytest.approx((1 / 3, 1 / 3, 1 / 3))
    assert s["robot stopped"] == pytest.approx(2 / 3)


def test_how_long_since_a_cylinder_passed_a_waypoint_of_its_loop():
    # a loop of legs of 3, 5 and 2 s (period 10), padded with its last keyframe
    times = np.array([0.0, 3.0, 8.0, 10.0, 10.0])
    assert causes.waypoint_age(times, 10.0, 0.0) == 0.0
    assert causes.waypoint_age(times, 10.0, 4.5) == pytest.approx(1.5)
    assert causes.waypoint_age(times, 10.0, 9.0) == pytest.approx(1.0)
    assert causes.waypoint_age(times, 10.0, 23.5) == pytest.approx(0.5)  # 3.5 s into a lap
    # within 2 s after a waypoint: 2 of the first leg, 2 of the second, all 2 of the last
    assert causes.near_waypoint_share(times, 10.0, 2.0) == pytest.approx(0.6)
    found = [
        causes.Cause("moving", 0.1, since_waypoint=0.5),
        causes.Cause("moving", 0.1, since_waypoint=3.0),
        causes.Cause("moving", 0.1, since_waypoint=1.0),
        causes.Cause("moving", 0.1),  # a spun loop: no waypoints
    ]
    s = causes.summary(found)
    assert s["median s since a waypoint"] == pytest.approx(1.0)
    assert s["within 2 s of a waypoint"] == pytest.approx(2 / 3)


def test_an_attempt_begins_at_its_episode_or_after_a_goal():
    # one row: episode 0 reaches a goal at step 2; episode 1 begins at step 5
    reached = np.array([[0, 0, 1, 0, 0, 0, 0, 1, 0]], bool)
    episode = np.array([[0, 0, 0, 0, 0, 1, 1, 1, 1]])
    assert causes.attempt_starts(reached, episode, 0, 1) == (1, False)
    assert causes.attempt_starts(reached, episode, 0, 3) == (0, True)
    assert causes.attempt_starts(reached, episode, 0, 4) == (1, True)
    assert causes.attempt_starts(reached, episode, 0, 5) == (0, False)
    assert causes.attempt_starts(reached, episode, 0, 8) == (0, True)
    found = [
        causes.Cause("moving", 0.1, into_attempt=3, after_goal=True),
        causes.Cause("moving", 0.1, into_attempt=9, after_goal=False),
        causes.Cause("moving", 0.1, into_attempt=40, after_goal=True),
    ]
    s = causes.summary(found)
    assert s["after a goal"] == pytest.approx(2 / 3)
    assert s["median steps into the attempt"] == 9


@pytest.mark.slow  # 4 s on 2 cores
def test_every_collision_of_the_test_is_counted_once(tmp_path_factory, capsys):
    """The paper's tiny run tested on stage 3, whose cylinders spin round its start:
    every collision the test's episodes end in is found, each with a moving cylinder
    (stage 3's walls lie beyond the ring the cylinders sweep)."""
    from jaxnav.experiments.evaluation import load_run
    from jaxnav.experiments.rollout import padded_mazes, run_tests

    _, run_dir = tiny_run(tmp_path_factory)
    found = causes.run_causes(str(run_dir), "stage3", 3)["stage3"][0]
    res = run_tests(load_run(run_dir).policies, padded_mazes(["stage3"]), 3)[0]
    assert len(found) == int(np.asarray(res.collided).sum()) > 0  # one per episode, at most
    reach = 0.13 + DT * (0.15 + 0.43)  # the robot's radius and what both move in a step
    assert all(c.surface == "moving" and c.gap < reach for c in found)
    assert probe(["collisions", str(run_dir), "--maze", "stage3", "--episodes", "3"]) == 0
    out = capsys.readouterr().out
    n = len(found)
    assert out.startswith(f"stage3: {n} collisions, 0 with a wall, {n} with a moving cylinder")
    assert out == causes.summary_line("stage3", found, np.nan) + "\n"


@pytest.mark.parametrize(
    "argv, message",
    [
        (["{tmp}/none"], "run directory {tmp}/none does not exist"),
        (["{tmp}", "--episodes", "0"], "--episodes must be at least 1, got 0"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, message, tmp_path, capsys):
    argv = [a.format(tmp=tmp_path) for a in argv]
    assert probe(["collisions", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxnav probe collisions: error: ") and err.count("\n") == 1
    assert message.format(tmp=tmp_path) in err, err
