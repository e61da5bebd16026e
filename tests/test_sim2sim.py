"""Sim-to-sim: the burger in MuJoCo drives, sees and collides as jaxnav's robot does,
and the command writes its CSV and table."""

from __future__ import annotations

import csv
import io
import json
import math
import shutil
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

mujoco = pytest.importorskip(
    "mujoco",
    reason="MuJoCo is not installed (pip install mujoco): jaxnav sim2sim needs it",
)

from _tiny_run import tiny_run  # noqa: E402

from jaxnav.commands import sim2sim  # noqa: E402
from jaxnav.core.config import load_config  # noqa: E402
from jaxnav.env import from_config  # noqa: E402
from jaxnav.experiments.sim2sim import goals_of, task_of  # noqa: E402
from jaxnav.report.sim2sim_tables import SUMMARY_COLUMNS, gap_markdown  # noqa: E402
from jaxnav.robot import mujoco_model, mujoco_rollout  # noqa: E402
from jaxnav.robot.deploy import FORMAT, FORMAT_VERSION, Policy  # noqa: E402
from jaxnav.robot.mujoco_model import wheel_speeds  # noqa: E402
from jaxnav.robot.mujoco_rollout import Burger  # noqa: E402
from jaxnav.robot.scan import clean_ranges  # noqa: E402
from jaxnav.world.maps import make_maze  # noqa: E402
from jaxnav.world.reward import progress_reward, reward_fn  # noqa: E402
from jaxnav.world.sensor import lidar_scan  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
DT = 0.2


@pytest.fixture(scope="module")
def open_floor():
    """The burger in square8, whose walls are 3.7 m from its centre."""
    return Burger(make_maze("square8"))


def _drive(robot: Burger, v: float, omega: float, periods: int) -> np.ndarray:
    """f[periods + 1, 3] poses (x, y, unwrapped yaw) at each control period's end."""
    poses = [robot.pose()]
    for _ in range(periods):
        assert not robot.drive(v, omega, DT)
        poses.append(robot.pose())
    p = np.asarray(poses)
    p[:, 2] = np.unwrap(p[:, 2])
    return p


def test_wheel_speeds_are_the_differential_drive_inverse():
    left, right = wheel_speeds(0.15, 1.5)
    r, L = mujoco_model.WHEEL_RADIUS, mujoco_model.WHEEL_SEPARATION
    assert (right + left) * r / 2 == pytest.approx(0.15)
    assert (right - left) * r / L == pytest.approx(1.5)
    assert (left, right) == pytest.approx(((0.15 - 0.12) / 0.033, (0.15 + 0.12) / 0.033))


def test_the_burger_weighs_about_one_kilogram(open_floor):
    m = open_floor.model
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "burger")
    assert m.body_subtreemass[body] == pytest.approx(1.0, abs=0.01)


def test_driven_straight_it_moves_0_15_m_per_s(open_floor):
    """(0.15, 0): 0.03 m per 0.2 s period once rolling (the first period accelerates
    from rest), straight ahead, no turn."""
    open_floor.place(-3.0, 0.0, 0.0)
    p = _drive(open_floor, 0.15, 0.0, 10)
    step = np.diff(p[:, 0])
    assert 0.02 < step[0] < 0.03  # spinning up from rest
    np.testing.assert_allclose(step[1:], 0.15 * DT, rtol=0.02)
    assert np.abs(p[:, 1]).max() < 1e-4 and np.abs(p[:, 2]).max() < 1e-4


