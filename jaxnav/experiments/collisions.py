"""What a run's policies collide with in their greedy test, and how.

For every collision of the test (each seed's ``episodes`` greedy episodes per test
maze, on the run's own test keys, as ``jaxnav evaluate`` plays them) it takes the
surface nearest the robot at the start of the colliding step: a wall (or a standing
cylinder) or a moving cylinder. For a moving cylinder it also says which of the two
closed the gap: the robot's closing speed is its driven speed along the line to the
cylinder's centre, the cylinder's is its velocity over the step before along the same
line, towards the robot; and where the cylinder stood: ahead of the robot (within 60
degrees of its heading), beside it (60 to 120) or behind it (beyond 120); and when: how
many steps into its goal attempt, and whether that attempt began at a goal reached or
at the episode's start; and how long before the collision the cylinder passed the last
waypoint of its loop (where it turns), beside the share of the loop's time that lies
that soon after a waypoint.

    jaxnav probe collisions runs/drive_stage4
    jaxnav probe collisions runs/drive_stage4 --maze stage4_humble --episodes 10

The moving stages' failures read this way: a policy that seldom touches a wall, hit
from the side by a cylinder it did not give way to, tells that what is left is the
moving cylinders, not the maze.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from jaxnav.experiments.evaluation import load_run
from jaxnav.experiments.rollout import padded_mazes, run_tests
from jaxnav.report.navigation import attempt_first_steps
from jaxnav.world.maps import make_maze

AHEAD, BEHIND = 60.0, 120.0  # degrees off the heading
WINDOW = 2.0  # s after a waypoint


@dataclass(frozen=True)
class Cause:
    """One collision: the surface nearest the robot at its step's start and, for a
    moving cylinder, who closed the gap and where the cylinder stood."""

    surface: str  # "wall" (walls and standing cylinders) or "moving"
    gap: float  # m, from the robot's centre to that surface
    robot_closing: float = 0.0  # m/s along the line to the cylinder
    cylinder_closing: float = 0.0  # m/s along the same line, towards the robot
    bearing: float = 0.0  # degrees of the cylinder off the robot's heading, in [0, 180]
    stopped: bool = False  # the robot's driven speed was 0
    into_attempt: int = 0  # steps of its goal attempt before the colliding one
    after_goal: bool = False  # the attempt began at a goal reached, not at the episode's start
    cylinder: int = -1  # which moving cylinder (its row in the maze's motion)
    since_waypoint: float = math.nan  # s since that cylinder passed its loop's last waypoint


def segment_gaps(pos: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """f64[S]: distance from ``pos`` (f[2]) to each segment (f[S, 4]: x1, y1, x2, y2)."""
    a, b = segments[:, :2], segments[:, 2:]
    ab = b - a
    t = np.clip(np.sum((pos - a) * ab, 1) / np.maximum(np.sum(ab * ab, 1), 1e-12), 0.0, 1.0)
    return np.linalg.norm(a + t[:, None] * ab - pos, axis=1)


def cause(
    pos: np.ndarray,
    yaw: float,
    speed: float,
    segments: np.ndarray,
    standing: np.ndarray,
    moving: np.ndarray,
    moving_before: np.ndarray | None,
    dt: float,
) -> Cause:
    """The cause of a collision in a step that starts at pose (``pos``, ``yaw``) and
    drives ``speed`` m/s: ``segments`` f[S, 4] the walls, ``standing`` f[C, 3] and
    ``moving`` f[M, 3] the cylinders (x, y, r) at the step's start, ``moving_before``
    the moving ones a step earlier (None at an episode's first step: no velocity)."""
    pos = np.asarray(pos, np.float64)
    wall = min(
        [math.inf]
        + list(segment_gaps(pos, np.asarray(segments, np.float64)))
        + list(np.linalg.norm(standing[:, :2] - pos, axis=1) - standing[:, 2])
    )
    if len(moving) == 0:
        return Cause("wall", wall, stopped=speed == 0.0)
    gaps = np.linalg.norm(moving[:, :2] - pos, axis=1) - moving[:, 2]
    k = int(np.argmin(gaps))
    if wall <= gaps[k]:
        return Cause("wall", wall, stopped=speed == 0.0)
    u = (moving[k, :2] - pos) / max(float(np.linalg.norm(moving[k, :2] - pos)), 1e-12)
    heading = np.array([math.cos(yaw), math.sin(yaw)])
    velocity = np.zeros(2) if moving_before is None else (moving[k, :2] - moving_before[k, :2]) / dt
    bearing = math.degrees(math.acos(float(np.clip(np.dot(u, heading), -1.0, 1.0))))
    return Cause(
        "moving",
        float(gaps[k]),
        cylinder=k,
        robot_closing=float(speed * np.dot(heading, u)),
        cylinder_closing=float(-np.dot(velocity, u)),
        bearing=bearing,
        stopped=speed == 0.0,
    )


def summary(causes: list[Cause]) -> dict[str, float]:
    """Counts and shares of a list of collisions' causes."""
    moving = [c for c in causes if c.surface == "moving"]
    out = {"collisions": len(causes), "wall": len(causes) - len(moving), "moving": len(moving)}
    if moving:
        out["cylinder closed faster"] = np.mean(
            [c.cylinder_closing > c.robot_closing for c in moving]
        )
        out["ahead"] = np.mean([c.bearing < AHEAD for c in moving])
        out["beside"] = np.mean([AHEAD <= c.bearing <= BEHIND for c in moving])
        out["behind"] = np.mean([c.bearing > BEHIND for c in moving])
        out["robot stopped"] = np.mean([c.stopped for c in moving])
        out["after a goal"] = np.mean([c.after_goal for c in moving])
        out["median steps into the attempt"] = float(np.median([c.into_attempt for c in moving]))
        ages = np.asarray([c.since_waypoint for c in moving])
        ages = ages[~np.isnan(ages)]  # loops that turn about a centre have no waypoints
        if len(ages):
            out["median s since a waypoint"] = float(np.median(ages))
            out["within 2 s of a waypoint"] = float(np.mean(ages <= WINDOW))
    return out


def waypoint_age(times: np.ndarray, period: float, time: float) -> float:
    """Seconds since a loop's cylinder passed its last waypoint at ``time`` s into the
    episode: ``times`` f[K] the loop's keyframe times (0 first, the period last)."""
    tau = time % period
    return float(tau - times[times <= tau].max())


def near_waypoint_share(times: np.ndarray, period: float, window: float) -> float:
    """The share of a loop's time that lies within ``window`` s after a waypoint."""
    legs = np.diff(np.unique(np.concatenate([times, [period]])))
    return float(np.minimum(legs, window).sum() / period)


def attempt_starts(reached: np.ndarray, episode: np.ndarray, r: int, t: int) -> tuple[int, bool]:
    """(steps of the attempt before step ``t`` of row ``r``, whether it began at a goal
    reached): an attempt begins at its episode's first step or after a goal, as the
    navigation metrics split them (:func:`jaxnav.report.navigation.attempt_first_steps`)."""
    k = int(np.flatnonzero(attempt_first_steps(episode[r, : t + 1], reached[r, : t + 1]))[-1])
    return t - k, bool(k > 0 and episode[r, k - 1] == episode[r, k])


def run_causes(
    run_dir: str, maze: str | None, episodes: int
) -> dict[str, tuple[list[Cause], float]]:
    """Each test maze's collisions (``maze``: only that one) in the run's greedy test,
    and the share of its waypoint loops' time within WINDOW s after a waypoint."""
    run = load_run(run_dir)
    names = [maze] if maze else list(run.config.run.test_mazes or [run.config.env.maze])
    dt = float(run.policies.env_params.dt)
    out = {}
    for name in names:
        res = run_tests(run.policies, padded_mazes([name]), episodes, record=True, navigation=True)
        tr, steps = res[0].trajectory, res[0].steps
        m = make_maze(name)
        n_moving = 0 if m.motion is None else int(m.motion.n)
        segments = np.asarray(m.walls(), np.float64)
        times = np.zeros((0, 1)) if m.motion is None else np.asarray(m.motion.times, np.float64)
        periods = np.zeros(0) if m.motion is None else np.asarray(m.motion.period, np.float64)
        spins = np.zeros(0) if m.motion is None else np.asarray(m.motion.spin, np.float64)
        found = []
        collided, episode = np.asarray(tr.collided), np.asarray(tr.episode)
        reached = np.asarray(tr.reached)
        speeds = np.asarray(steps.command)[..., 0]
        for r, t in zip(*np.nonzero(collided & (episode < episodes))):
            circles = np.zeros((0, 3)) if tr.circles is None else np.asarray(tr.circles[r, t])
            real = circles[:, 2] > 0
            standing = circles[: len(circles) - n_moving][real[: len(circles) - n_moving]]
            moving = circles[len(circles) - n_moving :]
            before = None
            if n_moving and t > 0 and episode[r, t - 1] == episode[r, t]:
                before = np.asarray(tr.circles[r, t - 1])[len(circles) - n_moving :]
            speed = float(speeds[r, t])
            c = cause(
                tr.pos[r, t], float(tr.yaw[r, t]), speed, segments, standing, moving, before, dt
            )
            into, after_goal = attempt_starts(reached, episode, r, t)
            c = dataclasses.replace(c, into_attempt=into, after_goal=after_goal)
            if c.surface == "moving" and spins[c.cylinder] == 0.0:  # time at the step's start
                t_in = t - int(np.flatnonzero(episode[r, : t + 1] == episode[r, t])[0])
                age = waypoint_age(times[c.cylinder], periods[c.cylinder], t_in * dt)
                c = dataclasses.replace(c, since_waypoint=age)
            found.append(c)
        out[name] = (found, base_share(times[spins == 0.0], periods[spins == 0.0]))
    return out


def base_share(times: np.ndarray, periods: np.ndarray) -> float:
    """The share of the loops' time within WINDOW s after a waypoint (mean over the
    cylinders; nan without moving cylinders)."""
    if not len(periods):
        return math.nan
    return float(np.mean([near_waypoint_share(x, p, WINDOW) for x, p in zip(times, periods)]))


def summary_line(name: str, causes: list[Cause], base: float) -> str:
    """One test maze's collisions (:func:`run_causes`' entry) as one line."""
    s = summary(causes)
    line = (
        f"{name}: {s['collisions']} collisions, {s['wall']} with a wall, "
        f"{s['moving']} with a moving cylinder"
    )
    if s["moving"]:
        line += (
            f"; of those the cylinder closed faster {s['cylinder closed faster']:.2f}, "
            f"it stood ahead {s['ahead']:.2f}, beside {s['beside']:.2f}, behind "
            f"{s['behind']:.2f}, the robot was stopped {s['robot stopped']:.2f}; "
            f"the attempt began at a goal reached {s['after a goal']:.2f}, the collision "
            f"came a median {s['median steps into the attempt']:.0f} steps into it"
        )
    if "median s since a waypoint" in s:
        line += (
            f"; a median {s['median s since a waypoint']:.1f} s after the cylinder passed "
            f"a waypoint of its loop, within {WINDOW:.0f} s of one "
            f"{s['within 2 s of a waypoint']:.2f} (of the loops' time {base:.2f})"
        )
    return line
