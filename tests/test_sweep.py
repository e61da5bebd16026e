"""Sweeps: a grid of settings trained as data in one compiled program."""

import csv
import dataclasses
import gzip

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxnav import dqn
from jaxnav.core import strategies as registry
from jaxnav.core import sweep
from jaxnav.core.config import SWEEPABLE, load_config
from jaxnav.core.errors import ConfigError
from jaxnav.run.launch import resume, train_new
from jaxnav.run.training import Run

TINY = [
    "seeds=2",
    "episodes=6",
    "env.max_steps=80",
    "run.chunk_steps=120",
    "run.chunk_s=0",
    "run.checkpoint_s=0",  # a checkpoint after every chunk, as the kill below counts them
    "dqn.batch_size=16",
    "run.test_mazes=[square4]",
    "run.test_episodes=2",
]


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def _params(run_dir):
    with np.load(run_dir / "params.npz") as d:
        return {k: d[k] for k in d.files}


# ----------------------------------------------------------------------------
# The config
# ----------------------------------------------------------------------------


def test_several_keys_form_their_grid_first_key_slowest():
    cfg = load_config(None, ["sweep.dqn.lr=[1e-3, 1e-4]", "sweep.dqn.gamma=[0.9, 0.99, 0.5]"])
    points = cfg.points()
    assert len(points) == 6
    assert points[0] == (("dqn.lr", 1e-3), ("dqn.gamma", 0.9))
    assert points[1] == (("dqn.lr", 1e-3), ("dqn.gamma", 0.99))
    assert points[3] == (("dqn.lr", 1e-4), ("dqn.gamma", 0.9))
    assert cfg.n_runs == 6 * 2 * cfg.seeds  # two strategies
    assert cfg.at(points[4]).dqn.lr == 1e-4 and cfg.at(points[4]).dqn.gamma == 0.99


def test_a_strategy_varies_only_the_swept_keys_it_reads():
    cfg = load_config(
        None,
        [
            "seeds=3",
            "strategies=[ebe, boltzmann, epsilon_greedy]",
            "sweep.exploration.ebe_temperature=[0.1, 1]",
            "sweep.exploration.boltzmann_temperature=[0.3, 3]",
            "sweep.dqn.lr=[1e-3, 1e-4]",
        ],
    )
    arms = cfg.arm_names()
    assert arms == [
        "ebe ebe_temperature=0.1 lr=0.001",
        "ebe ebe_temperature=0.1 lr=0.0001",
        "ebe ebe_temperature=1 lr=0.001",
        "ebe ebe_temperature=1 lr=0.0001",
        "boltzmann boltzmann_temperature=0.3 lr=0.001",
        "boltzmann boltzmann_temperature=0.3 lr=0.0001",
        "boltzmann boltzmann_temperature=3 lr=0.001",
        "boltzmann boltzmann_temperature=3 lr=0.0001",
        "epsilon_greedy lr=0.001",
        "epsilon_greedy lr=0.0001",
    ]
    assert cfg.n_runs == 10 * 3
    # The logs leave the keys a strategy does not read empty, and name the arm back.
    fields = cfg.run_fields()
    header = sweep.with_swept(("strategy", "seed"), cfg.sweep)
    for (arm, seed), f in zip(cfg.run_labels(), fields):
        assert sweep.row_arm(dict(zip(header, map(str, f)))) == arm
        assert f[-1] == seed


class _Reads:
    """An exploration settings object that records which names are read."""

    def __init__(self):
        self.read = set()

    def __getattr__(self, name):
        self.read.add(name)
        return getattr(load_config(None).exploration, name)


@pytest.mark.parametrize("strategy", registry.names("discrete"))
def test_each_strategy_reads_exactly_its_listed_settings(strategy):
    reads = _Reads()
    q = jnp.asarray([0.1, 0.5, 0.2, 0.0, 0.3])
    registry.get(strategy).function()(jax.random.PRNGKey(0), q, jnp.int32(3), reads)
    listed = {k.split(".", 1)[1] for k in registry.get(strategy).keys}
    # the settings of an intrinsic reward or of a noisy network are read where those are
    # made (tests/test_exploration_methods.py), not by the act
    beside_the_act = {"rnd_scale", "count_scale", "count_cell", "noisy_sigma"}
    assert reads.read == listed - beside_the_act


