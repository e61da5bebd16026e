"""The test protocol: greedy, consecutive episodes in the training env; the tables."""

import csv
import io
import shutil
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _tiny_run import tiny_run

from jaxnav.agent.exploration import ebe, epsilon_greedy, epsilon_schedule
from jaxnav.commands.evaluate import main
from jaxnav.experiments.evaluation import evaluate, evaluate_to_dir, load_run
from jaxnav.experiments.rollout import eval_keys, padded_mazes, run_tests
from jaxnav.report import stats
from jaxnav.report.results import RESULT_COLUMNS
from jaxnav.report.tables import tables_markdown

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return tiny_run(tmp_path_factory)


@pytest.fixture(scope="module")
def evaluated(run):
    cfg, out = run
    evaluate_to_dir(out)
    return cfg, out


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_evaluation_covers_every_run_maze_and_episode(evaluated):
    cfg, out = evaluated
    rows = _rows(out / "eval" / "results.csv")
    assert tuple(rows[0]) == RESULT_COLUMNS
    per_mode = cfg.n_runs * len(cfg.run.test_mazes) * cfg.run.test_episodes
    # the greedy test: the policies, then the oracle and DWA once per seed
    per_driver = cfg.seeds * len(cfg.run.test_mazes) * cfg.run.test_episodes
    assert len(rows) == 2 * per_mode + 2 * per_driver
    greedy = rows[: per_mode + 2 * per_driver]
    assert [r["mode"] for r in rows[:: per_mode + 2 * per_driver]] == ["greedy", "exploring"]
    assert [r["maze"] for r in rows[: per_mode : cfg.n_runs * cfg.run.test_episodes]] == list(
        cfg.run.test_mazes
    )
    assert {(r["strategy"], r["seed"]) for r in rows} == {
        (s, str(k)) for s in (*cfg.strategies, "oracle", "dwa") for k in range(cfg.seeds)
    }
    assert {r["strategy"] for r in rows if r["mode"] == "exploring"} == set(cfg.strategies)
    assert [r["strategy"] for r in greedy[per_mode::per_driver]] == ["oracle", "dwa"]
    for r in rows:
        length, collided = int(r["length"]), int(r["collided"])
        assert 1 <= length <= cfg.env.max_steps
        # an episode ends early only by a collision
        assert (length < cfg.env.max_steps) <= bool(collided)
        assert int(r["goals"]) >= 0 and np.isfinite(float(r["return"]))
    assert (out / "eval" / "tables.md").is_file() and (out / "eval" / "trajectories.npz").is_file()


@pytest.mark.slow
def test_tables_are_recomputed_from_results_csv(evaluated):
    cfg, out = evaluated
    text = (out / "eval" / "results.csv").read_text()
    tables = (out / "eval" / "tables.md").read_text()
    assert (
        tables_markdown(text, cfg.env.maze, cfg.seed, title=f"Test results of {out.name}") == tables
    )
    rows = [r for r in csv.DictReader(io.StringIO(text)) if r["mode"] == "greedy"]
    lines = tables.split("## Test mode: exploring")[0].splitlines()

    def returns(maze, strategy, seed):
        return [
            float(r["return"])
            for r in rows
            if (r["maze"], r["strategy"], int(r["seed"])) == (maze, strategy, seed)
        ]

    for maze in cfg.run.test_mazes:
        # paper form, seed 0: mean ± std over the test episodes
        cells = [
            f"{np.mean(returns(maze, s, 0)):.2f} ± {np.std(returns(maze, s, 0)):.2f}"
            for s in cfg.strategies
        ]
        # the policies' columns, then the oracle's and DWA's
        assert any(line.startswith(f"| {maze} | {cells[0]} | {cells[1]} | ") for line in lines)
        # across seeds: mean of the per-seed means, the IQM and the pooled rates
        for s, name in (("ebe", "EBE"), ("epsilon_greedy", "epsilon-greedy")):
            per_seed = [np.mean(returns(maze, s, k)) for k in range(cfg.seeds)]
            mine = [r for r in rows if r["maze"] == maze and r["strategy"] == s]
            goals = np.mean([float(r["goals"]) for r in mine])
            coll = np.mean([float(r["collided"]) for r in mine])
            row = next(line for line in lines if line.startswith(f"| {maze} | {name} | "))
            cells = [c.strip() for c in row.strip("|").split("|")]
            assert cells[2].startswith(f"{np.mean(per_seed):.1f} [")
            assert cells[3].startswith(f"{stats.iqm(per_seed):.1f} [")
            assert cells[4:] == [f"{goals:.2f}", f"{coll:.2f}"]
        p = stats.probability_of_improvement(
            [np.mean(returns(maze, "ebe", k)) for k in range(cfg.seeds)],
            [np.mean(returns(maze, "epsilon_greedy", k)) for k in range(cfg.seeds)],
        )
        assert any(line.startswith(f"| {maze} | {p:.2f} [") for line in lines)
    # the paper's Table 3 beside ours
    assert "Table 3" in tables
    assert any(line.startswith("| square4 | 4x4 Square | 3731.92 ± 368.35 |") for line in lines)
    assert any(line.startswith("| square2 | 2x2 Square | 4369.64 ± 935.56 |") for line in lines)