@pytest.mark.parametrize("omega", [1.5, -1.5])
def test_it_turns_at_about_the_commanded_rate(open_floor, omega):
    """(0.15, +-1.5) through wheel physics: the steady yaw rate within 5% of the command.

    Two losses are expected, both small: the flat 18 mm tyre touches the floor at both
    rims, so a turn scrubs them sideways, and the proportional servo lags its speed
    under that load (measured together: about 0.5% at 1.5 rad/s, 2% at 0.75 rad/s).
    5% leaves room for them and still fails a wrong wheel separation (10% off per 16
    mm), a wrong wheel radius or a wrong sign; left and right turns are mirror images.
    """
    open_floor.place(0.0, 0.0, 0.0)
    p = _drive(open_floor, 0.15, omega, 10)
    rate = np.diff(p[:, 2]) / DT
    assert np.sign(rate[0]) == np.sign(omega) and abs(rate[0]) < abs(omega)  # spin-up
    np.testing.assert_allclose(rate[2:].mean(), omega, rtol=0.05)
    assert rate[2:].std() < 0.05 * abs(omega)
    # The path is an arc of radius v / omega = 0.1 m (a least-squares circle fit).
    x, y = p[2:, 0], p[2:, 1]
    a, b, c = np.linalg.lstsq(np.stack([x, y, np.ones_like(x)], 1), x * x + y * y, rcond=None)[0]
    radius = np.sqrt(c + a * a / 4 + b * b / 4)
    assert radius == pytest.approx(0.15 / abs(omega), rel=0.05)
    assert np.hypot(x - a / 2, y - b / 2) == pytest.approx(radius, abs=1e-3)


@pytest.mark.parametrize(
    "maze", ["square4", "square4_obstacles", str(ROOT / "configs/mazes/corridor.yaml")]
)
def test_the_mujoco_lidar_agrees_with_jaxnavs_exact_lidar(maze):
    """Noise off, 360 rays from the LiDAR's site: the ray-cast boxes and cylinders give
    jaxnav's analytic ranges (walls, cylinders, and the corridor's L-shaped outline and
    box obstacle), to float32 precision."""
    m = make_maze(maze)
    robot = Burger(m)
    points = np.asarray(m.goal_points)[: int(m.n_goal_points)]
    rng = np.random.default_rng(0)
    worst = 0.0
    for i in rng.choice(len(points), 6, replace=False):
        robot.place(*points[i], rng.uniform(-math.pi, math.pi), settle=0)
        x, y, yaw = robot.lidar_pose()
        raw = robot.scan()
        mj = clean_ranges(raw, 0.12, 3.5)
        jx = np.asarray(lidar_scan(m, jnp.asarray([x, y]), jnp.asarray(yaw), 360))
        assert np.isposinf(raw[jx >= 3.5 - 1e-3]).all()  # no return within 3.5 m: inf
        worst = max(worst, float(np.abs(mj - jx).max()))
    assert worst < 1e-3


def test_the_lidar_sits_behind_the_axle_and_reports_inf_without_return(open_floor):
    open_floor.place(0.0, 0.0, 0.5, settle=0)
    x, y, yaw = open_floor.lidar_pose()
    assert (x, y, yaw) == pytest.approx((-0.032 * math.cos(0.5), -0.032 * math.sin(0.5), 0.5))
    assert np.isposinf(open_floor.scan()).all()  # square8's walls are 3.7 m or more away


def test_the_lidar_noise_is_gaussian_with_the_given_sigma():
    robot = Burger(make_maze("square4"))
    robot.place(0.0, 0.0, 0.0, settle=0)
    clean = robot.scan()
    rng = np.random.default_rng(1)
    err = np.concatenate([robot.scan(rng, 0.01) - clean for _ in range(20)])
    assert abs(err.mean()) < 0.001 and err.std() == pytest.approx(0.01, rel=0.1)


def test_driving_into_a_wall_is_a_contact_collision():
    """square2's wall is 0.925 m ahead; the chassis' front is 0.038 m ahead of the axle,
    so the contact comes after 0.887 m of driving, in period 30 at 0.15 m/s, not before."""
    robot = Burger(make_maze("square2"))
    robot.place(0.0, 0.0, 0.0)
    collided = [robot.drive(0.15, 0.0, DT) for _ in range(30)]
    assert collided == [False] * 29 + [True]
    assert robot.touching()
    front = robot.pose()[0] + (mujoco_model.CHASSIS_POS[0] + mujoco_model.CHASSIS_SIZE[0] / 2)
    assert front == pytest.approx(0.925, abs=0.003)


