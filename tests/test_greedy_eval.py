"""The greedy evaluation while a run trains (run.eval_every): eval.csv's rows, their
values against a rollout of the saved policies, training left as it is, resume."""

import csv

import numpy as np
import pytest

from jaxnav.commands.train import main
from jaxnav.core import rundir
from jaxnav.core.config import load_config
from jaxnav.experiments.evaluation import load_run
from jaxnav.experiments.rollout import padded_mazes, run_tests
from jaxnav.report.navigation import CUT, SUCCESS, split_attempts
from jaxnav.run import launch
from jaxnav.run.launch import train_new

# 1,000 env steps per run in chunks of 400; evaluations every 300 cut the chunks at
# 300, 600 and 900 (whole blocks of 100 steps), and the end at 1,000 is evaluated too.
TINY = [
    "seeds=2",
    "episodes=null",
    "total_steps=1000",
    "env.max_steps=100",
    "run.chunk_steps=400",
    "dqn.batch_size=16",
    "run.eval_episodes=3",
    "run.chunk_s=0",  # chunks of 400 (cut by the evaluations) and a checkpoint after each,
    "run.checkpoint_s=0",  # as the kill below counts them
]
EVAL = ["run.eval_every=300"]
PQN = [
    "agent=pqn",
    "seeds=2",
    "episodes=null",
    "total_steps=3200",
    "env.max_steps=50",
    "pqn.num_envs=4",
    "pqn.rollout=8",
    "pqn.minibatches=2",
    "run.chunk_steps=1600",
    "dqn.optimizer=radam",
    "dqn.lr=0.001",
    "run.eval_episodes=2",
]


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def _params(run_dir):
    with np.load(run_dir / rundir.PARAMS) as d:
        return {k: d[k] for k in d.files}


def _train(tmp_path_factory, name, args):
    out = tmp_path_factory.mktemp(name) / "run"
    train_new(load_config(None, args), out, quiet=True)
    return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The same tiny DQN run with and without evaluation."""
    return _train(tmp_path_factory, "on", TINY + EVAL), _train(tmp_path_factory, "off", TINY)


def _same_training(on, off):
    """Evaluation leaves training as it is: the same parameters, bit for bit, and the
    same log rows (in another order where a cut chunk appended them in two parts)."""
    a, b = _params(on), _params(off)
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    for log in (rundir.METRICS, rundir.EXPLORE):
        rows_on, rows_off = _rows(on / log), _rows(off / log)
        assert rows_on and sorted(map(str, rows_on)) == sorted(map(str, rows_off))
    assert not (off / rundir.EVAL).exists()


@pytest.mark.slow
def test_training_is_the_same_with_and_without_evaluation(runs):
    _same_training(*runs)


@pytest.mark.slow  # 12 s on 2 cores
def test_eval_rows_come_at_the_first_chunk_end_past_each_multiple_and_at_the_end(runs):
    on, _ = runs
    cfg = load_config(str(on / rundir.CONFIG))
    rows = _rows(on / rundir.EVAL)
    steps = sorted({int(r["env_step"]) for r in rows})
    assert steps == [300, 600, 900, 1000]
    assert len(rows) == len(steps) * cfg.n_runs
    for r in rows:
        attempts, successes = int(r["attempts"]), int(r["successes"])
        assert attempts >= cfg.run.eval_episodes and 0 <= successes <= attempts
        decided = attempts - int(r["cut"])  # success leaves out the cut attempts
        assert decided == successes + int(r["collisions"]) + int(r["timeouts"])
        assert float(r["success"]) == pytest.approx(successes / decided)
        assert float(r["wall_s"]) > 0


@pytest.mark.slow
def test_the_last_evaluation_is_the_greedy_test_of_the_saved_policies(runs):
    """An independent rollout of params.npz with ``jaxnav evaluate``'s key on the
    training maze gives the last evaluation's numbers."""
    on, _ = runs
    run = load_run(on)
    n = run.config.run.eval_episodes
    (res,) = run_tests(run.policies, padded_mazes([run.config.env.maze]), n, navigation=True)
    last = [r for r in _rows(on / rundir.EVAL) if int(r["env_step"]) == 1000]
    assert len(last) == len(run.policies.labels)
    for i, (arm, seed) in enumerate(run.policies.labels):
        (row,) = [r for r in last if (r["strategy"], int(r["seed"])) == (arm, seed)]
        s = res.steps
        limit = run.config.env.max_steps  # the attempt limit: the episode's
        att = split_attempts(
            s.pos[i], s.goal[i], s.reached[i], s.collided[i], s.episode[i], n, limit
        )
        assert row["return"] == f"{float(np.mean(res.ret[i])):.6g}"
        assert row["goals"] == f"{float(np.mean(res.goals[i])):.6g}"
        assert int(row["attempts"]) == len(att.outcome)
        assert int(row["successes"]) == int(np.sum(att.outcome == SUCCESS))
        assert int(row["cut"]) == int(np.sum(att.outcome == CUT))