@pytest.mark.slow  # 7 s on 2 cores
def test_rollout_plays_consecutive_greedy_episodes_like_a_step_loop(run):
    """The scan against a plain loop over env.step: argmax Q, auto-reset keeps the goal."""
    cfg, out = run
    loaded = load_run(out)
    mazes = padded_mazes(cfg.run.test_mazes)  # as evaluate() does: no new compile
    m = list(cfg.run.test_mazes).index("square2")
    n_eps = cfg.run.test_episodes
    res = run_tests(loaded.policies, mazes, n_eps, record=True)[m]
    maze = mazes[m]
    params = jax.tree.map(lambda x: x[0], loaded.policies.params)
    env_params = loaded.policies.env_params.replace(maze=maze)
    step = jax.jit(loaded.policies.env.step)
    q_fn = jax.jit(loaded.policies.network.apply)

    k_reset, key = jax.random.split(eval_keys(loaded.policies.labels[:1])[0])
    obs, state = loaded.policies.env.reset(k_reset, env_params)
    first_goal = np.asarray(state.goal)
    episodes, ret, goals, t = [], 0.0, 0, 0
    while len(episodes) < n_eps:
        key, k = jax.random.split(key)
        action = int(jnp.argmax(q_fn(params, obs)))
        obs, state, r, term, trunc, info = step(k, state, jnp.int32(action), env_params)
        ret, goals, t = ret + float(r), goals + int(info["goal_reached"]), t + 1
        if bool(term | trunc):
            episodes.append((ret, goals, bool(term), t))
            if goals == 0:  # the goal is kept across the reset
                np.testing.assert_array_equal(np.asarray(state.goal), first_goal)
            np.testing.assert_array_equal(np.asarray(state.pos), np.asarray(maze.start[:2]))
            ret, goals, t = 0.0, 0, 0
    for e, (r, g, c, n) in enumerate(episodes):
        assert res.ret[0, e] == pytest.approx(r, rel=1e-5, abs=1e-3)
        assert (res.goals[0, e], bool(res.collided[0, e]), res.length[0, e]) == (g, c, n)
    tr = res.trajectory
    assert tr.pos.shape == (cfg.n_runs, n_eps * cfg.env.max_steps, 2)
    np.testing.assert_array_equal(tr.pos[0, 0], np.asarray(maze.start[:2]))
    np.testing.assert_array_equal(tr.episode[0, : res.length[0, 0]], 0)


def test_exploring_test_acts_as_each_strategy_at_the_end_of_training(run):
    """The exploring test mode against a step loop calling ebe() and epsilon_greedy():
    EBE explores with probability H(s), epsilon-greedy with its last epsilon."""
    cfg, out = run
    loaded = load_run(out)
    mazes = padded_mazes(cfg.run.test_mazes)
    pol = loaded.policies
    res = run_tests(pol, mazes[:1], 1, mode="exploring")[0]
    env_params = pol.env_params.replace(maze=mazes[0])
    step = jax.jit(pol.env.step)
    q_fn = jax.jit(pol.network.apply)
    eps = float(epsilon_schedule(jnp.int32(cfg.episodes), 1.0, 0.99, 0.05))
    explored = 0
    for r, (strategy, _) in enumerate(pol.labels):
        params = jax.tree.map(lambda x, r=r: x[r], pol.params)
        k_reset, key = jax.random.split(eval_keys(pol.labels[r : r + 1])[0])
        obs, state = pol.env.reset(k_reset, env_params)
        ret, done = 0.0, False
        while not done:
            key, k = jax.random.split(key)
            q = q_fn(params, obs)
            k_act = jax.random.fold_in(k, 1)
            if strategy == "ebe":
                action, _ = ebe(k_act, q, cfg.exploration.ebe_temperature)
            else:
                action, _ = epsilon_greedy(k_act, q, eps)
            explored += int(action) != int(jnp.argmax(q))
            obs, state, rew, term, trunc, _ = step(k, state, jnp.int32(action), env_params)
            ret, done = ret + float(rew), bool(term | trunc)
        assert res.ret[r, 0] == pytest.approx(ret, rel=1e-5, abs=1e-3), strategy
    assert explored > 0  # the mode really explores


