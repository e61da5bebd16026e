"""jaxnav.experiments.imitation and ``jaxnav imitate``: the oracle's steps as
demonstrations and Q-networks fit to them, written as a run that ``jaxnav evaluate`` and
``run.init_from`` read.

References: the environment's own reset and the oracle's own plan for the first pair;
the written params, applied again, for the agreement the summary states; the share of
the oracle's commonest action, which a fit that learned must beat."""

from __future__ import annotations

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav.commands.imitate import main as imitate_main
from jaxnav.core import agents, cli, rundir
from jaxnav.core.config import load_config
from jaxnav.core.errors import RunError
from jaxnav.env import from_config
from jaxnav.experiments import imitation as imitate
from jaxnav.experiments.baselines import planner_of
from jaxnav.experiments.evaluation import load_run

ARGS = ["smoke", "--envs", "3", "--steps", "120", "--epochs", "150", "--quiet"]


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("imitate") / "run"
    assert imitate_main([*ARGS, "--out", str(out)]) == 0
    return out


@pytest.mark.slow
def test_the_first_pair_is_the_resets_observation_and_the_oracles_plan_there():
    cfg = load_config("smoke", [])
    obs, action, *_ = imitate.demonstrations(imitate.teacher_of(cfg), 3, 5, seed=0, quiet=True)
    assert obs.shape == (15, from_config(cfg)[0].obs_size) and action.shape == (15,)
    env, params = from_config(cfg.tested())
    first_obs, state = jax.vmap(env.reset, in_axes=(0, None))(
        jax.random.split(jax.random.PRNGKey(0), 3), params
    )
    np.testing.assert_array_equal(obs[:3], np.asarray(first_obs))  # step 0 of each env
    oracle = planner_of("oracle", env, [params.maze], params)
    memory = jax.vmap(oracle.start, in_axes=(None, 0))(params, state)
    planned, _ = jax.vmap(oracle.plan, in_axes=(0, 0, 0, None))(memory, first_obs, state, params)
    np.testing.assert_array_equal(action[:3], np.asarray(planned))


@pytest.mark.slow
def test_with_a_policy_the_policy_drives_and_the_oracle_labels(written):
    cfg = load_config("smoke", [])
    network = agents.get(cfg.agent).network_of(cfg)
    stacked = jax.tree.map(
        lambda *a: np.stack(a),
        *[rundir.load_params(written / rundir.PARAMS, s, n) for s, n in cfg.run_labels()],
    )
    obs, action, *_ = imitate.demonstrations(
        imitate.teacher_of(cfg), 3, 2, 0, quiet=True, policy=(network, stacked)
    )
    env, params = from_config(cfg.tested())
    obs0, state = jax.vmap(env.reset, in_axes=(0, None))(
        jax.random.split(jax.random.PRNGKey(0), 3), params
    )
    runs = len(cfg.run_labels())
    drive = [
        int(np.argmax(network.apply(jax.tree.map(lambda a, i=i: a[i % runs], stacked), obs0[i])))
        for i in range(3)
    ]
    _, k = jax.random.split(jax.random.PRNGKey(1))  # the first chunk's key
    key0 = jax.random.split(k, imitate.CHUNK)[0]
    obs1 = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
        jax.random.split(key0, 3), state, jnp.asarray(drive), params
    )[0]
    np.testing.assert_allclose(obs[3:6], np.asarray(obs1), atol=1e-6)  # where they drove
    oracle = planner_of("oracle", env, [params.maze], params)
    memory = jax.vmap(oracle.start, in_axes=(None, 0))(params, state)
    planned, _ = jax.vmap(oracle.plan, in_axes=(0, 0, 0, None))(memory, obs0, state, params)
    np.testing.assert_array_equal(action[:3], np.asarray(planned))  # what the oracle said


@pytest.mark.slow
def test_the_written_run_is_tested_like_a_trained_one_and_agrees_as_it_says(written):
    cfg = load_config(str(written / rundir.CONFIG))
    loaded = load_run(written)
    assert [tuple(label) for label in loaded.policies.labels] == cfg.run_labels()
    summary = json.loads((written / rundir.SUMMARY).read_text())
    cfg_demo = load_config("smoke", [])
    obs, action, goals, collisions, _ = imitate.demonstrations(
        imitate.teacher_of(cfg_demo), 3, 120, 0, quiet=True
    )
    assert (summary["oracle_goals"], summary["oracle_collisions"]) == (goals, collisions)
    assert summary["demonstration_steps"] == len(action) == 360
    network = agents.get(cfg.agent).network_of(cfg)
    commonest = np.bincount(action).max() / len(action)
    for (strategy, seed), stated in zip(cfg.run_labels(), summary["agreement"]):
        params = rundir.load_params(written / rundir.PARAMS, strategy, seed)
        greedy = np.argmax(np.asarray(network.apply(params, jnp.asarray(obs))), -1)
        agree = float(np.mean(greedy == action))
        assert agree == pytest.approx(stated, abs=1e-4)
        assert agree > commonest  # it learned more than the commonest action