@pytest.mark.slow
def test_with_drawn_mazes_every_evaluation_episode_is_a_layout_of_its_own(tmp_path):
    """Training keeps a layout for 10 episodes; the evaluation draws one per episode
    from the training split: jaxnav evaluate's grid:train test of the same policies."""
    from jaxnav.experiments.evaluation import drawn_policies

    drawn = ["env.generator=grid", "env.new_maze_every=10", "strategies=[ebe]"]
    out = tmp_path / "run"
    train_new(load_config(None, TINY + EVAL + drawn), out, quiet=True)
    policies = drawn_policies(load_run(out), split="train")
    n = 3
    (res,) = run_tests(policies, [policies.env_params.maze], n, navigation=True)
    segments = np.asarray(res.mazes.segments)
    assert all(len({segments[i, e].tobytes() for e in range(n)}) == n for i in range(2))
    last = [r for r in _rows(out / rundir.EVAL) if int(r["env_step"]) == 1000]
    for i, (arm, seed) in enumerate(policies.labels):
        (row,) = [r for r in last if (r["strategy"], int(r["seed"])) == (arm, seed)]
        assert row["return"] == f"{float(np.mean(res.ret[i])):.6g}"
        assert row["goals"] == f"{float(np.mean(res.goals[i])):.6g}"


class Killed(BaseException):
    """A kill between a chunk's log appends and its checkpoint."""


@pytest.mark.slow
def test_a_run_killed_before_a_checkpoint_resumes_with_the_same_eval_rows(
    runs, tmp_path, monkeypatch
):
    ref, _ = runs
    out = tmp_path / "run"
    real = rundir.atomic_write_npz
    written = []

    def dies_at_the_third_checkpoint(path, arrays):
        if path.name == "last.npz":
            if len(written) == 2:  # the chunk to step 600 appended its evaluation
                raise Killed
            written.append(path)
        real(path, arrays)

    monkeypatch.setattr(rundir, "atomic_write_npz", dies_at_the_third_checkpoint)
    with pytest.raises(Killed):
        train_new(load_config(None, TINY + EVAL), out, quiet=True)
    monkeypatch.undo()
    assert {int(r["env_step"]) for r in _rows(out / rundir.EVAL)} == {300, 600}
    launch.resume(out, quiet=True)

    def without_time(rows):
        return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]

    assert without_time(_rows(out / rundir.EVAL)) == without_time(_rows(ref / rundir.EVAL))
    assert (out / rundir.METRICS).read_bytes() == (ref / rundir.METRICS).read_bytes()


@pytest.mark.slow
def test_pqn_evaluates_at_whole_updates_and_trains_the_same(tmp_path_factory):
    on = _train(tmp_path_factory, "pqn_on", PQN + ["run.eval_every=500"])
    off = _train(tmp_path_factory, "pqn_off", PQN)
    _same_training(on, off)
    # 32 env steps per update, 100 per log block: a chunk is cut every 800 steps at most
    steps = sorted({int(r["env_step"]) for r in _rows(on / rundir.EVAL)})
    assert steps == [800, 1600, 2400, 3200]


@pytest.mark.parametrize(
    "arg, message",
    [
        ("run.eval_every=-1", "run.eval_every must be non-negative"),
        ("run.eval_episodes=0", "run.eval_episodes must be at least 1"),
        ("run.eval_every=1.5", "run.eval_every must be an integer"),
    ],
)
def test_a_bad_evaluation_setting_is_one_line_and_exit_2(arg, message, tmp_path, capsys):
    assert main([arg, "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and not (tmp_path / "run").exists()


def test_the_periodic_evaluation_plays_the_world_as_the_test_does():
    """A new drawn layout every episode, and the moving cylinders at their own pace
    (env.motion_pace is a training distribution), whatever training used."""
    import jaxnav
    from jaxnav.run.greedy import evaluation_env

    env, _ = jaxnav.make("stage4", motion_pace=(0.0, 2.0))
    assert evaluation_env(env).motion_pace == (1.0, 1.0)
    env, _ = jaxnav.make(generator="grid", new_maze_every=10)
    assert evaluation_env(env).new_maze_every == 1
    env, _ = jaxnav.make("stage4")
    assert evaluation_env(env) == env
