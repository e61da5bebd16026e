"""An exploration strategy is one function and one registry entry: a toy strategy,
registered here and nowhere else, trains, is swept, evaluated and exported like the
built-in ones."""

import csv

import jax.numpy as jnp
import pytest

from jaxnav.core import strategies as registry
from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError
from jaxnav.core.sweep import applies
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.robot.export import export_policy
from jaxnav.run.launch import train_new

STRAIGHT = 2  # the action index of angular velocity 0 (jaxnav.env.PAPER_OMEGAS)


def always_straight(key, q, episode, settings):
    """A toy strategy: always drive straight, never explore."""
    del key, q, episode, settings
    return jnp.int32(STRAIGHT), jnp.float32(0.0)


@pytest.fixture
def toy():
    registry.register("straight", always_straight, keys=(), about="always straight ahead")
    yield "straight"
    registry.unregister("straight")


def test_unknown_strategy_is_refused_until_registered(toy):
    registry.unregister(toy)
    with pytest.raises(ConfigError, match="unknown strategy 'straight'"):
        load_config(None, ["strategies=[ebe, straight]"])
    registry.register(toy, always_straight)
    assert load_config(None, ["strategies=[ebe, straight]"]).strategies == ("ebe", "straight")


@pytest.mark.slow
def test_a_registered_strategy_trains_evaluates_and_exports(toy, tmp_path):
    cfg = load_config(
        None,
        [
            "strategies=[ebe, straight]",
            "seeds=2",
            "episodes=3",
            "env.max_steps=30",
            "run.chunk_steps=60",
            "dqn.batch_size=8",
            "run.test_mazes=[square4]",
            "run.test_episodes=1",
            "sweep.exploration.ebe_temperature=[0.5, 1.0]",
        ],
    )
    # A sweep of EBE's settings gives the toy one arm: it reads none of them.
    assert cfg.arm_names() == [
        "ebe ebe_temperature=0.5",
        "ebe ebe_temperature=1",
        "straight",
    ]
    assert not applies("exploration.ebe_temperature", toy)
    out = tmp_path / "run"
    train_new(cfg, out, quiet=True)
    with open(out / "explore.csv") as f:
        rows = list(csv.DictReader(f))
    toy_rows = [r for r in rows if r["strategy"] == toy]
    assert toy_rows and all(float(r["explore"]) == 0.0 for r in toy_rows)
    assert any(float(r["explore"]) > 0.0 for r in rows if r["strategy"] == "ebe")
    with open(evaluate_to_dir(out) / "results.csv") as f:
        tested = {r["strategy"] for r in csv.DictReader(f)}
    # the learned arms, and the oracle and DWA beside them
    assert tested == {"ebe", toy, "oracle", "dwa"}
    assert any(k.endswith("/kernel") for k in export_policy(out, strategy=toy, seed=0))