@pytest.mark.parametrize("preset", ["paper", "robotis"])
def test_the_numpy_reward_is_jaxnavs(preset):
    cfg = load_config(None, [f"preset={preset}"])
    task = task_of(cfg)
    _, params = from_config(cfg)
    rng = np.random.default_rng(2)
    for _ in range(60):
        a = int(rng.integers(5))
        heading, dist, d0 = rng.uniform(-4, 4), rng.uniform(0, 3), rng.uniform(0.1, 3)
        reached, collided = bool(rng.random() < 0.2), bool(rng.random() < 0.2)
        want = reward_fn(
            params, a, jnp.float32(heading), jnp.float32(dist), jnp.float32(d0), reached, collided
        )
        got = mujoco_rollout.reward(task, task.omegas[a], heading, dist, d0, reached, collided)
        assert got == pytest.approx(float(want), rel=1e-4, abs=1e-3)


def test_the_numpy_progress_reward_is_jaxnavs():
    # drive_obstacles' reward (progress, a step and a proximity penalty), with the
    # change penalty of the SAC configs on top
    cfg = load_config("drive_obstacles", ["env.change_penalty=0.3"])
    task = task_of(cfg)
    _, params = from_config(cfg)
    assert task.reward_kind == "progress" and task.proximity_penalty > 0
    rng = np.random.default_rng(5)
    for _ in range(60):
        before, after = rng.uniform(0, 3), rng.uniform(0, 3)
        clearance, change = rng.uniform(0.0, 0.6), rng.uniform(0, 2)
        reached, collided = bool(rng.random() < 0.2), bool(rng.random() < 0.2)
        want = progress_reward(
            params, jnp.float32(before), jnp.float32(after), jnp.float32(clearance),
            reached, collided, jnp.float32(change),
        )  # fmt: skip
        got = mujoco_rollout.progress_reward(
            task, before, after, clearance, change, reached, collided
        )
        assert got == pytest.approx(float(want), rel=1e-4, abs=1e-4)


def test_a_steps_clearance_is_its_nearest_approach_to_a_wall_or_cylinder():
    walls = np.array([[0.0, 1.0, 2.0, 1.0]])  # y = 1 from x = 0 to 2
    circles = np.array([[3.0, 0.0, 0.25]])
    a, b = np.array([0.5, 0.0]), np.array([0.5, 0.6])  # towards the wall
    assert mujoco_rollout.clearance_of((walls, circles), a, b) == pytest.approx(0.4)
    a, b = np.array([2.0, 0.0]), np.array([2.5, 0.0])  # towards the cylinder
    assert mujoco_rollout.clearance_of((walls, circles), a, b) == pytest.approx(0.25)
    assert mujoco_rollout.clearance_of(None, a, b) == float("inf")


def test_goals_are_drawn_from_the_mazes_goal_set_away_from_the_last():
    cfg = load_config(None, [])
    task = task_of(cfg)
    maze = make_maze("square4")
    goals = goals_of(maze, task)
    rng = np.random.default_rng(3)
    last = np.zeros(2)
    for _ in range(200):
        g = mujoco_rollout.draw_goal(rng, last, goals)
        assert (np.abs(goals.points - g).sum(axis=1) == 0).any()
        assert np.hypot(*(g - last)) >= task.goal_min_separation
        last = g
    robotis = goals_of(maze, task._replace(goal_sampler="robotis"))
    np.testing.assert_allclose(robotis.first, (0.6, 0.0))


def test_walls_are_boxes_behind_the_segments_on_the_side_away_from_free_space():
    m = make_maze(str(ROOT / "configs/mazes/corridor.yaml"))
    walls = m.walls().astype(np.float64)
    inward = mujoco_model.free_side_normals(walls)
    mid = (walls[:, :2] + walls[:, 2:]) / 2
    outline = len(walls) - 4  # the last 4 segments are the box obstacle's
    box_centre = np.array([0.8, 1.8])
    # Into the box obstacle's free surroundings: away from its centre.
    assert (np.sum((mid[outline:] - box_centre) * inward[outline:], axis=1) > 0).all()
    # The outline's free side is inside: the L's segment y = -0.8 faces +y, x = 1.6 faces -x.
    np.testing.assert_allclose(inward[0], (0.0, 1.0), atol=1e-12)
    np.testing.assert_allclose(inward[1], (-1.0, 0.0), atol=1e-12)