def test_every_sweepable_key_is_one_field_of_the_run_settings():
    fields = {f.name for f in dataclasses.fields(dqn.Hyper)}
    assert {k.rsplit(".", 1)[1] for k in SWEEPABLE} == fields


@pytest.mark.parametrize(
    "item, message",
    [
        ("sweep.dqn.batch_size=[16, 32]", "sweep.dqn.batch_size cannot be swept"),
        ("sweep.dqn.hidden=[[32], [64]]", "sweep.dqn.hidden cannot be swept"),
        ("sweep.env.n_beams=[24, 360]", "sweep.env.n_beams cannot be swept"),
        ("sweep.env.maze=[square4, square2]", "sweep.env.maze cannot be swept"),
        ("sweep.env.beam_dropout=[0, 0.1]", "sweep.env.beam_dropout cannot be swept"),
        ("sweep.seed=[0, 1]", "sweep.seed is not a sweep key"),
        ("sweep.dqn.lr=0.001", "sweep.dqn.lr must be a non-empty list"),
        ("sweep.dqn.lr=[]", "sweep.dqn.lr must be a non-empty list"),
        ("sweep.dqn.lr=[0.001, -1]", "sweep.dqn.lr must be positive"),
        ("sweep.dqn.lr=[0.1, 0.1]", "sweep.dqn.lr lists a value twice"),
        ("sweep.dqn.lr=[fast]", "sweep.dqn.lr must be a number"),
        ("sweep.dqn.lrr=[0.1]", "unknown key 'dqn.lrr' in sweep"),
        ("sweep=3", "sweep must be a mapping"),
    ],
)
def test_a_key_that_cannot_be_swept_is_refused_in_one_line(item, message):
    with pytest.raises(ConfigError, match=message.replace("[", r"\[")) as e:
        load_config(None, [item])
    assert "\n" not in str(e.value)


def test_a_swept_config_survives_its_config_yaml(tmp_path):
    from jaxnav.core.config import dump_config

    cfg = load_config(
        None, ["sweep.exploration.ebe_temperature=[0.1, 1]", "sweep.env.R_plus=[500]"]
    )
    path = tmp_path / "config.yaml"
    path.write_text(dump_config(cfg))
    assert load_config(str(path)) == cfg
    nested = tmp_path / "nested.yaml"  # the sweep may also be written as nested mappings
    nested.write_text("sweep:\n  exploration:\n    ebe_temperature: [0.1, 1]\n")
    assert load_config(str(nested)).sweep == (("exploration.ebe_temperature", (0.1, 1.0)),)


# ----------------------------------------------------------------------------
# Training
# ----------------------------------------------------------------------------


@pytest.mark.slow
def test_a_sweep_of_one_value_equals_the_run_without_a_sweep_bit_for_bit(tmp_path):
    plain = load_config(None, TINY)
    swept = load_config(None, [*TINY, f"sweep.exploration.ebe_temperature=[{1.0}]"])
    train_new(plain, tmp_path / "plain", quiet=True)
    train_new(swept, tmp_path / "swept", quiet=True)
    a, b = _rows(tmp_path / "plain" / "metrics.csv"), _rows(tmp_path / "swept" / "metrics.csv")
    assert [r.pop("exploration.ebe_temperature") for r in b][:1] == ["1"]
    assert a == b
    pa, pb = _params(tmp_path / "plain"), _params(tmp_path / "swept")
    renamed = {k.replace("ebe ebe_temperature=1/", "ebe/"): v for k, v in pb.items()}
    assert pa.keys() == renamed.keys()
    assert all(np.array_equal(pa[k], renamed[k]) for k in pa)


