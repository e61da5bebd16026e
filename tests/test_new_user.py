"""What a new user tripped on, each refused or answered in one line before anything is
written: seeds a PRNG key cannot hold, a test maze that does not exist, a misspelt
setting, the version, and the shipped configs' descriptions in ``jaxnav list``."""

from __future__ import annotations

import pytest

from jaxnav.__main__ import main as jaxnav_main
from jaxnav.commands.train import main as train_main
from jaxnav.core.config import ConfigError, load_config
from jaxnav.core.shipped import builtin_configs


@pytest.mark.parametrize(
    "overrides, message",
    [
        (["seed=99999999999999999999"], "seed must be in [0, 2^32)"),
        (["seed=4294967296"], "seed must be in [0, 2^32)"),
        (["seed=4294967295", "seeds=2"], "would go up to seed 4294967296"),
        (["env.max_step=3"], "unknown key 'env.max_step' (did you mean 'env.max_steps'?)"),
        (["run.sed=1"], "unknown key 'run.sed' (did you mean 'seed'?)"),
        (["dqn.lerning_rate=1e-3"], "unknown key 'dqn.lerning_rate' (did you mean 'dqn.lr'?)"),
        (["dqn.learning_rate=1e-3"], "(did you mean 'dqn.lr'?)"),
        (
            ["sweep.dqn.gama=[0.9,0.99]"],
            "unknown key 'dqn.gama' in sweep (did you mean 'dqn.gamma'?)",
        ),
    ],
)
def test_settings_a_run_cannot_use_are_refused_in_one_line(overrides, message):
    with pytest.raises(ConfigError) as e:
        load_config("smoke", overrides)
    assert message in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("command", ["mazes", "render"])
@pytest.mark.parametrize("seed", ["99999999999999999999", "4294967296", "-1"])
def test_a_seed_option_a_key_cannot_hold_is_refused_in_one_line(command, seed, tmp_path, capsys):
    import importlib

    main = importlib.import_module(f"jaxnav.commands.{command}").main
    out = tmp_path / ("mazes" if command == "mazes" else "maze.png")
    argv = ["grid", "--seed", seed, "--out", str(out)] + (
        ["--n", "2"] if command == "mazes" else []
    )
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "argument --seed: must be in [0, 2^32)" in err[0], err
    assert not out.exists()


def test_a_study_seed_a_key_cannot_hold_is_refused_in_one_line():
    import yaml

    from jaxnav.core.shipped import STUDY_DIR
    from jaxnav.experiments.ladder import parse_study

    doc = yaml.safe_load((STUDY_DIR / "when_ebe_helps.yaml").read_text())
    for seed in (2**32, -1):
        with pytest.raises(ConfigError, match=r"^study s: seed must be in \[0, 2\^32\)"):
            parse_study(yaml.safe_dump({**doc, "seed": seed}), "study s")


def test_the_last_seed_a_key_can_hold_is_accepted():
    assert load_config("smoke", ["seed=4294967294", "seeds=2"]).seed == 4294967294