def _random_policy(obstacle_obs: bool = False, scale: float = 3.0) -> Policy:
    rng = np.random.default_rng(4)
    sizes = [24 + 2 + 2 * obstacle_obs, 64, 64, 5]
    layers = [
        (scale * rng.standard_normal((a, b)) / np.sqrt(a), np.zeros(b))
        for a, b in zip(sizes, sizes[1:])
    ]
    meta = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "n_beams": 24,
        "obstacle_obs": obstacle_obs,
        "min_range": 0.12,
        "max_range": 3.5,
        "omegas": [-1.5, -0.75, 0.0, 0.75, 1.5],
        "linear_velocity": 0.15,
    }
    return Policy(layers, json.loads(json.dumps(meta)))


def test_the_same_seed_plays_the_same_episodes():
    cfg = load_config(None, [])
    task = task_of(cfg)._replace(max_steps=25)
    maze = make_maze("square2")
    robot, goals = Burger(maze), goals_of(maze, task)
    policy, start = _random_policy(), np.asarray(maze.start)

    def play(seed):
        return mujoco_rollout.play(
            policy, robot, start, goals, task, 3, mujoco_rollout.sim_rng(seed, "square2")
        )

    a, b = play(0), play(0)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert len(a.ret) == 3 and (a.length <= 25).all()
    assert ((a.length == 25) | a.collided).all()


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return tiny_run(tmp_path_factory)


