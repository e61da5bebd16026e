"""Levels (``jaxnav evaluate RUN --levels N``): layouts of a drawn run's test split, each
played once by every policy from its own start to its own first goal; the mean and the
worst tenth over them, checked by hand."""

from __future__ import annotations

import csv

import jax
import numpy as np
import pytest

from jaxnav.commands.evaluate import main as evaluate_main
from jaxnav.commands.train import main as train_main
from jaxnav.experiments import levels
from jaxnav.experiments.evaluation import load_run

TINY = [
    "drive_anywhere",
    "seeds=2",
    "total_steps=2048",
    "pqn.num_envs=8",
    "env.maze_bank=16",
    "env.mix_worlds=[rooms, grid, cylinders, square4_obstacles]",
    "env.mix_weights=[]",
    "env.max_steps=60",
    "run.chunk_steps=1024",
    "run.eval_every=0",
    "run.test_mazes=[square4_obstacles]",
    "--quiet",
]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("levels") / "run"
    assert train_main([*TINY, "--out", str(out)]) == 0
    return out


def test_summary_is_the_mean_and_the_mean_of_the_worst_tenth():
    per = np.concatenate([np.zeros(3), np.full(17, 0.5), np.ones(10)])  # 30 levels
    s = levels.summary(per, np.random.default_rng(0))
    assert s["mean"] == pytest.approx(per.mean())
    assert s["worst_tenth"] == 0.0  # the 3 worst of 30
    assert s["mean_lo"] <= s["mean"] <= s["mean_hi"]
    s = levels.summary(np.linspace(0, 1, 20), np.random.default_rng(0))
    assert s["worst_tenth"] == pytest.approx(np.mean(np.linspace(0, 1, 20)[:2]))


@pytest.mark.slow
def test_a_level_starts_at_its_layouts_start_with_its_own_goal(run):
    loaded = load_run(run)
    mazes = levels.level_mazes(loaded, 6)
    env = levels._fixed(loaded.policies).env
    params = loaded.policies.env_params
    for maze in mazes:
        _, state = env.reset(jax.random.PRNGKey(3), params.replace(maze=maze))
        np.testing.assert_allclose(np.asarray(state.pos), np.asarray(maze.start)[:2])
        np.testing.assert_allclose(np.asarray(state.goal), np.asarray(maze.goal))
    # the same levels every time (one fixed key), of the test split
    again = levels.level_mazes(loaded, 6)
    for a, b in zip(mazes, again):
        np.testing.assert_array_equal(np.asarray(a.segments), np.asarray(b.segments))


@pytest.mark.slow
def test_evaluate_levels_writes_every_driver_on_every_level(run, tmp_path, capsys):
    out = tmp_path / "eval"
    assert evaluate_main([str(run), "--levels", "12", "--out", str(out)]) == 0
    rows = list(csv.DictReader((out / "levels.csv").open()))
    assert len(rows) == 24 and {r["driver"] for r in rows} == {"policy", "oracle"}
    assert all(0 <= int(r["solved"]) <= int(r["policies"]) for r in rows)
    assert {int(r["policies"]) for r in rows if r["driver"] == "policy"} == {2}
    assert {int(r["policies"]) for r in rows if r["driver"] == "oracle"} == {1}  # one seat
    printed = capsys.readouterr().out
    assert "12 levels: mean" in printed and "worst tenth" in printed
    assert evaluate_main([str(run), "--levels", "5", "--out", str(tmp_path / "e")]) == 2


@pytest.mark.slow
def test_the_oracle_drives_a_level_alike_from_every_seat(run):
    """Why a reference driver plays each level in one seat: from the level's start to its
    own goal the oracle's first attempt ends the same in every seat (each seed's)."""
    from jaxnav.experiments.baselines import in_place_of

    loaded = load_run(run)
    mazes = levels.level_mazes(loaded, 6)
    policies = levels._fixed(loaded.policies)
    every = levels.solved(in_place_of("oracle", policies, mazes), mazes)
    assert every.shape == (6, 2)
    np.testing.assert_array_equal(every[:, 0], every[:, 1])
    one = levels.solved(in_place_of("oracle", levels.one_seat(policies), mazes), mazes)
    np.testing.assert_array_equal(one[:, 0], every[:, 0])


