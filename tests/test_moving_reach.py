"""jaxnav.world.reach and ``jaxnav probe reach``: the bound on where a robot can get in
a stage whose cylinders spin about the origin, held against what is known of each
stage: the oracle drives stage3_humble's goals (0.99 in docs/baselines.md), so the
bound must let a robot at the burger's speed out there; a robot far slower than the
cylinders (0.1 m/s against their 0.42 m/s) is dragged into them before it crosses
stage 3's ring, and one faster than them crosses it."""

from __future__ import annotations

import pytest

from jaxnav.commands.probe import main as probe
from jaxnav.core.errors import MazeError
from jaxnav.world import reach
from jaxnav.world.maps import make_maze

COARSE = {"cell": 0.01, "dt": 0.25, "horizon": 60.0}  # still an over-approximation


def farthest(name: str, speed: float):
    return reach.farthest_reach(reach.spinning(make_maze(name), name), speed, **COARSE)


def test_a_slow_robot_cannot_cross_stage3s_ring():
    far, lo, hi, _ = farthest("stage3", 0.1)
    assert (lo, hi) == pytest.approx((0.849 - 0.28, 0.849 + 0.28), abs=1e-3)
    assert lo <= far < hi  # into the ring between its cylinders, never out of it


def test_speed_alone_does_not_rule_stage3_out_for_the_burger():
    far, _, hi, _ = farthest("stage3", reach.BURGER_SPEED)
    assert far > hi


def test_the_bound_lets_a_robot_out_where_the_oracle_drives():
    far, _, hi, _ = farthest("stage3_humble", reach.BURGER_SPEED)
    assert far > hi


def test_a_robot_faster_than_the_rim_gets_out_of_stage3():
    far, _, hi, _ = farthest("stage3", 0.6)  # the rim: 0.42 m/s
    assert far > hi


def test_a_stage_whose_cylinders_follow_paths_is_refused():
    with pytest.raises(MazeError, match="stage4: its cylinders do not all spin"):
        reach.spinning(make_maze("stage4"), "stage4")
    with pytest.raises(MazeError, match="square4: no moving obstacles"):
        reach.spinning(make_maze("square4"), "square4")


def test_the_command_says_the_verdict_of_each_stage(capsys):
    argv = ["--cell", "0.01", "--dt", "0.25", "--horizon", "60"]
    assert probe(["reach", "stage3", "stage3_humble", "--speed", "0.1", *argv]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(":")[0] for line in lines] == ["stage3", "stage3_humble"]
    far, lo, hi, t = farthest("stage3", 0.1)
    assert lines[0] == (
        f"stage3: a robot at up to 0.1 m/s in any direction reaches at most {far:.3f} m from "
        f"the centre (within {t:.0f} s); the cylinders' ring spans {lo:.3f}-{hi:.3f} m for "
        "the robot's centre: it cannot leave the ring: no goal beyond it is reachable"
    )


@pytest.mark.parametrize(
    "argv, message",
    [
        (["nowhere"], "unknown maze 'nowhere'"),
        (["stage3", "stage4"], "stage4: its cylinders do not all spin"),
        (["stage3", "--cell", "0"], "--cell must be positive"),
        (["stage3", "--speed", "-1"], "--speed must be 0 or more"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, message, capsys):
    assert probe(["reach", *argv]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # nothing of a first stage before the refusal of a second
    assert err.startswith("jaxnav probe reach: error: ") and err.count("\n") == 1
    assert message in err, err