def test_the_command_writes_the_csv_and_the_gap_table(run, tmp_path, capsys):
    _, run_dir = run
    out = tmp_path / "gap.csv"
    argv = [str(run_dir), "--mazes", "square2", "--episodes", "1", "--seeds", "0"]
    assert sim2sim.main([*argv, "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert tuple(rows[0]) == SUMMARY_COLUMNS
    got = sorted((r["simulator"], r["strategy"], r["seed"], r["maze"]) for r in rows)
    want = sorted(
        (sim, s, "0", "square2") for sim in ("jaxnav", "mujoco") for s in ("ebe", "epsilon_greedy")
    )
    assert got == want
    mj = [r for r in rows if r["simulator"] == "mujoco"]
    assert all(r["episodes"] == "1" and 0 < float(r["length"]) <= 60 for r in mj)
    table = out.with_suffix(".md").read_text()
    assert "| EBE | return |" in table and "| square2 | epsilon-greedy |" in table
    title = table.splitlines()[0].removeprefix("# ")
    assert table.startswith(gap_markdown(out.read_text(), title))  # from the CSV alone


@pytest.mark.parametrize(
    "argv, words",
    [
        (["{missing}"], "no-such-run"),
        (["{run}", "--mazes", "nowhere"], "unknown maze 'nowhere'"),
        (["{run}", "--seeds", "7"], "no policy of seed 7"),
        (["{run}", "--episodes", "0"], "--episodes must be at least 1"),
        (["{run}", "--out", "{missing}/x.csv"], "does not exist"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(run, tmp_path, capsys, argv, words):
    _, run_dir = run
    fill = {"run": str(run_dir), "missing": str(tmp_path / "no-such-run")}
    assert sim2sim.main([a.format(**fill) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxnav sim2sim: error: ") and err.count("\n") == 1
    assert words in err


def test_an_existing_out_is_refused_before_any_work_unless_overwrite(
    run, tmp_path, capsys, monkeypatch
):
    """--out FILE: an existing FILE or FILE's .md table is refused, untouched, before
    anything is simulated; --overwrite replaces both."""
    from jaxnav.experiments import sim2sim as pipeline

    def simulate(*args, **kwargs):
        raise AssertionError("simulated before the output was checked")

    monkeypatch.setattr(pipeline, "jaxnav_results", simulate)
    monkeypatch.setattr(pipeline, "mujoco_results", simulate)
    _, run_dir = run
    out = tmp_path / "gap.csv"
    argv = [
        str(run_dir),
        "--mazes",
        "square2",
        "--episodes",
        "1",
        "--seeds",
        "0",
        "--out",
        str(out),
    ]
    for existing in (out, out.with_suffix(".md")):
        existing.write_text("earlier\n")
        assert sim2sim.main(argv) == 2
        err = capsys.readouterr().err
        assert (
            err == f"jaxnav sim2sim: error: {existing} exists already (--overwrite replaces it)\n"
        )
        assert existing.read_text() == "earlier\n"
        existing.unlink()

    one = mujoco_rollout.Episodes(np.ones(1), np.zeros(1), np.zeros(1, bool), np.full(1, 60))
    results = {("square2", s, 0): one for s in ("ebe", "epsilon_greedy")}
    monkeypatch.setattr(pipeline, "jaxnav_results", lambda *args: (results, "stub"))
    monkeypatch.setattr(pipeline, "mujoco_results", lambda *args, **kwargs: results)
    out.write_text("earlier\n")
    out.with_suffix(".md").write_text("earlier\n")
    assert sim2sim.main([*argv, "--overwrite"]) == 0
    assert tuple(next(csv.reader(out.open()))) == SUMMARY_COLUMNS
    assert out.with_suffix(".md").read_text().startswith("# Sim-to-sim gap of ")


@pytest.mark.slow
def test_the_reproduction_adds_the_sim_to_sim_gap_of_its_first_seeds(run, tmp_path):
    from jaxnav.experiments import reproduce

    cfg, src = run
    out = tmp_path / "repro"
    out.mkdir()
    shutil.copytree(src, out / "paper_no_obstacles", ignore=shutil.ignore_patterns("eval", "plots"))
    timings, section = reproduce._experiment(
        "paper_no_obstacles", "No obstacles", cfg, out, True, lambda _: None, sim_seeds=1
    )
    stages = [name for name, _, _ in timings]
    assert stages[-1] == "sim2sim paper_no_obstacles"
    text = "\n".join(section)
    assert "Sim-to-sim gap of paper_no_obstacles" in text and "MuJoCo" in text
    rows = list(csv.DictReader((out / "paper_no_obstacles" / "sim2sim" / "sim2sim.csv").open()))
    assert {r["seed"] for r in rows} == {str(cfg.seed)}  # the first seed only


def test_the_reproduction_says_at_once_when_mujoco_is_missing(monkeypatch, tmp_path, capsys):
    import importlib.util

    from jaxnav.commands import reproduce

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "mujoco" else real(name, *a)
    )
    out = tmp_path / "repro"
    assert reproduce.main(["--quick", "--out", str(out), "--sim2sim", "1", "--quiet"]) == 2
    assert "--sim2sim needs MuJoCo" in capsys.readouterr().err
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.slow  # 3 s on 2 cores
def test_a_continuous_policy_drives_the_burger_in_mujoco(tmp_path):
    """A SAC run's policies (continuous commands) through the same command."""
    from jaxnav.run.launch import train_new

    cfg = load_config(
        "smoke",
        [
            "preset=modern",
            "agent=sac",
            "strategies=[policy]",
            "env.actions=continuous",
            "seeds=1",
            "episodes=null",
            "total_steps=128",
            "env.max_steps=30",
            "sac.num_envs=4",
            "sac.batch_size=16",
            "sac.learning_starts=32",
            "sac.hidden=[16, 16]",
        ],
    )
    train_new(cfg, tmp_path / "run", quiet=True)
    out = tmp_path / "gap.csv"
    argv = [str(tmp_path / "run"), "--mazes", "square2", "--episodes", "1", "--out", str(out)]
    assert sim2sim.main(argv) == 0
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert sorted((r["simulator"], r["strategy"]) for r in rows) == [
        ("jaxnav", "policy"),
        ("mujoco", "policy"),
    ]