def test_an_unknown_test_maze_is_refused_before_training_and_leaves_no_directory(tmp_path, capsys):
    out = tmp_path / "run"
    assert train_main(["smoke", "run.test_mazes=[square4,nosuch]", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "run.test_mazes: unknown maze 'nosuch'" in err[0]
    assert not out.exists()


def test_an_unknown_test_maze_is_refused_before_a_study_makes_its_folder(tmp_path, capsys):
    from jaxnav.commands.study import main as study_main

    out = tmp_path / "study"
    assert study_main(["temperature", "run.test_mazes=[square4,nosuch]", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "run.test_mazes: unknown maze 'nosuch'" in err[0], err
    assert not out.exists()


def test_version_is_one_line(capsys):
    assert jaxnav_main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("jaxnav ")


def test_list_gives_each_shipped_config_its_whole_first_sentence():
    about = builtin_configs()
    assert about["stage4"].endswith("episodes last up to 500 steps")
    assert about["paper_no_obstacles"].startswith("Paper, Sec. 6.1 / Table 3")
    assert about["pqn"].startswith("PQN (Gallici et al. 2024) beside the paper's DQN")
    # a sentence that a digit or a path follows ends there too
    assert about["drive_obstacles"].endswith("with ten times the budget")
    assert about["pqn"].endswith("under a minute on 2 CPU cores")


@pytest.mark.parametrize("maze", ["grid4", "square4"])
def test_a_sheet_too_large_to_draw_is_refused_in_one_line(maze, tmp_path, capsys):
    """render square4 --samples 100000 grew to 15.7 GB in 10 minutes without a word."""
    from jaxnav.commands.render import main as render_main

    out = tmp_path / "sheet.png"
    assert render_main([maze, "--samples", "100000", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 1 and "--samples 100000: a sheet of 100000 panels would take about " in err[0]
    )
    assert "20.0 GB to draw; a sheet holds at most 400 panels (about 80 MB)" in err[0]
    assert not out.exists()


def test_reading_a_run_another_process_trains_says_so(tmp_path):
    from jaxnav.core import rundir
    from jaxnav.core.config import dump_config
    from jaxnav.core.errors import RunError

    run = tmp_path / "run"
    run.mkdir()
    (run / rundir.CONFIG).write_text(dump_config(load_config("smoke")))
    with pytest.raises(RunError, match="resume it first"):
        rundir.existing(run, finished=True)
    with rundir.Lock(run):  # flock locks per open file: as another process would hold it
        assert rundir.in_use(run)
        with pytest.raises(RunError, match="being trained by another process"):
            rundir.existing(run, finished=True)
    assert not rundir.in_use(run)


def test_the_advice_after_ctrl_c_repeats_the_options_that_sized_the_run():
    from jaxnav.core.cli import resume_advice

    line = resume_advice("reproduce", ["--quick", "--out", "runs/r", "--seeds", "3"], "runs/r")
    assert line.endswith("reproduce --quick --seeds 3 --resume --out runs/r")
    again = resume_advice("ablation", ["--quick", "--resume", "--out=runs/a"], "runs/a")
    assert again.endswith("ablation --quick --resume --out runs/a")


def test_the_advice_after_ctrl_c_in_a_study_is_a_whole_command(monkeypatch):
    """It was "continue with --resume --out DIR": without the config, which study needs."""
    import jaxnav.commands.study as command

    told = []
    monkeypatch.setattr(
        command.cli, "run", lambda prog, work, interrupted: told.append(interrupted)
    )
    command.main(["temperature", "seeds=2", "--out", "my runs/t", "--quiet"])
    assert told[0].endswith("study temperature seeds=2 --quiet --resume --out 'my runs/t'")


def test_a_page_that_runs_the_tensorboard_viewer_says_how_to_install_it():
    """The extra 'tensorboard' writes the event files (tensorboardX); the viewer that
    the docs run is either in the extra or installed as the page says."""
    import re
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    extra = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    extra = extra["optional-dependencies"]["tensorboard"]
    has_viewer = any(re.match(r"tensorboard\b(?!X)", r, re.I) for r in extra)
    pages = [root / "README.md", *sorted((root / "docs").rglob("*.md"))]
    running = [p for p in pages if "tensorboard --logdir" in p.read_text()]
    assert running, "no page says how to watch a run"
    for page in running:
        assert has_viewer or "pip install tensorboard" in page.read_text(), page


@pytest.mark.parametrize("command", ["evaluate", "export"])
def test_evaluate_and_export_of_a_run_another_process_trains_say_so(command, tmp_path, capsys):
    """They said "resume it first", and a resume is refused while the run trains."""
    import importlib

    from jaxnav.core import rundir
    from jaxnav.core.config import dump_config

    main = importlib.import_module(f"jaxnav.commands.{command}").main
    run = tmp_path / "run"
    run.mkdir()
    (run / rundir.CONFIG).write_text(dump_config(load_config("smoke")))
    with rundir.Lock(run):
        assert main([str(run)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"jaxnav {command}: error: {run} is being trained by another process: wait for it to finish"
    ]
    assert main([str(run)]) == 2  # not training, not finished: a resume finishes it
    assert "resume it first" in capsys.readouterr().err
    assert {p.name for p in run.iterdir()} == {rundir.CONFIG, rundir.LOCK}  # nothing written


@pytest.mark.parametrize(
    "command, argv, message",
    [
        ("train", ["smok"], "no such file smok (did you mean 'smoke'?"),
        ("study", ["drivng", "--out", "OUT"], "no such file drivng (did you mean 'driving'?"),
        ("study", [], "name a config or a shipped study (jaxnav list studies"),
        ("study", ["worlds"], "--out DIR is required"),
    ],
)
def test_a_mistyped_or_missing_name_gets_one_line_that_helps(
    command, argv, message, tmp_path, capsys
):
    import importlib

    main = importlib.import_module(f"jaxnav.commands.{command}").main
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in argv]
    try:
        code = main(argv)
    except SystemExit as e:  # the parser's own errors
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "out").exists()


def test_the_studies_are_listed_with_what_each_costs(capsys):
    from jaxnav.commands.list import main as list_main
    from jaxnav.commands.study import main as study_main
    from jaxnav.core.shipped import shipped_studies

    assert list_main(["studies"]) == 0
    out = capsys.readouterr().out
    costs = shipped_studies("cost")
    assert costs and all(costs.values())  # every shipped study says what it took
    for name, cost in costs.items():
        assert name in out and f"cost: {cost}" in out
    with pytest.raises(SystemExit):
        study_main(["--help"])
    assert "when_ebe_helps" in capsys.readouterr().out
