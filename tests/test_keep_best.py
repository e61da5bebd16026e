"""run.keep_best: params.npz keeps each run's policy at its best greedy evaluation on
held-out episodes. The kept policy is the one a run trained to that step ends with,
its score is an independent rollout's on the held-out keys, resume keeps the choice,
and the test's episodes never choose."""

import json

import numpy as np
import pytest
from test_greedy_eval import EVAL, Killed
from test_greedy_eval import TINY as PLAIN

from jaxnav.agent.rollout import EVAL_SALT, VALID_SALT, eval_keys
from jaxnav.commands.train import main
from jaxnav.core import rundir
from jaxnav.core.config import load_config
from jaxnav.experiments import rollout as experiments_rollout
from jaxnav.experiments.evaluation import load_run
from jaxnav.experiments.rollout import padded_mazes, run_tests
from jaxnav.report.navigation import CUT, SUCCESS, split_attempts
from jaxnav.run import launch
from jaxnav.run.greedy import BestPolicy
from jaxnav.run.launch import train_new

# test_greedy_eval's tiny DQN run: evaluations at 300, 600, 900 and 1,000 env steps
TINY = PLAIN + EVAL
BEST = TINY + ["run.keep_best=true"]


def _params(run_dir):
    with np.load(run_dir / rundir.PARAMS) as d:
        return {k: d[k] for k in d.files}


def test_the_best_policy_is_kept_by_success_then_collisions_later_on_ties():
    best = BestPolicy(4)
    first = {"w": np.zeros((4, 2))}
    score = np.array([[0.5, -0.1], [0.5, -0.1], [0.5, -0.1], [0.5, -0.1]])
    best.offer(first, score, np.full(4, 300), np.ones(4, bool))
    assert np.array_equal(best.step, [300] * 4)
    second = {"w": np.ones((4, 2))}
    # run 0 better success; 1 the same success, more collisions; 2 a tie; 3 diverged
    score = np.array([[0.6, -0.5], [0.5, -0.2], [0.5, -0.1], [1.0, 0.0]])
    best.offer(second, score, np.full(4, 600), np.array([True, True, True, False]))
    assert np.array_equal(best.step, [600, 300, 600, 300])
    assert np.array_equal(best.params["w"][:, 0], [1, 0, 1, 0])
    assert np.array_equal(best.score[0], [0.6, -0.5]) and np.array_equal(best.score[3], [0.5, -0.1])
    # the kept copies are the host's own: changing what was offered changes nothing
    second["w"][:] = 7
    assert best.params["w"].max() == 1


def test_held_out_keys_are_neither_the_tests_nor_the_same_per_seed():
    labels = [("ebe", 0), ("ebe", 1)]
    held, test = np.asarray(eval_keys(labels, VALID_SALT)), np.asarray(eval_keys(labels))
    assert VALID_SALT != EVAL_SALT
    assert not np.array_equal(held[0], test[0]) and not np.array_equal(held[0], held[1])


@pytest.fixture(scope="module")
def best_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("best") / "run"
    train_new(load_config(None, BEST), out, quiet=True)
    return out


@pytest.mark.slow
def test_the_kept_policy_is_what_a_run_trained_to_its_step_ends_with(best_run, tmp_path):
    """Each run's kept parameters, bit for bit, are those of the same run trained to
    the kept step alone (the evaluation leaves training as it is)."""
    chosen = json.loads((best_run / rundir.SUMMARY).read_text())["best"]
    kept = _params(best_run)
    for step in sorted({c["env_step"] for c in chosen}):
        out = tmp_path / f"to{step}"
        args = [a for a in TINY if not a.startswith("total_steps")] + [f"total_steps={step}"]
        train_new(load_config(None, args), out, quiet=True)
        ref = _params(out)
        for c in chosen:
            if c["env_step"] != step:
                continue
            prefix = f"{c['strategy']}/seed{c['seed']}/"
            names = [k for k in ref if k.startswith(prefix)]
            assert names and all(np.array_equal(kept[k], ref[k]) for k in names)


@pytest.mark.slow
def test_the_kept_score_is_a_rollout_of_the_kept_policy_on_the_held_out_keys(best_run, monkeypatch):
    """An independent rollout of params.npz with the held-out keys scores what
    summary.json says, at one of the evaluated steps."""
    monkeypatch.setattr(
        experiments_rollout, "eval_keys", lambda labels: eval_keys(labels, VALID_SALT)
    )
    run = load_run(best_run)
    n = run.config.run.eval_episodes
    (res,) = run_tests(run.policies, padded_mazes([run.config.env.maze]), n, navigation=True)
    chosen = json.loads((best_run / rundir.SUMMARY).read_text())["best"]
    assert [(c["strategy"], c["seed"]) for c in chosen] == list(run.policies.labels)
    s = res.steps
    for i, c in enumerate(chosen):
        att = split_attempts(s.pos[i], s.goal[i], s.reached[i], s.collided[i], s.episode[i], n, 100)
        decided = int(np.sum(att.outcome != CUT))
        success = np.sum(att.outcome == SUCCESS) / decided if decided else 0.0
        assert c["held_out_success"] == pytest.approx(success, abs=1e-4)
        assert c["env_step"] in (300, 600, 900, 1000)


@pytest.mark.slow
def test_a_killed_run_resumes_to_the_same_kept_policy(best_run, tmp_path, monkeypatch):
    out = tmp_path / "run"
    real = rundir.atomic_write_npz
    written = []

    def dies_at_the_third_checkpoint(path, arrays):
        if path.name == "last.npz":
            if len(written) == 2:
                raise Killed
            written.append(path)
        real(path, arrays)

    monkeypatch.setattr(rundir, "atomic_write_npz", dies_at_the_third_checkpoint)
    with pytest.raises(Killed):
        train_new(load_config(None, BEST), out, quiet=True)
    monkeypatch.undo()
    launch.resume(out, quiet=True)
    a, b = _params(out), _params(best_run)
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    summary = json.loads((out / rundir.SUMMARY).read_text())
    assert summary["best"] == json.loads((best_run / rundir.SUMMARY).read_text())["best"]


def test_keep_best_without_evaluations_is_one_line_and_exit_2(tmp_path, capsys):
    assert main(["run.keep_best=true", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert "run.keep_best" in err and "run.eval_every" in err and "\n" not in err
    assert not (tmp_path / "run").exists()
