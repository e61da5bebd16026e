"""The ladder study: its file is checked whole before any training, its verdicts are
the claims table's rule on rliable's own statistic, its page comes from its data alone,
and an interrupted study resumes without training a finished cell again."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rliable import metrics

from jaxnav.core.errors import ConfigError
from jaxnav.experiments import ladder
from jaxnav.report import ladder as page
from jaxnav.report import stats

STUDY = """\
title: Tiny
seeds: 2
total_steps: 512
test_episodes: 2
strategies: [ebe, epsilon_greedy, boltzmann]
settings: {run: {chunk_steps: 256}, env: {max_steps: 60}}
generalise_to: [square2]
agents:
  dqn: {label: DQN}
rungs:
  square4_dense: {config: paper_no_obstacles}
  grid4_dense:
    config: grid4
    settings: {env: {reward: geodesic}}     # its fixed-maze test scores the dense reward
    larger: {env: {grid_rows: 5, grid_cols: 5}}
"""


def _parse(text: str):
    return ladder.parse_study(text, "study x.yaml")


def test_the_shipped_study_parses_and_every_cell_builds():
    study = ladder.load_study(str(ladder.CONFIG_DIR / "studies" / "when_ebe_helps.yaml"))
    assert study.eval_points == 10
    dqn_rungs = next(a for a in study.agents if a.name == "dqn").rungs
    assert dqn_rungs == ("square4",)
    assert len(study.cells()) == len(study.rungs) + len(dqn_rungs)
    for rung, agent in study.cells():
        cfg = ladder.cell_config(study, rung, agent)
        assert cfg.total_steps == rung.total_steps and cfg.episodes is None
        assert cfg.run.eval_every * study.eval_points == rung.total_steps
        assert cfg.run.chunk_steps == cfg.run.eval_every
        assert cfg.strategies == study.strategies and cfg.seeds == study.seeds
        assert cfg.exploration.ebe_temperature == 0.03
        # the drive config's recipe, or the paper's DQN without the recipe's PQN settings
        assert cfg.agent == ("dqn" if agent.name == "dqn" else "pqn")
        if rung.larger:
            big = ladder.larger_config(cfg, rung)
            assert big.env.split == "test"


def test_the_first_ladder_study_is_kept_with_its_budget_and_temperature():
    study = ladder.load_study(str(ladder.CONFIG_DIR / "studies" / "when_ebe_helps_40k.yaml"))
    assert len(study.cells()) == len(study.rungs) * len(study.agents)
    for rung, agent in study.cells():
        cfg = ladder.cell_config(study, rung, agent)
        assert cfg.total_steps == study.total_steps and cfg.episodes is None
        assert cfg.exploration.ebe_temperature == 3.0 and cfg.run.eval_every == 0
        if rung.larger:
            big = ladder.larger_config(cfg, rung)
            assert big.env.split == "test" and big.env.grid_rows > cfg.env.grid_rows


@pytest.mark.parametrize(
    "change, message",
    [
        (("seeds: 2", "seeds: 0"), "seeds must be at least 1"),
        (("seeds: 2", "seedz: 2"), "unknown key 'seedz'"),
        (("title: Tiny\n", ""), "title is required"),
        (("config: paper_no_obstacles", "config: nope"), "no shipped config 'nope'"),
        (("max_steps: 60", "max_stepz: 60"), "unknown key 'env.max_stepz'"),
        (("grid_rows: 5", "grid_rows: -5"), "grid4_dense.larger"),
        (("total_steps: 512", "total_steps: many"), "total_steps must be an integer"),
        (("generalise_to: [square2]", "generalise_to: [nomaze]"), "unknown maze 'nomaze'"),
        (("  dqn: {label: DQN}", "  dqn: {label: DQN, settings: {dqn: {double: 3}}}"), "double"),
        (("  dqn: {label: DQN}", "  dqn: {label: DQN, rungs: [nope]}"), "no rung 'nope'"),
        (("seeds: 2", "seeds: 2\neval_points: 3"), "does not split into eval_points=3"),
        (("seeds: 2", "seeds: 2\nnotes: [1]"), "notes must be a list of lines"),
    ],
)
def test_a_wrong_study_file_is_one_line_naming_the_problem(change, message):
    with pytest.raises(ConfigError) as e:
        _parse(STUDY.replace(*change))
    assert message in str(e.value) and "\n" not in str(e.value)


def test_larger_needs_a_drawn_family():
    bad = STUDY.replace(
        "square4_dense: {config: paper_no_obstacles}",
        "square4_dense: {config: paper_no_obstacles, larger: {env: {grid_rows: 5}}}",
    )
    with pytest.raises(ConfigError, match="larger needs a drawn family"):
        _parse(bad)


@pytest.mark.slow  # 3 s on 2 cores
def test_the_cli_refuses_a_broken_study_with_exit_2(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(STUDY.replace("seeds: 2", "seeds: -1"))
    done = subprocess.run(
        [sys.executable, "-m", "jaxnav", "study", str(path), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "seeds must be at least 1" in done.stderr
    assert not (tmp_path / "o").exists()


def test_key_value_overrides_reach_the_cells_and_the_studys_text(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(STUDY)
    items = ["seeds=3", "settings.env.max_steps=40", "agents.dqn.settings.dqn.lr=0.001"]
    study = ladder.load_study(str(path), items)
    assert study.seeds == 3
    for rung, agent in study.cells():
        cfg = ladder.cell_config(study, rung, agent)
        assert cfg.seeds == 3 and cfg.env.max_steps == 40 and cfg.dqn.lr == 0.001
    assert study.text.startswith(f"# s.yaml with {' '.join(items)}")
    assert ladder.parse_study(study.text, "again") == study  # the folder's copy is the study
    assert ladder.load_study(str(path)).seeds == 2  # the file itself is unchanged


@pytest.mark.parametrize(
    "item, message",
    [
        ("seedz=3", "unknown key 'seedz'"),
        ("agents.ppo.settings.dqn.lr=0.1", "agents.ppo is not in the study"),
        ("title.x=1", "title is not a mapping"),
        ("seeds=0", "seeds must be at least 1"),
        ("settings.env.max_stepz=40", "unknown key 'env.max_stepz'"),
    ],
)
def test_a_wrong_override_is_one_line_naming_it(tmp_path, item, message):
    path = tmp_path / "s.yaml"
    path.write_text(STUDY)
    with pytest.raises(ConfigError) as e:
        ladder.load_study(str(path), [item])
    assert message in str(e.value) and "\n" not in str(e.value)


@pytest.mark.slow  # 6 s on 2 cores
def test_a_world_may_have_its_own_budget_and_the_page_says_it(tmp_path):
    text = STUDY.replace(
        "square4_dense: {config: paper_no_obstacles}",
        "square4_dense: {config: paper_no_obstacles, total_steps: 2048}",
    )
    study = _parse(text)
    budgets = {
        r.name: ladder.cell_config(study, r, study.agents[0]).total_steps for r in study.rungs
    }
    assert budgets == {"square4_dense": 2048, "grid4_dense": 512}  # the other keeps the study's
    with pytest.raises(ConfigError, match="total_steps must be at least 1"):
        _parse(text.replace("total_steps: 2048", "total_steps: 0"))
    folder = tmp_path / "d"
    _synthetic(folder)
    doc = (folder / "study.yaml").read_text()
    (folder / "study.yaml").write_text(
        doc.replace(
            "a: {config: paper_no_obstacles}", "a: {config: paper_no_obstacles, total_steps: 2048}"
        )
    )
    md = page.ladder_markdown(folder, "d")
    assert "its world's budget of environment steps per seed" in md
    assert "| world | config | settings over it | env steps per seed |" in md
    assert "| a | `paper_no_obstacles` | none | 2,048 |" in md
    assert "| b | `grid4` | `env.reward=geodesic` | 512 |" in md


@pytest.mark.slow  # 6 s on 2 cores
def test_the_page_says_how_each_arm_drives_beside_the_oracle(tmp_path):
    folder = tmp_path / "d"
    _synthetic(folder)
    md = page.ladder_markdown(folder, "d")
    table = md.split("## How they drive")[1].split("## Does it generalise?")[0]
    assert "| world | agent | driver | success | collision | time-out | SPL |" in table
    # rung a: EBE reaches every goal, never collides: nothing is left for time-outs
    assert "| a | DQN | EBE | 1.00 [1.00, 1.00] | 0.00 [0.00, 0.00] | 0.00 [0.00, 0.00] |" in table
    assert "| a |  | oracle | 1.00 [1.00, 1.00] |" in table
    assert table.count("| oracle |") == 2  # once per world


def test_the_shipped_studies_are_package_data_and_listed():
    import tomllib

    from jaxnav.commands.list import catalog
    from jaxnav.core.shipped import STUDY_DIR, shipped_studies

    root = Path(__file__).resolve().parent.parent
    data = tomllib.loads((root / "pyproject.toml").read_text())
    patterns = data["tool"]["setuptools"]["package-data"]["jaxnav"]
    for path in STUDY_DIR.glob("*.yaml"):
        rel = path.relative_to(STUDY_DIR.parent.parent)
        assert any(rel.match(p) for p in patterns), rel
    assert "when_ebe_helps" in shipped_studies()
    assert "  when_ebe_helps  " in catalog()


def test_every_shipped_study_file_of_every_kind_loads_whole():
    from jaxnav.core.shipped import STUDY_DIR, shipped_studies
    from jaxnav.experiments import studies, studyfile

    kinds = {}
    for name in shipped_studies():
        path = str(STUDY_DIR / f"{name}.yaml")
        loaded = studies.load(path)
        kinds[name] = studyfile.kind_of(path)
        assert loaded.kind is studies.kinds()[kinds[name]]
        assert loaded.study.title == shipped_studies()[name]
    assert set(kinds.values()) == set(studyfile.KINDS)


def _synthetic(folder: Path, n: int = 16, oracle: bool = True) -> None:
    """A data folder: on rung a, EBE reaches every goal and the others half; on rung b
    all three draw from the same distribution; the oracle reaches every goal on a and
    0.99 on b (``oracle=False``: a folder written before cut attempts were counted
    apart, without the cut column and the oracle's rows)."""
    rng = np.random.default_rng(0)
    doc = _parse(STUDY).text.replace("square4_dense", "a").replace("grid4_dense", "b")
    folder.mkdir()
    (folder / "study.yaml").write_text(doc)
    rows = []
    for rung in ("a", "b"):
        for strategy in ("ebe", "epsilon_greedy", "boltzmann"):
            for seed in range(n):
                for test in ("own",) if rung == "a" else ("own", "test"):
                    good = rung == "a" and strategy == "ebe"
                    s = 1.0 if good else float(rng.uniform(0.3, 0.7))
                    rows.append([rung, "dqn", strategy, seed, test, 2, 4, s * 100, s, s, 0, 0, s])
            if oracle:
                for seed in range(n):
                    s = 1.0 if rung == "a" else 0.99
                    rows.append([rung, "dqn", "oracle", seed, "own", 2, 4, 0, s, s, 0, 0, s])
    columns = list(ladder.SCORE_COLUMNS)
    if not oracle:
        columns = columns[: columns.index("cut")]  # nor goals per minute
        rows = [r[: len(columns)] for r in rows]
    with open(folder / "scores.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(columns)
        w.writerows(rows)
    (folder / "curves.csv").write_text("rung,agent,strategy,share,goals,low,high\n")
    (folder / "cells.csv").write_text(
        "rung,agent,runs,env_steps,train_s,test_s,transitions_per_s,compile_s\n"
        "a,dqn,48,1,60,6,1000,1\nb,dqn,48,1,54,0,1000,1\n"
    )
    (folder / "run.json").write_text(json.dumps({"command": "c", "machine": "m"}))


@pytest.mark.slow  # 7 s on 2 cores
def test_verdicts_are_rliables_probability_of_improvement_with_the_claims_rule(tmp_path):
    _synthetic(tmp_path / "d")
    data = page.Data(tmp_path / "d")
    for rung in ("a", "b"):
        x = data.per_seed(rung, "dqn", "own", "ebe", "success")
        y = data.per_seed(rung, "dqn", "own", "epsilon_greedy", "success")
        p, word = page.compare(data, rung, "dqn", "own", "epsilon_greedy", "success")
        assert p.value == pytest.approx(
            float(metrics.probability_of_improvement(x[:, None], y[:, None]))
        )
        assert word == ("EBE better" if rung == "a" else "no detectable difference")
        assert word == "EBE better" or p.low < 0.5 < p.high
    assert page.summary_sentence(data) == (
        "Across 2 worlds of growing difficulty and 1 agent (2 cells, 16 seeds per arm), "
        "entropy-based exploration reaches more goals than epsilon-greedy in 1, fewer in 0, "
        "shows no detectable difference in 1."
    )
    # solved: within 0.02 of the oracle's success on the same test
    assert page.oracle_success(data, "a") == 1.0
    assert page.solved_by(data, "a") == [("dqn", "ebe")] and page.solved_by(data, "b") == []
    assert "an arm solves a world when" in page.ladder_markdown(tmp_path / "d", "x")
    assert page.trajectory_cell(data) == ("a", "dqn")  # b draws its mazes: no fixed maze


@pytest.mark.slow  # 6 s on 2 cores
def test_data_counted_before_cut_attempts_were_told_apart_names_no_solved_world(tmp_path):
    _synthetic(tmp_path / "d", oracle=False)
    data = page.Data(tmp_path / "d")
    assert not data.counted_cut and page.solved_by(data, "a") is None
    text = page.ladder_markdown(tmp_path / "d", "x")
    assert "It does not say which worlds are solved" in text and "is solved by" not in text


@pytest.mark.slow  # 6 s on 2 cores
def test_the_page_says_too_few_seeds_below_the_minimum(tmp_path):
    _synthetic(tmp_path / "d", n=stats.MIN_SEEDS - 1)
    text = page.ladder_markdown(tmp_path / "d", "x")
    assert stats.TOO_FEW_SEEDS in text and "] EBE better" not in text
    assert "Total: 2 minutes" in text


@pytest.mark.slow
def test_a_tiny_study_end_to_end_and_its_resume(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(STUDY)
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "jaxnav", "study", str(path), "--out", str(out), "--quiet"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    data = out / "study"
    text = (out / "study.md").read_text()
    assert text == page.ladder_markdown(data, "study")
    with open(data / "scores.csv") as f:
        rows = list(csv.DictReader(f))
    tests = {(r["rung"], r["test"]) for r in rows}
    assert tests == {
        ("square4_dense", "own"),
        ("square4_dense", "square2"),
        ("grid4_dense", "own"),
        ("grid4_dense", "test"),
        ("grid4_dense", "larger"),
        ("grid4_dense", "square2"),
    }
    learned = [r for r in rows if r["strategy"] not in ("oracle", "dwa")]
    assert len(learned) == 6 * 3 * 2  # tests x strategies x seeds
    # the oracle and DWA drove every test once, beside the world's first agent
    assert len(rows) - len(learned) == 6 * 2 * 2
    assert all(r["cut"] != "" for r in rows)
    assert "an arm solves a world when its mean success is within 0.02" in text
    again = subprocess.run(cmd, capture_output=True, text=True)
    assert again.returncode == 2 and "--resume" in again.stderr
    params = out / "cells" / "grid4_dense.dqn" / "params.npz"
    before, scores = params.stat().st_mtime_ns, (data / "scores.csv").read_text()
    resumed = subprocess.run(cmd + ["--resume"], capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    assert params.stat().st_mtime_ns == before  # a finished cell is not trained again
    assert (data / "scores.csv").read_text() == scores
    other = tmp_path / "t.yaml"
    other.write_text(STUDY.replace("Tiny", "Other"))
    cmd[4] = str(other)
    refused = subprocess.run(cmd + ["--resume"], capture_output=True, text=True)
    assert refused.returncode == 2 and "holds another study" in refused.stderr