MAZE_WITH_A_CYLINDER = """\
outline: [[-1.5, -1.5], [1.5, -1.5], [1.5, 1.5], [-1.5, 1.5], [-1.5, -1.5]]
obstacles:
  - circle: [0.8, 0.8, 0.15]
"""


@pytest.mark.slow
def test_evaluation_on_two_mazes_by_name_and_file(run, tmp_path):
    """A maze YAML path works like a name, and a policy trained without obstacles keeps
    its 26-value observation on a maze with an obstacle."""
    cfg, out = run
    maze_file = tmp_path / "cylinder.yaml"
    maze_file.write_text(MAZE_WITH_A_CYLINDER)
    argv = [
        str(out),
        "--mazes",
        "pentagon",
        str(maze_file),
        "--episodes",
        "2",
        "--out",
        str(tmp_path / "e"),
        "--no-baselines",
    ]
    assert main(argv) == 0
    rows = _rows(tmp_path / "e" / "results.csv")
    assert len(rows) == 2 * (2 * cfg.n_runs * 2)  # two test modes, the policies alone
    mazes = [r["maze"] for r in rows[:: 2 * cfg.n_runs]]
    assert mazes == ["pentagon", str(maze_file)] * 2
    tables = (tmp_path / "e" / "tables.md").read_text()
    assert (
        "| pentagon | 4x4" not in tables and "| pentagon | Pentagon | 2794.04 ± 544.07 |" in tables
    )
    assert load_run(out).policies.env.obstacle_obs is False
    assert not (out / "eval" / "cylinder").exists()


@pytest.mark.slow  # 45 s on 2 cores
def test_same_run_same_results(evaluated):
    _, out = evaluated
    assert evaluate(out)[2] == (out / "eval" / "results.csv").read_text()


def _copy_run(src: Path, dst: Path, params: bool = True) -> Path:
    dst.mkdir()
    shutil.copy(src / "config.yaml", dst / "config.yaml")
    if params:
        shutil.copy(src / "params.npz", dst / "params.npz")
    return dst