@pytest.mark.slow
def test_each_point_of_a_sweep_trains_as_the_run_of_its_values(tmp_path):
    """Runs are independent along the run axis: a point of a 3-point sweep gives the
    numbers of a separate run at that point's values (same seeds)."""
    swept = load_config(None, [*TINY, "sweep.dqn.lr=[1e-3, 3e-4, 1e-4]", "sweep.env.R_plus=[500]"])
    alone = load_config(None, [*TINY, "dqn.lr=3e-4", "env.R_plus=500"])
    run, ts_swept = _train_state(swept)
    assert run.chunk._cache_size() == 1  # one program for every point, no recompiling
    _, ts_alone = _train_state(alone)
    arms = swept.run_labels()
    for r, (arm, seed) in enumerate(alone.run_labels()):
        s = arms.index((f"{arm} lr=0.0003 R_plus=500", seed))
        for a, b in zip(jax.tree.leaves(ts_alone.metrics), jax.tree.leaves(ts_swept.metrics)):
            np.testing.assert_array_equal(np.asarray(a)[r], np.asarray(b)[s])
    # and the points differ from each other
    ret = np.asarray(ts_swept.metrics.ep_return)
    assert not np.array_equal(ret[0], ret[swept.seeds])


@pytest.mark.slow
def test_agent_switches_swept_train_each_point_as_the_run_of_its_values():
    """dqn.double, dqn.tau and dqn.loss are data when swept: their 8 points share one
    program, and a point gives the numbers of a separate run with its switches set.

    The separate runs have as many seeds as the sweep has runs, so the run axis has
    the same size: spread over the CPU devices, a different size can round the
    network's matrix products differently, whatever is swept."""
    base = [*TINY, "strategies=[ebe]", "dqn.learning_starts=16", "dqn.lr=0.003"]
    swept = load_config(
        None,
        [*base, "sweep.dqn.double=[false, true]", "sweep.dqn.tau=[1.0, 0.5]",
         "sweep.dqn.loss=[mse, huber]"],
    )  # fmt: skip
    run, ts_swept = _train_state(swept)
    assert run.chunk._cache_size() == 1
    arms = swept.run_labels()
    points = {
        "ebe double=False tau=1 loss=mse": [],
        "ebe double=True tau=0.5 loss=huber": ["dqn.double=true", "dqn.tau=0.5", "dqn.loss=huber"],
        "ebe double=True tau=1 loss=mse": ["dqn.double=true"],
        "ebe double=False tau=0.5 loss=huber": ["dqn.tau=0.5", "dqn.loss=huber"],
    }
    returns = []
    for arm, overrides in points.items():
        alone = load_config(None, [*base, *overrides, f"seeds={swept.n_runs}"])
        _, ts_alone = _train_state(alone)
        for r in range(swept.seeds):
            s = arms.index((arm, swept.seed + r))
            for a, b in zip(jax.tree.leaves(ts_alone.params), jax.tree.leaves(ts_swept.params)):
                np.testing.assert_allclose(np.asarray(a)[r], np.asarray(b)[s], rtol=0, atol=0)
        returns.append(np.asarray(ts_alone.metrics.ep_return))
    assert not np.array_equal(returns[0], returns[1])


def _train_state(cfg):
    """(the Run, its final state) of a run trained in memory, without files."""
    run = Run(cfg, None, quiet=True)
    ts = run.fresh_state()
    while run.active(ts).any():
        ts, _ = run.chunk(ts, np.int32(run.steps_needed(ts)))
    return run, ts


