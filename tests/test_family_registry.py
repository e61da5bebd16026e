"""A maze family is one static shape with a ``draw`` and one registry entry: a toy
family, registered here and nowhere else, is checked when a config loads, trains and
is evaluated like the built-in ones; an unknown family is refused in one line."""

from __future__ import annotations

import csv
import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
from jaxnav.commands.list import catalog
from jaxnav.core import families
from jaxnav.core.config import SETTINGS, load_config
from jaxnav.core.errors import ConfigError
from jaxnav.env import NavEnv
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.run.launch import train_new
from jaxnav.world.generators import SPLITS
from jaxnav.world.maps import GOAL_CLEARANCE, ROBOTIS_ARENA, Maze


class EmptyRoom(NamedTuple):
    """A toy family: an empty square room of side ``side`` m, the robot at its centre
    facing a random yaw, the goal one of a 5 x 5 lattice of points other than the
    centre. The split picks the draw's key, so train and test draw differently."""

    side: float

    def draw(self, key, split: str = "train"):
        h = self.side / 2
        corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]], np.float32)
        walls = np.concatenate([corners, np.roll(corners, -1, axis=0)], axis=1)
        ticks = np.linspace(-h + GOAL_CLEARANCE, h - GOAL_CLEARANCE, 5)
        ty, tx = np.meshgrid(ticks, ticks, indexing="ij")
        points = jnp.asarray(np.stack([tx.ravel(), ty.ravel()], 1), jnp.float32)
        k_goal, k_yaw = jax.random.split(jax.random.fold_in(key, SPLITS.index(split)))
        i = jax.random.randint(k_goal, (), 0, 24)
        goal = points[i + (i >= 12)]  # any point but the centre, the start
        yaw = jax.random.uniform(k_yaw, (1,), jnp.float32, -jnp.pi, jnp.pi)
        maze = Maze(
            segments=jnp.asarray(walls),
            segment_mask=jnp.ones(4, bool),
            circles=jnp.asarray([[1e4, 1e4, 0.0]], jnp.float32),
            circle_mask=jnp.zeros(1, bool),
            start=jnp.concatenate([jnp.zeros(2, jnp.float32), yaw]),
            goal_points=points,
            n_goal_points=jnp.asarray(25, jnp.int32),
            bounds=jnp.asarray([-h, -h, h, h], jnp.float32),
            n_obstacles=jnp.asarray(0, jnp.int32),
            robotis_goals=jnp.resize(points, (256, 2)),
            n_robotis_goals=jnp.asarray(25, jnp.int32),
            robotis_scale=jnp.asarray(self.side / ROBOTIS_ARENA, jnp.float32),
        )
        return maze, goal


def _one_start(env) -> str | None:
    """The toy's refusal: its room has one start."""
    return "env.random_start: the empty room starts at its centre" if env.random_start else None


@pytest.fixture
def toy():
    families.register(
        "empty",
        lambda env: EmptyRoom(3.0),
        problem=_one_start,
        text=lambda env: "3 m empty rooms",
        about="an empty 3 m room, a random goal",
    )
    yield "empty"
    families.unregister("empty")


def test_an_unknown_family_is_refused_in_one_line_listing_the_registered_ones():
    with pytest.raises(ConfigError) as e:
        load_config(None, ["env.generator=empty"])
    assert str(e.value) == (
        'config: env.generator must be "" (the fixed env.maze), grid, cylinders, rooms, barn or mix'
    )
    with pytest.raises(
        ValueError, match="^generator must be .*, grid, cylinders, rooms, barn or mix$"
    ):
        jaxnav.make(generator="empty")
    with pytest.raises(ConfigError, match="'empty' is no maze family") as e:
        families.get("empty")
    assert "\n" not in str(e.value) and "grid, cylinders, rooms, barn or mix" in str(e.value)


def test_a_registered_family_is_a_choice_and_its_refusals_run_when_a_config_loads(toy):
    assert "  empty      an empty 3 m room, a random goal" in catalog()
    cfg = load_config(None, ["env.generator=empty"])
    assert cfg.env.generator == toy and families.family_text(cfg.env) == "3 m empty rooms"
    with pytest.raises(
        ConfigError, match="config: env.generator must be .*, rooms, barn, mix or empty$"
    ):
        load_config(None, ["env.generator=void"])
    with pytest.raises(ConfigError, match="^config: env.random_start: the empty room starts"):
        load_config(None, ["env.generator=empty", "env.random_start=true"])
    # no shortest paths: the geodesic reward is refused, naming the families that have them
    with pytest.raises(ConfigError, match="env.reward geodesic needs env.generator grid"):
        load_config(None, ["env.generator=empty", "env.reward=geodesic"])
    env, params = jaxnav.make(generator=toy, max_steps=30)
    assert env.family == EmptyRoom(3.0) and not env.obstacle_obs
    _, state = jax.jit(env.reset)(jax.random.PRNGKey(0), params)
    assert np.allclose(state.pos, 0.0) and np.linalg.norm(state.goal) > 0.5


def test_a_family_registered_late_cannot_declare_settings():
    @dataclasses.dataclass(frozen=True)
    class Side:
        empty_side: float = 3.0

    with pytest.raises(ConfigError, match="its settings would not be config keys"):
        families.register("sized", lambda env: EmptyRoom(env.empty_side), Side)
    assert "sized" not in families.names()


def test_each_family_setting_is_declared_once_in_its_family():
    """The config's settings and the environment's fields of a family are its own
    declarations, laid out after env.generator in registration order."""
    keys = list(SETTINGS)
    after = keys.index("env.generator") + 1
    env_fields = {f.name: f for f in dataclasses.fields(NavEnv)}
    for name in families.names():
        declared = families.get(name).settings
        for f in dataclasses.fields(declared) if declared else ():
            assert keys[after] == f"env.{f.name}"
            assert SETTINGS[f"env.{f.name}"].help == f.metadata["help"]
            assert SETTINGS[f"env.{f.name}"].default == env_fields[f.name].default == f.default
            after += 1


@pytest.mark.slow
def test_a_registered_family_trains_and_is_evaluated(toy, tmp_path):
    cfg = load_config(
        None,
        [
            "env.generator=empty",
            "seeds=1",
            "episodes=3",
            "env.max_steps=30",
            "run.chunk_steps=60",
            "dqn.batch_size=8",
            "run.test_mazes=[]",
            "run.test_episodes=1",
        ],
    )
    out = tmp_path / "run"
    train_new(cfg, out, quiet=True)
    with open(out / "metrics.csv") as f:
        assert len(list(csv.DictReader(f))) == 3 * 2  # 3 episodes of both strategies
    with open(evaluate_to_dir(out, modes=("greedy",), references=()) / "results.csv") as f:
        tested = {r["maze"] for r in csv.DictReader(f)}
    assert tested == {"empty:train", "empty:test"}
    assert "Trained on `3 m empty rooms (train split)`" in (out / "eval" / "tables.md").read_text()