@pytest.mark.parametrize(
    "case, message",
    [
        ("missing", "does not exist"),
        ("no_params", "has no params.npz"),
        ("corrupt_params", "cannot be read"),
        ("unknown_maze", "unknown maze 'nowhere'"),
        ("setting_after_mazes", "'env.goal_radius=1.0' is a setting, not a maze"),
        ("broken_maze", "not closed"),
        ("zero_episodes", "at least 1"),
        ("not_env_setting", "other environment settings only"),
        ("unreadable_setting", "does not match the network"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(run, case, message, tmp_path, capsys):
    _, src = run
    d = tmp_path / "run"
    argv = [str(d)]
    if case == "missing":
        pass
    elif case == "no_params":
        _copy_run(src, d, params=False)
    elif case == "corrupt_params":
        _copy_run(src, d, params=False)
        (d / "params.npz").write_bytes(b"PK\x03\x04 this is not a zip")
    else:
        _copy_run(src, d)
        if case == "unknown_maze":
            argv += ["--mazes", "nowhere"]
        elif case == "setting_after_mazes":  # --mazes takes every word after it
            argv += ["--mazes", "square4", "env.goal_radius=1.0"]
        elif case == "not_env_setting":
            argv += ["dqn.lr=0.1"]
        elif case == "unreadable_setting":  # 12 beams: an observation the network never read
            argv += ["env.n_beams=12"]
        elif case == "broken_maze":
            bad = tmp_path / "bad.yaml"
            bad.write_text("outline: [[0, 0], [1, 0], [1, 1]]\n")
            argv += ["--mazes", "square2", str(bad)]
        else:
            argv += ["--episodes", "0"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and "Traceback" not in err
    assert not (d / "eval").exists()  # nothing half-written


def test_outputs_are_checked_before_the_test_starts(run, tmp_path, capsys, monkeypatch):
    """An existing result file needs --overwrite, a file is no output folder, a missing
    parent folder is refused: each in one line before anything is tested."""
    import jaxnav.commands.evaluate as command

    _, src = run
    tested = []

    def evaluate_to_dir(*a, references=(), say=None, overrides=()):
        tested.append(a)
        Path(a[3]).mkdir(exist_ok=True)
        (Path(a[3]) / "results.csv").write_text("strategy,seed,mode\n")  # no episodes
        return Path(a[3])

    monkeypatch.setattr(command, "evaluate_to_dir", evaluate_to_dir)
    monkeypatch.setattr(
        command, "robustness_to_dir", lambda *a, say=None: tested.append(a) or Path(a[3])
    )
    full = tmp_path / "full"
    full.mkdir()
    (full / "results.csv").write_text("mine")
    (full / "robustness.md").write_text("mine")
    a_file = tmp_path / "file"
    a_file.write_text("mine")
    for out, extra, message in (
        (full, [], f"{full / 'results.csv'} exists already (--overwrite replaces it)"),
        (full, ["--robustness"], f"{full / 'robustness.md'} exists already"),
        (a_file, [], f"{a_file} exists and is not a folder"),
        (tmp_path / "no" / "e", [], f"the folder {tmp_path / 'no'} does not exist"),
    ):
        assert main([str(src), "--out", str(out), *extra]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    assert not tested and (full / "results.csv").read_text() == "mine"
    capsys.readouterr()
    assert main([str(src), "--out", str(full), "--overwrite"]) == 0
    assert main([str(src), "--out", str(tmp_path / "new")]) == 0  # a new folder needs nothing
    assert len(tested) == 2


@pytest.mark.slow
def test_evaluate_ends_with_trains_table_per_test_mode(run, tmp_path, capsys):
    """Per test mode and strategy: seeds, return, goals, collisions, each a mean over
    seeds with its interval, in the table train prints (report.tables.outcome_text)."""
    from jaxnav.report.nav_tables import navigation_text
    from jaxnav.report.tables import outcome_text

    cfg, out = run
    assert main([str(out), "--out", str(tmp_path / "e")]) == 0
    printed = capsys.readouterr().out
    rows = _rows(tmp_path / "e" / "results.csv")
    mazes = ", ".join(cfg.run.test_mazes)
    tail = printed.split("\n", 1)[1]  # after the "wrote ..." line
    expected = ""
    for mode in ("greedy", "exploring"):
        mine = [r for r in rows if r["mode"] == mode]
        expected += f"{mode} test on {mazes}, every test episode of each seed, mean over seeds"
        expected += f" [95% CI]:\n{outcome_text(mine)}\n"
        expected += "per goal attempt, every attempt of each seed, mean over seeds [95% CI]:\n"
        expected += f"{navigation_text(mine)}\n"
    assert tail == expected
    header, ebe, eps, oracle, dwa = outcome_text(
        [r for r in rows if r["mode"] == "greedy"]
    ).splitlines()
    assert (oracle.split()[0], dwa.split()[0]) == ("oracle", "dwa")
    assert (
        header.split()
        == "strategy seeds return goals per episode share ending in a collision".split()
    )
    per_seed = [
        np.mean(
            [
                float(r["return"])
                for r in rows
                if (r["mode"], r["strategy"], r["seed"]) == ("greedy", "ebe", str(k))
            ]
        )
        for k in range(cfg.seeds)
    ]
    iv = stats.mean_ci(per_seed)
    assert ebe.split()[:2] == ["ebe", str(cfg.seeds)]
    assert f"{iv.value:.0f} [{iv.low:.0f}, {iv.high:.0f}]" in ebe
    assert eps.split()[0] == "epsilon_greedy"


@pytest.mark.slow
def test_results_count_every_goal_attempt_of_every_episode(evaluated):
    """Each episode's attempts tile its steps: its goals are its successes (the attempt
    limit is the episode's), it ends in a collision, a time-out (an attempt spanning the
    whole episode) or a cut attempt (unless its last step reached a goal); the path
    driven over its decided attempts is at most its length times v dt."""
    cfg, out = evaluated
    rows = _rows(out / "eval" / "results.csv")
    step_m, dt = 0.15 * 0.2, 0.2
    columns = ("attempts", "successes", "timeouts", "collisions", "cut", "collided", "goals")
    for r in rows:
        n = {c: float(r[c]) for c in columns}
        assert n["successes"] == n["goals"] and n["collisions"] == n["collided"]
        assert n["attempts"] == n["successes"] + n["collided"] + n["timeouts"] + n["cut"]
        assert n["collided"] + n["timeouts"] + n["cut"] <= 1
        assert n["timeouts"] == (int(r["length"]) == cfg.env.max_steps and n["goals"] == 0)
        assert float(r["path_m"]) <= int(r["length"]) * step_m + 1e-4
        assert float(r["drive_s"]) == pytest.approx(int(r["length"]) * dt, abs=1e-4)
        assert 0 <= float(r["spl_sum"]) <= n["successes"] + 1e-9
        assert 0 <= float(r["time_s"]) <= int(r["length"]) * dt + 1e-4
    tables = (out / "eval" / "tables.md").read_text()
    header = "| maze | strategy | success | collision | timeout | cut | path_length_m | spl |"
    assert header in tables


def test_a_run_with_no_test_mazes_is_refused_unless_its_mazes_are_drawn():
    from types import SimpleNamespace

    from jaxnav.core.errors import JaxnavError
    from jaxnav.experiments.evaluation import test_setup

    def run(generator):
        env = SimpleNamespace(generator=generator)
        return SimpleNamespace(
            config=SimpleNamespace(env=env, run=SimpleNamespace(test_episodes=3))
        )

    with pytest.raises(JaxnavError, match="no test mazes"):
        test_setup(run(""), None, None, [])
    assert test_setup(run("grid"), None, None, []) == ([], 3)  # its train and test splits


def test_a_drawn_test_draws_a_new_layout_every_episode_whatever_training_kept():
    import dataclasses

    from jaxnav.core.config import load_config
    from jaxnav.env import from_config
    from jaxnav.experiments.evaluation import drawn_policies

    cfg = load_config("cylinders", ["env.new_maze_every=10"])
    env, params = from_config(cfg)
    assert env.new_maze_every == 10

    class Run:  # what drawn_policies reads of a loaded run
        config = cfg
        policies = type("P", (), {"_replace": lambda self, **k: k})()

    drawn = drawn_policies(Run(), "test")
    assert drawn["env"].new_maze_every == 1 and drawn["env"].split == "test"
    assert dataclasses.replace(drawn["env"], new_maze_every=10, split="train") == env


@pytest.mark.slow  # its fixture is a slow test's
def test_the_failure_map_holds_every_failed_greedy_attempt_of_results_csv(evaluated, tmp_path):
    """failures.npz's points, per maze and arm, are results.csv's greedy collisions and
    time-outs, one point each; a collision's point is within reach of a wall (the pose
    it collided from); the map is drawn."""
    from jaxnav.report.plots import plot_failure_maps
    from jaxnav.report.results import read_failures_npz
    from jaxnav.world.maps import clearance, make_maze

    cfg, out = evaluated
    failures, seeds, episodes = read_failures_npz(out / "eval" / "failures.npz")
    assert seeds == cfg.seeds and episodes == cfg.run.test_episodes
    rows = [r for r in _rows(out / "eval" / "results.csv") if r["mode"] == "greedy"]
    assert set(failures) == set(cfg.run.test_mazes)
    for maze, per_arm in failures.items():
        for arm, points in per_arm.items():
            mine = [r for r in rows if r["maze"] == maze and r["strategy"] == arm]
            assert len(points["collision"]) == sum(int(r["collisions"]) for r in mine)
            assert len(points["timeout"]) == sum(int(r["timeouts"]) for r in mine)
            m = make_maze(maze)
            if len(points["collision"]):  # one step (at most v dt + radius) from a surface
                near = clearance(points["collision"], m.walls(), m.obstacles())
                assert near.max() < 0.15 * 0.2 + 0.13 + 1e-3
    maps = plot_failure_maps(out, tmp_path)
    assert [p.name for p in maps] == [f"failures_{m}.png" for m in failures]


@pytest.mark.parametrize("robustness", [False, True])
def test_evaluate_says_what_it_tests_where_a_person_watches(
    robustness, tmp_path, capsys, monkeypatch
):
    """A test of a run takes up to a minute: a line before each part of it on a
    terminal (none where stderr is piped, so an interrupted evaluate ends in one line)."""
    import sys

    import jaxnav.commands.evaluate as command
    from jaxnav.core import rundir
    from jaxnav.core.config import dump_config, load_config

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / rundir.CONFIG).write_text(dump_config(load_config("smoke")))
    (run_dir / rundir.PARAMS).write_bytes(b"")

    def tested(run_dir, mazes, episodes, out, references=(), say=None, **_):
        if say is not None:
            say("testing 4 policies on square4")
        Path(out).mkdir(exist_ok=True)
        (Path(out) / "results.csv").write_text("strategy,seed,mode\n")
        return Path(out)

    monkeypatch.setattr(command, "evaluate_to_dir", tested)
    monkeypatch.setattr(command, "robustness_to_dir", tested)
    argv = [str(run_dir), "--out", str(tmp_path / "eval")] + ["--robustness"] * robustness
    for terminal in (False, True):
        monkeypatch.setattr(sys.stderr, "isatty", lambda t=terminal: t)
        assert command.main([*argv, "--overwrite"]) == 0
        err = capsys.readouterr().err
        assert err == ("testing 4 policies on square4 ...\n" if terminal else ""), err


@pytest.mark.slow
def test_a_run_is_tested_in_other_environment_settings_when_asked(run, tmp_path):
    """env.random_start=true starts the first test episode away from the start pose the
    run trained from; the tables' title names the setting; nothing else changes."""
    cfg, src = run
    start = np.asarray(load_run(src).policies.env_params.maze.start)[:2]
    _, names, _, plain, _ = evaluate(src, references=())
    _, _, _, moved, _ = evaluate(src, references=(), overrides=["env.random_start=true"])
    for name in names:
        for arm in plain[name]:
            assert np.allclose(plain[name][arm]["pos"][0], start, atol=0.05)
            assert not np.allclose(moved[name][arm]["pos"][0], start, atol=0.05)
    out = evaluate_to_dir(
        src, out=tmp_path / "eval", references=(), overrides=["env.random_start=true"]
    )
    assert "tested with env.random_start=true" in (out / "tables.md").read_text()


def test_a_paced_run_is_tested_at_the_worlds_own_pace(tmp_path):
    """env.motion_pace is a training distribution: the test, and each periodic
    evaluation, play the moving cylinders at their own pace unless a test setting
    asks for another."""
    from jaxnav.core.config import dump_config, load_config
    from jaxnav.experiments.evaluation import tested_config

    cfg = load_config(None, ["env.maze=stage4", "env.motion_pace=[0.5,2]"])
    path = tmp_path / "config.yaml"
    path.write_text(dump_config(cfg))
    assert tuple(tested_config(path).env.motion_pace) == (1.0, 1.0)
    assert tuple(tested_config(path, ["env.motion_pace=[2,2]"]).env.motion_pace) == (2.0, 2.0)
    plain = tmp_path / "plain.yaml"
    plain.write_text(dump_config(load_config(None, ["env.maze=stage4"])))
    assert tested_config(plain) == load_config(str(plain))


def test_a_drawn_run_is_tested_with_new_goals_at_restarts_whatever_training_kept(tmp_path):
    """``evaluate --mazes FILE env.restart_goal=new`` of a run trained on drawn mazes
    that kept each layout for several episodes was refused ("needs env.new_maze_every
    1"), though its test draws a new layout every episode anyway."""
    from jaxnav.core.config import dump_config, load_config
    from jaxnav.experiments.evaluation import tested_config

    path = tmp_path / "config.yaml"
    path.write_text(dump_config(load_config("grid4", ["env.new_maze_every=4"])))
    cfg = tested_config(path, ["env.restart_goal=new"])
    assert cfg.env.restart_goal == "new" and cfg.env.new_maze_every == 1
    assert tested_config(path).env.new_maze_every == 1  # as the test plays it anyway
