"""What the commands say about their outputs: the flags their messages name."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

import jaxnav.commands.train as train_command

SMOKE = [
    "configs/smoke.yaml",
    "seeds=1",
    "episodes=2",
    "env.max_steps=20",
    "dqn.batch_size=16",  # fits the 40 transitions of the run's replay memory
    "--quiet",
]


def test_train_into_a_folder_that_holds_no_run_names_no_flag_that_cannot_help(tmp_path, capsys):
    """--resume and --overwrite both refuse a folder without config.yaml: the message
    must not offer them."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    for extra in ([], ["--overwrite"]):
        assert train_command.main([*SMOKE, "--out", str(out), *extra]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "holds no run" in err and "choose another --out" in err
        assert "--overwrite" not in err and "--resume" not in err
    assert [p.name for p in out.iterdir()] == ["notes.txt"]


def test_study_checks_its_doc_files_before_training(tmp_path, capsys, monkeypatch):
    import jaxnav.commands.study as study_command

    def no_study(*a, **k):
        raise AssertionError("the study started before its outputs were checked")

    monkeypatch.setattr(study_command, "study", no_study)
    doc = tmp_path / "temperature.md"
    argv = ["configs/temperature.yaml", "--out", str(tmp_path / "s"), "--quiet"]
    for existing in ("temperature.md", "temperature-sweep.png", "temperature-results.csv.gz"):
        (tmp_path / existing).write_text("mine")
        assert study_command.main([*argv, "--doc", str(doc)]) == 2
        err = capsys.readouterr().err
        assert err == (
            f"jaxnav study: error: {tmp_path / existing} exists already (--overwrite replaces it)\n"
        )
        (tmp_path / existing).unlink()
    missing = tmp_path / "no" / "t.md"
    assert study_command.main([*argv, "--doc", str(missing)]) == 2
    assert f"the folder {missing.parent} does not exist" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


@pytest.mark.slow
def test_train_ends_with_the_outcome_table(tmp_path, capsys):
    """The table evaluate prints too (report.tables.outcome_text), of the last 50
    training episodes of each seed."""
    from jaxnav.core.rundir import METRICS, CsvLog
    from jaxnav.report.tables import outcome_text

    out = tmp_path / "run"
    assert train_command.main([*SMOKE, "seeds=2", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    table = outcome_text(CsvLog(out / METRICS, ()).read(), last=50)
    assert (
        f"last 50 training episodes of each seed, mean over seeds [95% CI]:\n{table}\n" in printed
    )
    assert table.splitlines()[0].split()[:3] == ["strategy", "seeds", "return"]
    assert [line.split()[0] for line in table.splitlines()[1:]] == ["ebe", "epsilon_greedy"]


@pytest.mark.slow  # 3 s on 2 cores
def test_train_refuses_a_run_larger_than_the_machine_before_allocating(tmp_path):
    """seeds=100000 used to allocate for minutes with no progress."""
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "jaxnav.commands.train",
            "smoke",
            "seeds=100000",
            "--out",
            tmp_path / "r",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 2
    assert run.stderr.startswith("jaxnav train: error: this run needs about ")
    assert "GiB of replay memory" in run.stderr and run.stderr.count("\n") == 1
    assert not (tmp_path / "r").exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    "argv",
    [
        ["jaxnav.commands.reproduce", "--seeds", "100000", "--out", "{out}"],
        ["jaxnav.commands.study", "smoke", "seeds=100000", "--out", "{out}"],
    ],
    ids=["reproduce", "study"],
)
def test_reproduce_and_study_ask_the_same_memory_question_as_train(tmp_path, argv):
    out = tmp_path / "r"
    run = subprocess.run(
        [sys.executable, "-m", *(a.replace("{out}", str(out)) for a in argv)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 2, run.stderr
    assert run.stderr.count("\n") == 1 and "GiB of replay memory" in run.stderr
    assert not out.exists()


@pytest.mark.parametrize("command", ["reproduce", "ablation"])
@pytest.mark.parametrize("flag", ["--seeds", "--episodes", "--max-steps", "--test-episodes"])
def test_the_experiments_sizes_below_one_are_one_line_and_nothing_is_written(
    command, flag, tmp_path, capsys
):
    module = importlib.import_module(f"jaxnav.commands.{command}")
    out = tmp_path / "r"
    assert module.main([flag, "0", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err == f"jaxnav {command}: error: {flag} must be at least 1\n"
    assert not out.exists()


def test_the_experiments_sizes_are_read_alike():
    """--quick's sizes, an option given over them, and the default seeds."""
    from jaxnav.core import cli
    from jaxnav.experiments.reproduce import DEFAULT_SEEDS, QUICK

    p = cli.Parser(prog="x")
    cli.add_sizes(p, DEFAULT_SEEDS, QUICK)
    seeds, sizes = cli.chosen_sizes(p.parse_args([]), DEFAULT_SEEDS, QUICK)
    assert (seeds, sizes) == (DEFAULT_SEEDS, dict.fromkeys(sizes))
    seeds, sizes = cli.chosen_sizes(p.parse_args(["--quick", "--max-steps", "7"]), 0, QUICK)
    assert seeds == QUICK["seeds"] and sizes["max_steps"] == 7
    assert sizes["episodes"] == QUICK["episodes"]
    assert sizes["test_episodes"] == QUICK["test_episodes"]