@pytest.mark.slow
def test_the_command_trains_strategies_and_points_in_one_program(tmp_path, capsys):
    from jaxnav.commands.train import main

    out = tmp_path / "run"
    argv = [
        *TINY,
        "strategies=[ebe,boltzmann,epsilon_greedy]",
        "sweep.exploration.ebe_temperature=[0.1,1.0]",
        "--out",
        str(out),
        "--quiet",
    ]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "ebe ebe_temperature=0.1" in text and "training curves:" in text
    metrics = _rows(out / "metrics.csv")
    assert list(metrics[0])[:3] == ["strategy", "exploration.ebe_temperature", "seed"]
    arms = {(r["strategy"], r["exploration.ebe_temperature"]) for r in metrics}
    assert arms == {("ebe", "0.1"), ("ebe", "1"), ("boltzmann", ""), ("epsilon_greedy", "")}
    explore = _rows(out / "explore.csv")
    assert list(explore[0])[:3] == ["strategy", "exploration.ebe_temperature", "seed"]
    params = _params(out)
    assert {k.split("/")[0] for k in params} == {
        "ebe ebe_temperature=0.1",
        "ebe ebe_temperature=1",
        "boltzmann",
        "epsilon_greedy",
    }


@pytest.mark.parametrize(
    "settings",
    [
        ["sweep.dqn.gamma=[0.9, 0.99]"],
        # the agent switches: Adam's state, the dueling parameters, the swept switches
        # carried in Hyper, n-step sampling
        [
            "dqn.optimizer=adam",
            "dqn.dueling=true",
            "dqn.n_step=3",
            "sweep.dqn.double=[false, true]",
            "sweep.dqn.tau=[1.0, 0.5]",
            "sweep.dqn.loss=[huber]",
        ],
    ],
)
@pytest.mark.slow
def test_a_swept_run_resumes_to_the_uninterrupted_result(tmp_path, monkeypatch, settings):
    cfg = load_config(None, [*TINY, *settings])
    train_new(cfg, tmp_path / "ref", quiet=True)
    saves = []
    save = Run.save

    def save_then_die(self, *args, **kwargs):
        save(self, *args, **kwargs)
        saves.append(1)
        if len(saves) == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(Run, "save", save_then_die)
    with pytest.raises(KeyboardInterrupt):
        train_new(cfg, tmp_path / "killed", quiet=True)
    monkeypatch.undo()
    assert not (tmp_path / "killed" / "params.npz").exists()
    resume(tmp_path / "killed", quiet=True)
    for name in ("metrics.csv", "explore.csv"):
        ref = (tmp_path / "ref" / name).read_bytes()
        assert (tmp_path / "killed" / name).read_bytes() == ref
    a, b = _params(tmp_path / "ref"), _params(tmp_path / "killed")
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.slow
def test_a_swept_environment_setting_changes_the_reward_of_its_runs():
    cfg = load_config(None, [*TINY, "sweep.env.R_minus=[-150, -1000]", "strategies=[ebe]"])
    _, ts = _train_state(cfg)
    m = ts.metrics
    collided = np.asarray(m.ep_collided)
    ret = np.asarray(m.ep_return)
    # A collision's reward is the run's own R-: the -1000 runs lose ~850 more per crash.
    mild, harsh = (ret[r][collided[r]] for r in (slice(0, cfg.seeds), slice(cfg.seeds, None)))
    assert len(mild) and len(harsh)
    assert harsh.mean() < mild.mean() - 400


# ----------------------------------------------------------------------------
# Testing, tables and figures
# ----------------------------------------------------------------------------


