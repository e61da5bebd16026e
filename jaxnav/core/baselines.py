"""The reference drivers by name: what results files, tables and commands call them.

Their planners are :mod:`jaxnav.planners` (JAX); this module holds only their names,
labels and one line each, so the report, the configs and the command line can know
them without JAX. Their rows in results files carry the name in the ``strategy``
column, beside the learned policies' strategies.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Baseline:
    name: str
    label: str  # how tables and figures name it
    about: str


BASELINES = {
    b.name: b
    for b in (
        Baseline(
            "oracle",
            "oracle",
            "privileged planner: reads the map, the moving cylinders and the goal, simulates "
            "action sequences with the environment's own kinematics, never collides where "
            "it can help it (from a start inside turning cylinders it drives a way out "
            "found by a search in space and time); what the robot, its actions and its "
            "time limit allow",
        ),
        Baseline(
            "dwa",
            "DWA",
            "the dynamic window approach (Fox et al. 1997), the local planner of ROS "
            "move_base and Nav2: the scan and the goal only, no map (where the policies "
            "are given the maze's shortest path, env.waypoint, it follows that path too)",
        ),
    )
}


def names() -> tuple[str, ...]:
    return tuple(BASELINES)


def is_baseline(arm: str) -> bool:
    """Whether a results row's arm is a reference driver's."""
    return arm in BASELINES


def check(name: str) -> str:
    """``name`` if it is a reference driver, else a ValueError naming the choices."""
    if name not in BASELINES:
        raise ValueError(f"no baseline {name!r} (choose from {', '.join(BASELINES)})")
    return name
