"""scripts/moving_reach.py: the bound on where a robot can get in a stage whose
cylinders spin about the origin, held against what is known of each stage: the oracle
drives stage3_humble's goals (0.99 in docs/baselines.md), so the bound must let a robot
at the burger's speed out there; a robot far slower than the cylinders (0.1 m/s against
their 0.42 m/s) is dragged into them before it crosses stage 3's ring, and one faster
than them crosses it."""

from __future__ import annotations

import pytest
from _scripts import load_script

reach = load_script("moving_reach")

COARSE = {"cell": 0.01, "dt": 0.25, "horizon": 60.0}  # still an over-approximation


def test_a_slow_robot_cannot_cross_stage3s_ring():
    far, lo, hi, _ = reach.farthest_reach("stage3", 0.1, **COARSE)
    assert (lo, hi) == pytest.approx((0.849 - 0.28, 0.849 + 0.28), abs=1e-3)
    assert lo <= far < hi  # into the ring between its cylinders, never out of it


def test_speed_alone_does_not_rule_stage3_out_for_the_burger():
    far, _, hi, _ = reach.farthest_reach("stage3", reach.BURGER_SPEED, **COARSE)
    assert far > hi


def test_the_bound_lets_a_robot_out_where_the_oracle_drives():
    far, _, hi, _ = reach.farthest_reach("stage3_humble", reach.BURGER_SPEED, **COARSE)
    assert far > hi


def test_a_robot_faster_than_the_rim_gets_out_of_stage3():
    far, _, hi, _ = reach.farthest_reach("stage3", 0.6, **COARSE)  # the rim: 0.42 m/s
    assert far > hi


def test_a_stage_whose_cylinders_follow_paths_is_refused():
    with pytest.raises(SystemExit, match="stage4: its cylinders do not all spin"):
        reach.spinning("stage4")
    with pytest.raises(SystemExit, match="unknown maze 'nowhere'"):
        reach.spinning("nowhere")