@pytest.mark.slow
def test_the_study_command_tests_tabulates_and_draws_a_sweep(tmp_path, capsys):
    from jaxnav.commands.study import main

    out, doc = tmp_path / "study", tmp_path / "docs" / "temperature.md"
    doc.parent.mkdir()
    argv = [
        "configs/temperature.yaml",
        *TINY,
        "sweep.exploration.ebe_temperature=[0.1, 1]",
        "sweep.exploration.boltzmann_temperature=[0.3]",
        "--out",
        str(out),
        "--doc",
        str(doc),
        "--quiet",
    ]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert f"study: {out / 'study.md'}" in printed
    assert "2 seeds per arm, fewer than the 4 a verdict needs" in printed
    results = _rows(out / "run" / "eval" / "results.csv")
    columns = ["strategy", "exploration.ebe_temperature", "exploration.boltzmann_temperature"]
    assert list(results[0])[:4] == [*columns, "seed"]
    assert {r["mode"] for r in results} == {"greedy", "exploring"}
    tables = (out / "run" / "eval" / "tables.md").read_text()
    assert "Sweep: return at each point" in tables and "P(arm > epsilon-greedy)" in tables
    text = doc.read_text()
    for mode in ("greedy", "exploring"):
        assert f"### Test mode: {mode}" in text
    assert "EBE ebe_temperature=0.1" in text and "Best points against each other" in text
    # the answers, in words: at 2 seeds per arm, too few for any verdict
    assert "EBE against epsilon-greedy: too few seeds for a verdict (2 per arm" in text
    assert "beats" not in text and "better |" not in text
    assert "![" in text and (doc.parent / "temperature-sweep.png").is_file()
    packed = (doc.parent / "temperature-results.csv.gz").read_bytes()
    assert gzip.decompress(packed).decode() == (out / "run" / "eval" / "results.csv").read_text()
    assert (out / "sweep.png").is_file() and (out / "training_curves.png").is_file()
    # An arm exports as a robot policy, with its own settings in its metadata.
    from jaxnav.robot.deploy import Policy
    from jaxnav.robot.export import export_policy

    arrays = export_policy(out / "run", "ebe ebe_temperature=0.1", 0)
    policy = Policy.from_arrays(arrays)
    assert policy.meta["strategy"] == "ebe ebe_temperature=0.1"
    assert "ebe_temperature: 0.1" in policy.meta["config"]
    # A config without a sweep is refused in one line.
    assert main(["configs/smoke.yaml", "--out", str(tmp_path / "none")]) == 2
    assert "has no sweep" in capsys.readouterr().err


@pytest.mark.slow
def test_exploring_test_uses_each_points_own_temperature(tmp_path):
    """The exploring test of a point explores with that point's temperature: at a tiny
    temperature EBE's entropy is near 0, so it acts almost greedily."""
    from jaxnav.experiments.evaluation import load_run
    from jaxnav.experiments.rollout import run_tests
    from jaxnav.world.maps import make_maze

    cfg = load_config(
        None, [*TINY, "strategies=[ebe]", "sweep.exploration.ebe_temperature=[1e-4, 100]"]
    )
    out = tmp_path / "run"
    train_new(cfg, out, quiet=True)
    run = load_run(out)
    hyper = run.policies.hyper
    np.testing.assert_allclose(hyper.ebe_temperature, [1e-4, 1e-4, 100, 100], rtol=1e-6)
    maze = [make_maze("square4")]
    greedy = run_tests(run.policies, maze, 2, mode="greedy")[0]
    exploring = run_tests(run.policies, maze, 2, mode="exploring")[0]
    # T = 1e-4: the same episodes as greedy; T = 100: near-uniform random actions.
    np.testing.assert_array_equal(exploring.ret[:2], greedy.ret[:2])
    assert not np.array_equal(exploring.ret[2:], greedy.ret[2:])


@pytest.mark.slow
@pytest.mark.parametrize("name, seed", [("temperature", 0), ("temperature-confirm", 100)])
def test_the_committed_temperature_studies_are_computed_from_their_results(name, seed):
    from pathlib import Path

    from jaxnav.report.tables import sweep_markdown

    root = Path(__file__).resolve().parent.parent
    doc = root / "docs" / "studies" / f"{name}.md"
    if not doc.is_file():
        pytest.skip(f"no committed {name} study")
    packed = (doc.parent / f"{name}-results.csv.gz").read_bytes()
    results = gzip.decompress(packed).decode()
    text = doc.read_text()
    assert "\n".join(sweep_markdown(results, seed)) in text
    # What docs/studies.md says of the studies is their own words.
    page = (root / "docs" / "studies.md").read_text()
    begin, end = f"<!-- {name} study: begin -->", f"<!-- {name} study: end -->"
    quoted = page[page.index(begin) + len(begin) : page.index(end)].strip().splitlines()
    assert quoted
    for line in (q for q in quoted if q.startswith("- ")):
        assert line in text, line