@pytest.mark.parametrize(
    "name", ["drive_anywhere", "curriculum_replay_half", "curriculum_replay_most"]
)
def test_the_shipped_policys_page_quotes_its_committed_levels(name):
    """The 1,000-level figures on jaxnav/policies/drive_anywhere.md are those of
    docs/levels/NAME.csv (the shipped policy's, and the level-replay arms' of the
    curriculum study), the mean and the worst tenth computed by hand."""
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    rows = list(csv.DictReader((root / "docs" / "levels" / f"{name}.csv").open()))
    page = (root / "jaxnav" / "policies" / "drive_anywhere.md").read_text()
    page = " ".join(page.split())
    for driver in ("policy", "oracle"):
        per = np.asarray(
            [int(r["solved"]) / int(r["policies"]) for r in rows if r["driver"] == driver]
        )
        assert len(per) == 1000
        s = levels.summary(per, np.random.default_rng(0))
        assert s["mean"] == pytest.approx(per.mean())
        assert s["worst_tenth"] == pytest.approx(np.sort(per)[:100].mean())
        if driver == "policy":
            assert f"{s['mean']:.3f} [{s['mean_lo']:.3f}, {s['mean_hi']:.3f}]" in page
            assert f"{s['worst_tenth']:.3f} [{s['worst_lo']:.3f}, {s['worst_hi']:.3f}]" in page
        else:
            assert s["mean"] == s["worst_tenth"] == 1.0


def test_the_policys_page_breaks_its_levels_down_by_kind_of_world():
    """The levels lie in the mix's bank source by source, each its weight's share of the
    1,000 (Mix.shares): the page's per-kind means and its count of levels that fewer
    than half the seeds solve, recomputed."""
    from pathlib import Path

    from jaxnav.world.mix import Mix

    root = Path(__file__).resolve().parent.parent
    rows = list(csv.DictReader((root / "docs" / "levels" / "drive_anywhere.csv").open()))
    page = " ".join((root / "jaxnav" / "policies" / "drive_anywhere.md").read_text().split())
    per = np.asarray(
        [int(r["solved"]) / int(r["policies"]) for r in rows if r["driver"] == "policy"]
    )
    weights = np.asarray([1, 1, 1, 0.5, 1]) / 4.5  # configs/drive_anywhere.yaml's mix
    shares = Mix(sources=(), names=(), weights=tuple(weights)).shares(1000)
    assert shares == (223, 222, 222, 111, 222)
    parts = np.split(per, np.cumsum(shares)[:-1])
    means = [f"{x.mean():.2f}" for x in parts]  # rooms, cylinders, grid, square4_obstacles, stage4
    assert means == ["0.82", "0.99", "0.95", "1.00", "0.99"]
    low = [int((x < 0.5).sum()) for x in parts]
    assert sum(low) == 49 and low[0] == 38 and low[2] == 11
    assert (
        "of the 49 levels that fewer than half the seeds solve, 38 are 2 x 2 rooms and 11" in page
    )


def test_the_policys_page_gives_the_level_replay_arms_rooms():
    """The rooms' share of their levels (the bank's first 223) for the two level-replay
    arms, as the policy's page quotes them."""
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    page = " ".join((root / "jaxnav" / "policies" / "drive_anywhere.md").read_text().split())
    rooms = []
    for name in ("curriculum_replay_half", "curriculum_replay_most"):
        rows = list(csv.DictReader((root / "docs" / "levels" / f"{name}.csv").open()))
        per = [int(r["solved"]) / int(r["policies"]) for r in rows if r["driver"] == "policy"]
        rooms.append(f"{np.mean(per[:223]):.2f}")
    assert f"the rooms stay the failures ({rooms[0]} and {rooms[1]} of their levels)" in page