@pytest.mark.slow
def test_training_starts_from_the_imitation(written):
    from jaxnav.run.training import Run

    cfg = load_config("smoke", [f"run.init_from={written}"])
    ts = Run(cfg, None).fresh_state()
    for r, (strategy, seed) in enumerate(cfg.run_labels()):
        want = rundir.load_params(written / rundir.PARAMS, strategy, seed)
        got = jax.tree.map(lambda a, r=r: np.asarray(a)[r], ts.params)
        jax.tree.map(np.testing.assert_array_equal, got, want)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["smoke", "--envs", "0"], "--envs, --steps and --epochs must be at least 1"),
        (["drive_sac_obstacles"], "give a Q-learner's config"),
        (["smoke", "env.nope=1"], "nope"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(argv, message, tmp_path, capsys):
    out = tmp_path / "run"
    assert imitate_main([*argv, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err, err
    assert err.startswith("jaxnav imitate: error: ")
    assert not out.exists()


@pytest.mark.slow
def test_dagger_rounds_add_the_policies_states_to_the_demonstrations(tmp_path):
    out = tmp_path / "run"
    assert imitate_main([*ARGS, "--dagger", "1", "--out", str(out)]) == 0
    summary = json.loads((out / rundir.SUMMARY).read_text())
    assert summary["demonstration_steps"] == 2 * 360
    assert len(summary["dagger_rounds"]) == 1
    assert set(summary["dagger_rounds"][0]) == {"goals", "collisions", "episodes"}


@pytest.mark.slow
def test_an_existing_directory_is_refused(written, capsys):
    assert imitate_main([*ARGS, "--out", str(written)]) == 2
    assert "exists already" in capsys.readouterr().err


def test_a_folder_that_is_no_run_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "notes"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    assert imitate_main(["smoke", "--out", str(out), "--overwrite", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err == f"jaxnav imitate: error: {out} is not a run directory (no config.yaml); " + (
        "not overwriting it\n"
    )
    (out / rundir.CONFIG).write_text("seed: 0\n")  # a run's file beside one it never writes
    assert imitate_main(["smoke", "--out", str(out), "--overwrite", "--quiet"]) == 2
    assert "holds 'mine.txt', which a run does not write" in capsys.readouterr().err
    assert (out / "mine.txt").read_text() == "keep"
    with pytest.raises(SystemExit) as e:  # a seed a PRNG key cannot hold: the parser's line
        imitate_main(["smoke", "--out", str(tmp_path / "run"), "--seed", "-1"])
    assert e.value.code == 2 and capsys.readouterr().err.count("\n") == 1


def _fake_params(monkeypatch):
    monkeypatch.setattr(imitate, "params_arrays", lambda cfg, params: {"w": np.asarray(params)})


def test_the_run_is_written_beside_and_replaces_a_run_only_whole(tmp_path, monkeypatch):
    _fake_params(monkeypatch)
    cfg = load_config("smoke", [])
    out = tmp_path / "run"
    imitate.write_run(out, cfg, np.zeros(2), {"n": 1})
    (out / "plots").mkdir()  # what a run's commands add later
    assert json.loads((out / rundir.SUMMARY).read_text()) == {"n": 1}
    with pytest.raises(RunError, match="exists already"):
        imitate.write_run(out, cfg, np.ones(2), {"n": 2})  # not without overwrite
    assert json.loads((out / rundir.SUMMARY).read_text()) == {"n": 1}
    imitate.replaceable(out)  # a run directory: it may be replaced
    imitate.write_run(out, cfg, np.ones(2), {"n": 2}, overwrite=True)
    assert json.loads((out / rundir.SUMMARY).read_text()) == {"n": 2}
    np.testing.assert_array_equal(np.load(out / rundir.PARAMS)["w"], np.ones(2))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no .part, no old copy
    assert sorted(p.name for p in out.iterdir()) == [rundir.CONFIG, rundir.PARAMS, rundir.SUMMARY]
    with rundir.Lock(out), pytest.raises(RunError, match="in use by another process"):
        imitate.replaceable(out)


def test_ctrl_c_while_the_run_is_written_leaves_nothing(tmp_path, monkeypatch, capsys):
    cfg = load_config("smoke", [])
    out = tmp_path / "run"

    def interrupted(cfg, params):
        assert (tmp_path / "run.part" / rundir.CONFIG).is_file()  # written beside, first
        raise KeyboardInterrupt

    monkeypatch.setattr(imitate, "params_arrays", interrupted)
    write = lambda: imitate.write_run(out, cfg, None, {})
    assert cli.run("jaxnav imitate", write, interrupted="interrupted; nothing written") == 130
    assert capsys.readouterr().err.strip() == "jaxnav imitate: interrupted; nothing written"
    assert list(tmp_path.iterdir()) == []
