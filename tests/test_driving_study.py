"""The driving study (``jaxnav study driving``): its file names every shipped drive_*
config, a run of one config replaces only its row of the page's data, the committed
page is what the study writes from the committed data, and a finished config is reused
while an interrupted one or one trained with other settings is refused."""

from __future__ import annotations

import csv
import io
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from jaxnav.core.config import config_to_dict, load_config
from jaxnav.core.errors import ConfigError, JaxnavError
from jaxnav.core.rundir import csv_text
from jaxnav.core.shipped import CONFIG_DIR, builtin_configs
from jaxnav.experiments import driving, studies, studyfile
from jaxnav.report.agents_sac import FIGURE
from jaxnav.report.driving_page import (
    EVALS,
    RUN_COLUMNS,
    RUNS,
    commands_of,
    config_tests,
    machines_of,
    setting_text,
    written_by,
)

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = str(CONFIG_DIR / "studies" / "driving.yaml")
DOCS = ROOT / "docs" / "driving"


def test_the_shipped_study_is_every_drive_config_as_shipped():
    assert studyfile.kind_of(SHIPPED) == "driving"
    study = driving.load_study(SHIPPED)
    # drive_barn's test is BARN's protocol, its page docs/barn.md
    shipped = {n for n in builtin_configs() if n.startswith("drive_")} - {"drive_barn"}
    assert set(study.configs) == shipped
    assert study.test_episodes == 10 and study.settings == {}
    for name in study.configs:  # the cell's config is the shipped config, as jaxnav train's
        assert driving.config_of(study, name) == load_config(name)
    # the committed page lists the configs in the study's order
    runs = [r["config"] for r in csv.DictReader(io.StringIO((DOCS / RUNS).read_text()))]
    assert runs == list(study.configs)


def test_names_on_the_command_line_pick_configs_and_settings_reach_them():
    study = driving.load_study(SHIPPED, ["drive_grid4", "settings.total_steps=2048"])
    assert study.configs == ("drive_grid4",)
    assert driving.config_of(study, "drive_grid4").total_steps == 2048
    assert study.overrides() == ["total_steps=2048"]
    assert driving.load_study(SHIPPED).configs[0] == "drive_square4"  # the file is unchanged


def test_each_test_is_environment_settings_with_a_results_folder_of_its_own():
    study = driving.load_study(SHIPPED)
    # the table's test draws a new goal at each restart; the retried goal stays beside it
    assert study.tests == (("env.restart_goal=new", "env.new_maze_every=1"), ())
    folders = [driving.results_folder(t) for t in study.tests]
    assert folders == ["eval-env.restart_goal=new,env.new_maze_every=1", "eval"]
    run = json.loads((DOCS / "run.json").read_text())
    assert config_tests(run, list(study.configs)) == {
        c: [list(t) for t in study.tests] for c in study.configs
    }
    assert config_tests({}, ["a"]) == {"a": [[]]}  # a folder written before tests: as trained
    assert setting_text("env.x", "new") == "env.x=new"
    assert setting_text("env.x", [1, 2]) == "env.x=[1, 2]"
    assert setting_text("env.x", "a b") == 'env.x="a b"'
    one = driving.load_study(SHIPPED, ["drive_square4", "tests=[{env: {restart_goal: new}}]"])
    assert one.tests == (("env.restart_goal=new",),)


@pytest.mark.parametrize(
    "items, message",
    [
        (["tests=[]"], "tests must list at least one test"),
        (["tests=[1]"], "tests[0] must be a mapping of settings"),
        (["tests=[{}, {}]"], "tests names a test twice"),
        (["tests=[{dqn.lr: 0.1}]"], "tested with other environment settings only"),
        (["tests=[{env.restart_goal: nw}]"], "env.restart_goal"),
        (["drive_grid4", "tests=[{env.restart_goal: new}]"], "env.new_maze_every 1"),
        (["drive_nowhere"], "no shipped config 'drive_nowhere'"),
        (["test_episodes=0"], "test_episodes must be at least 1"),
        (["settings.env.max_stepz=3"], "unknown key 'env.max_stepz'"),
        (["configz=[smoke]"], "unknown key 'configz'"),
        (["smoke", "smoke"], "names a config twice"),
    ],
)
def test_a_wrong_study_is_one_line_naming_the_problem(items, message):
    with pytest.raises(ConfigError) as e:
        driving.load_study(SHIPPED, items)
    assert message in str(e.value) and "\n" not in str(e.value)


