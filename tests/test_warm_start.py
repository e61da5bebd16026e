"""run.init_from: every run starts from the policy of the same seed of a finished run.

The reference is the source run's own params.npz, read with NumPy: the started state's
params (and a DQN's target network) equal it array for array, a strategy the source
lacks takes the same seed's, and a source that cannot give every run its network is
one line before anything is written."""

import dataclasses

import jax
import numpy as np
import pytest
from _tiny_run import tiny_run

from jaxnav.commands.train import main
from jaxnav.core import rundir
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.run.checkpoint import start_params
from jaxnav.run.training import Run


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    """(config, run directory) of a finished 2-seed DQN run."""
    return tiny_run(tmp_path_factory)


def _stored(run_dir, strategy: str, seed: int) -> dict[str, np.ndarray]:
    with np.load(run_dir / rundir.PARAMS) as d:
        prefix = rundir.params_key(strategy, seed, "")
        return {k[len(prefix) :]: d[k] for k in d.files if k.startswith(prefix)}


def _by_name(tree, run: int) -> dict[str, np.ndarray]:
    flat, _ = jax.tree_util.tree_flatten_with_path(tree)
    return {
        "/".join(str(getattr(k, "key", k)) for k in p): np.asarray(leaf)[run] for p, leaf in flat
    }


def _warm(cfg, out, **changes):
    run = dataclasses.replace(cfg.run, init_from=str(out))
    return dataclasses.replace(cfg, run=run, **changes)


def test_every_run_and_its_target_network_start_from_the_same_seed_of_the_source(source):
    cfg, out = source
    ts = Run(_warm(cfg, out), None).fresh_state()
    for r, (strategy, seed) in enumerate(cfg.run_labels()):
        want = _stored(out, strategy, seed)
        for tree in (ts.params, ts.target_params):
            got = _by_name(tree, r)
            assert got.keys() == want.keys()
            for name in want:
                np.testing.assert_array_equal(got[name], want[name])
    fresh = Run(cfg, None).fresh_state()  # without it: the initialiser's own draw
    assert not np.array_equal(_by_name(fresh.params, 0)[name], want[name])


def test_a_strategy_the_source_lacks_starts_from_that_seeds_policy_of_its_first(source):
    cfg, out = source
    first = cfg.run_labels()[0][0]
    other = _warm(cfg, out, strategies=("boltzmann",))
    params = start_params(other, Run(cfg, None).fresh_state().params)
    for r, (_, seed) in enumerate(other.run_labels()):
        want = _stored(out, first, seed)
        for name, value in _by_name(params, r).items():
            np.testing.assert_array_equal(value, want[name])


def test_a_source_without_a_seed_or_with_another_network_is_one_config_error(source):
    cfg, out = source
    shapes = Run(cfg, None).fresh_state().params
    with pytest.raises(ConfigError, match="has no seed 2 \\(it holds seeds 0, 1\\)"):
        start_params(_warm(cfg, out, seeds=3), shapes)
    wide = jax.tree.map(lambda a: np.zeros((a.shape[0], *[n + 1 for n in a.shape[1:]])), shapes)
    with pytest.raises(ConfigError, match="holds another network"):
        start_params(_warm(cfg, out), wide)
    with pytest.raises(ConfigError, match="params.npz does not exist"):
        start_params(_warm(cfg, out.parent / "nothing"), shapes)


def test_a_continuous_agent_cannot_start_from_params(source):
    cfg, out = source
    sac = load_config("drive_sac_obstacles", [f"run.init_from={out}"])
    with pytest.raises(ConfigError, match="only a Q-learner"):
        start_params(sac, None)


def test_a_bad_source_on_the_command_line_is_one_line_and_writes_nothing(source, tmp_path, capsys):
    _, out = source
    target = tmp_path / "warm"
    argv = ["smoke", f"run.init_from={out}", "dqn.hidden=[8]", "--out", str(target), "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "holds another network" in err, err
    assert not target.exists()


def test_a_swept_source_whose_arm_names_a_path_gives_its_first_arms_seeds(tmp_path):
    arm = "ebe maze=mazes/a.yaml"  # a sweep arm's name may hold a slash
    w = {s: np.full(3, s + 1.0, np.float32) for s in (0, 1)}
    arrays = {rundir.params_key(arm, s, "params/w"): w[s] for s in (0, 1)}
    arrays[rundir.params_key("ebe maze=mazes/b.yaml", 0, "params/w")] = np.zeros(3, np.float32)
    (tmp_path / "src").mkdir()
    np.savez(tmp_path / "src" / rundir.PARAMS, **arrays)
    cfg = load_config("smoke", [f"run.init_from={tmp_path / 'src'}"])
    template = {"params": {"w": jax.ShapeDtypeStruct((cfg.n_runs, 3), np.float32)}}
    got = start_params(cfg, template)["params"]["w"]
    want = np.stack([w[seed] for _, seed in cfg.run_labels()])
    np.testing.assert_array_equal(got, want)
