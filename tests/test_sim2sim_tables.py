"""The sim-to-sim tables are computed from their per-seed CSVs alone: the gap table
and the realism table (which training options help in MuJoCo, with rliable's
probability of improvement), and the committed tables are that computation of the
committed CSVs."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest
from rliable import metrics

from jaxnav.core.rundir import csv_text
from jaxnav.report import stats
from jaxnav.report.sim2sim_tables import REALISM_COLUMNS, gap_markdown, realism_markdown

ROOT = Path(__file__).resolve().parent.parent
MAZES = ("square4", "triangle")
STRATEGIES = ("ebe", "epsilon_greedy")
SEEDS = range(8)


def _rows(option: str, jaxnav: np.ndarray, mujoco: np.ndarray) -> list[list]:
    """CSV rows of one option from returns f[strategies, seeds, mazes] per simulator."""
    rows = []
    for sim, ret in (("jaxnav", jaxnav), ("mujoco", mujoco)):
        for i, strategy in enumerate(STRATEGIES):
            for s in SEEDS:
                for j, maze in enumerate(MAZES):
                    rows.append([option, sim, strategy, s, maze, 5, ret[i, s, j], 1.0, 0.2, 300.0])
    return rows


def _table(md: str) -> dict[tuple[str, str], dict[str, str]]:
    """{(option, strategy): {column: cell}} of the markdown table."""
    lines = [line for line in md.splitlines() if line.startswith("|")]
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    cells = [[c.strip() for c in line.strip("|").split("|")] for line in lines[2:]]
    return {(r[0], r[1]): dict(zip(header, r)) for r in cells}


@pytest.fixture(scope="module")
def synthetic():
    rng = np.random.default_rng(0)
    shape = (len(STRATEGIES), len(SEEDS), len(MAZES))
    jx = rng.normal(6000, 1500, shape)
    plain_mj = jx + rng.normal(0, 800, shape)  # a gap of about 800 per seed and maze
    better_jx = rng.normal(6000, 1500, shape)
    better_mj = better_jx + 3000 + rng.normal(0, 10, shape)  # better in MuJoCo, gap +3000
    same_jx = rng.normal(6000, 1500, shape)
    same_mj = same_jx + rng.normal(0, 800, shape)
    rows = _rows("plain", jx, plain_mj)
    rows += _rows("better", better_jx, better_mj)
    rows += _rows("same", same_jx, same_mj)
    text = csv_text(REALISM_COLUMNS, rows)
    return text, {"plain": (jx, plain_mj), "better": (better_jx, better_mj)}


@pytest.mark.slow  # 3 s on 2 cores
def test_the_realism_table_uses_rliables_probability_of_improvement(synthetic):
    text, data = synthetic
    table = _table(realism_markdown(text))
    assert [k[0] for k in table] == ["plain", "plain", "better", "better", "same", "same"]
    for i, strategy in enumerate(STRATEGIES):
        name = {"ebe": "EBE", "epsilon_greedy": "epsilon-greedy"}[strategy]
        jx, mj = data["plain"][0][i], data["plain"][1][i]
        b_jx, b_mj = data["better"][0][i], data["better"][1][i]
        row = table[("better", name)]
        p = metrics.probability_of_improvement(b_mj, mj)  # rliable's own function
        assert row["P(MuJoCo return > plain's)"].startswith(f"{p:.2f} [")
        assert row["P(MuJoCo return > plain's)"].endswith("higher")
        assert row["MuJoCo return"].startswith(f"{b_mj.mean():.1f} [")
        assert row["gap"].startswith(f"{(b_mj - b_jx).mean():+.1f} [")
        # A constant +3000 gap is larger than plain's noise of 800: it widens.
        size = np.abs(b_mj - b_jx)
        assert row["size of gap"].startswith(f"{size.mean():.1f} [")
        assert row["narrows the gap?"] == "widens it"
        plain = table[("plain", name)]
        iv = stats.mean_ci(mj)
        assert plain["MuJoCo return"] == f"{iv.value:.1f} [{iv.low:.1f}, {iv.high:.1f}]"
        assert plain["P(MuJoCo return > plain's)"] == ""
        assert plain["gap"].startswith(f"{(mj - jx).mean():+.1f} [")
        # Equally distributed runs: no verdict either way.
        assert table[("same", name)]["P(MuJoCo return > plain's)"].endswith("no difference")


def test_the_realism_table_refuses_runs_that_do_not_match(synthetic):
    text, _ = synthetic
    rows = list(csv.reader(io.StringIO(text)))
    short = [r for r in rows if not (r[0] == "better" and r[3] == "7")]
    with pytest.raises(ValueError, match="better"):
        realism_markdown("\n".join(",".join(r) for r in short) + "\n")
    with pytest.raises(ValueError, match="no run named .none."):
        realism_markdown(text, baseline="none")


@pytest.mark.slow
def test_the_committed_gap_table_is_computed_from_its_csv():
    title = "Sim-to-sim gap of paper_no_obstacles: jaxnav and MuJoCo"
    md = gap_markdown((ROOT / "docs" / "sim2sim.csv").read_text(), title)
    one_level_down = "\n".join("#" + ln if ln.startswith("#") else ln for ln in md.splitlines())
    assert one_level_down in (ROOT / "docs" / "sim2sim.md").read_text()


@pytest.mark.slow
def test_the_committed_realism_table_is_computed_from_its_csv():
    md = realism_markdown((ROOT / "docs" / "sim2sim_realism.csv").read_text())
    assert md in (ROOT / "docs" / "sim2sim_realism.md").read_text()
    table = md[md.index("| option |") :]
    assert table in (ROOT / "docs" / "sim2sim.md").read_text()
    # One row per option and strategy: the plain run and the six options.
    options = [row.split("|")[1].strip() for row in table.splitlines()[2:]]
    assert options == [o for o in OPTIONS for _ in STRATEGIES]


@pytest.mark.slow
def test_the_committed_wheel_limit_table_is_computed_from_its_csv():
    md = realism_markdown((ROOT / "docs" / "sim2sim_wheel_limit.csv").read_text())
    assert md in (ROOT / "docs" / "sim2sim_wheel_limit.md").read_text()
    table = md[md.index("| option |") :]
    assert table in (ROOT / "docs" / "robot.md").read_text()
    arms = [row.split("|")[1].strip() for row in table.splitlines()[2:]]
    assert arms == [a for a in ("plain", "wheel_limit", "plain_unlimited") for _ in STRATEGIES]
    assert "4 seeds per strategy" in md


OPTIONS = (
    "plain",
    "action_delay",
    "maze_scale",
    "random_start",
    "odom_noise",
    "beam_dropout",
    "lidar_noise_std",
)
