"""A study of options (one strategy, several agents differing in settings): each arm
against the first by the claims' rule, its sentence's means and counts by hand, and its
page and figure from hand-made data."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from jaxnav.experiments.ladder import SCORE_COLUMNS
from jaxnav.report import options, stats, study_pages
from jaxnav.report.ladder import Data

STUDY = """\
title: Which observation generalises?
seed: 0
seeds: 16
total_steps: 1000
test_episodes: 10
strategies: [epsilon_greedy]
agents:
  shipped:
    label: as shipped
  worse:
    label: without the history
    settings: {env: {scan_history: 0}}
  same:
    label: without the convolutions
    settings: {dqn: {scan_conv: []}}
rungs:
  mix:
    label: a mix of worlds
    config: drive_anywhere
notes:
  - "A note."
"""
OFFICE, CORRIDOR = "configs/mazes/heldout/office.yaml", "configs/mazes/heldout/corridor_long.yaml"
N = 16


def _success(agent: str, test: str, rng) -> np.ndarray:
    """Every arm about alike, but ``worse`` far below the others in the office."""
    if agent == "worse" and test == OFFICE:
        return rng.uniform(0.0, 0.3, N)
    return rng.uniform(0.6, 1.0, N)


def _folder(tmp_path, with_refs: bool = True):
    folder = tmp_path / "data"
    folder.mkdir()
    (folder / "study.yaml").write_text(STUDY)
    rng = np.random.default_rng(0)
    rows, want = [], {}
    for agent in ("shipped", "worse", "same"):
        for test in ("own", "test", OFFICE, CORRIDOR):
            x = _success(agent, test, rng)
            want[agent, test] = x
            rows += [
                dict(rung="mix", agent=agent, strategy="epsilon_greedy", seed=s, test=test,
                     episodes=10, attempts=20, success=v, collision=1 - v)
                for s, v in enumerate(x)
            ]  # fmt: skip
            if agent == "shipped" and with_refs:  # the reference drivers beside the first
                for who, v in (("oracle", 1.0), ("dwa", 0.5 if test == CORRIDOR else 0.9)):
                    rows += [
                        dict(rung="mix", agent=agent, strategy=who, seed=s, test=test,
                             episodes=10, attempts=20, success=v, collision=0.0)
                        for s in range(N)
                    ]  # fmt: skip
    with open(folder / "scores.csv", "w", newline="") as f:
        w = csv.DictWriter(f, SCORE_COLUMNS, restval="0", lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    (folder / "curves.csv").write_text("rung,agent,strategy,share,goals,low,high\n")
    cells = ["rung,agent,runs,env_steps,train_s,test_s,transitions_per_s,compile_s"]
    cells += [f"mix,{a},16,16000,600.0,60.0,1000,10.0" for a in ("shipped", "worse", "same")]
    (folder / "cells.csv").write_text("\n".join(cells) + "\n")
    run = {"command": "jaxnav study options --out runs/o", "machine": "a test machine"}
    (folder / "run.json").write_text(json.dumps(run))
    return folder, want


def test_a_study_of_one_strategy_and_several_agents_is_a_study_of_options(tmp_path):
    folder, _ = _folder(tmp_path)
    assert study_pages.of_options(folder)
    assert options.of_options(Data(folder))


def test_each_arm_against_the_first_by_the_claims_rule(tmp_path):
    folder, want = _folder(tmp_path)
    data = Data(folder)
    for agent in ("worse", "same"):
        for test in ("own", "test", OFFICE, CORRIDOR):
            p, word = options.compare(data, "mix", test, agent)
            ref = stats.probability_of_improvement_ci(want[agent, test], want["shipped", test])
            assert p == ref  # rliable's statistic on the same seeds
            assert word == {1: "better", -1: "worse", 0: "-"}[stats.side(ref)]
    assert options.compare(data, "mix", OFFICE, "worse")[1] == "worse"
    assert options.compare(data, "mix", CORRIDOR, "same")[1] == "-"


def test_the_sentence_gives_the_held_out_means_and_counts_by_hand(tmp_path):
    folder, want = _folder(tmp_path)
    text = options.summary_sentence(Data(folder))
    held = (OFFICE, CORRIDOR)

    def mean(agent):
        return np.mean([want[agent, t].mean() for t in held])

    assert text.startswith("On 2 kinds of world no policy trained on (office, corridor_long)")
    assert f"mean success as shipped {mean('shipped'):.2f}, " in text
    assert (
        f"without the history {mean('worse'):.2f} (detectably lower on 1 of the 2, higher on 0)"
        in text
    )
    assert (
        f"without the convolutions {mean('same'):.2f} (detectably lower on 0 of the 2, higher on 0)"
        in text
    )
    # the reference drivers over the same tests: the oracle 1.0; DWA 0.9 and 0.5
    assert text.endswith("; the oracle 1.00, DWA 0.70 on the same tests.")
    assert study_pages.sentence(folder) == text


def test_a_study_without_reference_drivers_or_held_out_worlds_says_so(tmp_path):
    folder, _ = _folder(tmp_path, with_refs=False)
    assert "oracle" not in options.summary_sentence(Data(folder))
    text = (folder / "scores.csv").read_text().splitlines()
    kept = [r for r in text if "heldout" not in r]
    (folder / "scores.csv").write_text("\n".join(kept) + "\n")
    assert options.summary_sentence(Data(folder)).startswith("No policy")


def test_the_page_and_its_figure_from_the_data_alone(tmp_path):
    folder, want = _folder(tmp_path)
    text = study_pages.page(folder, "options")
    assert text.startswith("# Which observation generalises?")
    assert "in 33 minutes on a test machine" in text  # 3 cells of 600 + 60 s
    mean = stats.mean_ci(want["worse", OFFICE])
    row = next(r for r in text.splitlines() if r.startswith("| a mix of worlds | office |"))
    assert f"{mean.value:.2f} [{mean.low:.2f}, {mean.high:.2f}]" in row
    assert row.endswith("| 1.00 | 0.90 |")  # the oracle and DWA on the same episodes
    # their collisions too, in the collisions' table
    assert text.count("| a mix of worlds | office |") == 3  # success, verdicts, collisions
    assert text.split("## Collisions")[1].count("| 0.00 | 0.00 |") == 4
    assert "- A note." in text
    assert study_pages.figure_names(folder) == options.FIGURES
    (png,) = study_pages.figures(folder, tmp_path, "options")
    assert png.name == "options-options.png" and png.stat().st_size > 0


@pytest.mark.parametrize("path", ["jaxnav/configs/studies/observation_anywhere.yaml"])
def test_the_observation_study_builds_each_arm_with_its_observation(path):
    from jaxnav.experiments.ladder import cell_config, load_study

    study = load_study(path)
    got = {a.name: cell_config(study, r, a) for r, a in study.cells()}
    shipped = got["shipped"]
    assert (shipped.env.scan_history, shipped.dqn.scan_conv, shipped.env.scan_beams) == (
        3,
        (16, 16),
        72,
    )
    assert got["no_history"].env.scan_history == 0 and got["no_history"].dqn.scan_conv == (16, 16)
    assert got["no_conv"].dqn.scan_conv == () and got["no_conv"].env.scan_history == 3
    blind = got["no_command"]
    assert not blind.env.observe_command and blind.env.scan_history == 3
    assert all(c.env.observe_command for k, c in got.items() if k != "no_command")
    plain = got["plain"]
    assert (plain.env.scan_history, plain.dqn.scan_conv, plain.env.scan_beams) == (0, (), 0)
    # every other setting is the shipped arm's
    for cfg in got.values():
        assert cfg.env.generator == "mix" and cfg.total_steps == shipped.total_steps
        assert cfg.strategies == ("epsilon_greedy",)


def test_the_curriculum_study_changes_only_how_the_next_layout_is_picked():
    import dataclasses

    from jaxnav.core.config import load_config
    from jaxnav.experiments.ladder import cell_config, load_study

    study = load_study("jaxnav/configs/studies/curriculum_anywhere.yaml")
    got = {a.name: cell_config(study, r, a) for r, a in study.cells()}
    assert {k: c.pqn.level_replay for k, c in got.items()} == {
        "shipped": 0.0,
        "replay_half": 0.5,
        "replay_most": 0.9,
    }
    shipped = got["shipped"]
    for cfg in got.values():  # the rest is the shipped arm's, which is drive_anywhere's
        same = dataclasses.replace(cfg, pqn=dataclasses.replace(cfg.pqn, level_replay=0.0))
        assert same == shipped
    assert shipped.env == load_config("drive_anywhere").env