def test_an_unknown_kind_is_one_line_and_exit_2(tmp_path, capsys):
    from jaxnav.commands.study import main

    path = tmp_path / "s.yaml"
    path.write_text("kind: drivng\ntitle: x\n")
    with pytest.raises(ConfigError, match="unknown kind 'drivng'"):
        studies.is_study(str(path))
    assert main([str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown kind 'drivng' (known: ladder, driving, sim2sim)" in err
    assert not (tmp_path / "o").exists()


def _run_dir(study, name: str, out: Path, **settings) -> Path:
    """A run directory started (config.yaml only) with the cell's config, or other settings."""
    cfg = driving.config_of(study, name)
    doc = config_to_dict(cfg)
    doc.update(settings)
    (out / name).mkdir(parents=True)
    (out / name / "config.yaml").write_text(yaml.safe_dump(doc))
    return out / name


def test_an_interrupted_or_differently_trained_config_is_refused(tmp_path):
    study = driving.load_study(SHIPPED, ["smoke"])
    _run_dir(study, "smoke", tmp_path / "a")
    with pytest.raises(JaxnavError, match="was interrupted: its time would not be one command's"):
        driving.run_cell(study, tmp_path / "a", "smoke", lambda _: None)
    _run_dir(study, "smoke", tmp_path / "b", seeds=7)
    with pytest.raises(JaxnavError, match="was started with other settings"):
        driving.run_cell(study, tmp_path / "b", "smoke", lambda _: None)


def _data(out: Path, configs: list[str]) -> None:
    """A finished study's data folder holding the committed data of ``configs``."""
    data = out / "data"
    data.mkdir(parents=True)
    rows = [r for r in csv.DictReader(io.StringIO((DOCS / RUNS).read_text()))]
    mine = [[r[c] for c in RUN_COLUMNS] for r in rows if r["config"] in configs]
    (data / RUNS).write_text(csv_text(RUN_COLUMNS, mine))
    (data / EVALS).mkdir()
    for name in configs:
        for path in DOCS.glob(f"{name}.*csv"):  # its tests: NAME.csv, NAME.test2.csv
            shutil.copyfile(path, data / path.name)
        shutil.copyfile(DOCS / EVALS / f"{name}.csv", data / EVALS / f"{name}.csv")
    shutil.copyfile(DOCS / "run.json", data / "run.json")


def test_one_config_run_again_replaces_its_row_and_keeps_the_others(tmp_path, monkeypatch):
    folder = tmp_path / "docs" / "driving"
    shutil.copytree(DOCS, folder)
    before = (folder / RUNS).read_text()
    out = tmp_path / "runs"
    _data(out, ["drive_grid4"])
    row = (out / "data" / RUNS).read_text()
    (out / "data" / RUNS).write_text(row.replace("grid 4x4", "grid 4x4 again"))
    ran = {"commands": {"drive_grid4": "c"}, "machines": {"drive_grid4": "m"}, "machine": "m"}
    (out / "data" / "run.json").write_text(json.dumps(ran) + "\n")
    kept = json.loads((folder / "run.json").read_text())
    drawn = []
    monkeypatch.setattr(driving, "driving_markdown", lambda *a: drawn.append(a) or "page\n")
    study = driving.load_study(SHIPPED, ["drive_grid4"])
    written = driving.publish(study, out, tmp_path / "docs" / "driving.md")
    # the page, its data, and the figure of SAC beside PQN, whose configs are in it
    assert written == [tmp_path / "docs" / "driving.md", tmp_path / "docs" / FIGURE, folder]
    assert (tmp_path / "docs" / "driving.md").read_text() == "page\n"
    configs = [r["config"] for r in csv.DictReader(io.StringIO(before))]
    was = commands_of(kept, configs)  # each other row keeps the command that wrote it
    on = machines_of(kept, configs)  # and the machine it ran on
    tests = {**config_tests(kept, configs), "drive_grid4": [[]]}  # ran with one test, as trained
    assert drawn == [(folder, {**was, "drive_grid4": "c"}, {**on, "drive_grid4": "m"}, tests)]
    assert not (folder / "drive_grid4.test2.csv").exists()  # its earlier second test is gone
    assert (folder / "drive_rooms.test2.csv").is_file()  # another config's stays
    assert json.loads((folder / "run.json").read_text())["commands"]["drive_grid4"] == "c"
    after = (folder / RUNS).read_text()
    assert after == before.replace("grid 4x4", "grid 4x4 again")  # its row, in its place
    assert (folder / "gpu_h200_eval.csv").is_file()  # other files of the folder stay


def test_a_config_new_to_the_page_takes_its_place_in_the_studys_order(tmp_path, monkeypatch):
    """drive_stage4_long run alone into a page that lacks it lands after drive_stage4,
    where the shipped study lists it, not at the end."""
    folder = tmp_path / "docs" / "driving"
    shutil.copytree(DOCS, folder)
    rows = list(csv.DictReader(io.StringIO((folder / RUNS).read_text())))
    without = [r for r in rows if r["config"] != "drive_stage4_long"]
    (folder / RUNS).write_text(csv_text(list(rows[0]), [list(r.values()) for r in without]))
    out = tmp_path / "runs"
    _data(out, ["drive_stage4_long"])
    monkeypatch.setattr(driving, "driving_markdown", lambda *a: "page\n")
    page = tmp_path / "docs" / "driving.md"
    driving.publish(driving.load_study(SHIPPED, ["drive_stage4_long"]), out, page)
    after = [r["config"] for r in csv.DictReader(io.StringIO((folder / RUNS).read_text()))]
    assert after == [r["config"] for r in rows] == list(driving.load_study(SHIPPED).configs)


@pytest.mark.slow  # the page's bootstrap intervals
def test_the_committed_page_is_what_the_study_writes_from_the_committed_data(tmp_path):
    folder = tmp_path / "docs" / "driving"
    shutil.copytree(DOCS, folder)
    out = tmp_path / "runs"
    study = driving.load_study(SHIPPED)
    _data(out, list(study.configs))
    page = tmp_path / "docs" / "driving.md"
    driving.publish(study, out, page)
    assert page.read_text() == (ROOT / "docs" / "driving.md").read_text()
    evals = [f"{EVALS}/{c}.csv" for c in study.configs]
    for name in (RUNS, "run.json", *[f"{c}.csv" for c in study.configs], *evals):
        assert (folder / name).read_bytes() == (DOCS / name).read_bytes(), name


TINY = """\
kind: driving
title: Tiny
test_episodes: 1
configs: [smoke]
settings: {seeds: 1, episodes: 2, env: {max_steps: 20}, dqn: {batch_size: 16},
           run: {test_mazes: [square2]}}
"""


@pytest.mark.slow
def test_a_tiny_driving_study_end_to_end_and_its_resume(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(TINY)
    out, doc = tmp_path / "o", tmp_path / "docs" / "drive.md"
    doc.parent.mkdir()
    cmd = [sys.executable, "-m", "jaxnav", "study", str(path), "--out", str(out), "--quiet"]
    done = subprocess.run([*cmd, "--doc", str(doc)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(io.StringIO((doc.parent / "drive" / RUNS).read_text())))
    steps = json.loads((out / "smoke" / "summary.json").read_text())["env_steps"]
    runs = load_config(str(out / "smoke" / "config.yaml")).n_runs
    got = [(r["config"], r["world"], r["seeds"], r["env_steps"]) for r in rows]
    assert got == [("smoke", "square4", "1", str(steps // runs))]  # per run
    assert float(rows[0]["command_s"]) > 0
    results = (doc.parent / "drive" / "smoke.csv").read_text()
    assert {r["strategy"] for r in csv.DictReader(io.StringIO(results))} >= {"oracle", "dwa"}
    assert "`smoke`" in doc.read_text() and "Written by `jaxnav study" in doc.read_text()
    params = out / "smoke" / "params.npz"
    before = params.stat().st_mtime_ns
    again = subprocess.run([*cmd, "--resume"], capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    assert params.stat().st_mtime_ns == before  # a finished config is not trained again
    # a test added to a finished study runs on the finished training, beside the first
    path.write_text(TINY + "tests: [{}, {env.restart_goal: new}]\n")
    more = [*cmd, "--resume", "--doc", str(doc), "--overwrite"]
    more = subprocess.run(more, capture_output=True, text=True)
    assert more.returncode == 0, more.stderr
    assert params.stat().st_mtime_ns == before
    assert (out / "smoke" / "eval-env.restart_goal=new" / "results.csv").is_file()
    assert (doc.parent / "drive" / "smoke.test2.csv").is_file()
    assert "## The same policies in other tests" in doc.read_text()
    page = doc.read_text()  # its row, or (no restart in so short a test) the same results
    assert "| `env.restart_goal=new` |" in page or "gave the very same results" in page
    path.write_text(TINY.replace("episodes: 2", "episodes: 3"))
    refused = subprocess.run([*cmd, "--resume"], capture_output=True, text=True)
    assert refused.returncode == 2 and "was trained with other settings" in refused.stderr


@pytest.mark.slow  # 3 s on 2 cores
def test_the_other_tests_table_comes_from_the_committed_data():
    """Each row of the smaller table (the same policies retested) against the committed
    file read with the csv module and the statistics library alone."""
    import statistics

    from jaxnav.report.driving_page import data_name, other_tests, trained_label

    tests = config_tests(json.loads((DOCS / "run.json").read_text()), driving.shipped_order())
    lines = other_tests(DOCS, tests)
    assert lines[0] == "## The same policies in other tests"
    rows = [line for line in lines if line.startswith("| `")]
    checked, same = 0, []
    for config, its in tests.items():
        for k in range(1, len(its)):
            if (DOCS / data_name(config, k)).read_bytes() == (DOCS / f"{config}.csv").read_bytes():
                same.append(f"`{config}`")  # no row: the very same test
                assert not any(r.startswith(f"| `{config}` |") for r in rows)
                continue
            got = list(csv.DictReader(io.StringIO((DOCS / data_name(config, k)).read_text())))
            policy = next(r["strategy"] for r in got if r["strategy"] not in ("oracle", "dwa"))
            for maze in dict.fromkeys(r["maze"] for r in got):
                success = statistics.mean(_rate(got, maze, policy))
                oracle = statistics.mean(_rate(got, maze, "oracle"))
                row = next(r for r in rows if r.startswith(f"| `{config}` | {maze} |"))
                cells = [c.strip() for c in row.strip("|").split("|")]
                assert cells[4].startswith(f"{success:.2f} [") and cells[6].startswith(
                    f"{oracle:.2f} ["
                )
                assert cells[7] == ("yes" if success >= oracle - 0.02 else "no")
                checked += 1
    assert checked == len(rows) > 0
    if same:
        assert f"For {', '.join(same)} the other tests gave the very same results" in lines[2]
    # the retried goal is named as each config trained with it
    assert trained_label("drive_stage4", ["env.restart_goal=new", "env.new_maze_every=1"]) == (
        "as trained (`env.restart_goal=keep`)"
    )
    assert trained_label("drive_grid4", ["env.new_maze_every=10"]) == "as trained"


def test_the_page_names_each_command_with_the_configs_it_wrote():
    one = {"drive_square4": "jaxnav study driving", "drive_rooms": "jaxnav study driving"}
    assert written_by(one, "M") == "Written by `jaxnav study driving` on M."
    two = {**one, "drive_rooms": "jaxnav study driving drive_rooms --resume"}
    assert written_by(two, "M") == (
        "Written by `jaxnav study driving` (`drive_square4`); "
        "`jaxnav study driving drive_rooms --resume` (`drive_rooms`), on M."
    )
    # a folder written before rows kept their own command: its one command for every row
    assert commands_of({"command": "c", "machine": "M"}, ["a", "b"]) == {"a": "c", "b": "c"}
    # rows measured on different machines name each command's machine
    on = {"drive_square4": "M", "drive_rooms": "N"}
    assert written_by(two, on) == (
        "Written by `jaxnav study driving` (`drive_square4`) on M; "
        "`jaxnav study driving drive_rooms --resume` (`drive_rooms`) on N."
    )
    assert machines_of({"machine": "M"}, ["a"]) == {"a": "M"}


def _rate(rows: list[dict], maze: str, driver: str) -> list[float]:
    """Per seed, the successes over the decided goal attempts of the greedy test on ``maze``."""
    rows = [r for r in rows if r["mode"] == "greedy"]
    out = []
    for seed in sorted({r["seed"] for r in rows if r["strategy"] == driver}, key=int):
        mine = [r for r in rows if (r["strategy"], r["seed"], r["maze"]) == (driver, seed, maze)]
        decided = sum(float(r["attempts"]) - float(r["cut"]) for r in mine)
        out.append(sum(float(r["successes"]) for r in mine) / decided)
    return out


def test_sac_beside_pqn_comes_from_the_committed_data():
    """docs/agents.md's SAC table: each number against the committed files read here
    with the csv module and the statistics library alone."""
    import statistics

    from jaxnav.report import agents_sac

    text = agents_sac.block(DOCS)
    for sac, pqn in agents_sac.PAIRS:
        for config in (sac, pqn):
            rows = list(csv.DictReader(io.StringIO((DOCS / f"{config}.csv").read_text())))
            maze = rows[0]["maze"]
            policy = "policy" if config == sac else "epsilon_greedy"

            success = statistics.mean(_rate(rows, maze, policy))
            oracle = statistics.mean(_rate(rows, maze, "oracle"))
            assert f"`{config}` ({'SAC' if config == sac else 'PQN'})" in text
            assert f"| {success:.3f} [" in text and f"({oracle:.3f})" in text
            # the first evaluation whose mean success over seeds is within 0.02 of the oracle
            evals = list(csv.DictReader(io.StringIO((DOCS / EVALS / f"{config}.csv").read_text())))
            steps = sorted({int(r["env_step"]) for r in evals})
            first = next(
                (s for s in steps
                 if statistics.mean(float(r["success"]) for r in evals if int(r["env_step"]) == s)
                 >= oracle - 0.02),
                None,
            )  # fmt: skip
            e = agents_sac.entry(DOCS, config)
            assert (e["solved_at"] is None) == (first is None)
            if first is not None:
                assert e["solved_at"][0] == first
